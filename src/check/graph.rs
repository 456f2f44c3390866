//! The cell graph: cells no portal path joins to the rest (usually a wall with no doorway
//! modelled, or a room the designer forgot to connect), and one-way portals into cells with no
//! way back out (a player who drops down there is stuck).

use super::{edges, Subject};
use crate::diag::{Code, Diagnostic, Diagnostics, Location};
use crate::scc::components;

/// Union-find root with path halving.
fn root(parent: &mut [usize], mut a: usize) -> usize {
    while parent[a] != a {
        parent[a] = parent[parent[a]];
        a = parent[a];
    }
    a
}

fn list(s: &Subject, cells: &[usize]) -> String {
    const SHOWN: usize = 6;
    let mut names: Vec<&str> = cells.iter().take(SHOWN).map(|&c| s.cell(c)).collect();
    let more = cells.len().saturating_sub(SHOWN);
    let extra = if more > 0 {
        format!(" and {more} more")
    } else {
        String::new()
    };
    if names.len() == 1 {
        return format!("{}{extra}", names[0]);
    }
    let last = names.pop().unwrap_or_default();
    format!("{} and {last}{extra}", names.join(", "))
}

fn at_cell(s: &Subject, c: usize) -> Location {
    let loc = s
        .cells
        .get(c)
        .map_or_else(|| Location::file(&s.file), |c| c.at.clone());
    match s.cell_point(c) {
        Some(p) => loc.with_position(p.to_array()),
        None => loc,
    }
}

/// `seeds`: (occupant, cell) pairs; the parts of the level holding an occupant are the
/// level's, else the part with the most cells.
pub(super) fn check(s: &Subject, seeds: &[(usize, usize)], out: &mut Diagnostics) {
    let n = s.cells.len();
    if n < 2 {
        return;
    }
    let es = edges(s);
    let mut parent: Vec<usize> = (0..n).collect();
    for &(a, b, _) in &es {
        let (ra, rb) = (root(&mut parent, a), root(&mut parent, b));
        if ra != rb {
            parent[ra.max(rb)] = ra.min(rb);
        }
    }
    let mut parts: std::collections::BTreeMap<usize, Vec<usize>> = Default::default();
    for c in 0..n {
        let r = root(&mut parent, c);
        parts.entry(r).or_default().push(c);
    }
    if parts.len() > 1 {
        // Every part an occupant stands in is the level's; without occupants, the largest.
        let mut main: std::collections::BTreeSet<usize> =
            seeds.iter().map(|&(_, c)| root(&mut parent, c)).collect();
        if main.is_empty() {
            let mut best = (0usize, usize::MAX);
            for (r, cs) in &parts {
                if cs.len() > best.0 {
                    best = (cs.len(), *r);
                }
            }
            main.insert(best.1);
        }
        let reference = match seeds {
            [] => format!(
                "the largest part ({})",
                list(s, &parts[main.first().unwrap_or(&0)])
            ),
            [(k, _)] => s.starts[*k].label.clone(),
            [(k, _), ..] => format!("{} or any other occupant", s.starts[*k].label),
        };
        for (r, cs) in &parts {
            if main.contains(r) {
                continue;
            }
            out.push(
                Diagnostic::new(
                    Code::GRAPH_UNREACHABLE,
                    format!(
                        "{} cannot be reached from {reference}: no portal joins {}",
                        list(s, cs),
                        if cs.len() == 1 { "it" } else { "them" }
                    ),
                    at_cell(s, cs[0]),
                )
                .hint("model the doorway between them (an opening in the wall, or an authored portal), or remove the cells if they are not part of the level"),
            );
        }
    }
    dead_ends(s, n, &es, out);
}

/// A strongly connected part with a way in from elsewhere but no way out.
fn dead_ends(s: &Subject, n: usize, es: &[(usize, usize, usize)], out: &mut Diagnostics) {
    let mut adj = vec![Vec::new(); n];
    for &(a, b, _) in es {
        adj[a].push(b);
    }
    let comp = components(n, &adj);
    let count = comp.iter().copied().max().map_or(0, |m| m + 1);
    let mut has_out = vec![false; count];
    let mut entries: Vec<Vec<usize>> = vec![Vec::new(); count];
    for &(a, b, p) in es {
        if comp[a] != comp[b] {
            has_out[comp[a]] = true;
            entries[comp[b]].push(p);
        }
    }
    for k in 0..count {
        if has_out[k] || entries[k].is_empty() {
            continue;
        }
        let cells: Vec<usize> = (0..n).filter(|&c| comp[c] == k).collect();
        let mut ways: Vec<usize> = entries[k].clone();
        ways.sort_unstable();
        ways.dedup();
        let names: Vec<&str> = ways.iter().take(4).map(|&p| s.portal(p)).collect();
        let first = ways[0];
        out.push(
            Diagnostic::new(
                Code::GRAPH_ONE_WAY_DEAD_END,
                format!(
                    "one-way {} lead{} into {}, and no portal leads back out",
                    names.join(", "),
                    if ways.len() == 1 { "s" } else { "" },
                    list(s, &cells)
                ),
                s.at(first, super::centroid(&s.portals.portals[first].polygon)),
            )
            .hint("make one of the portals two-way, or add a way out of those cells"),
        );
    }
}
