//! `--tags auto`: rooms found in geometry nobody tagged.
//!
//! The air is found on a voxel grid in the level's own frame (`frame`): every voxel a
//! triangle touches is surface (`voxels`), and a voxel is air when the surfaces around it
//! face it (`air`). The air is split into rooms where it narrows, by a watershed on its
//! distance field (`rooms`), and each room's voxels become a few boxes (`boxes`), grown into
//! the surface voxels up to the first triangle (`grow`): where each room is.
//!
//! The voxels find rooms, not cells: a box stops short of a slanted wall, and a ray slipping
//! through that gap would reach a cell no portal leads to. The cells stage reads the level's
//! cells exactly, from its own planes, and gives each to the room whose boxes it overlaps
//! most (`cells::generated`); every later stage (portals, checks, PVS, export) runs unchanged.
//!
//! Rooms are generated where geometry lies in no tagged room (`pipeline::load` decides); in a
//! level tagged in part, the tagged cells bound the generated ones (`cells::generated`).

pub(crate) mod air;
mod boxes;
mod frame;
mod grow;
mod rooms;
mod voxels;

use std::time::Instant;

use glam::DVec3;
use serde::Serialize;

pub use frame::Frame;

use crate::geom::aabb::Aabb;
use crate::geom::polyhedron::ConvexPolyhedron;
use crate::scene::{NodeId, Scene};
use crate::tags::{Generated, Room, Tagging};

/// `[auto]`: how rooms are found in untagged geometry.
#[derive(Debug, Clone, serde::Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct AutoConfig {
    /// Edge of a voxel (m); unset: from the level's size and `max_voxels`. Openings narrower
    /// than about two voxels close.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub voxel: Option<f64>,
    /// The voxel budget the default voxel size is chosen for.
    pub max_voxels: usize,
    /// Two basins of the air stay apart, as two rooms, where the opening between them is
    /// narrower than this share of the smaller one's depth.
    pub split_ratio: f64,
    /// Planes whose triangles add up to less than this area (m²) are detail: they do not cut
    /// the cells (trims, pipes, the facets of a curved patch). Unset: a voxel's face.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub detail_area: Option<f64>,
}

impl Default for AutoConfig {
    fn default() -> Self {
        AutoConfig {
            voxel: None,
            max_voxels: 1 << 21,
            split_ratio: 0.6,
            detail_area: None,
        }
    }
}

/// The most voxels a grid may have, whatever `[auto] voxel` asks for.
const MOST_VOXELS: f64 = (1u64 << 26) as f64;

/// The priority of generated rooms: below every tagged room's.
pub const PRIORITY: i64 = -(1 << 40);

/// The nodes whose geometry blocks sight: every mesh node but those the tags ignore, mark as
/// detail, or use as portals, bounds or footprints.
fn blocking_nodes(scene: &Scene, t: &Tagging) -> Vec<NodeId> {
    let mut skip = vec![false; scene.nodes.len()];
    let refs = (t.ignored.iter().map(|r| r.node))
        .chain(t.detail.iter().map(|r| r.node))
        .chain(t.portals.iter().map(|p| p.node))
        .chain(t.bounds.iter().map(|b| b.node))
        .chain(t.footprints.iter().map(|b| b.node))
        .chain(t.rooms.iter().flat_map(|r| r.detail.iter().copied()));
    for n in refs {
        if let Some(s) = skip.get_mut(n) {
            *s = true;
        }
    }
    scene
        .walk()
        .into_iter()
        .filter(|&n| scene.nodes[n].mesh.is_some() && !skip[n])
        .collect()
}

/// Adds the rooms found in `scene`'s air to `tagging` and returns what was found.
pub fn generate(scene: &Scene, tagging: &mut Tagging, cfg: &AutoConfig) -> Generated {
    let mut seconds = Vec::new();
    let mut clock = Instant::now();
    let mut lap = |name: &'static str, seconds: &mut Vec<(&'static str, f64)>| {
        seconds.push((name, clock.elapsed().as_secs_f64()));
        clock = Instant::now();
    };
    let nodes = blocking_nodes(scene, tagging);
    let per_node: Vec<Vec<[DVec3; 3]>> = nodes.iter().map(|&n| world_triangles(scene, n)).collect();
    let world: Vec<[DVec3; 3]> = per_node.iter().flatten().copied().collect();
    let centre = centroid(&world);
    let tris: Vec<[DVec3; 3]> = world.iter().map(|t| t.map(|p| p - centre)).collect();
    let frame = Frame::of(&tris);
    let mut lo = DVec3::splat(f64::INFINITY);
    let mut hi = DVec3::splat(f64::NEG_INFINITY);
    for p in tris.iter().flatten() {
        let q = frame.to_frame(*p);
        lo = lo.min(q);
        hi = hi.max(q);
    }
    if tris.is_empty() {
        (lo, hi) = (DVec3::ZERO, DVec3::ONE);
    }
    let size = (hi - lo).max(DVec3::splat(1e-9));
    let h = cfg
        .voxel
        .filter(|v| v.is_finite() && *v > 0.0)
        .unwrap_or_else(|| (size.x * size.y * size.z / cfg.max_voxels.max(1) as f64).cbrt())
        .max(size.max_element() / 4096.0)
        // However small a voxel is asked for, the grid stays within memory (about 9 bytes a
        // voxel): the voxel used is the one the output records.
        .max((size.x * size.y * size.z / MOST_VOXELS).cbrt());
    let grid = voxels::Grid::around(frame, centre, lo, hi, h);
    lap("frame", &mut seconds);
    let surface = voxels::surface(&grid, &world, 1e-6);
    lap("voxelise", &mut seconds);
    let air = air::find(&grid, &surface, &world);
    lap("air", &mut seconds);
    let dist = rooms::distance(&grid, &air);
    let (label, count) = rooms::watershed(&grid, &dist, cfg.split_ratio);
    lap("rooms", &mut seconds);
    let per_room = boxes::boxes(&grid, &label, count);
    let in_grid: Vec<[DVec3; 3]> = world.iter().map(|t| t.map(|p| grid.to_grid(p))).collect();
    let grown = grow::grow(&grid, &surface, &in_grid, &per_room);
    let boxes: Vec<Vec<ConvexPolyhedron>> = grown
        .iter()
        .map(|bs| bs.iter().map(|b| oriented_box(&grid, b)).collect())
        .collect();
    lap("boxes", &mut seconds);
    let first_room = tagging.rooms.len();
    add_rooms(scene, tagging, &nodes, &per_node, &boxes, h);
    Generated {
        voxel: h,
        split_ratio: cfg.split_ratio,
        detail_area: cfg.detail_area.unwrap_or(h * h),
        grid: grid.dims,
        axes: frame.axes.map(|a| a.to_array()),
        surface_voxels: surface.iter().filter(|&&s| s).count(),
        air_voxels: air.iter().filter(|&&a| a).count(),
        first_room,
        boxes,
        seconds,
        nodes: {
            let mut v: Vec<(NodeId, Aabb)> = nodes
                .iter()
                .zip(&per_node)
                .map(|(&n, t)| (n, Aabb::from_points(t.iter().flatten())))
                .collect();
            v.sort_by_key(|x| x.0);
            v
        },
    }
}

/// A node's triangles in world space, as it winds them, leaving out any with a non-finite
/// corner.
fn world_triangles(scene: &Scene, n: NodeId) -> Vec<[DVec3; 3]> {
    let Some(m) = scene.nodes[n].mesh else {
        return Vec::new();
    };
    let world = scene.world_positions(n);
    let winding = scene.winding(n);
    (scene.meshes[m].triangles.iter())
        .filter_map(|&t| {
            let [a, b, c] = winding.order(t).map(|i| world.get(i as usize).copied());
            Some([a?, b?, c?]).filter(|t| t.iter().all(|p| p.is_finite()))
        })
        .collect()
}

/// The area-weighted centre of the triangles: it moves and turns with the level.
fn centroid(tris: &[[DVec3; 3]]) -> DVec3 {
    let (mut sum, mut area) = (DVec3::ZERO, 0.0);
    for t in tris {
        let a = 0.5 * (t[1] - t[0]).cross(t[2] - t[0]).length();
        sum += (t[0] + t[1] + t[2]) / 3.0 * a;
        area += a;
    }
    if area > 0.0 {
        sum / area
    } else {
        tris.first().map(|t| t[0]).unwrap_or(DVec3::ZERO)
    }
}

/// The world polyhedron of a box of voxels.
fn oriented_box(grid: &voxels::Grid, b: &grow::GridBox) -> ConvexPolyhedron {
    let local = ConvexPolyhedron::from_aabb(&Aabb {
        min: grid.origin + b[0] * grid.h,
        max: grid.origin + b[1] * grid.h,
    });
    let move_point = |p: DVec3| grid.centre + grid.frame.to_world(p);
    ConvexPolyhedron {
        faces: local
            .faces
            .into_iter()
            .map(|f| {
                let normal = grid.frame.to_world(f.plane.normal);
                let points: Vec<DVec3> = f.points.into_iter().map(move_point).collect();
                let d = normal.dot(points[0]);
                crate::geom::polyhedron::Face {
                    plane: crate::geom::plane::Plane { normal, d },
                    points,
                }
            })
            .collect(),
    }
}

/// Appends one tagging room per generated room: its structure is every blocking node whose
/// box comes within two voxels of the room's boxes, but for the tagged rooms' own: their
/// cells stand for them (`cells::generated`).
fn add_rooms(
    scene: &Scene,
    tagging: &mut Tagging,
    nodes: &[NodeId],
    per_node: &[Vec<[DVec3; 3]>],
    boxes: &[Vec<ConvexPolyhedron>],
    h: f64,
) {
    let node_boxes: Vec<Aabb> = per_node
        .iter()
        .map(|t| Aabb::from_points(t.iter().flatten()))
        .collect();
    let mut placed = vec![false; scene.nodes.len()];
    let mut tagged = vec![false; scene.nodes.len()];
    for n in (tagging.rooms.iter()).flat_map(|r| r.structure.iter().chain(&r.detail)) {
        if let Some(t) = tagged.get_mut(*n) {
            *t = true;
        }
    }
    for (k, room_boxes) in boxes.iter().enumerate() {
        let b = room_boxes
            .iter()
            .fold(Aabb::EMPTY, |b, c| b.union(&c.bounds()));
        let near = |nb: &Aabb| {
            (nb.min - 2.0 * h).cmple(b.max).all() && (nb.max + 2.0 * h).cmpge(b.min).all()
        };
        let structure: Vec<NodeId> = (nodes.iter().zip(&node_boxes))
            .filter(|(&n, nb)| !tagged[n] && !nb.is_empty() && near(nb))
            .map(|(&n, _)| n)
            .collect();
        for &n in &structure {
            placed[n] = true;
        }
        let node = structure
            .first()
            .copied()
            .or(nodes.first().copied())
            .unwrap_or(0);
        tagging.push_generated(Room {
            name: format!("auto-{k}"),
            node,
            path: "(generated)".into(),
            rule: "auto".into(),
            group: None,
            volume: crate::tags::rules::VolumeHint::Geometry,
            priority: PRIORITY,
            structure,
            detail: Vec::new(),
            bounds: Vec::new(),
            footprints: Vec::new(),
            area_of: None,
        });
    }
    tagging.unassigned.retain(|r| !placed[r.node]);
}
