//! Each portal's shape and place, and each pair's agreement: at least three distinct points,
//! planar, convex, on its cells' boundary, between two different cells, paired with a partner
//! that has the same polygon the other way, and no two portals overlapping between the same
//! cells. Portals portcullis derives satisfy these by construction; a stored annotation that
//! was edited or written by another tool may not, and an engine trusts them blindly.

use glam::{DVec2, DVec3};

use super::{centroid, Subject};
use crate::diag::{Code, Diagnostic, Diagnostics};
use crate::geom::boolean2::intersection;
use crate::geom::plane::Plane;
use crate::geom::polyhedron::{usable_polygon, ConvexPolyhedron};
use crate::portals::Portal;
use crate::tags::rules::PortalKind;

/// The cosine (of 2.6 degrees) above which a face of a portal's cell is parallel enough to
/// the portal for it to lie on that face ([`on_face`], [`nearest_face`]). Not the angle
/// tolerance: the portals checked are read from a file or drawn by hand (a mirror's quad is a
/// few degrees off its wall and still on it), and their planes are measured from their stored
/// points; which face a portal lies on is settled by the distance, within the wall's reach.
const ON_FACE_COS: f64 = 0.999;

/// Two portals between the same cells are compared for overlap when their planes are within
/// this (radians) and ten tolerances of each other. Not the angle tolerance: each plane is
/// measured from a portal's stored points, each within the distance tolerance (up to a
/// millimetre), so across a portal a metre or two wide it is only good to about this.
const DUPLICATE_ANGLE: f64 = 1e-3;

/// Distinct points of a polygon, within `eps`.
fn distinct(poly: &[DVec3], eps: f64) -> Vec<DVec3> {
    let mut out: Vec<DVec3> = Vec::new();
    for p in poly {
        if !out.iter().any(|q| q.distance_squared(*p) <= eps * eps) {
            out.push(*p);
        }
    }
    out
}

/// Coordinates in `plane`, for 2D tests.
fn on_plane(poly: &[DVec3], plane: &Plane) -> Vec<DVec2> {
    let (u, v) = plane.basis();
    poly.iter()
        .map(|p| DVec2::new(p.dot(u), p.dot(v)))
        .collect()
}

/// The worst reflex turn (m): how far a vertex lies on the wrong side of the line through its
/// neighbours; 0 for a convex polygon.
fn reflex_depth(ring: &[DVec2]) -> f64 {
    let n = ring.len();
    let mut worst = 0.0f64;
    for i in 0..n {
        let (a, b, c) = (ring[(i + n - 1) % n], ring[i], ring[(i + 1) % n]);
        let base = (c - a).length();
        if base <= 0.0 {
            continue;
        }
        // Positive for a left (convex) turn of a counter-clockwise ring.
        let turn = (b - a).perp_dot(c - b) / base;
        worst = worst.max(-turn);
    }
    worst
}

/// How far `p` is outside `poly` (0 inside): the largest plane distance, a lower bound of
/// the true distance that is exact across a face.
fn outside(poly: &ConvexPolyhedron, p: DVec3) -> f64 {
    poly.planes().map(|pl| pl.distance(p)).fold(0.0, f64::max)
}

/// Whether `plane` lies on a face of `poly`, within `reach` across it.
fn on_face(poly: &ConvexPolyhedron, plane: &Plane, c: DVec3, reach: f64) -> bool {
    poly.planes()
        .any(|f| f.normal.dot(plane.normal).abs() > ON_FACE_COS && f.distance(c).abs() <= reach)
}

pub(super) fn check(s: &Subject, out: &mut Diagnostics) {
    let tol = 10.0 * s.eps;
    let mut shapes: Vec<Option<Plane>> = Vec::with_capacity(s.portals.portals.len());
    for (i, p) in s.portals.portals.iter().enumerate() {
        let c = centroid(&p.polygon);
        let pts = distinct(&p.polygon, s.eps);
        let plane = Plane::from_polygon(&pts)
            .filter(|pl| usable_polygon(&p.polygon, pl.normal, s.eps).is_some());
        let Some(plane) = plane else {
            out.push(
                Diagnostic::new(
                    Code::PORTAL_TOO_FEW_POINTS,
                    format!(
                        "{} has {} distinct point(s){}, so it has no area",
                        s.portal(i),
                        pts.len(),
                        if pts.len() >= 3 {
                            ", all on one line or nearly"
                        } else {
                            ""
                        }
                    ),
                    s.at(i, c),
                )
                .hint(
                    "give the portal a polygon of at least three points that are not on one line",
                ),
            );
            shapes.push(None);
            continue;
        };
        shapes.push(Some(plane));
        let off = pts
            .iter()
            .map(|q| plane.distance(*q).abs())
            .fold(0.0, f64::max);
        if off > tol {
            out.push(
                Diagnostic::new(
                    Code::PORTAL_NOT_PLANAR,
                    format!(
                        "{} is not planar: a vertex is {off:.4} m off its plane",
                        s.portal(i)
                    ),
                    s.at(i, c),
                )
                .hint("flatten the portal polygon onto one plane"),
            );
        }
        let depth = reflex_depth(&on_plane(&pts, &plane));
        if depth > tol {
            out.push(
                Diagnostic::new(
                    Code::PORTAL_NOT_CONVEX,
                    format!(
                        "{} is not convex: a vertex turns {depth:.4} m the wrong way",
                        s.portal(i)
                    ),
                    s.at(i, c),
                )
                .hint("split the portal into convex polygons, or use its convex hull"),
            );
        }
        boundary(s, i, p, &plane, c, out);
        if p.transform.is_none() && p.to == Some(p.from) {
            out.push(
                Diagnostic::new(
                    Code::PORTAL_SEPARATES_NOTHING,
                    format!(
                        "{} leads from {} into itself: it separates nothing",
                        s.portal(i),
                        s.cell(p.from)
                    ),
                    s.at(i, c),
                )
                .hint("remove the portal, or move it into the opening between two rooms"),
            );
        }
    }
    pairing(s, &shapes, out);
    duplicates(s, &shapes, out);
}

/// A portal lies on its source cell's boundary (across a wall up to the configured
/// thickness), and its target cell is on the other side within the same reach.
fn boundary(s: &Subject, i: usize, p: &Portal, plane: &Plane, c: DVec3, out: &mut Diagnostics) {
    let reach = s.max_wall_thickness + 10.0 * s.eps;
    let poly_of = |k: usize| s.cells.get(k).and_then(|c| c.poly.as_ref());
    let mut problems = Vec::new();
    if let Some(from) = poly_of(p.from) {
        let d = outside(from, c);
        if d > reach || !on_face(from, plane, c, reach) {
            // No face parallel to it: there is no distance to give ("inf m" said nothing).
            let near = nearest_face(from, plane, c).max(d);
            problems.push(if near.is_finite() {
                format!(
                    "it is {near:.3} m from the nearest face of {} that it could lie on",
                    s.cell(p.from)
                )
            } else {
                format!(
                    "no face of {} is parallel to it, so it lies on none",
                    s.cell(p.from)
                )
            });
        }
    }
    if p.transform.is_none() {
        if let Some(to) = p.to.and_then(poly_of) {
            let d = outside(to, c);
            if d > reach {
                problems.push(format!(
                    "its target {} is {d:.3} m away",
                    s.cell(p.to.unwrap_or(0))
                ));
            }
        }
    }
    if !problems.is_empty() {
        out.push(
            Diagnostic::new(
                Code::PORTAL_NOT_ON_BOUNDARY,
                format!(
                    "{} does not lie on its cells' boundary: {}",
                    s.portal(i),
                    problems.join("; ")
                ),
                s.at(i, c),
            )
            .hint("move the portal onto the wall between its cells, or recompute the annotation with `portcullis convert`"),
        );
    }
}

/// Distance from `c` to the nearest face of `poly` parallel to `plane` (infinite if none).
fn nearest_face(poly: &ConvexPolyhedron, plane: &Plane, c: DVec3) -> f64 {
    poly.planes()
        .filter(|f| f.normal.dot(plane.normal).abs() > ON_FACE_COS)
        .map(|f| f.distance(c).abs())
        .fold(f64::INFINITY, f64::min)
}

/// Whether two polygons have the same vertices (within `tol`), in any order.
fn same_points(a: &[DVec3], b: &[DVec3], tol: f64) -> bool {
    let near = |p: &DVec3, set: &[DVec3]| set.iter().any(|q| q.distance(*p) <= tol);
    a.iter().all(|p| near(p, b)) && b.iter().all(|p| near(p, a))
}

fn pairing(s: &Subject, shapes: &[Option<Plane>], out: &mut Diagnostics) {
    let ps = &s.portals.portals;
    let tol = 10.0 * s.eps;
    for (i, p) in ps.iter().enumerate() {
        let c = centroid(&p.polygon);
        let Some(j) = p.partner else {
            let two_way = !p.one_way && p.to.is_some_and(|t| t != p.from);
            if two_way && p.kind != PortalKind::Mirror {
                out.push(
                    Diagnostic::new(
                        Code::PORTAL_UNPAIRED,
                        format!("{} is two-way but has no partner going back", s.portal(i)),
                        s.at(i, c),
                    )
                    .hint("flag it one-way, or add the portal back with the same polygon reversed"),
                );
            }
            continue;
        };
        let Some(q) = ps.get(j) else { continue };
        let mut problems = Vec::new();
        if q.partner != Some(i) {
            problems.push(format!("portal {j} does not name it back"));
        } else if j != i && (q.from != p.to.unwrap_or(usize::MAX) || q.to != Some(p.from)) {
            problems.push(format!(
                "portal {j} joins {} and {} rather than the same cells the other way",
                s.cell(q.from),
                q.to.map_or("the exterior", |t| s.cell(t))
            ));
        }
        // Teleporters' partners are their exits, compared through the transform elsewhere.
        if j > i && p.transform.is_none() && q.transform.is_none() {
            // Across a wall the two lie on opposite faces: compare them on one plane.
            if let (Some(a), Some(b)) = (&shapes[i], shapes.get(j).and_then(|s| s.as_ref())) {
                let flat: Vec<DVec3> = q
                    .polygon
                    .iter()
                    .map(|v| *v - a.normal * a.distance(*v))
                    .collect();
                let apart = q
                    .polygon
                    .iter()
                    .map(|v| a.distance(*v).abs())
                    .fold(0.0, f64::max);
                if apart > s.max_wall_thickness + tol || !same_points(&p.polygon, &flat, tol) {
                    problems.push(format!("portal {j} has a different polygon"));
                } else if a.normal.dot(b.normal) > 0.0 {
                    problems.push(format!(
                        "portal {j} has the same winding, so both face the same way"
                    ));
                }
            }
        }
        if !problems.is_empty() {
            out.push(
                Diagnostic::new(
                    Code::PORTAL_PARTNER_MISMATCH,
                    format!(
                        "{} and its partner disagree: {}",
                        s.portal(i),
                        problems.join("; ")
                    ),
                    s.at(i, c),
                )
                .hint("partners must name each other and share one polygon, reversed; recompute the annotation with `portcullis convert`"),
            );
        }
    }
}

/// Portals between the same cells, the same way, that cover some of the same area.
fn duplicates(s: &Subject, shapes: &[Option<Plane>], out: &mut Diagnostics) {
    let ps = &s.portals.portals;
    let mut order: Vec<usize> = (0..ps.len()).filter(|&i| shapes[i].is_some()).collect();
    order.sort_by_key(|&i| (ps[i].from, ps[i].to, i));
    let grid = s.eps * 0.5;
    for (k, &i) in order.iter().enumerate() {
        for &j in &order[k + 1..] {
            let (p, q) = (&ps[i], &ps[j]);
            if (q.from, q.to) != (p.from, p.to) {
                break;
            }
            let (Some(a), Some(b)) = (&shapes[i], &shapes[j]) else {
                continue;
            };
            if !a.same_as(b, 10.0 * s.eps, DUPLICATE_ANGLE) {
                continue;
            }
            let shared: f64 =
                intersection(&[on_plane(&p.polygon, a)], &[on_plane(&q.polygon, a)], grid)
                    .iter()
                    .map(|r| r.area())
                    .sum();
            let smaller = area(&p.polygon, a).min(area(&q.polygon, a));
            if shared > 1e-3 * smaller && shared > s.eps * s.eps {
                out.push(
                    Diagnostic::new(
                        Code::PORTAL_DUPLICATE,
                        format!(
                            "{} and {} overlap by {shared:.4} m² between the same cells",
                            s.portal(i),
                            s.portal(j)
                        ),
                        s.at(j, centroid(&q.polygon)),
                    )
                    .hint("remove one of them; one portal per opening is enough"),
                );
            }
        }
    }
}

fn area(poly: &[DVec3], plane: &Plane) -> f64 {
    crate::geom::polyhedron::polygon_area(poly, plane.normal)
}
