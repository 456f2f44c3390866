//! "Is this face region covered?" without a polygon boolean.
//!
//! Most faces a level's cells share are whole walls, floors and ceilings: the blocking
//! triangles cover them and there is no opening. Answering that with i_overlay (union of every
//! blocker, then a difference) is most of the portals stage on a big level. Here the region is
//! cut by each (convex) cover in turn — a convex piece minus a convex cover is at most one
//! convex piece per cover edge — and only the area left matters. The answer is used one way
//! only: a region whose uncovered area is below the threshold has no opening, anything else
//! goes through the exact boolean as before, so the portals found do not change.
//!
//! A cover is applied through the intersection of its edges' inner half-planes (for a ring that
//! is not quite convex, a snapped one, that is a subset of it), each pushed out by `grow` and
//! bevelled at the corners, so every point it removes is within grow·√2 of the cover: cracks
//! of float noise between covers that meet close, openings wider than that stay. Slivers
//! dropped along the way are counted as uncovered.

use glam::DVec2;

/// More pieces than this and the caller falls back to the boolean.
const MAX_PIECES: usize = 256;

/// A cover grown by `grow` reaches at most `grow`·√2 past its bounds (at a corner); pieces
/// further than this many `grow`s from them are not looked at.
const GROWN_REACH: f64 = 2.0;

/// One convex piece: its points in the shared buffer, with its bounds and area kept.
#[derive(Clone, Copy)]
struct Piece {
    start: usize,
    len: usize,
    lo: DVec2,
    hi: DVec2,
    area: f64,
}

/// Pieces in one flat buffer of points (cutting makes thousands of small polygons per level;
/// a buffer each made the allocator the hot spot).
#[derive(Default)]
struct Pieces {
    pts: Vec<DVec2>,
    list: Vec<Piece>,
}

impl Pieces {
    fn clear(&mut self) {
        self.pts.clear();
        self.list.clear();
    }

    fn points(&self, p: &Piece) -> &[DVec2] {
        &self.pts[p.start..p.start + p.len]
    }

    /// Adds a piece (its area and bounds computed here), or returns its area when it is a
    /// sliver and is dropped.
    fn push(&mut self, ring: &[DVec2], sliver: f64) -> Option<f64> {
        let area = signed_area(ring).abs();
        if area <= sliver {
            return Some(area);
        }
        let (lo, hi) = bounds(ring);
        self.list.push(Piece {
            start: self.pts.len(),
            len: ring.len(),
            lo,
            hi,
            area,
        });
        self.pts.extend_from_slice(ring);
        None
    }

    fn keep(&mut self, from: &Pieces, p: &Piece) {
        self.list.push(Piece {
            start: self.pts.len(),
            ..*p
        });
        self.pts.extend_from_slice(from.points(p));
    }
}

/// What is left of a region as covers are cut from it.
pub(crate) struct Remainder {
    pieces: Pieces,
    next: Pieces,
    cover: Vec<DVec2>,
    planes: Vec<(DVec2, f64)>,
    rest: Vec<DVec2>,
    outside: Vec<DVec2>,
    inside: Vec<DVec2>,
    /// Pieces below this area are dropped as they appear (and counted in `dropped`), so float
    /// noise along shared edges cannot multiply pieces.
    sliver: f64,
    /// Covers are grown by this much, so the float noise between two covers that meet
    /// (an f32 crack between two wall triangles) is no opening.
    grow: f64,
    dropped: f64,
    overflow: bool,
}

impl Remainder {
    /// `region`: a ring of either winding.
    pub fn new(region: &[DVec2], grow: f64, sliver: f64) -> Remainder {
        let mut r = Remainder {
            pieces: Pieces::default(),
            next: Pieces::default(),
            cover: Vec::new(),
            planes: Vec::new(),
            rest: Vec::new(),
            outside: Vec::new(),
            inside: Vec::new(),
            sliver,
            grow,
            dropped: 0.0,
            overflow: false,
        };
        if let Some(a) = r.pieces.push(&ccw(region), sliver) {
            r.dropped += a;
        }
        r
    }

    /// Cuts a cover (a ring of either winding, treated as convex) from what is left.
    pub fn cut(&mut self, c: &[DVec2]) {
        if c.len() < 3 || self.pieces.list.is_empty() || self.overflow {
            return;
        }
        let (lo, hi) = bounds(c);
        let (lo, hi) = (
            lo - DVec2::splat(GROWN_REACH * self.grow),
            hi + DVec2::splat(GROWN_REACH * self.grow),
        );
        let apart = |p: &Piece| p.hi.x < lo.x || p.hi.y < lo.y || p.lo.x > hi.x || p.lo.y > hi.y;
        if self.pieces.list.iter().all(apart) {
            return;
        }
        self.cover.clear();
        self.cover.extend_from_slice(c);
        if signed_area(&self.cover) < 0.0 {
            self.cover.reverse();
        }
        half_planes(&self.cover, self.grow, &mut self.planes);
        self.next.clear();
        for i in 0..self.pieces.list.len() {
            let p = self.pieces.list[i];
            let pts = self.pieces.points(&p);
            // A piece the cover's box misses, or that one of its half-planes leaves wholly
            // outside, is kept whole rather than cut into fragments along the others.
            if apart(&p)
                || self
                    .planes
                    .iter()
                    .any(|(m, limit)| pts.iter().all(|q| m.dot(*q) > *limit))
            {
                self.next.keep(&self.pieces, &p);
                continue;
            }
            self.rest.clear();
            self.rest.extend_from_slice(pts);
            for &(m, limit) in &self.planes {
                split(
                    &self.rest,
                    |q| limit - m.dot(q),
                    &mut self.outside,
                    &mut self.inside,
                );
                if self.outside.len() >= 3 {
                    if let Some(a) = self.next.push(&self.outside, self.sliver) {
                        self.dropped += a;
                    }
                }
                std::mem::swap(&mut self.rest, &mut self.inside);
                if self.rest.len() < 3 {
                    break;
                }
            }
        }
        std::mem::swap(&mut self.pieces, &mut self.next);
        self.overflow = self.pieces.list.len() > MAX_PIECES;
    }

    /// The area left (with the dropped slivers), or `None` when it took too many pieces to tell.
    pub fn area(&self) -> Option<f64> {
        (!self.overflow)
            .then(|| self.dropped + self.pieces.list.iter().map(|p| p.area).sum::<f64>())
    }

    /// True when what is left is known to be at most `limit`.
    pub(crate) fn at_most(&self, limit: f64) -> bool {
        self.area().is_some_and(|a| a <= limit)
    }
}

/// An upper bound on the area a cover grown by `grow` removes: the grown cover lies within
/// grow·√2 of the ring, and that neighbourhood has area A + √2·grow·P + 2π·grow².
pub(crate) fn grown_area_bound(cover: &[DVec2], grow: f64) -> f64 {
    let perimeter: f64 = (0..cover.len())
        .map(|i| cover[i].distance(cover[(i + 1) % cover.len()]))
        .sum();
    signed_area(cover).abs()
        + std::f64::consts::SQRT_2 * grow * perimeter
        + 2.0 * std::f64::consts::PI * grow * grow
}

/// True when `covers` (grown by `grow`) leave at most `closed` of `region` uncovered. Gives up
/// (false) as soon as the covers not yet cut could not remove what is left, so a region with
/// a real opening costs little more than the sum of its covers' areas.
pub(crate) fn is_covered<R: AsRef<[DVec2]>>(
    region: &[DVec2],
    covers: &[R],
    grow: f64,
    sliver: f64,
    closed: f64,
) -> bool {
    // Largest first: they leave few pieces for the rest, and the budget of what is not yet
    // cut falls fastest.
    let mut order: Vec<(f64, &[DVec2])> = covers
        .iter()
        .map(|c| (grown_area_bound(c.as_ref(), grow), c.as_ref()))
        .collect();
    order.sort_by(|a, b| b.0.total_cmp(&a.0));
    let mut budget: f64 = order.iter().map(|o| o.0).sum();
    if signed_area(region).abs() > budget + closed || open_somewhere(region, covers, grow, closed) {
        return false;
    }
    let mut left = Remainder::new(region, grow, sliver);
    for (b, c) in order {
        left.cut(c);
        budget -= b;
        match left.area() {
            None => return false,
            Some(a) if a <= closed => return true,
            Some(a) if a > budget + closed => return false,
            _ => {}
        }
    }
    left.at_most(closed)
}

/// True when a disc of area more than `closed` inside `region` (convex, either winding) is
/// shown to meet none of the `covers` (grown by `grow`): a door in a wall is usually found by
/// one of a few sample points, without cutting. Each test is sufficient only (a half-plane of
/// the cover that leaves the disc outside), so "false" means "not shown".
fn open_somewhere<R: AsRef<[DVec2]>>(
    region: &[DVec2],
    covers: &[R],
    grow: f64,
    closed: f64,
) -> bool {
    // The disc's radius: its area is 1.3·closed.
    let r = (1.3 * closed / std::f64::consts::PI).sqrt();
    let region = ccw(region);
    let n = region.len();
    if n < 3 {
        return false;
    }
    let inside = |p: DVec2, margin: f64, ring: &[DVec2]| {
        (0..ring.len()).all(|i| {
            let (a, b) = (ring[i], ring[(i + 1) % ring.len()]);
            let len = a.distance(b);
            len > 0.0 && (b - a).perp_dot(p - a) / len >= margin
        })
    };
    let (lo, hi) = bounds(&region);
    let centroid = region.iter().copied().sum::<DVec2>() / n as f64;
    let grid = (1..=5)
        .flat_map(|i| (1..=5).map(move |j| lo + (hi - lo) * DVec2::new(i as f64, j as f64) / 6.0));
    // Each cover's edges (start, direction, length, the winding's sign), computed once rather
    // than per sample point.
    let mut edges: Vec<(DVec2, DVec2, f64, f64)> = Vec::new();
    let mut spans: Vec<(usize, usize)> = Vec::with_capacity(covers.len());
    for c in covers {
        let c = c.as_ref();
        let start = edges.len();
        if c.len() >= 3 {
            let sign = if signed_area(c) < 0.0 { -1.0 } else { 1.0 };
            edges.extend((0..c.len()).map(|i| {
                let (a, b) = (c[i], c[(i + 1) % c.len()]);
                (a, b - a, a.distance(b), sign)
            }));
        }
        spans.push((start, edges.len()));
    }
    let apart = -(r + std::f64::consts::SQRT_2 * grow);
    // Some edge of the cover (either winding) with the disc and the grown cover apart: the
    // grown cover is within grow·√2 of the ring. A cover without three points is apart.
    let clear = |p: DVec2, (start, end): (usize, usize)| {
        start == end
            || edges[start..end]
                .iter()
                .any(|&(a, d, len, sign)| len > 0.0 && sign * d.perp_dot(p - a) / len < apart)
    };
    // The cover that stopped the last point is tried first: neighbouring points are usually
    // under the same one (the answer does not depend on the order).
    let mut last = 0;
    std::iter::once(centroid).chain(grid).any(|p| {
        if !inside(p, r, &region) {
            return false;
        }
        if spans.get(last).is_some_and(|&s| !clear(p, s)) {
            return false;
        }
        match spans.iter().position(|&s| !clear(p, s)) {
            Some(k) => {
                last = k;
                false
            }
            None => true,
        }
    })
}

/// The area of `region` not covered by `covers` (see [`Remainder`]), or `None` when it would
/// take too many pieces to tell. Pieces below `sliver` are dropped and counted.
#[cfg(test)]
pub(crate) fn uncovered_area<'a>(
    region: &[DVec2],
    covers: impl IntoIterator<Item = &'a [DVec2]>,
    grow: f64,
    sliver: f64,
) -> Option<f64> {
    let mut r = Remainder::new(region, grow, sliver);
    for c in covers {
        r.cut(c);
    }
    r.area()
}

/// The half-planes (outward unit normal, limit: inside when `m·q <= limit`) of the convex CCW
/// ring `s` grown by `grow`: each edge pushed out, then a bevel at its end vertex, so a sharp
/// corner grows by at most grow·√2, not by a long miter.
fn half_planes(s: &[DVec2], grow: f64, out: &mut Vec<(DVec2, f64)>) {
    out.clear();
    let n = s.len();
    // Outward unit normals of the edges (zero for a repeated vertex).
    let normal = |i: usize| {
        let d = s[(i + 1) % n] - s[i];
        let len = d.length();
        if len > 0.0 {
            DVec2::new(d.y, -d.x) / len
        } else {
            DVec2::ZERO
        }
    };
    for i in 0..n {
        let ni = normal(i);
        let nj = normal((i + 1) % n);
        let bevel = (ni + nj).normalize_or_zero();
        for (m, at) in [(ni, s[i]), (bevel, s[(i + 1) % n])] {
            if m != DVec2::ZERO {
                out.push((m, m.dot(at) + grow));
            }
        }
    }
}

/// The parts of a ring with `side < 0` (into `neg`) and `side >= 0` (into `pos`)
/// (Sutherland–Hodgman; for a ring that is not convex the parts may have zero-width bridges,
/// which keep their areas right).
fn split(ring: &[DVec2], side: impl Fn(DVec2) -> f64, neg: &mut Vec<DVec2>, pos: &mut Vec<DVec2>) {
    neg.clear();
    pos.clear();
    let n = ring.len();
    let mut da = side(ring[n - 1]);
    let mut a = ring[n - 1];
    for &b in ring {
        let db = side(b);
        if (da < 0.0) != (db < 0.0) {
            let x = a + (b - a) * (da / (da - db));
            neg.push(x);
            pos.push(x);
        }
        if db < 0.0 {
            neg.push(b);
        } else {
            pos.push(b);
        }
        (a, da) = (b, db);
    }
}

fn ccw(r: &[DVec2]) -> Vec<DVec2> {
    let mut r = r.to_vec();
    if signed_area(&r) < 0.0 {
        r.reverse();
    }
    r
}

fn bounds(r: &[DVec2]) -> (DVec2, DVec2) {
    r.iter().fold(
        (DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY)),
        |(lo, hi), q| (lo.min(*q), hi.max(*q)),
    )
}

fn signed_area(r: &[DVec2]) -> f64 {
    super::boolean2::signed_area(r)
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::geom::shapes::rect;

    fn left(covers: &[Vec<DVec2>], region: &[DVec2]) -> f64 {
        uncovered_area(region, covers.iter().map(Vec::as_slice), 0.0, 1e-12).unwrap()
    }

    #[test]
    fn a_wall_of_two_triangles_covers_its_face() {
        let wall = rect(0., 0., 4., 3.);
        // Clockwise and counter-clockwise triangles, as a mesh's winding gives them.
        let t1 = vec![DVec2::new(0., 0.), DVec2::new(4., 3.), DVec2::new(4., 0.)];
        let t2 = vec![DVec2::new(0., 0.), DVec2::new(4., 3.), DVec2::new(0., 3.)];
        assert!(left(&[t1.clone(), t2], &wall) < 1e-12);
        assert!((left(&[t1], &wall) - 6.0).abs() < 1e-12);
    }

    #[test]
    fn a_door_stays_open() {
        // A 6×2 wall minus two jambs and a lintel leaves the 2×1.8 door.
        let covers = [
            rect(0., 0., 2., 2.),
            rect(4., 0., 6., 2.),
            rect(2., 1.8, 4., 2.),
        ];
        assert!((left(&covers, &rect(0., 0., 6., 2.)) - 3.6).abs() < 1e-9);
        // Covers beyond the region change nothing.
        let far = [rect(10., 10., 11., 11.)];
        assert!((left(&far, &rect(0., 0., 1., 1.)) - 1.0).abs() < 1e-12);
    }

    #[test]
    fn overlapping_covers_are_not_counted_twice() {
        let covers = [rect(0., 0., 3., 1.), rect(2., 0., 5., 1.)];
        assert!((left(&covers, &rect(0., 0., 6., 1.)) - 1.0).abs() < 1e-12);
    }

    #[test]
    fn grown_covers_close_cracks_but_not_doors() {
        let wall = rect(0., 0., 4., 3.);
        let area = |covers: &[Vec<DVec2>], grow: f64| {
            uncovered_area(&wall, covers.iter().map(Vec::as_slice), grow, 1e-15).unwrap()
        };
        // Two halves with a 1e-7 crack between them (and sharp triangles meeting at a corner).
        let halves = [rect(0., 0., 2., 3.), rect(2. + 1e-7, 0., 4., 3.)];
        assert!(area(&halves, 0.0) > 2e-7);
        assert!(area(&halves, 1e-6) == 0.0);
        // A 1e-5 door between them stays open, less at most 2·grow·√2 of its width.
        let door = [rect(0., 0., 2., 3.), rect(2. + 1e-5, 0., 4., 3.)];
        let left = area(&door, 1e-6);
        assert!(left > 3.0 * (1e-5 - 3e-6) && left < 3e-5, "{left}");
        // A sliver triangle does not grow a long miter at its sharp tip.
        let needle = [vec![
            DVec2::new(0., 1.),
            DVec2::new(4., 1.0005),
            DVec2::new(0., 1.001),
        ]];
        let point = rect(4.0 + 1e-5, 0.99, 4.1, 1.01);
        let left = uncovered_area(&point, needle.iter().map(Vec::as_slice), 1e-6, 1e-15).unwrap();
        assert!((left - (0.1 - 1e-5) * 0.02).abs() < 1e-12, "{left}");
    }

    #[test]
    fn a_door_is_seen_without_cutting_and_a_wall_is_not_taken_for_one() {
        let wall = rect(0., 0., 6., 2.);
        let jambs = [
            rect(0., 0., 2., 2.),
            rect(4., 0., 6., 2.),
            rect(2., 1.8, 4., 2.),
        ];
        assert!(open_somewhere(&wall, &jambs, 1e-6, 1e-12));
        assert!(!is_covered(&wall, &jambs, 1e-6, 1e-15, 1e-12));
        // The door filled: no point is shown open, and the cuts find it closed.
        let mut filled = jambs.to_vec();
        filled.push(rect(2., 0., 4., 1.8));
        assert!(!open_somewhere(&wall, &filled, 1e-6, 1e-12));
        assert!(is_covered(&wall, &filled, 1e-6, 1e-15, 1e-12));
        // A crack narrower than the grown covers is not an opening at any sample point.
        let cracked = [rect(0., 0., 3., 2.), rect(3. + 1e-7, 0., 6., 2.)];
        assert!(!open_somewhere(&wall, &cracked, 1e-6, 1e-12));
    }

    #[test]
    fn a_non_convex_cover_counts_as_its_kernel_at_most() {
        // An L covers 3 of the 4 unit squares; taken as convex it may cover less, never more.
        let l = vec![
            DVec2::new(0., 0.),
            DVec2::new(2., 0.),
            DVec2::new(2., 1.),
            DVec2::new(1., 1.),
            DVec2::new(1., 2.),
            DVec2::new(0., 2.),
        ];
        assert!(left(&[l], &rect(0., 0., 2., 2.)) >= 1.0 - 1e-12);
    }
}
