//! Loops through transformed portals. A renderer may stop at cells it has already drawn for
//! plain portals, but not behind a mirror or a teleporter, whose far side is the same cell seen
//! from elsewhere; a cycle of sightlines through such portals then recurses without bound
//! (two facing mirrors, a teleporter looking at its own exit). This module finds those cycles
//! and the depth bound a run-time renderer (and `vis`) should use.
//!
//! A portal `q` can follow `p` when `q` leaves the cell `p` enters, is open, and has a vertex
//! strictly beyond `p`'s exit plane (the plane of `p`'s polygon mapped by `p`'s transform,
//! facing the direction of travel mapped the same way). That is the classic "might see" test
//! of portal flow, so every cycle reported is one a conservative renderer would follow.
//!
//! The shortest cycle through each transformed portal is found by BFS, deduplicated by its set of
//! portals. Each loop's run-time depth bound is the number of rounds until the composed transform
//! moves the first portal's centre farther than the level is wide (or maps it back onto itself),
//! capped at 8 rounds, times the cycle length; `recursion_depth` is the deepest bound (or, with no
//! loops, the number of transformed portals), capped at 64. It is what the loop check prints and
//! the default depth of `vis`.

use std::collections::VecDeque;

use glam::{DMat4, DVec3};

use super::{Portal, PortalSet};

/// Rounds of a loop allowed before its images are far enough away to stop, when they never
/// get farther than the level is wide (a loop that turns instead of drifting).
const MAX_ROUNDS: usize = 8;
/// A transform composed round a loop is the identity when every entry is within this of
/// it: composing a few f64 transforms loses about 1e-15, a million times less.
const BACK_HOME: f64 = 1e-9;
/// The distance tolerance of following sightlines through transformed portals, as a share
/// of the level's extent (at least a metre): the floor of f64 noise the geometry's own
/// tolerance has too ([`crate::geom::tolerance`]), as the portals carry no tolerance here.
const FOLLOW_NOISE: f64 = 1e-9;
/// No run-time recursion deeper than this is ever recommended.
pub(crate) const MAX_DEPTH: usize = 64;

/// A cycle of portals that recurses through at least one transform.
#[derive(Debug, Clone, PartialEq)]
pub struct TransformLoop {
    /// Portal indices in traversal order; the last is followed by the first.
    pub portals: Vec<usize>,
    /// How far one round moves a point of the first portal (0 when the round maps the level
    /// onto itself).
    pub drift: f64,
    /// Portal traversals after which the images of this loop are farther than the level is
    /// wide, or repeat: the recursion depth to use at run time.
    pub depth: usize,
}

fn centroid(poly: &[DVec3]) -> DVec3 {
    poly.iter().copied().sum::<DVec3>() / poly.len().max(1) as f64
}

fn transform_of(p: &Portal) -> DMat4 {
    p.transform.unwrap_or(DMat4::IDENTITY)
}

/// Whether `q` can be seen through `p` (see the module comment).
fn follows(p: &Portal, q: &Portal, eps: f64) -> bool {
    if p.to != Some(q.from) || q.closed || q.polygon.is_empty() {
        return false;
    }
    let t = transform_of(p);
    let origin = t.transform_point3(centroid(&p.polygon));
    let Some(forward) = t.transform_vector3(p.normal).try_normalize() else {
        return false;
    };
    q.polygon.iter().any(|v| (*v - origin).dot(forward) > eps)
}

/// For each portal, the portals that can follow it, ascending.
fn follow_graph(set: &PortalSet, eps: f64) -> Vec<Vec<usize>> {
    let mut leaving: Vec<Vec<usize>> = Vec::new();
    for (i, p) in set.portals.iter().enumerate() {
        if leaving.len() <= p.from {
            leaving.resize(p.from + 1, Vec::new());
        }
        leaving[p.from].push(i);
    }
    set.portals
        .iter()
        .map(|p| {
            if p.closed {
                return Vec::new();
            }
            let Some(to) = p.to else { return Vec::new() };
            leaving
                .get(to)
                .map(|qs| {
                    qs.iter()
                        .copied()
                        .filter(|&q| follows(p, &set.portals[q], eps))
                        .collect()
                })
                .unwrap_or_default()
        })
        .collect()
}

/// The shortest cycle from `start` back to it, as portal indices starting with `start`.
fn shortest_cycle(graph: &[Vec<usize>], start: usize) -> Option<Vec<usize>> {
    let mut prev = vec![usize::MAX; graph.len()];
    let mut queue = VecDeque::from([start]);
    let mut seen = vec![false; graph.len()];
    while let Some(p) = queue.pop_front() {
        for &q in &graph[p] {
            if q == start {
                let mut cycle = vec![p];
                let mut c = p;
                while c != start {
                    c = prev[c];
                    cycle.push(c);
                }
                cycle.reverse();
                return Some(cycle);
            }
            if !seen[q] {
                seen[q] = true;
                prev[q] = p;
                queue.push_back(q);
            }
        }
    }
    None
}

/// Rounds until the images of `point` under `m` are `extent` away or come back.
fn rounds(m: DMat4, point: DVec3, extent: f64) -> usize {
    let mut acc = m;
    for k in 1..=MAX_ROUNDS {
        let moved = (acc.transform_point3(point) - point).length();
        let back = acc.abs_diff_eq(DMat4::IDENTITY, BACK_HOME);
        if moved > extent || back {
            return k;
        }
        acc = m * acc;
    }
    MAX_ROUNDS
}

/// Every cycle of sightlines through at least one transformed portal, each once (shortest
/// first, then by portal index).
pub fn find_loops(set: &PortalSet, extent: f64) -> Vec<TransformLoop> {
    let eps = FOLLOW_NOISE * extent.max(1.0);
    let graph = follow_graph(set, eps);
    let mut found: Vec<TransformLoop> = Vec::new();
    let mut keys: Vec<Vec<usize>> = Vec::new();
    for (i, p) in set.portals.iter().enumerate() {
        if p.transform.is_none() {
            continue;
        }
        let Some(cycle) = shortest_cycle(&graph, i) else {
            continue;
        };
        // One report per cycle, whichever of its portals found it.
        let mut key = cycle.clone();
        key.sort_unstable();
        if keys.contains(&key) {
            continue;
        }
        keys.push(key);
        // Composed in traversal order: the first portal's transform applies first.
        let m = cycle.iter().fold(DMat4::IDENTITY, |acc, &k| {
            transform_of(&set.portals[k]) * acc
        });
        let c = centroid(&set.portals[cycle[0]].polygon);
        let drift = (m.transform_point3(c) - c).length();
        let depth = (rounds(m, c, extent) * cycle.len()).clamp(1, MAX_DEPTH);
        found.push(TransformLoop {
            portals: cycle,
            drift,
            depth,
        });
    }
    found.sort_by(|a, b| (a.portals.len(), &a.portals).cmp(&(b.portals.len(), &b.portals)));
    found
}

/// The recursion depth through transformed portals a renderer should allow: the deepest loop
/// bound, or — without loops — the number of transformed portals, since a chain without a
/// cycle passes each at most once. At least 1.
pub(crate) fn recursion_depth(set: &PortalSet, extent: f64) -> usize {
    let loops = find_loops(set, extent);
    let depth = match loops.iter().map(|l| l.depth).max() {
        Some(d) => d,
        None => set.portals.iter().filter(|p| p.transform.is_some()).count(),
    };
    depth.clamp(1, MAX_DEPTH)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tags::rules::PortalKind;

    fn quad_x(x: f64, facing: f64) -> Vec<DVec3> {
        // CCW seen from the side `facing` points to.
        let mut q = vec![
            DVec3::new(x, 0.0, -1.0),
            DVec3::new(x, 0.0, 1.0),
            DVec3::new(x, 2.0, 1.0),
            DVec3::new(x, 2.0, -1.0),
        ];
        if facing < 0.0 {
            q.reverse();
        }
        q
    }

    fn mirror(x: f64, front: f64) -> Portal {
        let n = DVec3::new(front, 0.0, 0.0);
        let mut m = DMat4::from_scale(DVec3::new(-1.0, 1.0, 1.0));
        m.w_axis.x = 2.0 * x;
        Portal {
            from: 0,
            to: Some(0),
            polygon: quad_x(x, front),
            normal: -n,
            area: 4.0,
            kind: PortalKind::Mirror,
            one_way: false,
            closed: false,
            door: false,
            internal: false,
            transform: Some(m),
            authored: None,
            partner: None,
        }
    }

    #[test]
    fn facing_mirrors_loop_and_drift_twice_their_distance() {
        let set = PortalSet {
            portals: vec![mirror(0.0, 1.0), mirror(5.0, -1.0)],
            ..Default::default()
        };
        let loops = find_loops(&set, 12.0);
        assert_eq!(loops.len(), 1);
        assert_eq!(loops[0].portals, vec![0, 1]);
        assert!((loops[0].drift - 10.0).abs() < 1e-9, "{}", loops[0].drift);
        // One round moves 10 m, two move 20 m > 12 m: two rounds of two portals.
        assert_eq!(loops[0].depth, 4);
        assert_eq!(recursion_depth(&set, 12.0), 4);
    }

    #[test]
    fn a_lone_mirror_does_not_see_itself() {
        let set = PortalSet {
            portals: vec![mirror(0.0, 1.0)],
            ..Default::default()
        };
        assert!(find_loops(&set, 10.0).is_empty());
        assert_eq!(recursion_depth(&set, 10.0), 1);
    }

    #[test]
    fn mirrors_back_to_back_do_not_loop() {
        // Both face away from each other (-x at x=0, +x at x=5): neither is beyond the other.
        let set = PortalSet {
            portals: vec![mirror(0.0, -1.0), mirror(5.0, 1.0)],
            ..Default::default()
        };
        assert!(find_loops(&set, 12.0).is_empty());
    }

    #[test]
    fn a_teleporter_that_exits_facing_its_own_entry_loops() {
        // Entry on the west wall (x = 0, front +x), exit on the east wall of the same cell
        // facing west: walking in at x = 0 comes out at x = 4, looking back at the entry.
        let set = PortalSet {
            portals: vec![Portal {
                kind: PortalKind::Teleporter,
                normal: DVec3::NEG_X,
                transform: Some(DMat4::from_translation(DVec3::new(4.0, 0.0, 0.0))),
                ..mirror(0.0, 1.0)
            }],
            ..Default::default()
        };
        let loops = find_loops(&set, 12.0);
        assert_eq!(loops.len(), 1);
        assert_eq!(loops[0].portals, vec![0]);
        assert!((loops[0].drift - 4.0).abs() < 1e-12);
        // 4, 8, 12 m are within the 12 m level; the fourth image, 16 m away, is not.
        assert_eq!(loops[0].depth, 4);
    }

    #[test]
    fn a_closed_mirror_breaks_the_loop() {
        let mut b = mirror(5.0, -1.0);
        b.closed = true;
        let set = PortalSet {
            portals: vec![mirror(0.0, 1.0), b],
            ..Default::default()
        };
        assert!(find_loops(&set, 12.0).is_empty());
    }
}
