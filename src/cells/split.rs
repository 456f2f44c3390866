//! `--split-geometry`: meshes that span several cells cut along the cell planes, so each cell
//! renders only its own part.
//!
//! Every triangle of a node listed by several cells is clipped to each of them. A part lying on
//! a face shared by two cells (a wall between two rooms) goes to the cell it faces into, the
//! one from which it can be seen, so the pieces of a mesh partition its surface.

use glam::DVec3;
use serde::Serialize;

use super::gather::node_triangles;
use super::CellSet;
use crate::geom::polyhedron::{clip_polygon, ConvexPolyhedron};
use crate::scene::{NodeId, Scene};

/// The part of one node's surface inside one cell, in world coordinates.
#[derive(Debug, Clone, Serialize)]
pub struct SplitPiece {
    /// Index into [`super::CellSet::cells`].
    pub cell: usize,
    /// The scene node the triangles were cut from.
    pub node: NodeId,
    /// The node's triangles clipped to the cell, world coordinates.
    pub triangles: Vec<[DVec3; 3]>,
}

/// Clips a triangle to a cell; returns the part as a convex polygon (empty if none).
fn clip_to_cell(t: &[DVec3; 3], cell: &ConvexPolyhedron, eps: f64) -> Vec<DVec3> {
    let normal = (t[1] - t[0]).cross(t[2] - t[0]);
    let mut poly: Vec<DVec3> = t.to_vec();
    for f in &cell.faces {
        // On this face: keep the part only if it faces into the cell.
        if t.iter().all(|p| f.plane.distance(*p).abs() <= eps) {
            if normal.dot(f.plane.normal) > 0.0 {
                return Vec::new();
            }
            continue;
        }
        poly = clip_polygon(&poly, f.plane.normal, f.plane.d);
        if poly.len() < 3 {
            return Vec::new();
        }
    }
    poly
}

/// The pieces of every node rendered by more than one cell (nodes in one cell stay whole and
/// are not listed).
pub fn split_geometry(scene: &Scene, set: &CellSet) -> Vec<SplitPiece> {
    let eps = set.tolerance.distance;
    let mut cells_of: std::collections::BTreeMap<NodeId, Vec<usize>> = Default::default();
    for (c, cell) in set.cells.iter().enumerate() {
        for &n in &cell.nodes {
            cells_of.entry(n).or_default().push(c);
        }
    }
    let mut out = Vec::new();
    for (node, cells) in cells_of {
        if cells.len() < 2 {
            continue;
        }
        let tris = node_triangles(scene, &[node], DVec3::ZERO);
        for c in cells {
            let mut piece = Vec::new();
            for t in &tris {
                let poly = clip_to_cell(t, &set.cells[c].poly, eps);
                for w in poly.windows(2).skip(1) {
                    let tri = [poly[0], w[0], w[1]];
                    if (tri[1] - tri[0]).cross(tri[2] - tri[0]).length_squared() > 0.0 {
                        piece.push(tri);
                    }
                }
            }
            if !piece.is_empty() {
                out.push(SplitPiece {
                    cell: c,
                    node,
                    triangles: piece,
                });
            }
        }
    }
    out
}
