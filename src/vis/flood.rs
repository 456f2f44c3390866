//! `flood`: every cell reachable through open portals. The loosest bound, and the one the
//! others must stay inside.

use super::graph::VisGraph;
use super::pvs::Pvs;

pub fn pvs(g: &VisGraph) -> Pvs {
    let mut out = Pvs::identity(g.cells);
    let mut stack = Vec::new();
    for c in 0..g.cells {
        stack.clear();
        stack.push(c);
        while let Some(k) = stack.pop() {
            for &p in &g.leaving[k] {
                let to = g.portals[p].to;
                if !out.sees(c, to) {
                    out.bits.set(c, to);
                    stack.push(to);
                }
            }
        }
    }
    out
}
