//! `flood`: every cell reachable through open portals. The loosest bound, and the one the
//! others must stay inside.
//!
//! Every cell of a strongly connected part reaches the same cells, so reachability is
//! computed once per part, in the order where what a part leads into is done first: a few
//! row unions instead of a walk from every cell.

use super::bits;
use super::graph::VisGraph;
use super::Pvs;

pub fn pvs(g: &VisGraph) -> Pvs {
    let adj: Vec<Vec<usize>> = g
        .leaving
        .iter()
        .map(|ps| ps.iter().map(|&p| g.portals[p].to).collect())
        .collect();
    let comp = crate::scc::components(g.cells, &adj);
    let parts = comp.iter().copied().max().map_or(0, |m| m + 1);
    let mut members = vec![Vec::new(); parts];
    for (c, &k) in comp.iter().enumerate() {
        members[k].push(c);
    }
    let words = bits::words(g.cells);
    let mut reach: Vec<Vec<u64>> = Vec::with_capacity(parts);
    for (k, cells) in members.iter().enumerate() {
        let mut row = vec![0u64; words];
        for &c in cells {
            bits::set(&mut row, c);
            for &t in &adj[c] {
                let kt = comp[t];
                if kt != k {
                    // `kt < k`: finished.
                    for (a, b) in row.iter_mut().zip(&reach[kt]) {
                        *a |= b;
                    }
                }
            }
        }
        reach.push(row);
    }
    let mut out = Pvs::identity(g.cells);
    for c in 0..g.cells {
        out.bits.row_mut(c).copy_from_slice(&reach[comp[c]]);
    }
    out
}
