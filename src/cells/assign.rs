//! Which nodes each cell renders. Structure goes to every cell of its room it reaches into;
//! props go to the cell containing their centre, or, when their centre lies in a wall, to
//! every cell they reach into; geometry outside every room goes to every cell it reaches
//! into. What reaches into no cell but lies in a wall in front of a cell's face (the jambs
//! of a door through a thick wall) goes to the cells it faces; geometry in no cell and
//! facing none is reported, except in a brush map, where it is buried in solid.

use glam::DVec3;
use rayon::prelude::*;

use super::gather::node_triangles;
use super::{Cell, CellSet};
use crate::diag::{Code, Diagnostic, Location};
use crate::geom::aabb::Aabb;
use crate::geom::grid::BoxGrid;
use crate::geom::polyhedron::{clip_polygon, polygon_area, ConvexPolyhedron};
use crate::scene::{NodeId, Scene};
use crate::tags::Tagging;

/// The cells a node lying in no cell faces from inside a wall: a jamb, sill or lintel in the
/// reveal of a door through a thick wall, or trim buried in a wall, seen through the opening
/// from the cells on either side. A triangle's corner or middle counts when it lies in front
/// of a cell's face, at most `reach` (the thickest wall) away, and its foot on the face's
/// plane is in the cell.
fn facing_cells(tris: &[[DVec3; 3]], set: &CellSet, reach: f64, eps: f64) -> Vec<usize> {
    let mut b = crate::geom::aabb::Aabb::EMPTY;
    tris.iter().flatten().for_each(|p| b.add(*p));
    if b.is_empty() {
        return Vec::new();
    }
    let samples: Vec<DVec3> = tris
        .iter()
        .flat_map(|t| [t[0], t[1], t[2], (t[0] + t[1] + t[2]) / 3.0])
        .collect();
    let grow = reach + eps;
    (0..set.cells.len())
        .filter(|&c| {
            let cb = &set.cells[c].bounds;
            (b.min - grow).cmple(cb.max).all() && (b.max + grow).cmpge(cb.min).all()
        })
        .filter(|&c| {
            let poly = &set.cells[c].poly;
            poly.faces.iter().any(|f| {
                samples.iter().any(|&p| {
                    let d = f.plane.distance(p);
                    d > eps && d <= grow && poly.contains(p - f.plane.normal * d, eps)
                })
            })
        })
        .collect()
}

/// Whether a meaningful part of the triangle (not a sliver along a shared face) is in the cell.
fn triangle_in_cell(t: &[DVec3; 3], cell: &ConvexPolyhedron, eps: f64) -> bool {
    let n = (t[1] - t[0]).cross(t[2] - t[0]);
    let area = 0.5 * n.length();
    let Some(normal) = n.try_normalize() else {
        return false;
    };
    let mut poly: Vec<DVec3> = t.to_vec();
    for f in &cell.faces {
        poly = clip_polygon(&poly, f.plane.normal, f.plane.d + eps);
        if poly.len() < 3 {
            return false;
        }
    }
    polygon_area(&poly, normal) > IN_CELL_SHARE * area
}

/// The share of a triangle's area that must lie in a cell for the cell to render it: a
/// triangle touching the cell only along a shared face or an edge, clipped with the
/// tolerance, leaves a sliver a tolerance wide inside, a vanishing share of its area.
const IN_CELL_SHARE: f64 = 1e-3;

fn node_in_cell(tris: &[[DVec3; 3]], cell: &Cell, eps: f64) -> bool {
    let b = &cell.bounds;
    tris.iter().any(|t| {
        let outside = (0..3).any(|k| {
            t.iter().all(|p| p[k] < b.min[k] - eps) || t.iter().all(|p| p[k] > b.max[k] + eps)
        });
        !outside && triangle_in_cell(t, &cell.poly, eps)
    })
}

/// The box of a node's triangles.
fn tris_bounds(tris: &[[DVec3; 3]]) -> Aabb {
    Aabb::from_points(tris.iter().flatten())
}

/// A room's structure lying farther than `reach` (the thickest wall) from every cell of its
/// room is not the room's shell but something misplaced (a crate left 30 m away under the
/// room's node): it is taken off the cells that rendered it by default and reported as
/// geometry in no cell, as a prop there would be.
pub fn drop_far_structure(scene: &Scene, tagging: &Tagging, set: &mut CellSet, reach: f64) {
    let eps = set.tolerance.distance;
    let props: std::collections::HashSet<NodeId> = set.props.iter().map(|p| p.node).collect();
    let mut far: Vec<NodeId> = Vec::new();
    for (ri, room) in tagging.rooms.iter().enumerate() {
        let mine = &set.room_cells[ri];
        // A generated room's structure is every node near it; unreached nodes are placed.
        let generated = generated_of(tagging, ri).is_some();
        if mine.is_empty() || generated {
            continue;
        }
        for &n in room.structure.iter().filter(|n| !props.contains(n)) {
            let mut b = crate::geom::aabb::Aabb::EMPTY;
            scene.world_positions_used_iter(n).for_each(|p| b.add(p));
            if b.is_empty() {
                continue;
            }
            let near = mine.iter().any(|&c| {
                let cb = &set.cells[c].bounds;
                let grow = reach + eps;
                (b.min - grow).cmple(cb.max).all() && (b.max + grow).cmpge(cb.min).all()
            });
            if !near {
                far.push(n);
            }
        }
    }
    if far.is_empty() {
        return;
    }
    for c in &mut set.cells {
        c.nodes.retain(|n| !far.contains(n));
    }
    far.sort_unstable();
    if !buried_in_solid(set) {
        set.diagnostics
            .extend(far.into_iter().map(|n| outside_diagnostic(scene, n)));
    }
}

/// Whether geometry in no cell, facing none, is buried in solid and needs no cell: where every
/// room is read as solid blocks (a brush map as qbsp reads one, or the same brushes in any
/// format), everything but the air the outside fill leaves is solid, so a detail brush in no
/// cell lies wholly in a wall or in the filled void, and nothing can see it (reported, such
/// brushes are only noise to a qbsp user). Detail touching a cell's face is in that cell, and
/// detail in a wall facing a cell through an opening is that cell's, so neither comes here.
/// Around rooms read otherwise the space outside them is open, and geometry there (a crate
/// left 30 m away) is reported.
fn buried_in_solid(set: &CellSet) -> bool {
    set.solid_beyond
}

/// `CELL_GEOMETRY_OUTSIDE` for node `n`, placed at the middle of its box.
fn outside_diagnostic(scene: &Scene, n: NodeId) -> Diagnostic {
    let pts = scene.world_positions_used(n);
    let b = crate::geom::aabb::Aabb::from_points(pts.iter());
    Diagnostic::new(
        Code::CELL_GEOMETRY_OUTSIDE,
        format!(
            "`{}` lies in no cell, so no cell renders it",
            scene.node_label(n)
        ),
        Location::file(&scene.path)
            .with_source(scene.nodes[n].source.clone())
            .with_node(scene.node_path(n))
            .with_position(((b.min + b.max) * 0.5).to_array()),
    )
    .hint("move it inside a room, make it a child of the room it belongs to, or tag it `ignore`")
}

/// What `--tags auto` generated, if it made room `room`.
fn generated_of(tagging: &Tagging, room: usize) -> Option<&crate::tags::Generated> {
    let g = tagging.generated.as_deref()?;
    g.boxes_of(room).map(|_| g)
}

/// The generated rooms' structure, each node in every generated cell one of its triangles
/// touches (cells meet the walls, so within a few tolerances).
fn place_generated(
    placer: &Placer,
    scene: &Scene,
    tagging: &Tagging,
    set: &CellSet,
    out: &mut Placed,
) {
    let Some(g) = tagging.generated.as_deref() else {
        return;
    };
    let rooms = g.first_room..tagging.rooms.len();
    let own: std::collections::HashSet<usize> = rooms
        .clone()
        .flat_map(|r| set.room_cells.get(r).into_iter().flatten().copied())
        .collect();
    let mut nodes: Vec<NodeId> = rooms
        .flat_map(|r| tagging.rooms[r].structure.iter().copied())
        .collect();
    nodes.sort_unstable();
    nodes.dedup();
    let r = 4.0 * set.tolerance.distance;
    for n in nodes {
        let tris = node_triangles(scene, &[n], DVec3::ZERO);
        out.0.extend(
            placer
                .near_triangles(&tris, &own, r)
                .into_iter()
                .map(|c| (c, n)),
        );
    }
}

/// Generated rooms' structure that no generated cell comes near (it faces only the void, or
/// lies in a wall's middle) goes to the generated cell nearest its middle: drawn by a cell
/// that may see it rather than dropped.
fn place_unreached_generated(
    tagging: &Tagging,
    set: &CellSet,
    mut rooms: Vec<Placed>,
) -> Vec<Placed> {
    let Some(g) = tagging.generated.as_deref() else {
        return rooms;
    };
    let made: Vec<usize> = (g.first_room..tagging.rooms.len())
        .flat_map(|r| set.room_cells.get(r).into_iter().flatten().copied())
        .collect();
    let placed: std::collections::HashSet<NodeId> = rooms
        .iter()
        .flat_map(|p| p.0.iter().map(|&(_, n)| n))
        .collect();
    let mut wanted: Vec<NodeId> = (g.first_room..tagging.rooms.len())
        .flat_map(|r| tagging.rooms[r].structure.iter().copied())
        .filter(|n| !placed.contains(n))
        .collect();
    wanted.sort_unstable();
    wanted.dedup();
    let Some(last) = rooms.last_mut() else {
        return rooms;
    };
    for n in wanted {
        let Some(b) = g.node_bounds(n) else { continue };
        let mid = (b.min + b.max) * 0.5;
        let gap = |c: usize| set.cells[c].bounds.distance_to(mid);
        if let Some(c) = made
            .iter()
            .copied()
            .min_by(|&a, &b| gap(a).total_cmp(&gap(b)).then(a.cmp(&b)))
        {
            last.0.push((c, n));
        }
    }
    rooms
}

/// (cell, node) placements and nodes in no cell, of one room (or of the loose nodes).
type Placed = (Vec<(usize, NodeId)>, Vec<NodeId>);

/// Places nodes in cells, finding the cells near a node through a grid of their boxes (not
/// every cell for every node: a brush map's one room has thousands of both).
struct Placer<'a> {
    scene: &'a Scene,
    set: &'a CellSet,
    grid: BoxGrid,
    reach: f64,
    eps: f64,
}

impl<'a> Placer<'a> {
    fn new(scene: &'a Scene, set: &'a CellSet, reach: f64) -> Placer<'a> {
        let grid = BoxGrid::new(set.cells.iter().map(|c| c.bounds).collect());
        let eps = set.tolerance.distance;
        Placer {
            scene,
            set,
            grid,
            reach,
            eps,
        }
    }

    /// The cells whose boxes meet `b` (ascending).
    fn near(&self, b: &Aabb) -> Vec<usize> {
        self.grid.query(b, self.eps)
    }

    /// The cells of `own` some triangle comes within `r` of (ascending).
    fn near_triangles(
        &self,
        tris: &[[DVec3; 3]],
        own: &std::collections::HashSet<usize>,
        r: f64,
    ) -> Vec<usize> {
        let mut hit: Vec<usize> = Vec::new();
        for t in tris {
            let b = Aabb::from_points(t.iter());
            let grown = Aabb {
                min: b.min - r,
                max: b.max + r,
            };
            for c in self.near(&grown) {
                if own.contains(&c)
                    && !hit.contains(&c)
                    && triangle_in_cell(t, &self.set.cells[c].poly, r)
                {
                    hit.push(c);
                }
            }
        }
        hit.sort_unstable();
        hit
    }

    /// The cell containing `p`: one of `prefer` first, else the lowest-numbered.
    fn containing(&self, p: DVec3, prefer: &[usize]) -> Option<usize> {
        let inside = |c: &usize| self.set.cells[*c].poly.contains(p, self.eps);
        let point = Aabb { min: p, max: p };
        (prefer.iter().copied().find(inside)).or_else(|| self.near(&point).into_iter().find(inside))
    }

    /// A prop or detail node: the cell containing its middle (of `prefer` first), else every
    /// cell it reaches into or faces, else outside.
    fn prop(&self, n: NodeId, prefer: &[usize], out: &mut Placed) {
        let (scene, set, eps) = (self.scene, self.set, self.eps);
        let mut b = Aabb::EMPTY;
        scene.world_positions_used_iter(n).for_each(|p| b.add(p));
        if b.is_empty() {
            return;
        }
        if let Some(c) = self.containing((b.min + b.max) * 0.5, prefer) {
            out.0.push((c, n));
            return;
        }
        // Its middle is in a wall (a trim, a pillar or a door half in the wall): every cell
        // it reaches into renders it, as for structure; only what reaches none is outside.
        let tris = node_triangles(scene, &[n], DVec3::ZERO);
        let within = |c: &usize| node_in_cell(&tris, &set.cells[*c], eps);
        let mut hit: Vec<usize> = prefer.iter().copied().filter(within).collect();
        if hit.is_empty() {
            hit = self
                .near(&tris_bounds(&tris))
                .into_iter()
                .filter(within)
                .collect();
        }
        if hit.is_empty() {
            hit = facing_cells(&tris, set, self.reach, eps);
        }
        match hit.is_empty() {
            true => out.1.push(n),
            false => out.0.extend(hit.into_iter().map(|c| (c, n))),
        }
    }
}

/// Per cell, the nodes it renders (ascending), and a diagnostic for each node in no cell.
/// `took[r]` lists the cells of other rooms that took part of room `r`'s space where they
/// overlapped (`overlap.rs`): they render the room's structure they reach into too. Rooms
/// are placed in parallel and their findings joined in room order, so the result does not
/// depend on the thread count.
pub(crate) fn find(
    scene: &Scene,
    tagging: &Tagging,
    set: &CellSet,
    took: &[Vec<usize>],
    reach: f64,
) -> (Vec<Vec<NodeId>>, Vec<Diagnostic>) {
    let eps = set.tolerance.distance;
    let placer = Placer::new(scene, set, reach);
    let near = |b: &Aabb| placer.near(b);
    let place_prop = |n: NodeId, prefer: &[usize], out: &mut Placed| placer.prop(n, prefer, out);
    let props: std::collections::HashSet<NodeId> = set.props.iter().map(|p| p.node).collect();
    let rooms: Vec<Placed> = tagging
        .rooms
        .par_iter()
        .enumerate()
        .map(|(ri, room)| {
            let mut out: Placed = Default::default();
            let mine = &set.room_cells[ri];
            let own: std::collections::HashSet<usize> =
                mine.iter().chain(&took[ri]).copied().collect();
            if let Some(g) = generated_of(tagging, ri) {
                // The generated rooms share one reading of the level: their structure is
                // placed once, in every generated cell a triangle touches.
                if ri == g.first_room {
                    place_generated(&placer, scene, tagging, set, &mut out);
                }
                return out;
            }
            for &n in room.structure.iter().filter(|n| !props.contains(n)) {
                let tris = node_triangles(scene, &[n], DVec3::ZERO);
                let hit: Vec<usize> = near(&tris_bounds(&tris))
                    .into_iter()
                    .filter(|c| own.contains(c) && node_in_cell(&tris, &set.cells[*c], eps))
                    .collect();
                // Structure in none of its room's cells is still the room's: its first cell's.
                let hit = if hit.is_empty() {
                    mine.first().map(|&c| vec![c]).unwrap_or_default()
                } else {
                    hit
                };
                out.0.extend(hit.into_iter().map(|c| (c, n)));
            }
            for &n in room
                .detail
                .iter()
                .chain(room.structure.iter().filter(|n| props.contains(n)))
            {
                place_prop(n, mine, &mut out);
            }
            out
        })
        .collect();
    let mut lists: Vec<Vec<NodeId>> = vec![Vec::new(); set.cells.len()];
    let mut outside = Vec::new();
    let rooms = place_unreached_generated(tagging, set, rooms);
    for (placed, out) in rooms {
        placed.into_iter().for_each(|(c, n)| lists[c].push(n));
        outside.extend(out);
    }
    let mut loose: Placed = Default::default();
    for d in &tagging.detail {
        place_prop(d.node, &[], &mut loose);
    }
    if !set.cells.is_empty() {
        for u in &tagging.unassigned {
            let tris = node_triangles(scene, &[u.node], DVec3::ZERO);
            let mut hit: Vec<usize> = near(&tris_bounds(&tris))
                .into_iter()
                .filter(|&c| node_in_cell(&tris, &set.cells[c], eps))
                .collect();
            if hit.is_empty() {
                hit = facing_cells(&tris, set, reach, eps);
            }
            if hit.is_empty() {
                loose.1.push(u.node);
            }
            loose.0.extend(hit.into_iter().map(|c| (c, u.node)));
        }
    }
    loose.0.into_iter().for_each(|(c, n)| lists[c].push(n));
    outside.extend(loose.1);
    let diagnostics = match buried_in_solid(set) {
        true => Vec::new(),
        false => outside
            .into_iter()
            .map(|n| outside_diagnostic(scene, n))
            .collect(),
    };
    for l in &mut lists {
        l.sort_unstable();
        l.dedup();
    }
    (lists, diagnostics)
}
