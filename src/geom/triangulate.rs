//! Triangulation of simple planar polygons (OBJ n-gons, USD faces).
//!
//! Level polygons are often concave (an L-shaped floor, a wall with a door notch cut into it).
//! A fan over such a polygon covers area outside the face, and every later stage would then see
//! floor or wall where the artist left a hole. Ear clipping is correct for any simple polygon;
//! all its decisions are made with exact predicates on the polygon's projection so that
//! collinear vertices and near-degenerate corners cannot flip a decision.
//!
//! A polygon that is not simple has no correct triangulation at all, so that case is reported
//! rather than guessed at; the caller decides on a fallback and tells the user.

use std::fmt;

use glam::DVec3;
use robust::{orient2d, Coord};

/// Above this many vertices the quadratic simplicity check and ear search are not attempted:
/// no real level face comes near it, and a hostile file must not stall the importer.
pub(crate) const MAX_EXACT_VERTICES: usize = 10_000;

/// Why a polygon could not be triangulated as a simple polygon.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum NotSimple {
    /// Fewer than three distinct points, or no area: any triangulation covers nothing, so a fan
    /// is as good as any.
    Degenerate,
    /// Two edges cross or touch, or an edge doubles back on the previous one.
    SelfIntersecting,
    /// No ear was found although the polygon looked simple (possible only for polygons far
    /// from planar, whose projection misleads the checks).
    Stuck,
    /// More than [`MAX_EXACT_VERTICES`] vertices.
    TooLarge,
}

impl fmt::Display for NotSimple {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            NotSimple::Degenerate => "the polygon has no area",
            NotSimple::SelfIntersecting => "the polygon is self-intersecting",
            NotSimple::Stuck => "no ear could be clipped from the polygon",
            NotSimple::TooLarge => "the polygon has too many vertices to check",
        })
    }
}

impl std::error::Error for NotSimple {}

type P2 = Coord<f64>;

/// Triangulates a simple, roughly planar polygon given in order, concave or not.
///
/// The returned triangles index `points` and face the same way as the polygon (same winding).
/// A simple polygon with `n` distinct, non-collinear-in-a-row vertices gives `n - 2` triangles;
/// repeated consecutive points give none of their own, and a vertex lying exactly on the line
/// between its neighbours may be skipped if no ear can otherwise be found.
pub(crate) fn triangulate_polygon(points: &[DVec3]) -> Result<Vec<[usize; 3]>, NotSimple> {
    let n = points.len();
    if n < 3 {
        return Err(NotSimple::Degenerate);
    }
    if n > MAX_EXACT_VERTICES {
        return Err(NotSimple::TooLarge);
    }
    if points.iter().any(|p| !p.is_finite()) {
        return Err(NotSimple::Degenerate);
    }
    if n == 3 {
        // Nothing to choose; a triangle is its own triangulation whatever its shape.
        return Ok(vec![[0, 1, 2]]);
    }

    let mut normal = newell_normal(points);
    if normal == DVec3::ZERO {
        // Zero net area but not necessarily flat: a symmetric bow tie. Its plane still comes
        // from any two non-parallel edges, and the simplicity check below then rejects it.
        normal = largest_corner_cross(points);
    }
    if !normal.is_finite() || normal == DVec3::ZERO {
        return Err(NotSimple::Degenerate);
    }
    let a = normal.abs();
    // Dropping the axis the normal leans on most keeps the projection as large as possible, and
    // the projected coordinates are the input numbers themselves, so exact predicates on them
    // are exact statements about the input.
    let project: fn(DVec3) -> P2 = if a.x >= a.y && a.x >= a.z {
        |p| Coord { x: p.y, y: p.z }
    } else if a.y >= a.z {
        |p| Coord { x: p.z, y: p.x }
    } else {
        |p| Coord { x: p.x, y: p.y }
    };

    // Ring of original indices without consecutive duplicates (in the projection: two points
    // that differ only along the dropped axis would make a zero-length edge).
    let mut ring: Vec<usize> = Vec::with_capacity(n);
    for i in 0..n {
        match ring.last() {
            Some(&j) if same(project(points[j]), project(points[i])) => {}
            _ => ring.push(i),
        }
    }
    while ring.len() > 1 {
        let (first, last) = (ring[0], ring[ring.len() - 1]);
        if same(project(points[first]), project(points[last])) {
            ring.pop();
        } else {
            break;
        }
    }
    if ring.len() < 3 {
        return Err(NotSimple::Degenerate);
    }
    let mut pts: Vec<P2> = ring.iter().map(|&i| project(points[i])).collect();

    if self_intersecting(&pts) {
        return Err(NotSimple::SelfIntersecting);
    }
    let ccw = match orientation(&pts) {
        o if o > 0.0 => true,
        o if o < 0.0 => false,
        _ => return Err(NotSimple::Degenerate),
    };
    if !ccw {
        ring.reverse();
        pts.reverse();
    }
    let local = ear_clip(&pts)?;
    Ok(local
        .into_iter()
        .map(|[a, b, c]| {
            let t = [ring[a], ring[b], ring[c]];
            // Triangles come out counter-clockwise in the projection; a clockwise input must
            // get clockwise triangles back to face the same way.
            if ccw {
                t
            } else {
                [t[2], t[1], t[0]]
            }
        })
        .collect())
}

/// Newell's normal: robust to concave corners and collinear vertices, unlike a cross product
/// of two edges. Computed relative to the first point to keep large coordinates accurate.
pub(crate) fn newell_normal(points: &[DVec3]) -> DVec3 {
    let Some(&origin) = points.first() else {
        return DVec3::ZERO;
    };
    let mut n = DVec3::ZERO;
    for (i, &p) in points.iter().enumerate() {
        let c = p - origin;
        let d = points[(i + 1) % points.len()] - origin;
        n.x += (c.y - d.y) * (c.z + d.z);
        n.y += (c.z - d.z) * (c.x + d.x);
        n.z += (c.x - d.x) * (c.y + d.y);
    }
    n
}

fn largest_corner_cross(points: &[DVec3]) -> DVec3 {
    let m = points.len();
    (0..m)
        .map(|i| {
            let (a, b, c) = (points[(i + m - 1) % m], points[i], points[(i + 1) % m]);
            (b - a).cross(c - b)
        })
        .fold(DVec3::ZERO, |best, c| {
            if c.length_squared() > best.length_squared() {
                c
            } else {
                best
            }
        })
}

fn same(a: P2, b: P2) -> bool {
    a.x == b.x && a.y == b.y
}

fn orient(a: P2, b: P2, c: P2) -> f64 {
    orient2d(a, b, c)
}

/// Sign of the polygon's orientation, decided exactly at its lexicographically lowest vertex
/// (a hull vertex, so its turn is the polygon's turn when the polygon is simple).
fn orientation(p: &[P2]) -> f64 {
    let m = p.len();
    let mut lo = 0;
    for i in 1..m {
        if (p[i].x, p[i].y) < (p[lo].x, p[lo].y) {
            lo = i;
        }
    }
    orient(p[(lo + m - 1) % m], p[lo], p[(lo + 1) % m])
}

/// Whether `c`, known to be collinear with `a`-`b`, lies on the closed segment.
fn on_segment(a: P2, b: P2, c: P2) -> bool {
    c.x >= a.x.min(b.x) && c.x <= a.x.max(b.x) && c.y >= a.y.min(b.y) && c.y <= a.y.max(b.y)
}

/// Closed segment intersection (touching counts), exact.
fn segments_touch(a: P2, b: P2, c: P2, d: P2) -> bool {
    if a.x.max(b.x) < c.x.min(d.x)
        || c.x.max(d.x) < a.x.min(b.x)
        || a.y.max(b.y) < c.y.min(d.y)
        || c.y.max(d.y) < a.y.min(b.y)
    {
        return false;
    }
    let o1 = orient(a, b, c);
    let o2 = orient(a, b, d);
    let o3 = orient(c, d, a);
    let o4 = orient(c, d, b);
    if ((o1 > 0.0 && o2 < 0.0) || (o1 < 0.0 && o2 > 0.0))
        && ((o3 > 0.0 && o4 < 0.0) || (o3 < 0.0 && o4 > 0.0))
    {
        return true;
    }
    (o1 == 0.0 && on_segment(a, b, c))
        || (o2 == 0.0 && on_segment(a, b, d))
        || (o3 == 0.0 && on_segment(c, d, a))
        || (o4 == 0.0 && on_segment(c, d, b))
}

/// Whether the path `a` → `b` → `c` turns straight back on itself (a zero-width spike).
fn folds_back(a: P2, b: P2, c: P2) -> bool {
    if orient(a, b, c) != 0.0 {
        return false;
    }
    // Collinear: the rounded differences keep their exact signs, so this dot product's sign is
    // exact too.
    (b.x - a.x) * (c.x - b.x) + (b.y - a.y) * (c.y - b.y) < 0.0
}

/// Any two edges meeting other than at their shared corner, or a spike.
fn self_intersecting(p: &[P2]) -> bool {
    let m = p.len();
    for i in 0..m {
        let (a, b) = (p[i], p[(i + 1) % m]);
        for j in i + 1..m {
            let (c, d) = (p[j], p[(j + 1) % m]);
            let adjacent_after = j == i + 1;
            let adjacent_before = i == 0 && j == m - 1;
            if adjacent_after {
                if folds_back(a, b, d) {
                    return true;
                }
            } else if adjacent_before {
                if folds_back(c, a, b) {
                    return true;
                }
            } else if segments_touch(a, b, c, d) {
                return true;
            }
        }
    }
    false
}

/// Ear clipping on a simple counter-clockwise polygon with distinct vertices; indices into `p`.
fn ear_clip(p: &[P2]) -> Result<Vec<[usize; 3]>, NotSimple> {
    let m = p.len();
    let mut prev: Vec<usize> = (0..m).map(|i| (i + m - 1) % m).collect();
    let mut next: Vec<usize> = (0..m).map(|i| (i + 1) % m).collect();
    let mut alive = m;
    let mut out = Vec::with_capacity(m - 2);
    let mut v = 0;
    let mut misses = 0;
    while alive > 3 {
        let (a, b) = (prev[v], next[v]);
        if is_ear(p, &next, a, v, b) {
            out.push([a, v, b]);
            next[a] = b;
            prev[b] = a;
            alive -= 1;
            misses = 0;
            // The previous vertex's angle just changed; it may have become an ear.
            v = a;
            continue;
        }
        misses += 1;
        if misses >= alive {
            // A vertex on the straight line between its neighbours can block every ear (it sits
            // on a would-be diagonal). Dropping it removes no area; the triangle that later
            // spans its edge simply has it on a side.
            let start = v;
            let mut u = v;
            let mut dropped = false;
            loop {
                let (a, b) = (prev[u], next[u]);
                if orient(p[a], p[u], p[b]) == 0.0 && !folds_back(p[a], p[u], p[b]) {
                    next[a] = b;
                    prev[b] = a;
                    alive -= 1;
                    misses = 0;
                    v = a;
                    dropped = true;
                    break;
                }
                u = next[u];
                if u == start {
                    break;
                }
            }
            if !dropped {
                return Err(NotSimple::Stuck);
            }
            continue;
        }
        v = b;
    }
    let (a, b) = (prev[v], next[v]);
    if orient(p[a], p[v], p[b]) > 0.0 {
        out.push([a, v, b]);
    }
    Ok(out)
}

/// A strictly convex corner whose triangle holds no other remaining vertex, not even on its
/// boundary (a vertex on the new diagonal would make the remaining polygon touch itself).
fn is_ear(p: &[P2], next: &[usize], a: usize, v: usize, b: usize) -> bool {
    let (pa, pv, pb) = (p[a], p[v], p[b]);
    if orient(pa, pv, pb) <= 0.0 {
        return false;
    }
    let (minx, maxx) = (pa.x.min(pv.x).min(pb.x), pa.x.max(pv.x).max(pb.x));
    let (miny, maxy) = (pa.y.min(pv.y).min(pb.y), pa.y.max(pv.y).max(pb.y));
    let mut q = next[b];
    while q != a {
        let pq = p[q];
        if pq.x >= minx
            && pq.x <= maxx
            && pq.y >= miny
            && pq.y <= maxy
            && orient(pa, pv, pq) >= 0.0
            && orient(pv, pb, pq) >= 0.0
            && orient(pb, pa, pq) >= 0.0
        {
            return false;
        }
        q = next[q];
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{DMat3, DVec2};

    fn area2(poly: &[DVec2]) -> f64 {
        let m = poly.len();
        (0..m)
            .map(|i| poly[i].perp_dot(poly[(i + 1) % m]))
            .sum::<f64>()
            / 2.0
    }

    fn inside(poly: &[DVec2], q: DVec2) -> bool {
        // Even-odd crossing test; centroids never lie on an edge for these shapes.
        let mut c = false;
        let m = poly.len();
        for i in 0..m {
            let (a, b) = (poly[i], poly[(i + 1) % m]);
            if (a.y > q.y) != (b.y > q.y) {
                let x = a.x + (q.y - a.y) / (b.y - a.y) * (b.x - a.x);
                if q.x < x {
                    c = !c;
                }
            }
        }
        c
    }

    fn lift(poly: &[DVec2], rot: DMat3, offset: DVec3) -> Vec<DVec3> {
        poly.iter()
            .map(|p| rot * DVec3::new(p.x, p.y, 0.0) + offset)
            .collect()
    }

    fn rotations() -> Vec<DMat3> {
        vec![
            DMat3::IDENTITY,
            DMat3::from_rotation_x(std::f64::consts::FRAC_PI_2),
            DMat3::from_rotation_y(-std::f64::consts::FRAC_PI_2),
            DMat3::from_rotation_x(std::f64::consts::PI),
            DMat3::from_euler(glam::EulerRot::XYZ, 0.3, 1.1, -0.7),
            DMat3::from_euler(glam::EulerRot::ZYX, 2.5, -0.4, 1.9),
        ]
    }

    /// Checks the triangulation of a 2D polygon lifted into several planes: `expect` triangles,
    /// total area equal to the polygon's, every centroid inside, every triangle facing like
    /// the polygon.
    fn check(poly: &[DVec2], expect: usize) {
        check_in(poly, expect, &rotations(), false);
        check_in(poly, expect, &exact_planes(), true);
    }

    /// Axis permutations and reflections: the lifted coordinates are exact, so collinear input
    /// stays exactly collinear and no sliver triangle is acceptable.
    fn exact_planes() -> Vec<DMat3> {
        let (x, y, z) = (DVec3::X, DVec3::Y, DVec3::Z);
        vec![
            DMat3::from_cols(x, y, z),
            DMat3::from_cols(y, z, x),
            DMat3::from_cols(z, x, y),
            DMat3::from_cols(-y, x, z),
            DMat3::from_cols(x, -z, y),
            DMat3::from_cols(-z, -y, -x),
        ]
    }

    fn check_in(poly: &[DVec2], expect: usize, rots: &[DMat3], exact: bool) {
        let want = area2(poly).abs();
        for &rot in rots {
            for reversed in [false, true] {
                let mut poly = poly.to_vec();
                if reversed {
                    poly.reverse();
                }
                let pts = lift(&poly, rot, DVec3::new(3.0, -2.0, 7.5));
                let normal = newell_normal(&pts);
                let tris = triangulate_polygon(&pts).expect("simple polygon triangulates");
                assert_eq!(tris.len(), expect, "triangle count for {poly:?}");
                let mut total = 0.0;
                for t in &tris {
                    let [a, b, c] = t.map(|i| pts[i]);
                    let cross = (b - a).cross(c - a);
                    assert!(cross.dot(normal) > 0.0, "triangle {t:?} flipped");
                    let area = cross.length() / 2.0;
                    total += area;
                    if !exact && area < 1e-9 {
                        // Rounding in the rotation turns exactly collinear vertices into a
                        // sliver, which is then a legitimate part of the polygon.
                        continue;
                    }
                    let centroid = (poly[t[0]] + poly[t[1]] + poly[t[2]]) / 3.0;
                    assert!(inside(&poly, centroid), "triangle {t:?} outside {poly:?}");
                }
                assert!(
                    (total - want).abs() < 1e-9 * want.max(1.0),
                    "area {total} != {want}"
                );
            }
        }
    }

    fn v(pts: &[(f64, f64)]) -> Vec<DVec2> {
        pts.iter().map(|&(x, y)| DVec2::new(x, y)).collect()
    }

    #[test]
    fn convex_quad_and_triangle() {
        check(&v(&[(0., 0.), (2., 0.), (2., 1.), (0., 1.)]), 2);
        check(&v(&[(0., 0.), (2., 0.), (1., 1.)]), 1);
    }

    #[test]
    fn concave_quad_dart() {
        // A fan from the reflex vertex's neighbour would cover area outside.
        check(&v(&[(0., 0.), (2., 1.), (4., 0.), (2., 3.)]), 2);
        check(&v(&[(2., 1.), (4., 0.), (2., 3.), (0., 0.)]), 2);
    }

    #[test]
    fn concave_pentagon() {
        check(&v(&[(0., 0.), (4., 0.), (4., 4.), (2., 1.), (0., 4.)]), 3);
    }

    #[test]
    fn l_shape() {
        check(
            &v(&[(0., 0.), (3., 0.), (3., 1.), (1., 1.), (1., 3.), (0., 3.)]),
            4,
        );
    }

    #[test]
    fn u_shape() {
        check(
            &v(&[
                (0., 0.),
                (3., 0.),
                (3., 3.),
                (2., 3.),
                (2., 1.),
                (1., 1.),
                (1., 3.),
                (0., 3.),
            ]),
            6,
        );
    }

    #[test]
    fn comb() {
        // Five teeth of width 1 standing on a bar of height 1, open at the top.
        let mut pts = vec![(0., 0.), (9., 0.)];
        for k in (0..5).rev() {
            let (x0, x1) = (2.0 * k as f64, 2.0 * k as f64 + 1.0);
            if k < 4 {
                pts.push((x1, 1.0));
            }
            pts.push((x1, 4.0));
            pts.push((x0, 4.0));
            if k > 0 {
                pts.push((x0, 1.0));
            }
        }
        let poly = v(&pts);
        assert_eq!(poly.len(), 20);
        let n = poly.len();
        check(&poly, n - 2);
    }

    #[test]
    fn random_star_shapes() {
        // Star-shaped about the origin, so always simple; radii vary enough to make many
        // reflex corners. Deterministic xorshift so a failure reproduces.
        let mut x: u32 = 0x9E37_79B9;
        let mut rnd = || {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            f64::from(x) / f64::from(u32::MAX)
        };
        for n in [5usize, 8, 13, 40] {
            for _ in 0..10 {
                let poly: Vec<DVec2> = (0..n)
                    .map(|i| {
                        let a = std::f64::consts::TAU * (i as f64 + 0.8 * rnd()) / n as f64;
                        let r = 0.3 + 2.0 * rnd();
                        DVec2::new(r * a.cos(), r * a.sin())
                    })
                    .collect();
                check(&poly, n - 2);
            }
        }
    }

    #[test]
    fn collinear_vertices() {
        // Square with extra vertices along two sides, one of them in the middle of the bottom.
        let poly = v(&[
            (0., 0.),
            (1., 0.),
            (2., 0.),
            (3., 0.),
            (3., 3.),
            (0., 3.),
            (0., 1.5),
        ]);
        check(&poly, poly.len() - 2);
        // Collinear points next to a reflex corner.
        let poly = v(&[
            (0., 0.),
            (2., 0.),
            (4., 0.),
            (4., 2.),
            (2., 2.),
            (2., 4.),
            (0., 4.),
            (0., 2.),
        ]);
        check(&poly, poly.len() - 2);
    }

    #[test]
    fn duplicate_consecutive_points() {
        let pts = lift(
            &v(&[(0., 0.), (1., 0.), (1., 0.), (1., 1.), (0., 1.), (0., 0.)]),
            DMat3::IDENTITY,
            DVec3::ZERO,
        );
        let tris = triangulate_polygon(&pts).unwrap();
        assert_eq!(tris.len(), 2);
        for t in &tris {
            let [a, b, c] = t.map(|i| pts[i]);
            assert!((b - a).cross(c - a).z > 0.0);
        }
    }

    #[test]
    fn self_intersecting_bowtie_is_rejected() {
        let pts = lift(
            &v(&[(0., 0.), (1., 1.), (1., 0.), (0., 1.)]),
            DMat3::from_rotation_x(0.4),
            DVec3::ZERO,
        );
        assert_eq!(triangulate_polygon(&pts), Err(NotSimple::SelfIntersecting));
    }

    #[test]
    fn touching_and_spike_are_rejected() {
        // Vertex (2,0) touches the opposite edge.
        let touch = v(&[(0., 0.), (4., 0.), (4., 4.), (2., 0.), (0., 4.)]);
        let pts = lift(&touch, DMat3::IDENTITY, DVec3::ZERO);
        assert_eq!(triangulate_polygon(&pts), Err(NotSimple::SelfIntersecting));
        let spike = v(&[(0., 0.), (4., 0.), (6., 0.), (4., 0.5), (4., 4.), (0., 4.)]);
        let spike = lift(&spike, DMat3::IDENTITY, DVec3::ZERO);
        assert!(triangulate_polygon(&spike).is_ok());
        let spike = v(&[(0., 0.), (4., 0.), (6., 0.), (5., 0.), (4., 4.), (0., 4.)]);
        let spike = lift(&spike, DMat3::IDENTITY, DVec3::ZERO);
        assert_eq!(
            triangulate_polygon(&spike),
            Err(NotSimple::SelfIntersecting)
        );
    }

    #[test]
    fn degenerate_inputs() {
        let line: Vec<DVec3> = (0..4).map(|i| DVec3::new(i as f64, 0.0, 0.0)).collect();
        assert_eq!(triangulate_polygon(&line), Err(NotSimple::Degenerate));
        let same = vec![DVec3::ONE; 5];
        assert_eq!(triangulate_polygon(&same), Err(NotSimple::Degenerate));
        let nan = vec![
            DVec3::ZERO,
            DVec3::X,
            DVec3::new(f64::NAN, 1.0, 0.0),
            DVec3::Y,
        ];
        assert_eq!(triangulate_polygon(&nan), Err(NotSimple::Degenerate));
        assert_eq!(
            triangulate_polygon(&[DVec3::ZERO, DVec3::X]),
            Err(NotSimple::Degenerate)
        );
    }

    #[test]
    fn slightly_non_planar_quad() {
        let pts = vec![
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(1.0, 0.0, 0.01),
            DVec3::new(1.0, 1.0, 0.0),
            DVec3::new(0.0, 1.0, 0.02),
        ];
        assert_eq!(triangulate_polygon(&pts).map(|t| t.len()), Ok(2));
    }
}
