//! `fast`: Quake's "might see" per directed portal. A portal `q` can be seen through `p` only
//! if part of `q` is in front of `p` and part of `p` is behind `q`; a flood from `p`'s target
//! through such portals bounds what `p` sees. It is the method's result and the full flow's
//! starting filter.
//!
//! Behind a transformed portal the planes of the world no longer describe the view, so from
//! there the flood takes every reachable portal: still conservative, still inside `flood`.

use rayon::prelude::*;

use glam::DVec3;

use super::bits;
use super::graph::VisGraph;
use super::winding::sphere;
use super::Pvs;
use crate::geom::plane::Plane;

/// Per directed portal, the portals it might see (a bit row over portals).
pub(crate) fn might_see(g: &VisGraph, depth: usize) -> Vec<Vec<u64>> {
    let spheres = spheres(g);
    (0..g.portals.len())
        .into_par_iter()
        .map(|p| one(g, &spheres, p, depth))
        .collect()
}

/// Per portal, a sphere around its corners (centre, radius): most plane tests below are
/// decided by it alone, with the same answer the corners would give.
fn spheres(g: &VisGraph) -> Vec<(DVec3, f64)> {
    g.portals.iter().map(|p| sphere(&p.winding)).collect()
}

/// Whether some corner of the polygon (with its sphere) is beyond `eps` on the `sign` side.
fn any_beyond(pl: &Plane, poly: &[DVec3], (c, r): (DVec3, f64), sign: f64, eps: f64) -> bool {
    let dc = sign * pl.distance(c);
    if dc - r > eps {
        return true;
    }
    if dc + r <= eps {
        return false;
    }
    poly.iter().any(|v| sign * pl.distance(*v) > eps)
}

/// Whether `q` is in front of `p` and `p` partly behind `q`.
fn in_front(g: &VisGraph, s: &[(DVec3, f64)], p: usize, q: usize) -> bool {
    let (pp, qq) = (&g.portals[p], &g.portals[q]);
    let eps = g.epsilon;
    any_beyond(&pp.plane, &qq.winding, s[q], 1.0, eps)
        && any_beyond(&qq.plane, &pp.winding, s[p], -1.0, eps)
}

fn one(g: &VisGraph, s: &[(DVec3, f64)], p: usize, depth: usize) -> Vec<u64> {
    let n = g.portals.len();
    let mut might = vec![0u64; bits::words(n)];
    let src = &g.portals[p];
    if src.transform.is_some() {
        if depth > 0 {
            flood_all(g, src.to, &mut might);
        }
        return might;
    }
    // Quake's filter, tested only on the portals the flood reaches: the flood through the
    // portals in front of `p` and with `p` partly behind them. `tested` remembers the ones
    // that failed, so each portal is judged once. A portal's verdict does not depend on the
    // path to it, so each cell is expanded once: the outside's thousands of openings would
    // otherwise be walked again for every opening that leads into it.
    let mut tested = vec![0u64; bits::words(n)];
    let mut expanded = vec![0u64; bits::words(g.cells)];
    let mut stack = vec![src.to];
    while let Some(c) = stack.pop() {
        if bits::get(&expanded, c) {
            continue;
        }
        bits::set(&mut expanded, c);
        for &q in &g.leaving[c] {
            if bits::get(&might, q) || bits::get(&tested, q) {
                continue;
            }
            bits::set(&mut tested, q);
            if q == p || !in_front(g, s, p, q) {
                continue;
            }
            bits::set(&mut might, q);
            if g.portals[q].transform.is_some() {
                if depth > 0 {
                    flood_all(g, g.portals[q].to, &mut might);
                }
            } else {
                stack.push(g.portals[q].to);
            }
        }
    }
    might
}

/// Every portal reachable from `cell`, into `out`. Its own visited set of cells: a portal
/// already in `out` by the filtered flood may still lead somewhere only this unfiltered one goes.
fn flood_all(g: &VisGraph, cell: usize, out: &mut [u64]) {
    let mut seen = vec![0u64; bits::words(g.cells)];
    bits::set(&mut seen, cell);
    let mut stack = vec![cell];
    while let Some(c) = stack.pop() {
        for &q in &g.leaving[c] {
            bits::set(out, q);
            let to = g.portals[q].to;
            if !bits::get(&seen, to) {
                bits::set(&mut seen, to);
                stack.push(to);
            }
        }
    }
}

/// The cell PVS from per-portal sets: a cell sees itself, the cells its portals lead into
/// (through a transformed one only when `depth` allows one), and the targets of everything
/// its portals see.
pub(crate) fn cell_pvs(g: &VisGraph, portal_vis: &[Vec<u64>], depth: usize) -> Pvs {
    let mut out = Pvs::identity(g.cells);
    let mut row = vec![0u64; bits::words(g.portals.len())];
    for c in 0..g.cells {
        row.iter_mut().for_each(|w| *w = 0);
        for &p in &g.leaving[c] {
            if g.portals[p].transform.is_none() || depth > 0 {
                out.bits.set(c, g.portals[p].to);
            }
            for (w, v) in row.iter_mut().zip(&portal_vis[p]) {
                *w |= v;
            }
        }
        for q in bits::ones(&row) {
            out.bits.set(c, g.portals[q].to);
        }
    }
    out
}

pub fn pvs(g: &VisGraph, depth: usize) -> Pvs {
    cell_pvs(g, &might_see(g, depth), depth)
}
