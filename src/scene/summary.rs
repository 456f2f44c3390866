//! A scene summary: what `inspect` shows before any tag is applied, so a designer can check the
//! importer saw the level they exported.

use serde::Serialize;

use super::{Format, Scene};
use crate::geom::aabb::Aabb;

/// The world-space box around every mesh node (m).
#[derive(Debug, Clone, Serialize)]
pub struct Bounds {
    /// Least corner.
    pub min: [f64; 3],
    /// Greatest corner.
    pub max: [f64; 3],
    /// `max - min`.
    pub size: [f64; 3],
}

/// What `inspect` says about a scene before any tags apply.
#[derive(Debug, Clone, Serialize)]
pub struct SceneSummary {
    /// The file format it was read from.
    pub format: Format,
    /// All nodes, mesh or not.
    pub nodes: usize,
    /// Nodes that draw a mesh.
    pub mesh_nodes: usize,
    /// Distinct meshes (an instanced mesh counts once).
    pub meshes: usize,
    /// Triangles drawn, each instance counted.
    pub triangles: usize,
    /// `None` for a scene without geometry.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub bounds: Option<Bounds>,
    /// Material names (unnamed ones as `#index`).
    pub materials: Vec<String>,
}

/// Counts, bounds and material names of `scene`.
pub fn summarize(scene: &Scene) -> SceneSummary {
    let order = scene.walk();
    let mut bounds = Aabb::EMPTY;
    let mut mesh_nodes = 0;
    for &n in &order {
        if scene.nodes[n].mesh.is_some() {
            mesh_nodes += 1;
            for p in scene.world_positions_used_iter(n) {
                bounds.add(p);
            }
        }
    }
    SceneSummary {
        format: scene.format,
        nodes: order.len(),
        mesh_nodes,
        meshes: scene.meshes.len(),
        triangles: scene.triangle_count(),
        bounds: (!bounds.is_empty()).then(|| Bounds {
            min: bounds.min.to_array(),
            max: bounds.max.to_array(),
            size: bounds.size().to_array(),
        }),
        materials: scene
            .materials
            .iter()
            .enumerate()
            .map(|(i, m)| m.name.clone().unwrap_or_else(|| format!("#{i}")))
            .collect(),
    }
}
