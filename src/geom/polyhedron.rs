//! Convex polyhedra as planes plus face polygons, the representation a cell needs: planes for
//! containment and portal tests, faces for openings, drawing and volumes.
//!
//! Everything is built by clipping: a box clipped by half-spaces. Clipping classifies points
//! against a plane with the distance tolerance (a point within it is *on* the plane), so a
//! plane that grazes a vertex does not create sliver faces, and a redundant plane adds
//! nothing.

use glam::{DVec2, DVec3};
use serde::Serialize;

use super::aabb::Aabb;
use super::plane::Plane;
use super::tolerance::Tolerance;

/// One face of a convex polyhedron.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Face {
    /// Outward plane.
    pub plane: Plane,
    /// Vertices, counter-clockwise seen from outside (from the side the normal points to).
    pub points: Vec<DVec3>,
}

/// A convex solid given by its faces; a cell's volume.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ConvexPolyhedron {
    /// The boundary: the solid is the points behind every face's plane.
    pub faces: Vec<Face>,
}

/// On a cell of many faces, [`ConvexPolyhedron::simplified`] tries only the faces whose area
/// is under this many tolerances times their perimeter (a strip about two hundred tolerances
/// wide at most): only so thin a face can go (dropping its plane must move no vertex more than
/// a tolerance), and trying each of a big cell's faces costs a rebuild each.
const SLIVER: f64 = 100.0;

impl ConvexPolyhedron {
    /// The box as a polyhedron (six faces).
    pub fn from_aabb(b: &Aabb) -> ConvexPolyhedron {
        let (lo, hi) = (b.min, b.max);
        let p = |x: f64, y: f64, z: f64| DVec3::new(x, y, z);
        let face = |n: DVec3, d: f64, pts: [DVec3; 4]| Face {
            plane: Plane { normal: n, d },
            points: pts.to_vec(),
        };
        ConvexPolyhedron {
            faces: vec![
                face(
                    -DVec3::X,
                    -lo.x,
                    [
                        p(lo.x, lo.y, lo.z),
                        p(lo.x, lo.y, hi.z),
                        p(lo.x, hi.y, hi.z),
                        p(lo.x, hi.y, lo.z),
                    ],
                ),
                face(
                    DVec3::X,
                    hi.x,
                    [
                        p(hi.x, lo.y, lo.z),
                        p(hi.x, hi.y, lo.z),
                        p(hi.x, hi.y, hi.z),
                        p(hi.x, lo.y, hi.z),
                    ],
                ),
                face(
                    -DVec3::Y,
                    -lo.y,
                    [
                        p(lo.x, lo.y, lo.z),
                        p(hi.x, lo.y, lo.z),
                        p(hi.x, lo.y, hi.z),
                        p(lo.x, lo.y, hi.z),
                    ],
                ),
                face(
                    DVec3::Y,
                    hi.y,
                    [
                        p(lo.x, hi.y, lo.z),
                        p(lo.x, hi.y, hi.z),
                        p(hi.x, hi.y, hi.z),
                        p(hi.x, hi.y, lo.z),
                    ],
                ),
                face(
                    -DVec3::Z,
                    -lo.z,
                    [
                        p(lo.x, lo.y, lo.z),
                        p(lo.x, hi.y, lo.z),
                        p(hi.x, hi.y, lo.z),
                        p(hi.x, lo.y, lo.z),
                    ],
                ),
                face(
                    DVec3::Z,
                    hi.z,
                    [
                        p(lo.x, lo.y, hi.z),
                        p(hi.x, lo.y, hi.z),
                        p(hi.x, hi.y, hi.z),
                        p(lo.x, hi.y, hi.z),
                    ],
                ),
            ],
        }
    }

    /// The intersection of half-spaces `plane.distance(p) <= 0` inside `bounds` (which must
    /// contain the result; it only makes the start finite).
    pub(crate) fn from_planes(
        planes: &[Plane],
        bounds: &Aabb,
        eps: f64,
    ) -> Option<ConvexPolyhedron> {
        let b = bounds.grown(bounds.size().max_element().max(1.0));
        let mut p = ConvexPolyhedron::from_aabb(&b);
        for pl in planes {
            p = p.clip(pl, eps)?;
        }
        // Faces of the padding box that survived mean the planes did not close the volume.
        let bounded = p.faces.iter().all(|f| {
            planes
                .iter()
                .any(|q| Tolerance::recomputed(q, &f.plane, eps))
        });
        bounded.then_some(p)
    }

    /// The faces' outward planes: a point is inside when it is behind all of them.
    pub fn planes(&self) -> impl Iterator<Item = &Plane> {
        self.faces.iter().map(|f| &f.plane)
    }

    /// Distinct vertices.
    pub fn vertices(&self, eps: f64) -> Vec<DVec3> {
        let mut out: Vec<DVec3> = Vec::new();
        for f in &self.faces {
            for p in &f.points {
                if !out.iter().any(|q| q.distance_squared(*p) <= eps * eps) {
                    out.push(*p);
                }
            }
        }
        out
    }

    /// The box around the vertices.
    pub fn bounds(&self) -> Aabb {
        Aabb::from_points(self.faces.iter().flat_map(|f| f.points.iter()))
    }

    /// Mean of the face vertices: strictly inside for a non-degenerate polyhedron.
    pub(crate) fn interior_point(&self) -> DVec3 {
        let (sum, n) = self
            .faces
            .iter()
            .flat_map(|f| f.points.iter())
            .fold((DVec3::ZERO, 0usize), |(s, n), p| (s + *p, n + 1));
        sum / n.max(1) as f64
    }

    /// Cubic metres.
    pub fn volume(&self) -> f64 {
        let c = self.interior_point();
        let mut v = 0.0;
        for f in &self.faces {
            let a = f.points[0];
            for w in f.points[1..].windows(2) {
                v += (a - c).dot((w[0] - c).cross(w[1] - c)) / 6.0;
            }
        }
        v
    }

    /// Inside or within `eps` of the boundary.
    pub fn contains(&self, p: DVec3, eps: f64) -> bool {
        self.faces.iter().all(|f| f.plane.distance(p) <= eps)
    }

    /// Strictly inside, more than `eps` from every face.
    pub fn contains_strictly(&self, p: DVec3, eps: f64) -> bool {
        self.faces.iter().all(|f| f.plane.distance(p) < -eps)
    }

    /// The solid moved by `t`.
    pub(crate) fn translated(&self, t: DVec3) -> ConvexPolyhedron {
        ConvexPolyhedron {
            faces: self
                .faces
                .iter()
                .map(|f| Face {
                    plane: f.plane.translated(t),
                    points: f.points.iter().map(|p| *p + t).collect(),
                })
                .collect(),
        }
    }

    /// The part behind `plane` (`distance <= 0`). `None` when nothing of volume remains.
    pub(crate) fn clip(&self, plane: &Plane, eps: f64) -> Option<ConvexPolyhedron> {
        let mut any_out = false;
        let mut any_in = false;
        for f in &self.faces {
            for p in &f.points {
                let d = plane.distance(*p);
                any_out |= d > eps;
                any_in |= d < -eps;
            }
        }
        if !any_out {
            return Some(self.clone());
        }
        if !any_in {
            return None;
        }
        let mut faces = Vec::with_capacity(self.faces.len() + 1);
        let mut cap: Vec<DVec3> = Vec::new();
        for f in &self.faces {
            let n = f.points.len();
            let mut out = Vec::with_capacity(n + 2);
            for i in 0..n {
                let a = f.points[i];
                let b = f.points[(i + 1) % n];
                let (da, db) = (plane.distance(a), plane.distance(b));
                if da <= eps {
                    out.push(a);
                    if da.abs() <= eps {
                        cap.push(a);
                    }
                }
                if (da < -eps && db > eps) || (da > eps && db < -eps) {
                    let x = a + (b - a) * (da / (da - db));
                    out.push(x);
                    cap.push(x);
                }
            }
            dedupe_ring(&mut out, eps);
            if out.len() >= 3 && polygon_area(&out, f.plane.normal) > eps * eps {
                faces.push(Face {
                    plane: f.plane,
                    points: out,
                });
            }
        }
        let ring = convex_ring_on_plane(&cap, plane, eps);
        if ring.len() >= 3
            && !faces
                .iter()
                .any(|f| Tolerance::recomputed(&f.plane, plane, eps))
        {
            faces.push(Face {
                plane: *plane,
                points: ring,
            });
        }
        let p = ConvexPolyhedron { faces };
        (p.faces.len() >= 4 && p.volume() > eps * eps * eps).then_some(p)
    }

    /// Removes sliver faces: faces so thin that dropping their plane moves no vertex more than
    /// `eps` out of it. Float noise in the input (f32 positions through rotation matrices) makes
    /// hulls with such facets; a cell should not carry planes its shape does not need.
    pub(crate) fn simplified(&self, eps: f64) -> ConvexPolyhedron {
        let mut current = self.clone();
        loop {
            let bounds = current.bounds();
            let mut candidates: Vec<(f64, usize)> = current
                .faces
                .iter()
                .enumerate()
                .filter_map(|(i, f)| {
                    let area = polygon_area(&f.points, f.plane.normal);
                    let perimeter: f64 = (0..f.points.len())
                        .map(|k| f.points[k].distance(f.points[(k + 1) % f.points.len()]))
                        .sum();
                    // Every face is tried on small cells; big ones only try slivers.
                    (current.faces.len() <= 64 || area <= SLIVER * eps * perimeter)
                        .then_some((area, i))
                })
                .collect();
            candidates.sort_by(|a, b| a.0.total_cmp(&b.0));
            let mut changed = false;
            for (_, i) in candidates {
                let gone = current.faces[i].plane;
                // No other plane leaning towards this one's front: without it the shape is
                // unbounded along its normal, so it stays (a box's faces, most cells'). Said
                // here without rebuilding the polyhedron, which would only find the same.
                if current
                    .faces
                    .iter()
                    .enumerate()
                    .all(|(j, f)| j == i || f.plane.normal.dot(gone.normal) <= 0.0)
                {
                    continue;
                }
                let others: Vec<Plane> = current
                    .faces
                    .iter()
                    .enumerate()
                    .filter(|(j, _)| *j != i)
                    .map(|(_, f)| f.plane)
                    .collect();
                if let Some(p) = ConvexPolyhedron::from_planes(&others, &bounds, eps) {
                    if p.faces
                        .iter()
                        .flat_map(|f| f.points.iter())
                        .all(|v| gone.distance(*v) <= eps)
                    {
                        current = p;
                        changed = true;
                        break;
                    }
                }
            }
            if !changed {
                return current;
            }
        }
    }

    /// The parts behind and in front of `plane`.
    pub fn split(
        &self,
        plane: &Plane,
        eps: f64,
    ) -> (Option<ConvexPolyhedron>, Option<ConvexPolyhedron>) {
        (self.clip(plane, eps), self.clip(&plane.flipped(), eps))
    }

    /// The common part of two convex polyhedra.
    pub fn intersection(&self, other: &ConvexPolyhedron, eps: f64) -> Option<ConvexPolyhedron> {
        let mut p = self.clone();
        for f in &other.faces {
            p = p.clip(&f.plane, eps)?;
        }
        Some(p)
    }
}

fn dedupe_ring(pts: &mut Vec<DVec3>, eps: f64) {
    let e2 = eps * eps;
    pts.dedup_by(|a, b| a.distance_squared(*b) <= e2);
    while pts.len() > 1 && pts[0].distance_squared(pts[pts.len() - 1]) <= e2 {
        pts.pop();
    }
}

/// The part of a convex polygon behind the plane `normal · p = d` (Sutherland–Hodgman, no
/// tolerance: callers shift `d` by theirs). Fewer than three points means nothing is left.
pub(crate) fn clip_polygon(poly: &[DVec3], normal: DVec3, d: f64) -> Vec<DVec3> {
    let mut out = Vec::with_capacity(poly.len() + 2);
    for i in 0..poly.len() {
        let a = poly[i];
        let b = poly[(i + 1) % poly.len()];
        let (da, db) = (normal.dot(a) - d, normal.dot(b) - d);
        if da <= 0.0 {
            out.push(a);
        }
        if (da < 0.0 && db > 0.0) || (da > 0.0 && db < 0.0) {
            out.push(a + (b - a) * (da / (da - db)));
        }
    }
    out
}

/// The part of polygon `a` inside convex polygon `b` (both on one plane with `normal`, either
/// winding); fewer than three points when they do not overlap. The one convex overlap: the
/// block reading's shared faces and the authored portals' matching both use it.
pub(crate) fn overlap(a: &[DVec3], b: &[DVec3], normal: DVec3) -> Vec<DVec3> {
    let turn = b
        .windows(2)
        .skip(1)
        .fold(DVec3::ZERO, |n, w| n + (w[0] - b[0]).cross(w[1] - b[0]));
    let normal = if turn.dot(normal) < 0.0 {
        -normal
    } else {
        normal
    };
    let mut out = a.to_vec();
    for i in 0..b.len() {
        let (p, q) = (b[i], b[(i + 1) % b.len()]);
        let Some(m) = (q - p).cross(normal).try_normalize() else {
            continue;
        };
        out = clip_polygon(&out, m, m.dot(p));
        if out.len() < 3 {
            return Vec::new();
        }
    }
    out
}

/// Area of a planar polygon (projected on `normal`).
///
/// Measured from its first vertex: cross products of world positions cancel, and a 1 m² door
/// 2·10^5 m from the origin came out 1e-6 too large from products of 10^10 m².
pub fn polygon_area(pts: &[DVec3], normal: DVec3) -> f64 {
    let Some(&o) = pts.first() else {
        return 0.0;
    };
    let mut n = DVec3::ZERO;
    for w in pts[1..].windows(2) {
        n += (w[0] - o).cross(w[1] - o);
    }
    0.5 * n.dot(normal).abs()
}

/// A polygon as portals need it: vertices closer than `eps` to the previous one merged, and
/// `None` unless at least three remain and it is wider than `eps` on average (twice its area
/// over its perimeter) — the one test for "has an area" that building and checking share.
pub(crate) fn usable_polygon(pts: &[DVec3], normal: DVec3, eps: f64) -> Option<Vec<DVec3>> {
    let mut out: Vec<DVec3> = Vec::with_capacity(pts.len());
    for p in pts {
        if out.last().is_none_or(|q| q.distance(*p) > eps) {
            out.push(*p);
        }
    }
    while out.len() > 1 && out[0].distance(out[out.len() - 1]) <= eps {
        out.pop();
    }
    if out.len() < 3 {
        return None;
    }
    let perimeter: f64 = (0..out.len())
        .map(|i| out[i].distance(out[(i + 1) % out.len()]))
        .sum();
    (2.0 * polygon_area(&out, normal) > eps * perimeter).then_some(out)
}

/// The convex hull of points lying on `plane`, counter-clockwise about its normal. Exact
/// orientation predicates decide the hull; near-duplicates (within `eps`) are merged first.
pub(crate) fn convex_ring_on_plane(pts: &[DVec3], plane: &Plane, eps: f64) -> Vec<DVec3> {
    let mut uniq: Vec<DVec3> = Vec::new();
    for p in pts {
        if !uniq.iter().any(|q| q.distance_squared(*p) <= eps * eps) {
            uniq.push(*p);
        }
    }
    if uniq.len() < 3 {
        return uniq;
    }
    let (u, v) = plane.basis();
    let origin = uniq[0];
    let mut pp: Vec<(DVec2, DVec3)> = uniq
        .iter()
        .map(|p| (DVec2::new((*p - origin).dot(u), (*p - origin).dot(v)), *p))
        .collect();
    pp.sort_by(|a, b| a.0.x.total_cmp(&b.0.x).then(a.0.y.total_cmp(&b.0.y)));
    let orient = |a: DVec2, b: DVec2, c: DVec2| {
        robust::orient2d(
            robust::Coord { x: a.x, y: a.y },
            robust::Coord { x: b.x, y: b.y },
            robust::Coord { x: c.x, y: c.y },
        )
    };
    // Andrew's monotone chain; collinear points are dropped.
    let mut hull: Vec<(DVec2, DVec3)> = Vec::with_capacity(pp.len() * 2);
    for pass in 0..2 {
        let start = hull.len();
        let iter: Box<dyn Iterator<Item = &(DVec2, DVec3)>> = if pass == 0 {
            Box::new(pp.iter())
        } else {
            Box::new(pp.iter().rev())
        };
        for p in iter {
            while hull.len() >= start + 2
                && orient(hull[hull.len() - 2].0, hull[hull.len() - 1].0, p.0) <= 0.0
            {
                hull.pop();
            }
            hull.push(*p);
        }
        hull.pop();
    }
    let mut ring: Vec<DVec3> = hull.into_iter().map(|(_, p)| p).collect();
    dedupe_ring(&mut ring, eps);
    ring
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unit_box() -> ConvexPolyhedron {
        ConvexPolyhedron::from_aabb(&Aabb {
            min: DVec3::ZERO,
            max: DVec3::ONE,
        })
    }

    #[test]
    fn box_volume_and_orientation() {
        let b = unit_box();
        assert!((b.volume() - 1.0).abs() < 1e-12);
        for f in &b.faces {
            let pl = Plane::from_polygon(&f.points).unwrap();
            assert!(pl.same_as(&f.plane, 1e-12, 1e-9), "{f:?}");
        }
        assert!(b.contains(DVec3::splat(0.5), 0.0));
        assert!(!b.contains(DVec3::splat(1.5), 1e-9));
    }

    #[test]
    fn clipping_by_a_diagonal_halves_the_volume() {
        let b = unit_box();
        let pl = Plane::from_point_normal(DVec3::splat(0.5), DVec3::new(1., 1., 1.)).unwrap();
        let (back, front) = b.split(&pl, 1e-9);
        let (back, front) = (back.unwrap(), front.unwrap());
        assert!((back.volume() - 0.5).abs() < 1e-12);
        assert!((front.volume() - 0.5).abs() < 1e-12);
        assert_eq!(back.faces.len(), 7);
        for f in back.faces.iter().chain(front.faces.iter()) {
            let pl = Plane::from_polygon(&f.points).unwrap();
            assert!(pl.same_as(&f.plane, 1e-9, 1e-6), "{f:?}");
        }
    }

    #[test]
    fn redundant_and_grazing_planes_change_nothing() {
        let b = unit_box();
        let outside = Plane::from_point_normal(DVec3::new(2., 0., 0.), DVec3::X).unwrap();
        assert_eq!(b.clip(&outside, 1e-9).unwrap(), b);
        let on_face = Plane::from_point_normal(DVec3::new(1., 0., 0.), DVec3::X).unwrap();
        assert_eq!(b.clip(&on_face, 1e-9).unwrap().faces.len(), 6);
        let away = Plane::from_point_normal(DVec3::new(1., 0., 0.), -DVec3::X).unwrap();
        assert!(b.clip(&away, 1e-9).is_none());
    }

    #[test]
    fn overlap_is_the_shared_part_whichever_way_the_clip_polygon_turns() {
        let sq = |x0: f64, y0: f64, s: f64| {
            vec![
                DVec3::new(x0, y0, 0.0),
                DVec3::new(x0 + s, y0, 0.0),
                DVec3::new(x0 + s, y0 + s, 0.0),
                DVec3::new(x0, y0 + s, 0.0),
            ]
        };
        let (a, b) = (sq(0.0, 0.0, 2.0), sq(1.0, 1.0, 2.0));
        let mut b_cw = b.clone();
        b_cw.reverse();
        for (clip, normal) in [
            (&b, DVec3::Z),
            (&b_cw, DVec3::Z),
            (&b, -DVec3::Z),
            (&b_cw, -DVec3::Z),
        ] {
            let part = overlap(&a, clip, normal);
            assert!(
                (polygon_area(&part, normal) - 1.0).abs() < 1e-12,
                "{part:?}"
            );
        }
        assert!(overlap(&a, &sq(5.0, 5.0, 1.0), DVec3::Z).len() < 3);
    }

    #[test]
    fn from_planes_and_intersection() {
        let planes: Vec<Plane> = unit_box().faces.iter().map(|f| f.plane).collect();
        let big = Aabb {
            min: DVec3::splat(-5.),
            max: DVec3::splat(5.),
        };
        let p = ConvexPolyhedron::from_planes(&planes, &big, 1e-9).unwrap();
        assert!((p.volume() - 1.0).abs() < 1e-12);
        assert!(ConvexPolyhedron::from_planes(&planes[..5], &big, 1e-9).is_none());
        let shifted = unit_box().translated(DVec3::new(0.5, 0.5, 0.0));
        let i = unit_box().intersection(&shifted, 1e-9).unwrap();
        assert!((i.volume() - 0.25).abs() < 1e-12);
        let apart = unit_box().translated(DVec3::new(1.0, 0.0, 0.0));
        assert!(unit_box().intersection(&apart, 1e-9).is_none());
    }
}
