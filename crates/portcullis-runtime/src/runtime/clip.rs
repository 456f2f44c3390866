//! The few geometric operations the traversal repeats per portal: a half-space, clipping a
//! convex polygon to it into a reused buffer, and distances to a convex polygon. Kept apart
//! from `geom` so the runtime stays a self-contained reader of the extension.

use glam::DVec3;

/// The half-space `n·x <= d` (the inside of a cell plane or a view plane); `n` is unit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Half {
    pub n: DVec3,
    pub d: f64,
}

impl Half {
    /// Positive outside, negative inside.
    #[inline]
    pub fn dist(&self, p: DVec3) -> f64 {
        self.n.dot(p) - self.d
    }

    /// The plane through `p` with inside `n·x <= n·p`; `None` if `n` has no direction.
    pub fn through(p: DVec3, n: DVec3) -> Option<Half> {
        let n = n.try_normalize()?;
        Some(Half { n, d: n.dot(p) })
    }

    pub fn flipped(self) -> Half {
        Half {
            n: -self.n,
            d: -self.d,
        }
    }
}

/// Clips the convex polygon `input` to `h`, keeping what lies within `eps` of the inside, into
/// `out` (cleared first). Points within `eps` count as inside, so clipping never loses a sliver
/// the exact answer keeps: culling errs towards drawing.
pub fn clip(input: &[DVec3], h: Half, eps: f64, out: &mut Vec<DVec3>) {
    out.clear();
    let Some(&last) = input.last() else { return };
    let mut a = last;
    let mut da = h.dist(a);
    for &b in input {
        let db = h.dist(b);
        if da <= eps {
            out.push(a);
        }
        if (da <= eps) != (db <= eps) {
            // Cut at the plane moved out by eps, so the kept part is exactly what lies inside it.
            let t = (da - eps) / (da - db);
            out.push(a + (b - a) * t.clamp(0.0, 1.0));
        }
        a = b;
        da = db;
    }
}

/// Twice the signed area of `o`, `a`, `b` (positive counter-clockwise): which side of the
/// line `o`-`a` the point `b` lies on.
#[inline]
pub fn cross2(o: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])
}

/// Twice the signed area of a polygon on the screen (positive counter-clockwise).
pub fn area2(poly: &[[f64; 2]]) -> f64 {
    let n = poly.len();
    (0..n)
        .map(|i| {
            let (p, q) = (poly[i], poly[(i + 1) % n]);
            p[0] * q[1] - p[1] * q[0]
        })
        .sum()
}

/// The perimeter of a polygon on the screen.
pub fn perimeter2(poly: &[[f64; 2]]) -> f64 {
    let n = poly.len();
    (0..n)
        .map(|i| {
            let (p, q) = (poly[i], poly[(i + 1) % n]);
            (q[0] - p[0]).hypot(q[1] - p[1])
        })
        .sum()
}

/// Clips a screen polygon to the left of the directed line `a`-`b` (counter-clockwise inside),
/// keeping what lies within `eps` of it, into `out` (cleared first).
pub fn clip2(input: &[[f64; 2]], a: [f64; 2], b: [f64; 2], eps: f64, out: &mut Vec<[f64; 2]>) {
    out.clear();
    let Some(&last) = input.last() else { return };
    let len = ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2)).sqrt();
    let slack = eps * len;
    let side = |p: [f64; 2]| cross2(a, b, p) + slack;
    let (mut p, mut sp) = (last, side(last));
    for &q in input {
        let sq = side(q);
        if sp >= 0.0 {
            out.push(p);
        }
        if (sp >= 0.0) != (sq >= 0.0) {
            let t = (sp / (sp - sq)).clamp(0.0, 1.0);
            out.push([p[0] + (q[0] - p[0]) * t, p[1] + (q[1] - p[1]) * t]);
        }
        p = q;
        sp = sq;
    }
}

/// The Newell normal of a polygon (not normalised; zero for a degenerate one).
pub fn newell(poly: &[DVec3]) -> DVec3 {
    let Some(&first) = poly.first() else {
        return DVec3::ZERO;
    };
    let mut n = DVec3::ZERO;
    for (i, a) in poly.iter().enumerate() {
        let b = poly[(i + 1) % poly.len()];
        n += (*a - first).cross(b - first);
    }
    n
}

/// Distance from `p` to the convex planar polygon `poly` with unit normal `n`.
pub fn distance_to_polygon(p: DVec3, poly: &[DVec3], n: DVec3) -> f64 {
    let Some(&first) = poly.first() else {
        return f64::INFINITY;
    };
    let height = (p - first).dot(n);
    let q = p - n * height;
    let mut inside = poly.len() >= 3;
    let mut edge = f64::INFINITY;
    let orient = newell(poly).dot(n).signum();
    for (i, &a) in poly.iter().enumerate() {
        let b = poly[(i + 1) % poly.len()];
        if (b - a).cross(q - a).dot(n) * orient < 0.0 {
            inside = false;
        }
        edge = edge.min(segment_distance(p, a, b));
    }
    if inside {
        height.abs()
    } else {
        edge
    }
}

fn segment_distance(p: DVec3, a: DVec3, b: DVec3) -> f64 {
    let ab = b - a;
    let len2 = ab.length_squared();
    let t = if len2 > 0.0 {
        ((p - a).dot(ab) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    p.distance(a + ab * t)
}

/// A square of half-size `size` on the plane of `h`, centred at `centre` projected onto it:
/// the start of a cell face before the cell's other planes cut it.
pub fn plane_square(h: Half, centre: DVec3, size: f64) -> [DVec3; 4] {
    let o = centre - h.n * h.dist(centre);
    let helper = if h.n.x.abs() < 0.6 {
        DVec3::X
    } else {
        DVec3::Y
    };
    let u = h.n.cross(helper).normalize() * size;
    let v = h.n.cross(u);
    [o - u - v, o + u - v, o + u + v, o - u + v]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clipping_a_square_keeps_the_inside_half_in_order() {
        let sq = [
            DVec3::new(0., 0., 0.),
            DVec3::new(2., 0., 0.),
            DVec3::new(2., 2., 0.),
            DVec3::new(0., 2., 0.),
        ];
        let mut out = Vec::new();
        clip(
            &sq,
            Half {
                n: DVec3::X,
                d: 1.0,
            },
            0.0,
            &mut out,
        );
        assert_eq!(out.len(), 4);
        assert!(out.iter().all(|p| p.x <= 1.0 + 1e-12));
        assert!(newell(&out).dot(newell(&sq)) > 0.0, "winding kept");
        let area = newell(&out).length() / 2.0;
        assert!((area - 2.0).abs() < 1e-12, "{area}");
        clip(
            &sq,
            Half {
                n: DVec3::X,
                d: -0.5,
            },
            0.0,
            &mut out,
        );
        assert!(out.is_empty());
        clip(
            &sq,
            Half {
                n: DVec3::X,
                d: -0.5,
            },
            0.6,
            &mut out,
        );
        assert_eq!(out.len(), 4, "within eps counts as inside");
    }

    #[test]
    fn distance_to_a_square_inside_and_beside() {
        let sq = [
            DVec3::new(0., 0., 0.),
            DVec3::new(2., 0., 0.),
            DVec3::new(2., 2., 0.),
            DVec3::new(0., 2., 0.),
        ];
        assert_eq!(
            distance_to_polygon(DVec3::new(1., 1., 3.), &sq, DVec3::Z),
            3.0
        );
        assert_eq!(
            distance_to_polygon(DVec3::new(5., 1., 0.), &sq, DVec3::Z),
            3.0
        );
        assert_eq!(
            distance_to_polygon(DVec3::new(5., 1., 0.), &sq, -DVec3::Z),
            3.0
        );
    }
}
