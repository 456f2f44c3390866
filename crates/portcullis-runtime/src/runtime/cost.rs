//! What a view costs an engine to draw, in the units it pays: triangles and draw calls
//! submitted. Read from the glTF's JSON alone (accessor counts and the POSITION bounds the
//! glTF specification requires, nodes' transforms), as an engine knows its meshes, so the
//! figure needs no buffer and matches what an engine following the file would submit.
//!
//! Three ways of drawing are priced, each with frustum culling of every node's box on top (the
//! baseline every engine has): `frustum`, every node of the level's geometry (those some
//! cell names and the parts of split nodes, not the meshes of its portals or bounds); `nodes`, the nodes the
//! visible cells name (`cells[].nodes`, whole); `lists`, the visible cells' draw lists
//! ([`Level::draw_list`]). A cell seen through a mirror or teleporter is priced again for
//! each such view, without frustum culling (its geometry is drawn moved).

use std::path::Path;

use glam::{DMat4, DQuat, DVec3};
use serde::Deserialize;
use serde_json::Value;

use super::{DrawList, Level, LevelError, LoadError, Trace, View};

/// A glTF node's mesh as drawn: its world bounds and each primitive's triangles.
#[derive(Debug, Clone)]
struct NodeMesh {
    min: DVec3,
    max: DVec3,
    /// Triangles per primitive (0 for points and lines, still a draw call).
    primitives: Vec<u64>,
}

/// The meshes of a converted level's scene, per glTF node.
#[derive(Debug, Clone, Default)]
pub struct Meshes {
    nodes: Vec<Option<NodeMesh>>,
    /// The parts of nodes split by cell (`convert --split-by-cell`), ascending: level
    /// geometry even where no cell names them (the triangles that lie in no cell).
    parts: Vec<u32>,
}

/// What is submitted to draw.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize, Deserialize)]
pub struct Submitted {
    /// Triangles.
    pub triangles: u64,
    /// Draw calls: one per primitive of a node drawn whole, one per range of a draw list.
    pub calls: u64,
}

impl std::ops::AddAssign for Submitted {
    fn add_assign(&mut self, o: Submitted) {
        self.triangles += o.triangles;
        self.calls += o.calls;
    }
}

/// One view priced three ways (see the module).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize, Deserialize)]
pub struct ViewCost {
    /// Every node of the scene whose box is in view.
    pub frustum: Submitted,
    /// The visible cells' nodes, whole.
    pub nodes: Submitted,
    /// The visible cells' draw lists.
    pub lists: Submitted,
}

impl std::ops::AddAssign for ViewCost {
    fn add_assign(&mut self, o: ViewCost) {
        self.frustum += o.frustum;
        self.nodes += o.nodes;
        self.lists += o.lists;
    }
}

#[derive(Deserialize, Default)]
#[serde(default)]
struct Doc {
    scene: Option<usize>,
    scenes: Vec<SceneDef>,
    nodes: Vec<NodeDef>,
    meshes: Vec<MeshDef>,
    accessors: Vec<AccessorDef>,
}

#[derive(Deserialize, Default)]
#[serde(default)]
struct SceneDef {
    nodes: Vec<usize>,
}

#[derive(Deserialize, Default)]
#[serde(default)]
struct NodeDef {
    children: Vec<usize>,
    extensions: NodeExtensions,
    mesh: Option<usize>,
    matrix: Option<[f64; 16]>,
    translation: Option<[f64; 3]>,
    rotation: Option<[f64; 4]>,
    scale: Option<[f64; 3]>,
}

#[derive(Deserialize, Default)]
#[serde(default)]
struct NodeExtensions {
    #[serde(rename = "PORTCULLIS_portals")]
    ours: Option<OursDef>,
}

#[derive(Deserialize, Default)]
#[serde(default)]
struct OursDef {
    parts: Vec<u32>,
}

#[derive(Deserialize, Default)]
#[serde(default)]
struct MeshDef {
    primitives: Vec<PrimitiveDef>,
}

#[derive(Deserialize, Default)]
#[serde(default)]
struct PrimitiveDef {
    attributes: std::collections::BTreeMap<String, usize>,
    indices: Option<usize>,
    mode: Option<u64>,
}

#[derive(Deserialize, Default)]
#[serde(default)]
struct AccessorDef {
    count: u64,
    min: Option<Vec<f64>>,
    max: Option<Vec<f64>>,
}

impl Meshes {
    /// The meshes of the .glb or .gltf at `path` (its JSON only).
    pub fn load(path: &Path) -> Result<Meshes, LoadError> {
        let err = |kind: LevelError| LoadError {
            path: path.to_path_buf(),
            kind,
            hint: "check that the file is a glTF 2.0 document",
            unreadable: false,
        };
        let bytes = std::fs::read(path).map_err(|e| LoadError {
            kind: LevelError::Unreadable(e.to_string()),
            hint: "check the path and the file's permissions",
            unreadable: true,
            ..err(LevelError::NoExtension)
        })?;
        let (json, _) = super::load::split(&bytes).map_err(err)?;
        let doc: Value =
            serde_json::from_slice(json).map_err(|e| err(LevelError::NotGltf(e.to_string())))?;
        Meshes::of(&doc).map_err(err)
    }

    /// The meshes of a parsed glTF document.
    pub fn of(doc: &Value) -> Result<Meshes, LevelError> {
        let doc = Doc::deserialize(doc).map_err(|e| LevelError::NotGltf(e.to_string()))?;
        let mut parts: Vec<u32> = (doc.nodes.iter())
            .flat_map(|n| {
                n.extensions
                    .ours
                    .iter()
                    .flat_map(|o| o.parts.iter().copied())
            })
            .collect();
        parts.sort_unstable();
        parts.dedup();
        let mut out = Meshes {
            nodes: vec![None; doc.nodes.len()],
            parts,
        };
        let roots: Vec<usize> = match doc.scenes.get(doc.scene.unwrap_or(0)) {
            Some(s) => s.nodes.clone(),
            // No scene: every node that is no node's child.
            None => {
                let mut child = vec![false; doc.nodes.len()];
                for n in &doc.nodes {
                    for &c in &n.children {
                        if let Some(x) = child.get_mut(c) {
                            *x = true;
                        }
                    }
                }
                (0..doc.nodes.len()).filter(|&n| !child[n]).collect()
            }
        };
        let mut stack: Vec<(usize, DMat4)> = roots.iter().map(|&n| (n, DMat4::IDENTITY)).collect();
        let mut seen = vec![false; doc.nodes.len()];
        while let Some((n, parent)) = stack.pop() {
            let Some(node) = doc.nodes.get(n).filter(|_| !seen[n]) else {
                continue;
            };
            seen[n] = true;
            let world = parent * local(node);
            if let Some(mesh) = node.mesh.and_then(|m| doc.meshes.get(m)) {
                out.nodes[n] = Some(node_mesh(&doc, mesh, world));
            }
            stack.extend(node.children.iter().map(|&c| (c, world)));
        }
        Ok(out)
    }

    /// Triangles of glTF node `n`'s mesh (0 for a node without one or outside the scene).
    pub fn node_triangles(&self, n: usize) -> u64 {
        self.node(n).map_or(0, |m| m.primitives.iter().sum())
    }

    /// Triangles of every node of the scene.
    pub fn triangles(&self) -> u64 {
        (0..self.nodes.len()).map(|n| self.node_triangles(n)).sum()
    }

    fn node(&self, n: usize) -> Option<&NodeMesh> {
        self.nodes.get(n).and_then(Option::as_ref)
    }

    /// Node `n` drawn whole, if `view` (when given) sees its box.
    fn whole(&self, n: usize, view: Option<&View>) -> Submitted {
        match self.node(n) {
            Some(m) if view.is_none_or(|v| v.sees_box(m.min, m.max)) => Submitted {
                triangles: m.primitives.iter().sum(),
                calls: m.primitives.len() as u64,
            },
            _ => Submitted::default(),
        }
    }

    /// The draw list `list`, each part if `view` (when given) sees its node's box.
    fn list(&self, list: &DrawList, view: Option<&View>) -> Submitted {
        let mut s = Submitted::default();
        for &n in &list.nodes {
            s += self.whole(n, view);
        }
        for r in &list.ranges {
            let seen = self
                .node(r.node)
                .is_some_and(|m| view.is_none_or(|v| v.sees_box(m.min, m.max)));
            if seen {
                s += Submitted {
                    triangles: r.count as u64 / 3,
                    calls: 1,
                };
            }
        }
        s
    }
}

/// A node's local transform (`matrix`, else translation, rotation, scale).
fn local(n: &NodeDef) -> DMat4 {
    if let Some(m) = n.matrix {
        return DMat4::from_cols_array(&m);
    }
    let t = n.translation.map_or(DVec3::ZERO, DVec3::from);
    let r = n
        .rotation
        .map_or(DQuat::IDENTITY, |q| DQuat::from_array(q).normalize());
    let s = n.scale.map_or(DVec3::ONE, DVec3::from);
    DMat4::from_scale_rotation_translation(s, r, t)
}

/// A mesh drawn by a node at `world`: the box of its primitives' POSITION bounds moved there
/// (unbounded when a primitive states none), and each primitive's triangles.
fn node_mesh(doc: &Doc, mesh: &MeshDef, world: DMat4) -> NodeMesh {
    let (mut min, mut max) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
    let mut primitives = Vec::with_capacity(mesh.primitives.len());
    for p in &mesh.primitives {
        let pos = p
            .attributes
            .get("POSITION")
            .and_then(|&a| doc.accessors.get(a));
        let n = match p.indices.and_then(|a| doc.accessors.get(a)) {
            Some(ix) => ix.count,
            None => pos.map_or(0, |a| a.count),
        };
        primitives.push(match p.mode.unwrap_or(4) {
            4 => n / 3,
            5 | 6 => n.saturating_sub(2),
            _ => 0,
        });
        let bounds = pos.and_then(|a| {
            let (lo, hi) = (a.min.as_ref()?, a.max.as_ref()?);
            (lo.len() == 3 && hi.len() == 3).then(|| {
                (
                    DVec3::new(lo[0], lo[1], lo[2]),
                    DVec3::new(hi[0], hi[1], hi[2]),
                )
            })
        });
        let Some((lo, hi)) = bounds else {
            (min, max) = (DVec3::NEG_INFINITY, DVec3::INFINITY);
            continue;
        };
        for i in 0..8 {
            let c = DVec3::new(
                if i & 1 == 0 { lo.x } else { hi.x },
                if i & 2 == 0 { lo.y } else { hi.y },
                if i & 4 == 0 { lo.z } else { hi.z },
            );
            let w = world.transform_point3(c);
            min = min.min(w);
            max = max.max(w);
        }
    }
    NodeMesh {
        min,
        max,
        primitives,
    }
}

impl Level {
    /// What `view` costs to draw, by the cells `trace` (of that view) found visible: see the
    /// module. `list` is scratch, reused across views.
    pub fn cost(
        &self,
        meshes: &Meshes,
        view: &View,
        trace: &Trace,
        list: &mut DrawList,
    ) -> ViewCost {
        let mut cost = ViewCost::default();
        let named = self.draw.named();
        let unnamed = (meshes.parts.iter()).filter(|n| named.binary_search(n).is_err());
        for &n in named.iter().chain(unnamed) {
            cost.frustum += meshes.whole(n as usize, Some(view));
        }
        let direct = trace.visible().iter().filter(|v| v.transform.is_none());
        let cells: Vec<usize> = direct.filter_map(|v| v.cell).collect();
        let mut nodes: Vec<usize> = (cells.iter())
            .flat_map(|&c| self.draw.listed(c).iter().map(|&n| n as usize))
            .collect();
        nodes.sort_unstable();
        nodes.dedup();
        for &n in &nodes {
            cost.nodes += meshes.whole(n, Some(view));
        }
        self.draw_list(cells.iter().copied(), list);
        cost.lists += meshes.list(list, Some(view));
        for v in trace.visible().iter().filter(|v| v.transform.is_some()) {
            let Some(c) = v.cell else { continue };
            for &n in self.draw.listed(c) {
                cost.nodes += meshes.whole(n as usize, None);
            }
            self.draw_list([c], list);
            cost.lists += meshes.list(list, None);
        }
        cost
    }

    /// What cell `c` draws of its own, by its draw list, without culling.
    pub fn cell_cost(&self, meshes: &Meshes, c: usize, list: &mut DrawList) -> Submitted {
        self.draw_list([c], list);
        meshes.list(list, None)
    }
}
