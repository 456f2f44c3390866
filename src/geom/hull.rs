//! Convex hulls of point sets, as [`ConvexPolyhedron`]s.
//!
//! parry computes the hull triangles; we only take their planes, each pushed out to the
//! farthest point along its normal, and rebuild the polyhedron by clipping. That way every
//! input point is inside the result by construction, near-coplanar hull triangles collapse
//! into one face, and a failure inside parry (it panics on some degenerate inputs) becomes an
//! error instead of a crash.

use std::collections::HashSet;

use glam::DVec3;

use super::aabb::Aabb;
use super::plane::Plane;
use super::polyhedron::ConvexPolyhedron;
use super::tolerance::Tolerance;

#[derive(Debug, Clone, PartialEq)]
pub(crate) enum HullError {
    /// Fewer than four points, or all of them on one line or point.
    TooFewPoints,
    /// All points lie within tolerance of one plane: the shape has no volume.
    Flat { normal: DVec3 },
    /// The hull computation failed.
    Failed(String),
}

impl std::fmt::Display for HullError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            HullError::TooFewPoints => f.write_str("fewer than four distinct points"),
            HullError::Flat { normal } => {
                // Either side of the plane will do: the one whose largest component is
                // positive, each component rounded as printed (no "-0.000").
                let big = normal.abs().max_element();
                let first = normal.to_array().into_iter().find(|c| c.abs() == big);
                let n = if first.is_some_and(|c| c < 0.0) {
                    -*normal
                } else {
                    *normal
                };
                let r = |c: f64| (c * 1000.0).round() / 1000.0 + 0.0;
                write!(
                    f,
                    "all points lie in one plane (normal ({:.3}, {:.3}, {:.3})), so there is no volume",
                    r(n.x),
                    r(n.y),
                    r(n.z)
                )
            }
            HullError::Failed(s) => write!(f, "convex hull failed: {s}"),
        }
    }
}

/// Checks the points span a volume; returns the normal of the best-fit plane if they do not.
fn check_volume(points: &[DVec3], eps: f64) -> Result<(), HullError> {
    let p0 = *points.first().ok_or(HullError::TooFewPoints)?;
    let far = |f: &dyn Fn(DVec3) -> f64| {
        points
            .iter()
            .copied()
            .max_by(|a, b| f(*a).total_cmp(&f(*b)))
            .unwrap_or(p0)
    };
    let p1 = far(&|p| p.distance_squared(p0));
    let dir = (p1 - p0).try_normalize().ok_or(HullError::TooFewPoints)?;
    let off_line = |p: DVec3| (p - p0).reject_from_normalized(dir).length_squared();
    let p2 = far(&off_line);
    if off_line(p2).sqrt() <= eps {
        return Err(HullError::TooFewPoints);
    }
    let normal = dir.cross(p2 - p0).normalize();
    let p3 = far(&|p| (p - p0).dot(normal).abs());
    if (p3 - p0).dot(normal).abs() <= eps {
        return Err(HullError::Flat { normal });
    }
    Ok(())
}

/// Each point once (the same to the bit), at its last occurrence: a room's points are its
/// triangles' corners, each corner three to six times, and the hull work grows with the count.
/// Every use of the points below is a maximum or a minimum over them (`max_by` keeps the last
/// of equal candidates, so the last occurrence is the one it would have picked).
fn distinct(points: &[DVec3]) -> Vec<DVec3> {
    let mut seen: HashSet<[u64; 3], foldhash::fast::FixedState> =
        HashSet::with_capacity_and_hasher(points.len(), Default::default());
    let mut out: Vec<DVec3> = points
        .iter()
        .rev()
        .filter(|p| seen.insert(p.to_array().map(f64::to_bits)))
        .copied()
        .collect();
    out.reverse();
    out
}

/// The convex hull of `points`.
pub fn hull(points: &[DVec3], eps: f64) -> Result<ConvexPolyhedron, HullError> {
    if points.len() < 4 || points.iter().any(|p| !p.is_finite()) {
        return Err(HullError::TooFewPoints);
    }
    let pts = distinct(points);
    let points = pts.as_slice();
    check_volume(points, eps)?;
    let pts = points.to_vec();
    let result =
        std::panic::catch_unwind(move || parry3d_f64::transformation::try_convex_hull(&pts));
    let (verts, tris) = match result {
        Ok(Ok(v)) => v,
        Ok(Err(e)) => return Err(HullError::Failed(format!("{e:?}"))),
        Err(_) => return Err(HullError::Failed("the hull library panicked".into())),
    };
    let mut planes: Vec<Plane> = Vec::new();
    for t in &tris {
        let [a, b, c] = t.map(|i| verts.get(i as usize).copied().unwrap_or(DVec3::ZERO));
        let Some(n) = (b - a).cross(c - a).try_normalize() else {
            continue;
        };
        // A hull face made of many triangles gives the same plane many times: those are
        // dropped before the plane is pushed out to the farthest point (a pass over all
        // points), with the triangle's own offset, which is within rounding of it.
        let guess = Plane {
            normal: n,
            d: n.dot(a),
        };
        if planes.iter().any(|q| Tolerance::recomputed(q, &guess, eps)) {
            continue;
        }
        let d = points
            .iter()
            .map(|p| n.dot(*p))
            .fold(f64::NEG_INFINITY, f64::max);
        let pl = Plane { normal: n, d };
        if !planes.iter().any(|q| Tolerance::recomputed(q, &pl, eps)) {
            planes.push(pl);
        }
    }
    let bounds = Aabb::from_points(points.iter());
    ConvexPolyhedron::from_planes(&planes, &bounds, eps)
        .map(|p| p.simplified(eps))
        .ok_or_else(|| HullError::Failed("the hull planes do not enclose a volume".into()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_flat_room_names_one_side_of_its_plane_without_negative_zeros() {
        for n in [DVec3::new(-0.0, -1.0, 0.0), DVec3::new(0.0, 1.0, -1e-9)] {
            let text = HullError::Flat { normal: n }.to_string();
            assert!(text.contains("(0.000, 1.000, 0.000)"), "{text}");
        }
    }

    #[test]
    fn hull_of_a_box_with_coplanar_points() {
        let mut pts = Vec::new();
        for x in 0..=4 {
            for y in 0..=2 {
                for z in 0..=3 {
                    pts.push(DVec3::new(x as f64, y as f64 * 0.5, z as f64));
                }
            }
        }
        let h = hull(&pts, 1e-9).unwrap();
        assert_eq!(h.faces.len(), 6);
        assert!((h.volume() - 4.0 * 1.0 * 3.0).abs() < 1e-9);
        for p in &pts {
            assert!(h.contains(*p, 1e-9));
        }
    }

    /// A room's points come as triangle corners, each several times: the hull is the one of
    /// the distinct points, face for face, whatever the repeats.
    #[test]
    fn repeated_points_change_nothing() {
        let mut rng = crate::rng::SplitMix64::new(3);
        let pts: Vec<DVec3> = (0..60)
            .map(|_| DVec3::new(rng.unit(), rng.unit(), rng.unit()) * 4.0)
            .collect();
        let once = hull(&pts, 1e-9).unwrap();
        let mut repeated: Vec<DVec3> = pts.iter().flat_map(|p| [*p, *p]).collect();
        repeated.extend_from_slice(&pts);
        assert_eq!(hull(&repeated, 1e-9).unwrap(), once);
        // Each point at its last occurrence; -0.0 and 0.0 differ to the bit, and stay apart.
        let (a, b, c) = (DVec3::X, DVec3::Y, DVec3::new(-0.0, 0.0, 0.0));
        assert_eq!(
            distinct(&[a, b, a, DVec3::ZERO, c, b]),
            vec![a, DVec3::ZERO, c, b]
        );
    }

    #[test]
    fn degenerate_inputs_are_errors() {
        let flat: Vec<DVec3> = (0..10)
            .map(|i| DVec3::new(i as f64, (i * i) as f64, 0.0))
            .collect();
        assert!(matches!(hull(&flat, 1e-9), Err(HullError::Flat { .. })));
        let line: Vec<DVec3> = (0..10).map(|i| DVec3::splat(i as f64)).collect();
        assert_eq!(hull(&line, 1e-9), Err(HullError::TooFewPoints));
        assert_eq!(hull(&[], 1e-9), Err(HullError::TooFewPoints));
        let nan = vec![DVec3::NAN; 5];
        assert_eq!(hull(&nan, 1e-9), Err(HullError::TooFewPoints));
    }
}
