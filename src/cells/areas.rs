//! Areas: a block room that area portals cut into parts becomes one room per part, as id
//! Tech 4's dmap floods its areas from the visportals (and Quake 2's qbsp its areas from the
//! `func_areaportal`s), so the engine's rooms are the designer's areas and the portals at the
//! area portals are the portals between them.
//!
//! A room's cells are joined where they share a face, except across the boundary of an area
//! portal's volume (a cell in the gate on one side, not on the other). The parts outside the
//! gates that touch a gate are the areas; a gate's own cells join the area they touch first
//! (by cell number), and a part that touches no gate (a pocket cut off by a crack, which qbsp
//! would make an area of its own) stays with the first area. With one area nothing changes;
//! with more, the largest keeps the room and each other one, by volume, becomes a room
//! `NAME_areaK` (K from 1), declared by the same node and owning no nodes (the cells keep the
//! nodes they render).

use super::air::shared_faces;
use super::{CellSet, GateKind};
use crate::disjoint::DisjointSets;
use crate::geom::grid::BoxGrid;
use crate::geom::polyhedron::polygon_area;
use crate::geom::tolerance::Tolerance;
use crate::tags::{RoomId, Tagging};

/// Splits every room its area portals divide into its areas (see the module docs).
pub fn split(tagging: &mut Tagging, cells: &mut CellSet) {
    let eps = cells.tolerance.distance;
    for r in 0..cells.room_cells.len() {
        let members = cells.room_cells[r].clone();
        let portal_gates = |c: usize| {
            cells.cells[c]
                .gates
                .iter()
                .filter(|g| g.kind == GateKind::AreaPortal)
                .map(|g| g.node)
                .collect::<Vec<_>>()
        };
        if members.iter().all(|&c| portal_gates(c).is_empty()) {
            continue;
        }
        let gates: Vec<Vec<usize>> = members.iter().map(|&c| portal_gates(c)).collect();
        let n = members.len();
        let mut parts = DisjointSets::new(n);
        let grid = BoxGrid::new(members.iter().map(|&c| cells.cells[c].bounds).collect());
        let mut pairs = grid.pairs(Tolerance::touching(eps));
        pairs.sort_unstable();
        // Touching pairs that cross a gate's boundary, kept to attach the gates' cells after.
        let mut crossings: Vec<(usize, usize)> = Vec::new();
        for (i, j) in pairs {
            let (a, b) = (&cells.cells[members[i]].poly, &cells.cells[members[j]].poly);
            let area: f64 = shared_faces(a, b, eps)
                .map(|(common, normal)| polygon_area(&common, normal))
                .sum();
            if area <= eps * eps {
                continue;
            }
            if gates[i] == gates[j] {
                parts.union(i, j);
            } else {
                crossings.push((i.min(j), i.max(j)));
            }
        }
        // Areas: the parts outside every area portal that touch one, numbered by first cell.
        // A part that touches none (a pocket the crack rule or a sealed void cut off) is no
        // area of its own: it stays with the first.
        let mut touches = vec![false; n];
        for &(i, j) in &crossings {
            for (x, y) in [(i, j), (j, i)] {
                if gates[x].is_empty() && !gates[y].is_empty() {
                    touches[parts.find(x)] = true;
                }
            }
        }
        let mut area_of: Vec<Option<usize>> = vec![None; n];
        let mut roots: Vec<usize> = Vec::new();
        for k in (0..n).filter(|&k| gates[k].is_empty()) {
            let root = parts.find(k);
            area_of[k] = Some(match touches[root] {
                true => roots.iter().position(|&x| x == root).unwrap_or_else(|| {
                    roots.push(root);
                    roots.len() - 1
                }),
                false => 0,
            });
        }
        if roots.len() < 2 {
            continue;
        }
        // A gate's cells join the area they touch first, by cell number.
        crossings.sort_unstable();
        for _ in 0..n {
            let mut changed = false;
            for &(i, j) in &crossings {
                for (x, y) in [(i, j), (j, i)] {
                    if area_of[x].is_none() && area_of[y].is_some() {
                        area_of[x] = area_of[y];
                        changed = true;
                    }
                }
            }
            if !changed {
                break;
            }
        }
        // The largest area keeps the room (volumes in millionths of the room's, so the order
        // of the cells settles only near-equal ones), the others are numbered after it.
        let mut volume = vec![0.0f64; roots.len()];
        for (k, &c) in members.iter().enumerate() {
            volume[area_of[k].unwrap_or(0)] += cells.cells[c].volume;
        }
        let total: f64 = volume.iter().sum::<f64>().max(f64::MIN_POSITIVE);
        let mut rank: Vec<usize> = (0..roots.len()).collect();
        rank.sort_by_key(|&a| {
            (
                std::cmp::Reverse((volume[a] / total * 1e6).round() as i64),
                a,
            )
        });
        let name = tagging.rooms[r].name.clone();
        let mut ids: Vec<RoomId> = vec![r; roots.len()];
        for (k, &a) in rank.iter().enumerate().skip(1) {
            ids[a] = tagging.add_area(r, format!("{name}_area{k}"));
        }
        cells.room_cells.resize(tagging.rooms.len(), Vec::new());
        cells.room_cells[r].clear();
        for (k, &c) in members.iter().enumerate() {
            let room = ids[area_of[k].unwrap_or(0)];
            cells.cells[c].room = room;
            cells.room_cells[room].push(c);
        }
    }
}
