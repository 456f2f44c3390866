//! Vertices closer than a tolerance made one: f32 exports of one shape write a corner a few
//! ulps apart where its faces meet (a greybox exporter's brush has `0.0` and `2.8e-16` for one
//! corner), and a test of closed edges or a plan's union must see one point there.
//!
//! Points are joined transitively (a chain of near points is one cluster) and each cluster is
//! named by its least point in (x, y, z) order, so the answer depends neither on the order the
//! points come in nor on where the level stands.

use std::collections::HashMap;

use glam::DVec3;

use crate::disjoint::DisjointSets;

/// For each of `pts`, the least point of its cluster: points within `tol` of each other,
/// transitively. A tolerance that is not positive and finite welds nothing.
pub(crate) fn weld(pts: &[DVec3], tol: f64) -> Vec<DVec3> {
    let order = |a: &DVec3, b: &DVec3| {
        a.x.total_cmp(&b.x)
            .then(a.y.total_cmp(&b.y))
            .then(a.z.total_cmp(&b.z))
    };
    if !(tol > 0.0 && tol.is_finite()) {
        return pts.to_vec();
    }
    let mut uniq: Vec<DVec3> = pts.to_vec();
    uniq.sort_by(order);
    uniq.dedup();
    let mut parts = DisjointSets::new(uniq.len());
    // Points by cell of a grid `tol` wide: a point's neighbours within `tol` are in the 27
    // cells around its own (a sweep along one axis is quadratic in a column of vertices).
    let key = |p: DVec3| {
        let k = (p / tol).floor();
        (k.x as i64, k.y as i64, k.z as i64)
    };
    let mut cells: HashMap<(i64, i64, i64), Vec<usize>> = HashMap::new();
    for (i, p) in uniq.iter().enumerate() {
        cells.entry(key(*p)).or_default().push(i);
    }
    for (i, p) in uniq.iter().enumerate() {
        let (kx, ky, kz) = key(*p);
        for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    let Some(near) = cells.get(&(kx + dx, ky + dy, kz + dz)) else {
                        continue;
                    };
                    for &j in near {
                        if j > i && p.distance(uniq[j]) <= tol {
                            // The root is always the least index: the least point.
                            parts.union(i, j);
                        }
                    }
                }
            }
        }
    }
    pts.iter()
        .map(|p| match uniq.binary_search_by(|q| order(q, p)) {
            Ok(i) => uniq[parts.find(i)],
            Err(_) => *p,
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn near_points_join_the_least_whatever_their_order() {
        let pts = vec![
            DVec3::new(1.0, 0.0, 0.0),
            DVec3::new(1.0, 2.8e-16, 0.0),
            DVec3::new(1.0, -3.7e-14, 0.0),
            DVec3::new(2.0, 0.0, 0.0),
        ];
        let least = DVec3::new(1.0, -3.7e-14, 0.0);
        for order in [pts.clone(), pts.iter().rev().copied().collect()] {
            let out = weld(&order, 1e-9);
            assert_eq!(out.iter().filter(|p| **p == least).count(), 3);
            assert!(out.contains(&DVec3::new(2.0, 0.0, 0.0)));
        }
        // Nothing is welded without a tolerance, nor beyond it.
        assert_eq!(weld(&pts, 0.0), pts);
        assert_eq!(weld(&pts, 1e-15)[0], pts[0]);
    }
}
