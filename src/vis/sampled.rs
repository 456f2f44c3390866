//! `sampled`: a lower bound. Random segments start on a directed portal and are walked through
//! the cells: in each cell the segment leaves through the first portal it crosses, strictly
//! inside the polygon, or stops at the first wall. Every cell on such a walk is really visible
//! from every cell before it, so the result only ever misses pairs, never invents them; it
//! measures how much the conservative methods over-estimate.
//!
//! The cells are taken as the portal graph describes them: convex space bounded by opaque walls
//! and the portals (true of portcullis cells and Quake leaves; a Quake cluster is treated as
//! open space inside, as vis treats it). The outside is not walked into: what blocks there is
//! not known (`check --sightlines` traces the real triangles). Each source portal has its own seeded generator, so
//! the result does not depend on the thread count.

use glam::{DMat4, DVec3};
use rayon::prelude::*;

use super::graph::VisGraph;
use super::Pvs;
use super::{bits, bits::BitMatrix};

/// Longest walk, in portals; a bound against a ray bouncing forever between two mirrors.
const MAX_STEPS: usize = 4096;

use crate::rng::SplitMix64 as Rng;

/// An index in `0..n` from a uniform draw (the sampler's own pick, kept so seeded runs repeat).
fn below(r: &mut Rng, n: usize) -> usize {
    (r.unit() * n as f64) as usize % n.max(1)
}

/// A uniformly random point of a convex polygon, pulled slightly towards its centre so the
/// walk never starts on an edge.
fn point_in(poly: &[DVec3], r: &mut Rng) -> DVec3 {
    let c = poly.iter().copied().sum::<DVec3>() / poly.len() as f64;
    let areas: Vec<f64> = (0..poly.len())
        .map(|i| (poly[i] - c).cross(poly[(i + 1) % poly.len()] - c).length())
        .collect();
    let total: f64 = areas.iter().sum();
    let mut pick = r.unit() * total;
    let mut i = 0;
    while i + 1 < areas.len() && pick > areas[i] {
        pick -= areas[i];
        i += 1;
    }
    let (mut u, mut v) = (r.unit(), r.unit());
    if u + v > 1.0 {
        u = 1.0 - u;
        v = 1.0 - v;
    }
    let p = c + (poly[i] - c) * u + (poly[(i + 1) % poly.len()] - c) * v;
    c + (p - c) * 0.999
}

/// Where the ray `o + t d` (t > `after`) crosses the portal strictly inside its polygon, if it
/// does while travelling the portal's way.
fn hit(g: &VisGraph, q: usize, o: DVec3, d: DVec3, after: f64) -> Option<f64> {
    let p = &g.portals[q];
    let nd = p.plane.normal.dot(d);
    if nd <= 0.0 {
        return None;
    }
    let t = -p.plane.distance(o) / nd;
    if t <= after {
        return None;
    }
    let x = o + d * t;
    let w = &p.winding;
    let n = w.len();
    let mut sign = 0.0;
    for k in 0..n {
        let (a, b) = (w[k], w[(k + 1) % n]);
        let s = (b - a).cross(x - a).dot(p.plane.normal);
        let margin = g.epsilon * (b - a).length();
        if s.abs() <= margin {
            return None;
        }
        if sign == 0.0 {
            sign = s.signum();
        } else if s.signum() != sign {
            return None;
        }
    }
    Some(t)
}

/// `samples` segments from each directed portal.
pub fn pvs(g: &VisGraph, might: &[Vec<u64>], samples: usize, depth: usize, seed: u64) -> Pvs {
    let n = g.cells;
    let seen = (0..g.portals.len())
        .into_par_iter()
        .fold(
            || BitMatrix::new(n),
            |mut m, p| {
                walk_from(g, p, might, samples, depth, seed, &mut m);
                m
            },
        )
        .reduce(
            || BitMatrix::new(n),
            |mut a, b| {
                a.union_with(&b);
                a
            },
        );
    let mut out = Pvs::identity(n);
    out.bits.union_with(&seen);
    out
}

fn walk_from(
    g: &VisGraph,
    p: usize,
    might: &[Vec<u64>],
    samples: usize,
    depth: usize,
    seed: u64,
    out: &mut BitMatrix,
) {
    let src = &g.portals[p];
    if src.transform.is_some() && depth == 0 {
        return;
    }
    // Nothing is known of what blocks sight in the outside, so no walk is sure through it:
    // for a lower bound its openings are walls.
    if g.outside.is_some_and(|o| src.from == o || src.to == o) {
        return;
    }
    let targets: Vec<usize> = bits::ones(&might[p]).collect();
    let mut r = Rng::new(seed.wrapping_add((p as u64).wrapping_mul(0x2545_f491_4f6c_dd1d)));
    let mut chain = Vec::new();
    for s in 0..samples {
        let a = point_in(&src.winding, &mut r);
        // Three in four towards a point of a portal that might be seen; the rest in a random
        // direction through the portal, so no target list can hide a sightline kind.
        let dir = if s % 4 != 3 && !targets.is_empty() && src.transform.is_none() {
            let q = &g.portals[targets[below(&mut r, targets.len())]];
            point_in(&q.winding, &mut r) - a
        } else {
            let v = DVec3::new(r.unit() - 0.5, r.unit() - 0.5, r.unit() - 0.5);
            let v = v - src.plane.normal * v.dot(src.plane.normal);
            v + src.plane.normal * (0.05 + r.unit())
        };
        let Some(dir) = dir.try_normalize() else {
            continue;
        };
        if dir.dot(src.plane.normal) <= 0.0 {
            continue;
        }
        chain.clear();
        chain.push(src.from);
        let (mut o, mut d) = (a, dir);
        let mut transforms = 0;
        if let Some(m) = src.transform {
            (o, d) = apply(&m, o, d);
            transforms = 1;
        }
        chain.push(src.to);
        let mut cell = src.to;
        for _ in 0..MAX_STEPS {
            let mut best: Option<(f64, usize)> = None;
            for &q in &g.leaving[cell] {
                if let Some(t) = hit(g, q, o, d, g.epsilon) {
                    if best.is_none_or(|(bt, _)| t < bt) {
                        best = Some((t, q));
                    }
                }
            }
            let Some((t, q)) = best else { break };
            let portal = &g.portals[q];
            if g.outside == Some(portal.to) {
                break;
            }
            if portal.transform.is_some() {
                if transforms >= depth {
                    break;
                }
                transforms += 1;
            }
            o += d * t;
            if let Some(m) = portal.transform {
                (o, d) = apply(&m, o, d);
            }
            cell = portal.to;
            chain.push(cell);
        }
        for i in 0..chain.len() {
            for j in i + 1..chain.len() {
                out.set(chain[i], chain[j]);
            }
        }
    }
}

fn apply(m: &DMat4, o: DVec3, d: DVec3) -> (DVec3, DVec3) {
    (m.transform_point3(o), m.transform_vector3(d))
}
