//! Cracks: the parts of an opening narrower than the crack width (`[cells] crack_width`).
//!
//! Modelling leaves hairline gaps where pieces should meet (a stair's side a hair short of a
//! window's jamb, running down from its sill). Such a gap is a crack whether
//! it stands alone or joins a real opening, and whether a tolerance-sized rule keeps it
//! depends on the tolerance. Here a ring loses each corner whose triangle with its two
//! neighbours is thinner than the crack width (its inscribed circle narrower) and whose angle
//! is right or sharp: a needle off an opening is cut off at its root, a notch into it filled,
//! and a strip on its own comes down to nothing. A corner of a real opening whose sides are
//! at least `e` long has a triangle `e·sin θ / (1 + sin θ/2)` wide or wider (0.59·`e` at a right
//! angle, `e`/10 at 6 degrees), so a corner whose sides are ten crack widths long or more loses
//! only its tip, and only if it is sharper than 6 degrees. Corners wider than a right angle never are: a
//! round window's 64 sides bend, they are not cracks. No tolerance enters: the same corners go
//! whatever the tolerance.

use glam::DVec2;
use robust::{orient2d, Coord};

use super::partition::{ring_mean_width, Polygon2};
use super::tolerance::Tolerance;

/// The gaps narrower than the crack width that a stage closed: how many, and the widest with
/// where it is, so that a level at the wrong scale (or a crack width set too wide) shows in
/// `inspect` and `check` instead of losing openings without a word.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct ClosedGaps {
    /// How many gaps were closed.
    pub count: usize,
    /// The widest closed gap's width (m) and a point in it (world coordinates).
    pub widest: Option<(f64, glam::DVec3)>,
}

/// The share of the crack width under which a closed gap is not counted: blocks or walls
/// meant to meet that miss by a rounding hair, not gaps anyone drew. Of the crack width, not
/// the tolerance, so a tolerance four times coarser or finer counts the same gaps.
const GAP_FLOOR: f64 = 0.1;

/// Whether a gap `width` wide that a crack width of `crack` closed is counted (see
/// [`GAP_FLOOR`]); never one within two tolerances.
pub(crate) fn counts_as_gap(width: f64, crack: f64, eps: f64) -> bool {
    width > (GAP_FLOOR * crack).max(Tolerance::touching(eps))
}

impl ClosedGaps {
    /// Counts a gap `width` wide at `at`; of equal widths the first counted is kept, so a
    /// tally made in a fixed order is the same on every run.
    pub fn add(&mut self, width: f64, at: glam::DVec3) {
        self.count += 1;
        if self.widest.is_none_or(|(w, _)| width > w) {
            self.widest = Some((width, at));
        }
    }

    /// Both tallies, `self` first.
    pub fn merged(mut self, other: &ClosedGaps) -> ClosedGaps {
        self.count += other.count;
        if let Some((w, at)) = other.widest {
            if self.widest.is_none_or(|(v, _)| w > v) {
                self.widest = Some((w, at));
            }
        }
        self
    }

    /// The same gaps, their points moved by `by` (recentred readings back to the world).
    pub fn moved(mut self, by: glam::DVec3) -> ClosedGaps {
        self.widest = self.widest.map(|(w, at)| (w, at + by));
        self
    }
}

/// `p` without its cracks narrower than `width`: `None` when nothing else is left.
pub(crate) fn without_cracks(p: &Polygon2, width: f64) -> Option<Polygon2> {
    if width <= 0.0 {
        return Some(p.clone());
    }
    let outer = ring_without_cracks(&p.outer, width);
    if outer.len() < 3 {
        return None;
    }
    let holes = p
        .holes
        .iter()
        .map(|h| ring_without_cracks(h, width))
        .filter(|h| h.len() >= 3)
        .collect();
    Some(Polygon2 { outer, holes })
}

/// Whether a disc `width` across fits in `p`: its inward offset by half that (i_overlay's
/// outline, round joins, so a reflex corner keeps its arc) leaves something. An opening that
/// passes this is no crack wherever else it narrows: a ray as thick as a crack gets through.
pub(crate) fn holds_disc(p: &Polygon2, width: f64) -> bool {
    use i_overlay::mesh::float::outline::offset::OutlineOffset;
    use i_overlay::mesh::float::style::{LineJoin, OutlineStyle};
    let ring = |r: &[DVec2]| r.iter().map(|q| [q.x, q.y]).collect::<Vec<[f64; 2]>>();
    let shape: Vec<Vec<[f64; 2]>> = std::iter::once(ring(&p.outer))
        .chain(p.holes.iter().map(|h| ring(h)))
        .collect();
    let style = OutlineStyle::new(-0.5 * width).line_join(LineJoin::Round(0.25));
    shape.outline(&style).iter().any(|s| {
        s.first()
            .is_some_and(|outer| super::partition::ring_mean_width(&to_vec2(outer)) > 0.0)
    })
}

fn to_vec2(r: &[[f64; 2]]) -> Vec<DVec2> {
    r.iter().map(|q| DVec2::new(q[0], q[1])).collect()
}

/// The diameter of the circle inscribed in triangle `a b c`: twice its mean width (twice its
/// area over its perimeter is the inradius of a triangle).
fn inscribed_diameter(a: DVec2, b: DVec2, c: DVec2) -> f64 {
    2.0 * ring_mean_width(&[a, b, c])
}

fn coord(p: DVec2) -> Coord<f64> {
    Coord { x: p.x, y: p.y }
}

/// Whether `q` lies strictly inside triangle `a b c` (either winding), by exact predicates.
fn strictly_inside(q: DVec2, a: DVec2, b: DVec2, c: DVec2) -> bool {
    let s = [
        orient2d(coord(a), coord(b), coord(q)),
        orient2d(coord(b), coord(c), coord(q)),
        orient2d(coord(c), coord(a), coord(q)),
    ];
    s.iter().all(|&x| x > 0.0) || s.iter().all(|&x| x < 0.0)
}

/// A ring without the corners of a right angle or sharper whose triangle with their
/// neighbours is narrower than `width`, the thinnest first, one at a time until none is left (the next corner of a needle is a
/// needle's tip in turn). Thinnest first, so that where the ring starts does not matter. A
/// corner whose triangle holds another vertex of the ring stays, so the ring never crosses
/// itself.
fn ring_without_cracks(ring: &[DVec2], width: f64) -> Vec<DVec2> {
    let mut r = ring.to_vec();
    while r.len() >= 3 {
        let n = r.len();
        let corner = |i: usize| (r[(i + n - 1) % n], r[i], r[(i + 1) % n]);
        let clear = |i: usize| {
            let (a, b, c) = corner(i);
            (0..n)
                .filter(|&j| j != i && j != (i + n - 1) % n && j != (i + 1) % n)
                .all(|j| !strictly_inside(r[j], a, b, c))
        };
        // Only corners of a right angle or sharper: a nearly straight corner's triangle is
        // thin too, but it is the outline bending (a round window's 64 sides), not a crack.
        let thinnest = (0..n)
            .filter(|&i| {
                let (a, b, c) = corner(i);
                (a - b).dot(c - b) >= 0.0
            })
            .map(|i| {
                let (a, b, c) = corner(i);
                (inscribed_diameter(a, b, c), i)
            })
            .filter(|&(d, i)| d < width && clear(i))
            .min_by(|x, y| x.0.total_cmp(&y.0));
        let Some((_, i)) = thinnest else { break };
        r.remove(i);
    }
    if r.len() < 3 {
        r.clear();
    }
    r
}

#[cfg(test)]
mod tests {
    use super::*;

    fn v(x: f64, y: f64) -> DVec2 {
        DVec2::new(x, y)
    }

    fn poly(outer: Vec<DVec2>) -> Polygon2 {
        Polygon2 {
            outer,
            holes: Vec::new(),
        }
    }

    /// A disc fits where the shape is wide enough somewhere, however thin on average: a
    /// wedge 10 cm by 12.5 mm (11.7 mm across inside) holds an 8 mm disc, a wedge half as
    /// tall does not; a 1 cm square does, a 5 mm strip never; a
    /// ring 6 mm wide round a hole does not, though its outline alone would.
    #[test]
    fn a_disc_fits_where_the_shape_is_wide_enough_somewhere() {
        let wedge = |h: f64| poly(vec![v(0.0, 0.0), v(0.1, 0.0), v(0.1, h)]);
        assert!(holds_disc(&wedge(0.0125), 0.008));
        assert!(wedge(0.0125).mean_width() < 0.008);
        assert!(!holds_disc(&wedge(0.006), 0.008));
        let square = poly(vec![v(0.0, 0.0), v(0.01, 0.0), v(0.01, 0.01), v(0.0, 0.01)]);
        assert!(holds_disc(&square, 0.008));
        assert!(!holds_disc(&square, 0.011));
        let strip = poly(vec![v(0.0, 0.0), v(3.0, 0.0), v(3.0, 0.005), v(0.0, 0.005)]);
        assert!(!holds_disc(&strip, 0.008));
        let ring = Polygon2 {
            outer: vec![v(0.0, 0.0), v(0.1, 0.0), v(0.1, 0.1), v(0.0, 0.1)],
            holes: vec![vec![
                v(0.006, 0.006),
                v(0.006, 0.094),
                v(0.094, 0.094),
                v(0.094, 0.006),
            ]],
        };
        assert!(!holds_disc(&ring, 0.008));
        assert!(holds_disc(&poly(ring.outer.clone()), 0.008));
    }

    /// A 1 x 1 window with a needle 1e-5 wide running 1.5 down from its sill.
    fn needle_window() -> Vec<DVec2> {
        vec![
            v(0.0, 0.0),
            v(0.5, 0.0),
            v(0.5, -1.5),
            v(0.50001, 0.0),
            v(1.0, 0.0),
            v(1.0, 1.0),
            v(0.0, 1.0),
        ]
    }

    #[test]
    fn a_needle_off_an_opening_is_cut_at_its_root() {
        let p = poly(needle_window());
        let out = without_cracks(&p, 0.01).unwrap();
        assert!((out.area() - 1.0).abs() < 1e-9, "{out:?}");
        assert!(out.outer.iter().all(|q| q.y >= 0.0), "{out:?}");
    }

    #[test]
    fn a_strip_on_its_own_is_nothing() {
        let p = poly(vec![v(0.0, 0.0), v(2.0, 0.0), v(2.0, 0.001), v(0.0, 0.001)]);
        assert!(without_cracks(&p, 0.01).is_none());
        // Wider than the crack width, it stays whole.
        assert_eq!(without_cracks(&p, 0.0005).unwrap(), p);
    }

    #[test]
    fn a_door_one_edge_wide_is_untouched() {
        // Sides of at least e = 0.1 at right angles: every corner's triangle is 0.59 e wide.
        let p = poly(vec![v(0.0, 0.0), v(0.1, 0.0), v(0.1, 2.2), v(0.0, 2.2)]);
        assert_eq!(without_cracks(&p, 0.05).unwrap(), p);
        // An L-shaped opening keeps its reflex corner too.
        let l = poly(vec![
            v(0.0, 0.0),
            v(1.0, 0.0),
            v(1.0, 0.1),
            v(0.1, 0.1),
            v(0.1, 1.0),
            v(0.0, 1.0),
        ]);
        assert_eq!(without_cracks(&l, 0.05).unwrap(), l);
    }

    #[test]
    fn a_notch_into_an_opening_is_filled() {
        // A 10 x 10 opening with a blocker 2e-3 wide reaching 9 into it from the top.
        let p = poly(vec![
            v(0.0, 0.0),
            v(10.0, 0.0),
            v(10.0, 10.0),
            v(5.001, 10.0),
            v(5.0, 1.0),
            v(4.999, 10.0),
            v(0.0, 10.0),
        ]);
        let out = without_cracks(&p, 0.01).unwrap();
        assert!((out.area() - 100.0).abs() < 1e-9, "{out:?}");
    }

    #[test]
    fn where_the_ring_starts_does_not_matter() {
        let ring = needle_window();
        let area = |r: &[DVec2]| poly(r.to_vec()).area();
        let first = area(&ring_without_cracks(&ring, 0.01));
        for k in 1..ring.len() {
            let mut turned = ring.clone();
            turned.rotate_left(k);
            assert_eq!(
                area(&ring_without_cracks(&turned, 0.01)),
                first,
                "start {k}"
            );
        }
    }
}
