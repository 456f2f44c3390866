//! Openings to the exterior. In a level declared sealed each cell that opens to the exterior
//! is a leak, reported with the shortest chain of cells from a player start (or from the cell
//! itself when there is no start) and drawn as a polyline — like qbsp's leak file — from the
//! start through the portals to a point just outside the opening. Otherwise they are counted
//! in one note, since open-air levels are common.

use std::collections::VecDeque;

use super::{centroid, edges, Findings, Options, Subject};
use crate::diag::{Code, Diagnostic};

pub(super) fn check(s: &Subject, seeds: &[(usize, usize)], opts: &Options, f: &mut Findings) {
    if opts.sealed {
        void_starts(s, seeds, f);
    }
    if opts.sealed && s.cells.is_empty() {
        // No cell, so nothing closes the level: a sealed level cannot be open everywhere.
        f.diagnostics.push(
            Diagnostic::new(
                Code::LEAK,
                "leak: the level is declared sealed but no cell was built (no room was recognised, or no room encloses any air), so nothing closes it",
                crate::diag::Location::file(&s.file),
            )
            .hint("tag the level's rooms (see `portcullis inspect` for near misses and `--tags` for presets), close the room's blocks around its air, or drop --sealed / [check] sealed for an open level"),
        );
        return;
    }
    let ps = &s.portals.portals;
    // Exterior portals by cell, largest first.
    let mut by_cell: std::collections::BTreeMap<usize, Vec<usize>> = Default::default();
    for (i, p) in ps.iter().enumerate() {
        if p.to.is_none() && p.from < s.cells.len() {
            by_cell.entry(p.from).or_default().push(i);
        }
    }
    if by_cell.is_empty() {
        return;
    }
    for list in by_cell.values_mut() {
        list.sort_by(|&a, &b| ps[b].area.total_cmp(&ps[a].area).then(a.cmp(&b)));
    }
    let total: usize = by_cell.values().map(Vec::len).sum();
    let area: f64 = by_cell.values().flatten().map(|&i| ps[i].area).sum();
    if !opts.sealed {
        let (&c, list) = by_cell.iter().next().expect("not empty");
        f.diagnostics.push(
            Diagnostic::new(
                Code::EXTERIOR_OPENINGS,
                format!(
                    "{total} opening(s) to the exterior from {} cell(s), {area:.2} m² in all; the first is in {}",
                    by_cell.len(),
                    s.cell(c)
                ),
                s.at(list[0], centroid(&ps[list[0]].polygon)),
            )
            .hint("if the level should be closed, pass --sealed (or set [check] sealed = true) so each opening is a leak error with its path"),
        );
        return;
    }
    let (dist, prev) = bfs(s, seeds);
    let mut leaking: Vec<(usize, usize)> = by_cell
        .keys()
        .map(|&c| (dist[c].unwrap_or(usize::MAX), c))
        .collect();
    leaking.sort_unstable();
    let outward = 0.02 * s.extent.max(1.0);
    for (_, c) in leaking {
        let list = &by_cell[&c];
        let exit = list[0];
        let hole = centroid(&ps[exit].polygon);
        // The chain back to the start: cells, and the portals taken between them.
        let (mut cells, mut taken) = (vec![c], Vec::new());
        let mut cur = c;
        while let Some((from, portal)) = prev[cur] {
            cells.push(from);
            taken.push(portal);
            cur = from;
        }
        cells.reverse();
        taken.reverse();
        let start = seeds.iter().find(|&&(_, sc)| sc == cells[0]);
        let mut line = vec![match start {
            Some(&(k, _)) => s.starts[k].point,
            None => s.cell_point(cells[0]).unwrap_or(hole),
        }];
        line.extend(taken.iter().map(|&p| centroid(&ps[p].polygon)));
        line.push(hole);
        line.push(hole + ps[exit].normal * outward);
        let mut names: Vec<&str> = cells.iter().map(|&cell| s.cell(cell)).collect();
        names.push("the exterior");
        let from = match (start, seeds.is_empty()) {
            (Some(&(k, _)), _) => format!("from {}", s.starts[k].label),
            (None, true) => "(no player start: the cell itself)".to_string(),
            (None, false) => "(not reachable from any player start)".to_string(),
        };
        f.diagnostics.push(
            Diagnostic::new(
                Code::LEAK,
                format!(
                    "leak: {} opens to the exterior through {} portal(s), {:.2} m²; path {from}: {}",
                    s.cell(c),
                    list.len(),
                    list.iter().map(|&i| ps[i].area).sum::<f64>(),
                    names.join(" -> ")
                ),
                s.at(exit, hole),
            )
            .hint("close the opening here (a missing wall, floor or ceiling, or a gap between meshes), or add the room beyond it; the leak line is in the --debug output"),
        );
        f.leaks.push(line);
    }
}

/// A player start in no cell of a sealed level stands in the void outside every room, as an
/// entity outside a brush map's hull does for qbsp: a leak, drawn as the start itself.
fn void_starts(s: &Subject, seeds: &[(usize, usize)], f: &mut Findings) {
    for (k, st) in s.starts.iter().enumerate() {
        if seeds.iter().any(|&(j, _)| j == k) {
            continue;
        }
        f.diagnostics.push(
            Diagnostic::new(
                Code::LEAK,
                format!(
                    "leak: {} lies in no cell: in a sealed level it stands in the void outside every room",
                    st.label
                ),
                st.at.clone().with_position(st.point.to_array()),
            )
            .hint("move the start into a room, or close the room around it (a room of solid blocks is the air its blocks enclose)"),
        );
        f.leaks.push(vec![
            st.point,
            st.point + glam::DVec3::Y * 0.02 * s.extent.max(1.0),
        ]);
    }
}

/// Shortest cell chains from the player starts' cells, then from the other occupants' for the
/// cells no start reaches, or from every cell when there are none: distance and (previous
/// cell, portal) per cell.
#[allow(clippy::type_complexity)]
fn bfs(s: &Subject, seeds: &[(usize, usize)]) -> (Vec<Option<usize>>, Vec<Option<(usize, usize)>>) {
    let n = s.cells.len();
    let mut adj: Vec<Vec<(usize, usize)>> = vec![Vec::new(); n];
    for (a, b, p) in edges(s) {
        adj[a].push((b, p));
    }
    let mut dist = vec![None; n];
    let mut prev = vec![None; n];
    // Player starts first: a cell they reach is traced from one; the other occupants reach
    // the rest (each wave a breadth-first search of its own, so distances are per wave).
    let waves: Vec<Vec<usize>> = if seeds.is_empty() {
        vec![(0..n).collect()]
    } else {
        let (players, others): (Vec<_>, Vec<_>) =
            seeds.iter().partition(|&&(k, _)| s.starts[k].player);
        vec![
            players.iter().map(|&&(_, c)| c).collect(),
            others.iter().map(|&&(_, c)| c).collect(),
        ]
    };
    for sources in waves {
        let mut queue = VecDeque::new();
        for c in sources {
            if dist[c].is_none() {
                dist[c] = Some(0);
                queue.push_back(c);
            }
        }
        while let Some(c) = queue.pop_front() {
            let d = dist[c].unwrap_or(0);
            for &(t, p) in &adj[c] {
                if dist[t].is_none() {
                    dist[t] = Some(d + 1);
                    prev[t] = Some((c, p));
                    queue.push_back(t);
                }
            }
        }
    }
    (dist, prev)
}
