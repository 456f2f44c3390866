//! Overlapping cells of different rooms, made disjoint.
//!
//! Where two rooms' cells share space (a nested room of higher `priority`, or a Doom sector
//! drawn over another one), a ray could pass from one into the other without crossing a face,
//! so no portal joins them and the PVS left the pair out (small sectors standing in a
//! courtyard's air missed sightlines). The shared space is given to one
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

/// Volumes within this fraction of each other are equal: a moved or turned level's copy of one
/// cell differs from it by f64 rounding, far less, and must be ranked alike.
const SAME_VOLUME: f64 = 1e-9;

/// Whether cell `a` keeps the space it shares with cell `b`: the higher priority, then the
/// smaller (equal within [`SAME_VOLUME`], as a moved level's volumes are), then the room
/// earlier by name, then by number.
fn wins(tagging: &Tagging, set: &CellSet, a: usize, b: usize) -> bool {
    let (ca, cb) = (&set.cells[a], &set.cells[b]);
    let (ra, rb) = (&tagging.rooms[ca.room], &tagging.rooms[cb.room]);
    if ra.priority != rb.priority {
        return ra.priority > rb.priority;
    }
    if (ca.volume - cb.volume).abs() > SAME_VOLUME * ca.volume.max(cb.volume) {
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

/// The convex pieces of `loser` outside every one of `winners`, in turn. A piece a winner
/// does not reach into is kept whole: cut by every winner's planes, the pieces of a large
/// sector holding many small ones multiplied with each.
fn cut_around(
    loser: ConvexPolyhedron,
    winners: &[ConvexPolyhedron],
    eps: f64,
) -> Vec<ConvexPolyhedron> {
    let mut left = vec![loser];
    for w in winners {
        let wb = w.bounds();
        left = left
            .into_iter()
            .flat_map(|p| {
                let apart = !p.bounds().meets(&wb.grown(-eps))
                    || p.intersection(w, eps).is_none_or(|x| !thick(&x, eps));
                match apart {
                    true => vec![p],
                    false => minus(&p, w, eps),
                }
            })
            .collect();
    }
    left
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
        let loser = set.cells[l].poly.translated(-origin);
        let ws: Vec<ConvexPolyhedron> = ws
            .iter()
            .map(|&w| set.cells[w].poly.translated(-origin))
            .collect();
        let left = cut_around(loser, &ws, eps);
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::aabb::Aabb;

    fn cube(lo: [f64; 3], hi: [f64; 3]) -> ConvexPolyhedron {
        ConvexPolyhedron::from_aabb(&Aabb {
            min: DVec3::from_array(lo),
            max: DVec3::from_array(hi),
        })
    }

    /// The sectors' volume (they are placed apart: this asserts it).
    fn overlap_free(ws: &[ConvexPolyhedron]) -> f64 {
        for (i, a) in ws.iter().enumerate() {
            for b in &ws[i + 1..] {
                assert!(a.intersection(b, 1e-9).is_none_or(|x| x.volume() < 1e-9));
            }
        }
        ws.iter().map(|w| w.volume()).sum()
    }

    /// Sixteen 1 m sectors inside a 10 m one: the large one is cut into the pieces around
    /// them, its volume less theirs, each piece outside all of them, and each winner cuts
    /// only the pieces it reaches into.
    #[test]
    fn a_large_cell_is_cut_only_where_its_winners_stand() {
        let big = cube([0.0; 3], [10.0; 3]);
        // Sixteen 1 m sectors, scattered (not on one grid, as a Doom map's are).
        let mut ws = Vec::new();
        for k in 0..16 {
            let (x, y, z) = (
                (k * 7 % 16) as f64 * 0.55 + 0.3,
                (k * 5 % 16) as f64 * 0.55 + 0.3,
                (k * 3 % 4) as f64 * 2.0 + 1.0,
            );
            ws.push(cube([x, y, z], [x + 1.0, y + 1.0, z + 1.0]));
        }
        let pieces = cut_around(big, &ws, 1e-9);
        let v: f64 = pieces.iter().map(|p| p.volume()).sum();
        assert!((v - (1000.0 - overlap_free(&ws))).abs() < 1e-6, "{v}");
        // Cut by every winner's planes whether it reached in or not: 171 pieces.
        assert!(pieces.len() <= 128, "{} pieces", pieces.len());
        // Each winner leaves whole every piece it does not reach into.
        for k in 1..ws.len() {
            let before = cut_around(cube([0.0; 3], [10.0; 3]), &ws[..k], 1e-9);
            let after = cut_around(cube([0.0; 3], [10.0; 3]), &ws[..=k], 1e-9);
            for p in before
                .iter()
                .filter(|p| p.intersection(&ws[k], 1e-9).is_none())
            {
                let (b, v) = (p.bounds(), p.volume());
                let kept = after.iter().any(|q| {
                    (q.volume() - v).abs() < 1e-9
                        && q.bounds().min.distance(b.min) < 1e-9
                        && q.bounds().max.distance(b.max) < 1e-9
                });
                assert!(kept, "winner {k} cut a piece it does not reach: {b:?}");
            }
        }
        for p in &pieces {
            for w in &ws {
                assert!(p.intersection(w, 1e-9).is_none_or(|x| x.volume() < 1e-9));
            }
        }
    }
}
