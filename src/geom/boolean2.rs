//! 2D polygon booleans for portal openings (shared face region minus blocking geometry), on
//! i_overlay's integer engine with a fixed grid so the same input always gives the same
//! polygons.

use glam::DVec2;
use i_overlay::core::fill_rule::FillRule;
use i_overlay::core::overlay::{Overlay, ShapeType};
use i_overlay::core::overlay_rule::OverlayRule;
use i_overlay::i_float::int::point::IntPoint;

use super::partition::Polygon2;

const LIMIT: f64 = (1u64 << 52) as f64;

/// i_overlay's i32 engine takes coordinates within ±2^30; ours stay a bit inside that.
const LIMIT_I32: i64 = 1 << 29;

fn snap(p: DVec2, grid: f64) -> Option<IntPoint<i64>> {
    let (x, y) = ((p.x / grid).round(), (p.y / grid).round());
    (x.is_finite() && y.is_finite() && x.abs() < LIMIT && y.abs() < LIMIT)
        .then(|| IntPoint::new(x as i64, y as i64))
}

/// Rings snapped to the grid (repeated points dropped, rings left with fewer than three
/// dropped; a ring with a point out of range is dropped whole), with their shape type.
#[derive(Default)]
struct Snapped {
    pts: Vec<IntPoint<i64>>,
    rings: Vec<(usize, usize, ShapeType)>,
}

impl Snapped {
    fn add(&mut self, ring: &[DVec2], grid: f64, shape: ShapeType, reverse: bool) {
        let start = self.pts.len();
        let mut ok = true;
        let mut push = |p: &DVec2| match snap(*p, grid) {
            Some(q) if self.pts.len() > start && self.pts.last() == Some(&q) => {}
            Some(q) => self.pts.push(q),
            None => ok = false,
        };
        if reverse {
            ring.iter().rev().for_each(&mut push);
        } else {
            ring.iter().for_each(&mut push);
        }
        if ok && self.pts.len() - start >= 3 {
            self.rings.push((start, self.pts.len(), shape));
        } else {
            self.pts.truncate(start);
        }
    }

    /// The overlay of the rings, on i_overlay's i32 engine when every point is in its range
    /// (the arithmetic is exact either way, so the answer is the same; the narrow engine
    /// sorts and multiplies half-width numbers), on the i64 one otherwise.
    fn overlay(&self, rule: OverlayRule, fill: FillRule) -> Vec<Vec<Vec<IntPoint<i64>>>> {
        let small = self
            .pts
            .iter()
            .all(|p| p.x.abs() < LIMIT_I32 && p.y.abs() < LIMIT_I32);
        if small {
            let mut overlay = Overlay::<i32>::new(self.pts.len());
            for &(a, b, shape) in &self.rings {
                let ring: Vec<IntPoint<i32>> = self.pts[a..b]
                    .iter()
                    .map(|p| IntPoint::new(p.x as i32, p.y as i32))
                    .collect();
                overlay.add_contour(&ring, shape);
            }
            let shapes = overlay.overlay(rule, fill);
            shapes
                .into_iter()
                .map(|s| {
                    s.into_iter()
                        .map(|c| {
                            c.into_iter()
                                .map(|p| IntPoint::new(p.x as i64, p.y as i64))
                                .collect()
                        })
                        .collect()
                })
                .collect()
        } else {
            let mut overlay = Overlay::<i64>::new(self.pts.len());
            for &(a, b, shape) in &self.rings {
                overlay.add_contour(&self.pts[a..b], shape);
            }
            overlay.overlay(rule, fill)
        }
    }
}

fn run<R: AsRef<[DVec2]>>(
    subject: &[R],
    clip: &[R],
    rule: OverlayRule,
    grid: f64,
) -> Vec<Polygon2> {
    if !(grid.is_finite() && grid > 0.0) {
        return Vec::new();
    }
    let mut rings = Snapped::default();
    for r in subject {
        rings.add(r.as_ref(), grid, ShapeType::Subject, false);
    }
    for r in clip {
        rings.add(r.as_ref(), grid, ShapeType::Clip, false);
    }
    let shapes = rings.overlay(rule, FillRule::EvenOdd);
    polygons(&shapes, grid)
        .into_iter()
        .filter(|p| p.area() > grid * grid)
        .collect()
}

/// i_overlay shapes (outer contour first, then holes) back in metres, outer rings CCW, in a
/// canonical order: each ring starts at its least point (by x, then y, on the integer grid),
/// holes and polygons are sorted by that point. The same region then comes back the same
/// whatever order its inputs were given in (shuffled triangles, renumbered nodes), and the
/// convex partition after it sees the same rings.
fn polygons(shapes: &[Vec<Vec<IntPoint<i64>>>], grid: f64) -> Vec<Polygon2> {
    let least = |c: &[IntPoint<i64>]| c.iter().map(|p| (p.x, p.y)).min();
    let canonical = |c: &Vec<IntPoint<i64>>, ccw: Option<bool>| -> Vec<DVec2> {
        let mut c = c.clone();
        if ccw.is_some_and(|ccw| (int_area2(&c) > 0) != ccw) {
            c.reverse();
        }
        if let Some(at) = (0..c.len()).min_by_key(|&i| (c[i].x, c[i].y)) {
            c.rotate_left(at);
        }
        c.iter()
            .map(|p| DVec2::new(p.x as f64 * grid, p.y as f64 * grid))
            .collect()
    };
    let mut out: Vec<((i64, i64), Polygon2)> = shapes
        .iter()
        .filter(|s| !s.is_empty())
        .map(|s| {
            let mut holes: Vec<&Vec<IntPoint<i64>>> = s[1..].iter().collect();
            holes.sort_by_key(|h| least(h));
            let p = Polygon2 {
                outer: canonical(&s[0], Some(true)),
                holes: holes.into_iter().map(|h| canonical(h, None)).collect(),
            };
            (least(&s[0]).unwrap_or_default(), p)
        })
        .collect();
    out.sort_by_key(|(k, _)| *k);
    out.into_iter().map(|(_, p)| p).collect()
}

/// Twice the signed area of an integer ring, exactly (i128).
fn int_area2(c: &[IntPoint<i64>]) -> i128 {
    (0..c.len())
        .map(|i| {
            let (a, b) = (c[i], c[(i + 1) % c.len()]);
            a.x as i128 * b.y as i128 - b.x as i128 * a.y as i128
        })
        .sum()
}

pub fn signed_area(r: &[DVec2]) -> f64 {
    let mut a = 0.0;
    for (i, p) in r.iter().enumerate() {
        a += p.perp_dot(r[(i + 1) % r.len()]);
    }
    0.5 * a
}

/// `a ∩ b` (each a set of simple rings taken by the even-odd rule).
pub fn intersection(a: &[Vec<DVec2>], b: &[Vec<DVec2>], grid: f64) -> Vec<Polygon2> {
    run(a, b, OverlayRule::Intersect, grid)
}

/// `a − b`, where `b` may be any pile of rings, overlapping and of either winding (two faces
/// on one plane, front and back, must not cancel out). One overlay: `a`'s rings (outer rings
/// counter-clockwise, holes clockwise) and `b`'s (each turned counter-clockwise) are filled by
/// the non-zero rule, so a point any ring of `b` covers is taken out however many do.
pub fn difference<R: AsRef<[DVec2]>>(a: &[Polygon2], b: &[R], grid: f64) -> Vec<Polygon2> {
    if !(grid.is_finite() && grid > 0.0) {
        return Vec::new();
    }
    let mut rings = Snapped::default();
    let mut add_turned = |r: &[DVec2], ccw: bool, shape: ShapeType| {
        rings.add(r, grid, shape, (signed_area(r) >= 0.0) != ccw);
    };
    for p in a {
        add_turned(&p.outer, true, ShapeType::Subject);
        for h in &p.holes {
            add_turned(h, false, ShapeType::Subject);
        }
    }
    for r in b {
        add_turned(r.as_ref(), true, ShapeType::Clip);
    }
    let shapes = rings.overlay(OverlayRule::Difference, FillRule::NonZero);
    polygons(&shapes, grid)
        .into_iter()
        .filter(|p| p.area() > grid * grid)
        .collect()
}

/// The union of rings; overlapping rings are merged (non-zero would double-count holes made of
/// triangles, so each ring is added as its own positive shape first).
pub fn union<R: AsRef<[DVec2]>>(a: &[R], grid: f64) -> Vec<Polygon2> {
    if !(grid.is_finite() && grid > 0.0) {
        return Vec::new();
    }
    let mut rings = Snapped::default();
    for r in a {
        let r = r.as_ref();
        rings.add(r, grid, ShapeType::Subject, signed_area(r) < 0.0);
    }
    let shapes = rings.overlay(OverlayRule::Subject, FillRule::NonZero);
    polygons(&shapes, grid)
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::geom::shapes::rect;

    #[test]
    fn door_is_wall_minus_blockers() {
        let shared = intersection(&[rect(0., 0., 6., 2.)], &[rect(0., 0., 6., 2.)], 1e-6);
        assert_eq!(shared.len(), 1);
        let open = difference(
            &shared,
            &[
                rect(0., 0., 2., 2.),
                rect(4., 0., 6., 2.),
                rect(2., 1.8, 4., 2.),
            ],
            1e-6,
        );
        assert_eq!(open.len(), 1);
        assert!((open[0].area() - 2.0 * 1.8).abs() < 1e-9);
        // Blockers overlapping each other, one of them clockwise (a wall's back face), and the
        // same blocker twice: covered is covered, nothing cancels out.
        let mut back = rect(1., 0., 3., 2.);
        back.reverse();
        let open = difference(
            &shared,
            &[
                rect(0., 0., 2., 2.),
                back,
                rect(4., 0., 6., 2.),
                rect(4., 0., 6., 2.),
            ],
            1e-6,
        );
        assert_eq!(open.len(), 1);
        assert!((open[0].area() - 2.0).abs() < 1e-9, "{}", open[0].area());
        // A subject with a hole keeps it.
        let mut hole = rect(2., 0.5, 3., 1.5);
        hole.reverse();
        let framed = Polygon2 {
            outer: rect(0., 0., 6., 2.),
            holes: vec![hole],
        };
        let open = difference(&[framed], &[rect(0., 0., 1., 2.)], 1e-6);
        assert_eq!(open.len(), 1);
        assert!(
            (open[0].area() - (10.0 - 1.0)).abs() < 1e-9,
            "{}",
            open[0].area()
        );
        let u = union(&[rect(0., 0., 2., 2.), rect(1., 0., 3., 2.)], 1e-6);
        assert_eq!(u.len(), 1);
        assert!((u[0].area() - 6.0).abs() < 1e-9);
    }

    /// Near the origin the overlay runs on i_overlay's i32 engine, far from it (2^30 grid
    /// steps and more) on the i64 one: the same shapes, moved by an exact number of grid steps, give
    /// the same polygons moved back.
    #[test]
    fn narrow_and_wide_engines_agree() {
        let grid = 1.0 / (1u64 << 20) as f64;
        let far = DVec2::splat(4096.0);
        let shift = |r: &[DVec2], by: DVec2| r.iter().map(|p| *p + by).collect::<Vec<_>>();
        let wall = rect(0., 0., 6., 2.);
        let covers = [
            rect(0., 0., 2.5, 2.),
            rect(4., 0., 6., 2.),
            vec![
                DVec2::new(2., 1.6),
                DVec2::new(4.5, 1.9),
                DVec2::new(3., 2.1),
            ],
        ];
        let shared = intersection(
            std::slice::from_ref(&wall),
            std::slice::from_ref(&wall),
            grid,
        );
        let near = difference(&shared, &covers, grid);
        let moved: Vec<Polygon2> = shared
            .iter()
            .map(|p| Polygon2 {
                outer: shift(&p.outer, far),
                holes: p.holes.iter().map(|h| shift(h, far)).collect(),
            })
            .collect();
        let moved_covers: Vec<Vec<DVec2>> = covers.iter().map(|c| shift(c, far)).collect();
        let away = difference(&moved, &moved_covers, grid);
        let back: Vec<Vec<DVec2>> = away.iter().map(|p| shift(&p.outer, -far)).collect();
        let want: Vec<Vec<DVec2>> = near.iter().map(|p| p.outer.clone()).collect();
        assert_eq!(back, want);
        let corners: usize = want.iter().map(Vec::len).sum();
        assert!(corners > 4, "the tilted cover cuts the opening: {want:?}");
    }
}
