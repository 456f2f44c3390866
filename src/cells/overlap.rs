//! Overlapping cells of different rooms, made disjoint.
//!
//! Where two rooms' cells share space (a nested room of higher `priority`, or a Doom sector
//! drawn over another one), a ray could pass from one into the other without crossing a face,
//! so no portal joins them and the PVS left the pair out (Freedoom E3M3: two small sectors
//! standing in a courtyard's air, 122 missed sightlines). The shared space is given to one
//! cell, the *winner*: the higher priority, then the smaller cell (the nested one, as the
//! runtime's `locate` decides), then the room earlier by name. The other cell is cut into the
//! convex pieces of itself minus the winner; their faces on the winner's planes abut it, and
//! portal derivation opens them where nothing opaque lies between. The winner also renders the
//! loser's structure (`assign.rs`). Equal priorities overlapping are still reported
//! (`CELL_OVERLAP`), saying which room took the space.

use glam::DVec3;

use super::{Cell, CellSet};
use crate::config::CellsConfig;
use crate::diag::{Code, Diagnostic, Location};
use crate::geom::polyhedron::{polygon_area, ConvexPolyhedron};
use crate::scene::Scene;
use crate::tags::{RoomId, Tagging};

/// Where two rooms' cells overlapped, and the room whose cell took the space.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Overlap {
    /// The space the two cells shared (world coordinates).
    pub region: ConvexPolyhedron,
    /// The room whose cell kept the space, then the room whose cell was cut around it.
    pub rooms: [RoomId; 2],
}

/// A pair of overlapping cells: (winner, loser, the shared region, its volume).
type Found = (usize, usize, ConvexPolyhedron, f64);

/// The pairs of cells of different rooms that share more than `[cells] overlap_volume`, in the
/// order of the cells' numbers, each with its winner first.
fn find(tagging: &Tagging, cfg: &CellsConfig, set: &CellSet) -> Vec<Found> {
    let eps = set.tolerance.distance;
    // Only cells whose bounds overlap are compared (never all pairs), in the sweep's order.
    let (_, pairs) = set.pairs_in_order(0.0);
    let mut found = Vec::new();
    for (a, b) in pairs {
        let (ca, cb) = (&set.cells[a], &set.cells[b]);
        if ca.room == cb.room
            || (0..3).any(|k| {
                cb.bounds.min[k] >= ca.bounds.max[k] - eps
                    || cb.bounds.max[k] <= ca.bounds.min[k] + eps
            })
        {
            continue;
        }
        let Some(x) = ca.poly.intersection(&cb.poly, eps) else {
            continue;
        };
        let v = x.volume();
        if v > cfg.overlap_volume {
            let (w, l) = if wins(tagging, set, a, b) {
                (a, b)
            } else {
                (b, a)
            };
            found.push((w, l, x, v));
        }
    }
    found
}

/// Whether cell `a` keeps the space it shares with cell `b`: the higher priority, then the
/// smaller (equal within a billionth, as a moved level's volumes are), then the room earlier
/// by name, then by number.
fn wins(tagging: &Tagging, set: &CellSet, a: usize, b: usize) -> bool {
    let (ca, cb) = (&set.cells[a], &set.cells[b]);
    let (ra, rb) = (&tagging.rooms[ca.room], &tagging.rooms[cb.room]);
    if ra.priority != rb.priority {
        return ra.priority > rb.priority;
    }
    if (ca.volume - cb.volume).abs() > 1e-9 * ca.volume.max(cb.volume) {
        return ca.volume < cb.volume;
    }
    (ra.name.as_str(), ca.room, a) < (rb.name.as_str(), cb.room, b)
}

/// The convex pieces of `p` outside `w`: for each of `w`'s faces in turn, the part of what is
/// left in front of it. Pieces thinner on average than the tolerance are dropped.
fn minus(p: &ConvexPolyhedron, w: &ConvexPolyhedron, eps: f64) -> Vec<ConvexPolyhedron> {
    let mut out = Vec::new();
    let mut rest = p.clone();
    for f in &w.faces {
        let (behind, front) = rest.split(&f.plane, eps);
        out.extend(front.filter(|q| thick(q, eps)));
        match behind {
            Some(b) => rest = b,
            None => return out,
        }
    }
    out
}

/// Whether a solid is thicker on average than `eps` (twice its volume over its surface).
fn thick(p: &ConvexPolyhedron, eps: f64) -> bool {
    let area: f64 = p
        .faces
        .iter()
        .map(|f| polygon_area(&f.points, f.plane.normal))
        .sum();
    2.0 * p.volume() > eps * area
}

/// Makes the cells of different rooms disjoint (see the module's comment): each loser is
/// replaced by its pieces outside its winners, in its place among its room's cells, and the
/// cells are renumbered. Returns, per room, the cells of other rooms that took part of its
/// space (they render its structure too). Geometry is cut about `origin`, the level's centre.
pub(crate) fn resolve(
    scene: &Scene,
    tagging: &Tagging,
    cfg: &CellsConfig,
    set: &mut CellSet,
    origin: DVec3,
) -> Vec<Vec<usize>> {
    let eps = set.tolerance.distance;
    let found = find(tagging, cfg, set);
    let mut took = vec![Vec::new(); tagging.rooms.len()];
    if found.is_empty() {
        return took;
    }
    for (w, l, x, v) in &found {
        let (cw, cl) = (&set.cells[*w], &set.cells[*l]);
        let (rw, rl) = (&tagging.rooms[cw.room], &tagging.rooms[cl.room]);
        set.overlaps.push(Overlap {
            region: x.clone(),
            rooms: [cw.room, cl.room],
        });
        if rw.priority != rl.priority {
            continue;
        }
        set.diagnostics.push(
            Diagnostic::new(
                Code::CELL_OVERLAP,
                format!(
                    "cells of rooms `{}` and `{}` overlap by {v:.4} m³; the space is given to `{}` (the smaller cell) and `{}`'s cell is cut around it, so sightlines through it cross a portal",
                    rw.name, rl.name, rw.name, rl.name
                ),
                Location::file(&scene.path)
                    .with_node(rw.path.clone())
                    .with_position(x.interior_point().to_array()),
            )
            .hint(format!(
                "if the rooms should not share space, move the geometry of one out of the other; if one is nested in the other, give it a higher `priority` (room `{}` is at `{}`)",
                rl.name, rl.path
            )),
        );
    }
    // Each loser's winners, cut away in the order of their rooms' names.
    let mut winners: Vec<Vec<usize>> = vec![Vec::new(); set.cells.len()];
    for (w, l, ..) in &found {
        winners[*l].push(*w);
    }
    let key = |c: usize| {
        let r = set.cells[c].room;
        (tagging.rooms[r].name.clone(), r, c)
    };
    let mut pieces: Vec<Vec<ConvexPolyhedron>> = vec![Vec::new(); set.cells.len()];
    for (l, ws) in winners.iter_mut().enumerate() {
        if ws.is_empty() {
            continue;
        }
        ws.sort_by_key(|&w| key(w));
        let mut left = vec![set.cells[l].poly.translated(-origin)];
        for &w in ws.iter() {
            let wp = set.cells[w].poly.translated(-origin);
            left = left.iter().flat_map(|p| minus(p, &wp, eps)).collect();
        }
        pieces[l] = left.iter().map(|p| p.translated(origin)).collect();
    }
    // Renumber: a loser's pieces take its place, in order.
    let old = std::mem::take(&mut set.cells);
    let mut new_of: Vec<Vec<usize>> = vec![Vec::new(); old.len()];
    for (c, cell) in old.into_iter().enumerate() {
        if winners[c].is_empty() {
            new_of[c].push(set.cells.len());
            set.cells.push(cell);
            continue;
        }
        for poly in std::mem::take(&mut pieces[c]) {
            new_of[c].push(set.cells.len());
            set.cells.push(Cell {
                volume: poly.volume(),
                bounds: poly.bounds(),
                poly,
                ..cell.clone()
            });
        }
    }
    for list in &mut set.room_cells {
        *list = list
            .iter()
            .flat_map(|&c| new_of[c].iter().copied())
            .collect();
    }
    for ((w, ..), o) in found.iter().zip(&set.overlaps) {
        took[o.rooms[1]].extend(new_of[*w].iter().copied());
    }
    for t in &mut took {
        t.sort_unstable();
        t.dedup();
    }
    took
}
