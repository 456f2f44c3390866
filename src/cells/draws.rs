//! What each cell draws, triangle by triangle.
//!
//! A cell names whole nodes (`Cell::nodes`), and a node that reaches into several cells (a
//! sector's floor under four cells, a level merged into one mesh) is drawn whenever any of
//! them is seen. Here every triangle of such a node gets the cells it lies in, and the node's
//! triangles are grouped into runs of one set of cells each, in the primitive's own indices,
//! so an engine draws of a node only the runs of the cells it sees (dmap cuts surfaces by
//! area, qbsp lists each leaf's faces; here the cut is by index, not by geometry).
//!
//! The rule (the extension's page states it): a triangle *lies in* a cell when, shrunk
//! inward by a little more than the tolerance, it touches the cell's closed volume grown by
//! the tolerance (a floor on a cell's bottom face, a wall whose foot stands on it, a triangle
//! crossing it, but not a wall whose top edge meets the floor of the cell above), and, when
//! it is drawn from its front only, the cell reaches in front of its plane (a ceiling is not
//! the cell's above whose floor it lies on). A triangle in no cell (a jamb in a wall, trim
//! buried in it, a triangle dropped as degenerate) is drawn by the cells that draw its node.
//! In a sealed level of solid blocks (a brush map, or the same brushes in any format:
//! [`CellSet::solid_beyond`]) a triangle in no cell is drawn by none: the cells are qbsp's
//! air leaves, and a face that borders no air leaf (one facing the void, one against another
//! brush) is one qbsp gives no leaf's marksurfaces; it cannot be seen.
//! Runs are in order of their cells (as lists, lowest first, compared as sequences), each
//! run's triangles in the primitive's order.

use glam::DVec3;
use rayon::prelude::*;

use super::CellSet;
use crate::geom::aabb::Aabb;
use crate::geom::grid::BoxGrid;
use crate::geom::polyhedron::{clip_polygon, ConvexPolyhedron};
use crate::scene::{NodeId, Scene};

/// A run of one primitive's triangles that lie in the same cells.
#[derive(Debug, Clone, PartialEq)]
pub struct Run {
    /// The first of the run's triangles in [`PrimitiveDraws::triangles`].
    pub first: u32,
    /// How many triangles.
    pub count: u32,
    /// The cells that draw them, ascending.
    pub cells: Vec<u32>,
}

/// One primitive of a node's mesh, its triangles in runs.
#[derive(Debug, Clone, PartialEq)]
pub struct PrimitiveDraws {
    /// The primitive's index in its mesh, as written.
    pub primitive: usize,
    /// Its triangles in the primitive's own indices, run by run.
    pub triangles: Vec<[u32; 3]>,
    /// The runs covering `triangles`, in order.
    pub runs: Vec<Run>,
}

/// A node whose triangles lie in different sets of cells.
#[derive(Debug, Clone, PartialEq)]
pub struct NodeDraws {
    /// The node.
    pub node: NodeId,
    /// Its mesh's primitives with triangles, in mesh order.
    pub primitives: Vec<PrimitiveDraws>,
}

/// What every cell draws.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Draws {
    /// Per cell, the nodes it draws (whole or in part), ascending: each node in the cells its
    /// triangles lie in, and, for triangles in none, in the cells that draw it as a whole.
    pub nodes: Vec<Vec<NodeId>>,
    /// The nodes drawn in part, by node.
    pub split: Vec<NodeDraws>,
}

/// A mesh primitive's triangles as the output indexes them, with the scene triangle each
/// is (`None`: dropped on import) and the primitive's index in its written mesh.
struct Written {
    primitive: usize,
    triangles: Vec<[u32; 3]>,
    scene: Vec<Option<usize>>,
}

/// The primitives of node `n`'s mesh as the output writes them: a glTF input's as its file
/// has them, any other's as the scene has them (one written primitive per primitive with
/// triangles, `export::gltf_out`).
fn written(scene: &Scene, n: NodeId) -> Vec<Written> {
    let Some(m) = scene.nodes[n].mesh else {
        return Vec::new();
    };
    let mesh = &scene.meshes[m];
    let mut out = Vec::new();
    let mut ordinal = 0;
    for p in &mesh.primitives {
        let range = p.first_triangle..p.first_triangle + p.triangle_count;
        match &p.file {
            Some(f) => {
                let Some(k) = (p.source.pointer.as_deref())
                    .and_then(|s| s.rsplit('/').next())
                    .and_then(|k| k.parse().ok())
                else {
                    continue;
                };
                out.push(Written {
                    primitive: k,
                    triangles: f.triangles.clone(),
                    scene: (f.scene.iter())
                        .map(|&s| (s != u32::MAX).then_some(s as usize))
                        .collect(),
                });
            }
            None if p.triangle_count > 0 => {
                out.push(Written {
                    primitive: ordinal,
                    triangles: mesh.triangles.get(range.clone()).unwrap_or(&[]).to_vec(),
                    scene: range.map(Some).collect(),
                });
                ordinal += 1;
            }
            None => {}
        }
    }
    out
}

/// The triangle a cell must touch (grown by `eps`) for `t` to lie in it: `t` with its edges
/// moved [`INSET`] tolerances inward, so that a wall whose top edge meets the floor of the
/// cell above (or whose side edge meets the room next door) is not the upper cell's; a
/// triangle too thin to have such an inset, itself.
fn inset(t: &[DVec3; 3], eps: f64) -> [DVec3; 3] {
    let (a, b, c) = (
        (t[1] - t[2]).length(),
        (t[2] - t[0]).length(),
        (t[0] - t[1]).length(),
    );
    let perimeter = a + b + c;
    let area = 0.5 * (t[1] - t[0]).cross(t[2] - t[0]).length();
    let inradius = 2.0 * area / perimeter;
    let inset = INSET * eps;
    if inradius.is_nan() || inradius <= inset {
        return *t;
    }
    let centre = (t[0] * a + t[1] * b + t[2] * c) / perimeter;
    let k = (inradius - inset) / inradius;
    t.map(|p| centre + (p - centre) * k)
}

/// Past how many cells near a node its triangles' cells are looked up in the grid rather
/// than among the node's.
const NEAR_BY_GRID: usize = 32;

/// How far inward, in tolerances, a triangle's edges move before it is judged against a cell
/// ([`inset`]): past the tolerance a cell is grown by, and one more for the rounding of a
/// point placed on an edge.
const INSET: f64 = 2.0;

/// Per triangle of node `n`'s mesh, whether only its front is drawn: a glTF material without
/// `doubleSided` (or no material in a glTF file), a brush face but a liquid's.
fn one_sided(scene: &Scene, n: NodeId) -> Vec<bool> {
    let Some(mesh) = scene.nodes[n].mesh.map(|m| &scene.meshes[m]) else {
        return Vec::new();
    };
    let unstated = !matches!(
        scene.format,
        crate::scene::Format::Gltf | crate::scene::Format::Glb
    );
    let mut out = vec![false; mesh.triangles.len()];
    for p in &mesh.primitives {
        let both = p
            .material
            .and_then(|m| scene.materials.get(m))
            .map_or(unstated, |m| m.double_sided);
        let end = (p.first_triangle + p.triangle_count).min(out.len());
        out[p.first_triangle.min(end)..end].fill(!both);
    }
    out
}

/// Whether a cell lies wholly behind the plane through `at` facing `front` (within `eps`):
/// from no point of it, and through no point of it, is that side of the plane seen, so a
/// triangle drawn from its front only is never the cell's to draw, though it touch the cell
/// (a ceiling lying on the floor of the cell above, a wall backing onto the room next door).
fn behind(cell: &ConvexPolyhedron, front: DVec3, at: DVec3, eps: f64) -> bool {
    (cell.faces.iter())
        .flat_map(|f| &f.points)
        .all(|&p| front.dot(p - at) <= eps)
}

/// Whether a triangle touches a convex cell grown by `eps`.
fn touches(t: &[DVec3; 3], cell: &ConvexPolyhedron, eps: f64) -> bool {
    // Most triangles are wholly inside a cell or wholly beyond one of its faces: no clipping.
    let mut inside = true;
    for f in &cell.faces {
        let out = t.map(|p| f.plane.normal.dot(p) > f.plane.d + eps);
        if out.iter().all(|&o| o) {
            return false;
        }
        inside &= !out.iter().any(|&o| o);
    }
    if inside {
        return true;
    }
    let mut poly = t.to_vec();
    for f in &cell.faces {
        poly = clip_polygon(&poly, f.plane.normal, f.plane.d + eps);
        if poly.is_empty() {
            return false;
        }
    }
    true
}

/// Every cell's draw list (see the module's documentation). `sealed`: the level has no
/// opening to the exterior.
pub fn of(scene: &Scene, set: &CellSet, sealed: bool) -> Draws {
    let unseen = sealed && set.solid_beyond;
    let eps = set.tolerance.distance;
    let grid = BoxGrid::new(set.cells.iter().map(|c| c.bounds).collect());
    // The cells that draw each node whole: the cells stage's own lists.
    let mut whole: Vec<Vec<u32>> = vec![Vec::new(); scene.nodes.len()];
    for (c, cell) in set.cells.iter().enumerate() {
        for &n in &cell.nodes {
            whole[n].push(c as u32);
        }
    }
    // What no cell renders (a portal's or a bound's mesh, geometry reported in no cell) no
    // cell draws, in part or whole.
    let nodes: Vec<NodeId> = (0..scene.nodes.len())
        .filter(|&n| scene.nodes[n].mesh.is_some() && !whole[n].is_empty())
        .collect();
    let found: Vec<(NodeId, Vec<u32>, Option<NodeDraws>)> = nodes
        .par_iter()
        .map(|&n| {
            let orphans: &[u32] = if unseen { &[] } else { &whole[n] };
            node(scene, set, &grid, n, (&whole[n], orphans), eps)
        })
        .collect();
    let mut out = Draws {
        nodes: vec![Vec::new(); set.cells.len()],
        split: Vec::new(),
    };
    for (n, cells, split) in found {
        for c in cells {
            out.nodes[c as usize].push(n);
        }
        out.split.extend(split);
    }
    out
}

/// Node `n`'s cells (every cell drawing some of it) and, when its triangles lie in different
/// sets of cells, its runs.
fn node(
    scene: &Scene,
    set: &CellSet,
    grid: &BoxGrid,
    n: NodeId,
    (whole, orphans): (&[u32], &[u32]),
    eps: f64,
) -> (NodeId, Vec<u32>, Option<NodeDraws>) {
    let world = scene.world_positions(n);
    let winding = scene.winding(n);
    // A node in one cell that no other cell comes near is that cell's whole: each of its
    // triangles touches that cell or none (and then goes to the cells listing it).
    let near = grid.query(&Aabb::from_points(world.iter()), eps);
    if let [only] = whole {
        if orphans == whole && near.iter().all(|&c| c as u32 == *only) {
            return (n, whole.to_vec(), None);
        }
    }
    // The cells near a triangle: from the node's few near cells by box, or, for a node
    // spanning many (a sector's floor), from the grid.
    let near_triangle = |b: &Aabb| -> Vec<usize> {
        if near.len() > NEAR_BY_GRID {
            return grid.query(b, eps);
        }
        (near.iter().copied())
            .filter(|&c| {
                let cb = &set.cells[c].bounds;
                (b.min - eps).cmple(cb.max).all() && (b.max + eps).cmpge(cb.min).all()
            })
            .collect()
    };
    let mesh = scene.nodes[n].mesh.map(|m| &scene.meshes[m]);
    let scene_tris = mesh.map_or(&[][..], |m| &m.triangles[..]);
    let one_sided = one_sided(scene, n);
    let cells_of = |(k, t): (usize, &[u32; 3])| -> Vec<u32> {
        let Some(tri) = (winding
            .order(*t)
            .iter()
            .map(|&i| world.get(i as usize).copied()))
        .collect::<Option<Vec<DVec3>>>() else {
            return orphans.to_vec();
        };
        let tri = [tri[0], tri[1], tri[2]];
        let front = one_sided[k]
            .then(|| (tri[1] - tri[0]).cross(tri[2] - tri[0]).try_normalize())
            .flatten();
        let b = Aabb::from_points(tri.iter());
        let inner = inset(&tri, eps);
        let mut cs: Vec<u32> = (near_triangle(&b).into_iter())
            .filter(|&c| touches(&inner, &set.cells[c].poly, eps))
            .filter(|&c| front.is_none_or(|f| !behind(&set.cells[c].poly, f, tri[0], eps)))
            .map(|c| c as u32)
            .collect();
        cs.sort_unstable();
        if cs.is_empty() {
            cs = orphans.to_vec();
        }
        cs
    };
    let per_scene: Vec<Vec<u32>> = scene_tris.iter().enumerate().map(cells_of).collect();
    let prims: Vec<(Written, Vec<Vec<u32>>)> = written(scene, n)
        .into_iter()
        .map(|w| {
            let sets = (w.scene.iter())
                .map(|s| {
                    s.and_then(|s| per_scene.get(s).cloned())
                        .unwrap_or(orphans.to_vec())
                })
                .collect();
            (w, sets)
        })
        .collect();
    let mut all: Vec<u32> = prims
        .iter()
        .flat_map(|(_, s)| s.iter().flatten().copied())
        .collect();
    all.sort_unstable();
    all.dedup();
    // A node is drawn whole by the cells that list it when its triangles lie in just those.
    let as_listed = prims.iter().all(|(_, s)| s.iter().all(|x| x == whole));
    if as_listed {
        return (n, all, None);
    }
    let primitives = prims.into_iter().map(|(w, sets)| runs(w, sets)).collect();
    (
        n,
        all,
        Some(NodeDraws {
            node: n,
            primitives,
        }),
    )
}

/// A primitive's triangles sorted into runs by their cells.
fn runs(w: Written, sets: Vec<Vec<u32>>) -> PrimitiveDraws {
    let mut order: Vec<usize> = (0..w.triangles.len()).collect();
    // Stable: a run keeps the primitive's order.
    order.sort_by(|&a, &b| sets[a].cmp(&sets[b]));
    let mut runs: Vec<Run> = Vec::new();
    for (k, &t) in order.iter().enumerate() {
        match runs.last_mut() {
            Some(r) if r.cells == sets[t] => r.count += 1,
            _ => runs.push(Run {
                first: k as u32,
                count: 1,
                cells: sets[t].clone(),
            }),
        }
    }
    PrimitiveDraws {
        primitive: w.primitive,
        triangles: order.iter().map(|&t| w.triangles[t]).collect(),
        runs,
    }
}
