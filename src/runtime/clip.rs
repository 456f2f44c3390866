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

/// [`clip`] that also keeps, per vertex, a label for the edge leaving it: the input's labels
/// for what remains of the input's edges, and `cut` for the new edge along `h`. The walk
/// labels edges with the view plane they lie on, and reuses that plane instead of building a
/// new one through the eye.
pub fn clip_labelled(
    input: &[DVec3],
    labels: &[u32],
    h: Half,
    cut: u32,
    eps: f64,
    out: &mut Vec<DVec3>,
    out_labels: &mut Vec<u32>,
) {
    out.clear();
    out_labels.clear();
    let (Some(&last), Some(&last_label)) = (input.last(), labels.last()) else {
        return;
    };
    let (mut a, mut la) = (last, last_label);
    let mut da = h.dist(a);
    for (&b, &lb) in input.iter().zip(labels) {
        let db = h.dist(b);
        let (a_in, b_in) = (da <= eps, db <= eps);
        if a_in {
            out.push(a);
            out_labels.push(la);
        }
        if a_in != b_in {
            let t = ((da - eps) / (da - db)).clamp(0.0, 1.0);
            out.push(a + (b - a) * t);
            // Leaving: the edge to the next kept point runs along `h`. Entering: what is left
            // of the edge a-b.
            out_labels.push(if a_in { cut } else { la });
        }
        a = b;
        la = lb;
        da = db;
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
