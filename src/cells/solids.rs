//! Which of a room's meshes are solid blocks, and which of those are props.
//!
//! Levels are blocked out two ways, often mixed: surfaces that bound the air (a room shell, a
//! Doom sector's walls) and closed solids that bound it from outside (greybox slabs, CSG boxes,
//! brushes, wall kits). A *solid* is an edge-connected part of one node's mesh that is closed
//! (every edge is met by exactly as many triangles one way as the other, the vertices matched by
//! their world position within the tolerance) and encloses positive volume with its triangles facing out, by
//! the divergence theorem. A closed mesh facing in is a room shell, not a solid. The test reads
//! only the topology and the sign of a sum, so moving, turning or scaling a level cannot change
//! it.
//!
//! Which solids are props is decided in `props.rs`.

use std::collections::HashMap;

use glam::DVec3;

use crate::disjoint::DisjointSets;
use crate::geom::aabb::Aabb;
use crate::geom::hull::hull;
use crate::geom::plane::Plane;
use crate::geom::polyhedron::ConvexPolyhedron;
use crate::geom::tolerance::Tolerance;
use crate::scene::NodeId;

/// One closed, outward-facing part of a node's mesh.
#[derive(Debug, Clone)]
pub(crate) struct Solid {
    /// The node whose mesh it is part of.
    pub node: NodeId,
    /// Its triangles, facing out (recentred coordinates).
    pub tris: Vec<[DVec3; 3]>,
    pub bounds: Aabb,
    /// Its convex hull (the solid itself when `convex`).
    pub hull: Option<ConvexPolyhedron>,
    /// Every vertex lies behind every one of its triangles' planes.
    pub convex: bool,
}

impl Solid {
    /// Whether `p` lies inside the solid by more than `eps`.
    pub fn contains(&self, p: DVec3, eps: f64) -> bool {
        let (lo, hi) = (self.bounds.min, self.bounds.max);
        if (0..3).any(|k| p[k] <= lo[k] + eps || p[k] >= hi[k] - eps) {
            return false;
        }
        match (&self.hull, self.convex) {
            (Some(h), true) => h.contains_strictly(p, eps),
            _ => super::interior::winding_number(&self.tris, p) > 0.5,
        }
    }
}

impl Solid {
    /// Whether `p` lies inside the solid or on its boundary, within `eps`: where qbsp, finding
    /// an entity's leaf, prefers the side that seals.
    pub fn holds(&self, p: DVec3, eps: f64) -> bool {
        let (lo, hi) = (self.bounds.min, self.bounds.max);
        if (0..3).any(|k| p[k] < lo[k] - eps || p[k] > hi[k] + eps) {
            return false;
        }
        match (&self.hull, self.convex) {
            (Some(h), true) => h.contains(p, eps),
            _ => [
                DVec3::ZERO,
                DVec3::X,
                -DVec3::X,
                DVec3::Y,
                -DVec3::Y,
                DVec3::Z,
                -DVec3::Z,
            ]
            .iter()
            .any(|d| super::interior::winding_number(&self.tris, p + *d * eps) > 0.5),
        }
    }
}

/// A node's triangles split into its solids and the rest (surfaces).
pub(crate) fn split_node(
    node: NodeId,
    tris: &[[DVec3; 3]],
    eps: f64,
) -> (Vec<Solid>, Vec<[DVec3; 3]>) {
    let (solids, rest, _) = split_node_open(node, tris, eps);
    (solids, rest)
}

/// The most open edges a part may have and still be taken for a block left open by mistake:
/// a missing triangle opens three, a missing quad four, two missing triangles six. A room
/// shell open at the top faces in and a sheet of surface has a long open rim.
const MAX_OPEN_EDGES: usize = 6;

/// The open edges of one part, as segments.
pub(crate) type OpenEdges = Vec<[DVec3; 2]>;

/// [`split_node`], with the open edges (world segments, recentred) of each part that looks
/// meant as a block but is not closed: a few open edges, the rest closed, facing out.
pub(crate) fn split_node_open(
    node: NodeId,
    tris: &[[DVec3; 3]],
    eps: f64,
) -> (Vec<Solid>, Vec<[DVec3; 3]>, Vec<OpenEdges>) {
    // Vertices matched by position within the tolerance: a closed mesh shares them (an
    // exporter that split a box's corners for flat normals wrote the same coordinates three
    // times, and one writing f32 brushes wrote a corner where three faces meet as `0.0`,
    // `2.8e-16` and `-3.7e-14`).
    let corners: Vec<DVec3> = tris.iter().flatten().copied().collect();
    let welded = crate::geom::weld::weld(&corners, eps);
    let mut ids: HashMap<[u64; 3], u32> = HashMap::new();
    let mut id = |p: DVec3| {
        let key = [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()];
        let next = ids.len() as u32;
        *ids.entry(key).or_insert(next)
    };
    let tri_ids: Vec<[u32; 3]> = welded
        .chunks_exact(3)
        .map(|t| [id(t[0]), id(t[1]), id(t[2])])
        .collect();
    // Directed edge -> (triangles using it), and union-find over triangles sharing an edge.
    let mut edges: HashMap<(u32, u32), Vec<u32>> = HashMap::new();
    for (k, t) in tri_ids.iter().enumerate() {
        for i in 0..3 {
            let (a, b) = (t[i], t[(i + 1) % 3]);
            if a != b {
                edges.entry((a, b)).or_default().push(k as u32);
            }
        }
    }
    let mut parts = DisjointSets::new(tris.len());
    let mut keys: Vec<&(u32, u32)> = edges.keys().collect();
    keys.sort_unstable();
    for &(a, b) in keys {
        let mut all: Vec<u32> = edges[&(a, b)].clone();
        if let Some(r) = edges.get(&(b, a)) {
            all.extend_from_slice(r);
        }
        for w in all.windows(2) {
            parts.union(w[0] as usize, w[1] as usize);
        }
    }
    let mut groups: Vec<Vec<u32>> = Vec::new();
    let mut group_of: HashMap<u32, usize> = HashMap::new();
    for k in 0..tris.len() as u32 {
        let r = parts.find(k as usize) as u32;
        let g = *group_of.entry(r).or_insert_with(|| {
            groups.push(Vec::new());
            groups.len() - 1
        });
        groups[g].push(k);
    }
    let (mut solids, mut rest, mut open) = (Vec::new(), Vec::new(), Vec::new());
    for g in groups {
        // Each edge whose triangles one way and the other do not match, once.
        let mut gaps: Vec<[DVec3; 2]> = Vec::new();
        for &k in &g {
            let t = tri_ids[k as usize];
            for i in 0..3 {
                let (a, b) = (t[i], t[(i + 1) % 3]);
                let (fwd, back) = (
                    edges.get(&(a, b)).map_or(0, Vec::len),
                    edges.get(&(b, a)).map_or(0, Vec::len),
                );
                if a != b && fwd != back && (fwd > back || a < b) {
                    let p = tris[k as usize];
                    gaps.push([p[i], p[(i + 1) % 3]]);
                }
            }
        }
        let part: Vec<[DVec3; 3]> = g.iter().map(|&k| tris[k as usize]).collect();
        if gaps.is_empty() && g.len() >= 4 {
            if let Some(s) = solid(node, part.clone(), eps) {
                solids.push(s);
                continue;
            }
        }
        let few = !gaps.is_empty() && gaps.len() <= MAX_OPEN_EDGES && g.len() >= 8;
        if few && solid(node, part.clone(), eps).is_some() {
            open.push(gaps);
        }
        rest.extend(part);
    }
    (solids, rest, open)
}

/// A closed part as a solid, if it faces out and has volume.
fn solid(node: NodeId, tris: Vec<[DVec3; 3]>, eps: f64) -> Option<Solid> {
    let bounds = Aabb::from_points(tris.iter().flatten());
    let c = (bounds.min + bounds.max) * 0.5;
    let volume: f64 = tris
        .iter()
        .map(|t| (t[0] - c).dot((t[1] - c).cross(t[2] - c)) / 6.0)
        .sum();
    let size = bounds.size();
    if volume <= eps * size.x.max(size.y).max(size.z).powi(2) {
        return None;
    }
    let pts: Vec<DVec3> = tris.iter().flatten().copied().collect();
    let h = hull(&pts, eps).ok();
    let convex = h.is_some()
        && tris.iter().all(|t| {
            let Some(pl) = Plane::from_polygon(t) else {
                return true;
            };
            pts.iter().all(|p| pl.distance(*p) <= eps)
        });
    Some(Solid {
        node,
        tris,
        bounds,
        hull: h,
        convex,
    })
}

/// On how many distinct faces of a hull a solid has a face (lying on it, facing out).
pub(crate) fn on_hull_faces(s: &Solid, hull: &ConvexPolyhedron, eps: f64) -> usize {
    hull.faces
        .iter()
        .filter(|f| {
            s.tris.iter().any(|t| {
                t.iter()
                    .all(|p| f.plane.distance(*p).abs() <= Tolerance::touching(eps))
                    && (t[1] - t[0]).cross(t[2] - t[0]).dot(f.plane.normal) > 0.0
            })
        })
        .count()
}
