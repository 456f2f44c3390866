//! Ray oracles on a room's own triangles, shared by the cell tests and the runtime tests: they
//! call nothing of the library's geometry.

use std::collections::HashMap;

use glam::DVec3;
use portcullis::cells::CellSet;
use portcullis::pipeline::Tagged;

/// Where a ray from `p` along `d` meets a triangle (Möller–Trumbore): the distance, whether
/// the triangle's front faces `p`, and whether the hit is clear of the triangle's edges.
pub fn hit(p: DVec3, d: DVec3, t: &[DVec3; 3]) -> Option<(f64, bool, bool)> {
    let (e1, e2) = (t[1] - t[0], t[2] - t[0]);
    let h = d.cross(e2);
    let a = e1.dot(h);
    if a.abs() < 1e-14 * e1.length() * e2.length() {
        return None;
    }
    let s = p - t[0];
    let u = s.dot(h) / a;
    let q = s.cross(e1);
    let v = d.dot(q) / a;
    let dist = e2.dot(q) / a;
    let margin = 1e-9;
    if u < -margin || v < -margin || u + v > 1.0 + margin || dist <= 0.0 {
        return None;
    }
    let clear = u > margin && v > margin && u + v < 1.0 - margin;
    Some((dist, e1.cross(e2).dot(d) < 0.0, clear))
}

/// Inside (`Some(true)`), outside (`Some(false)`) or undecided, from thirteen ray directions; a
/// ray that grazes an edge does not vote. A closed room whose triangles face in is judged by
/// ray parity, ten of thirteen. Any other room (open, or made of solid blocks that face out) by
/// whether the nearest triangle hit faces the point (surfaces face the air), and only where
/// every ray hits the room and all agree: a point near an opening is left out.
pub fn classify(tris: &[[DVec3; 3]], closed: bool, p: DVec3) -> Option<bool> {
    const DIRS: [[f64; 3]; 13] = [
        [0.267, 0.534, 0.801],
        [-0.802, 0.267, 0.535],
        [0.123, -0.912, 0.391],
        [0.577, 0.577, -0.578],
        [-0.311, -0.299, -0.902],
        [0.905, -0.121, -0.408],
        [-0.446, 0.873, -0.197],
        // Near the axes, where openings in levels built on a grid line up (a hole in a floor
        // under a hole in a ceiling).
        [0.011, 0.9998, 0.017],
        [-0.013, -0.9997, 0.019],
        [0.9996, 0.021, -0.016],
        [-0.9995, -0.018, 0.023],
        [0.014, -0.022, 0.9996],
        [-0.019, 0.016, -0.9997],
    ];
    let (mut yes, mut no) = (0, 0);
    'dirs: for d in DIRS {
        let d = DVec3::from_array(d).normalize();
        let mut crossings = 0;
        let mut nearest: Option<(f64, bool)> = None;
        for t in tris {
            if let Some((dist, faces, clear)) = hit(p, d, t) {
                if !clear {
                    continue 'dirs;
                }
                crossings += 1;
                if nearest.is_none_or(|(n, _)| dist < n) {
                    nearest = Some((dist, faces));
                }
            }
        }
        let inside = if closed {
            crossings % 2 == 1
        } else {
            nearest?.1
        };
        if inside {
            yes += 1
        } else {
            no += 1
        }
    }
    let needed = if closed { DIRS.len() - 3 } else { DIRS.len() };
    if yes >= needed {
        Some(true)
    } else if no >= needed {
        Some(false)
    } else {
        None
    }
}

/// Every edge of the triangles has exactly one reversed partner (a closed, oriented surface).
pub fn is_closed(tris: &[[DVec3; 3]]) -> bool {
    let key = |p: DVec3| p.to_array().map(f64::to_bits);
    let mut edges: HashMap<([u64; 3], [u64; 3]), i32> = HashMap::new();
    for t in tris {
        for k in 0..3 {
            *edges.entry((key(t[k]), key(t[(k + 1) % 3]))).or_default() += 1;
        }
    }
    !edges.is_empty()
        && edges
            .iter()
            .all(|((a, b), n)| *n == 1 && edges.get(&(*b, *a)) == Some(&1))
}

/// The edges of the triangles that no other triangle shares: the rims of a room's openings.
pub fn open_edges(tris: &[[DVec3; 3]]) -> Vec<(DVec3, DVec3)> {
    let key = |p: DVec3| (p * 1e5).round().to_array().map(|x| x as i64);
    type Key = [i64; 3];
    let mut uses: HashMap<(Key, Key), (usize, DVec3, DVec3)> = HashMap::new();
    for t in tris {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            let (ka, kb) = (key(a), key(b));
            uses.entry((ka.min(kb), ka.max(kb))).or_insert((0, a, b)).0 += 1;
        }
    }
    uses.into_values()
        .filter(|(n, _, _)| *n == 1)
        .map(|(_, a, b)| (a, b))
        .collect()
}

/// The distance from `p` to the segment `a`-`b`.
pub fn segment_distance(p: DVec3, a: DVec3, b: DVec3) -> f64 {
    let ab = b - a;
    let t = ((p - a).dot(ab) / ab.length_squared().max(f64::MIN_POSITIVE)).clamp(0.0, 1.0);
    p.distance(a + ab * t)
}

/// Signed volume enclosed by triangles (divergence theorem): negative for a surface facing in.
pub fn signed_volume(tris: &[[DVec3; 3]]) -> f64 {
    tris.iter().map(|t| t[0].dot(t[1].cross(t[2])) / 6.0).sum()
}

/// A room's structural triangles in world space, read from the scene: no props, portals,
/// footprints or bounds.
pub fn room_triangles(t: &Tagged, c: &CellSet, r: usize) -> Vec<[DVec3; 3]> {
    let mut out = Vec::new();
    for &n in &t.tagging.rooms[r].structure {
        if c.is_prop(n) {
            continue;
        }
        let Some(m) = t.scene.nodes[n].mesh else {
            continue;
        };
        let w = t.scene.world_positions(n);
        for tri in &t.scene.meshes[m].triangles {
            out.push(tri.map(|i| w[i as usize]));
        }
    }
    out
}

/// The bounds of the triangles' corners.
pub fn bounds(tris: &[[DVec3; 3]]) -> (DVec3, DVec3) {
    let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
    for p in tris.iter().flatten() {
        lo = lo.min(*p);
        hi = hi.max(*p);
    }
    (lo, hi)
}
