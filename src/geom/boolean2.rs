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

fn snap(p: DVec2, grid: f64) -> Option<IntPoint<i64>> {
    let (x, y) = ((p.x / grid).round(), (p.y / grid).round());
    (x.is_finite() && y.is_finite() && x.abs() < LIMIT && y.abs() < LIMIT)
        .then(|| IntPoint::new(x as i64, y as i64))
}

fn add(overlay: &mut Overlay<i64>, ring: &[DVec2], grid: f64, shape: ShapeType) {
    let pts: Option<Vec<IntPoint<i64>>> = ring.iter().map(|p| snap(*p, grid)).collect();
    if let Some(mut pts) = pts {
        pts.dedup();
        if pts.len() >= 3 {
            overlay.add_contour(&pts, shape);
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
    let n = subject.iter().chain(clip).map(|r| r.as_ref().len()).sum();
    let mut overlay = Overlay::<i64>::new(n);
    for r in subject {
        add(&mut overlay, r.as_ref(), grid, ShapeType::Subject);
    }
    for r in clip {
        add(&mut overlay, r.as_ref(), grid, ShapeType::Clip);
    }
    let shapes = overlay.overlay(rule, FillRule::EvenOdd);
    polygons(&shapes, grid)
        .into_iter()
        .filter(|p| p.area() > grid * grid)
        .collect()
}

/// i_overlay shapes (outer contour first, then holes) back in metres, outer rings CCW.
fn polygons(shapes: &[Vec<Vec<IntPoint<i64>>>], grid: f64) -> Vec<Polygon2> {
    let back = |c: &Vec<IntPoint<i64>>| -> Vec<DVec2> {
        c.iter()
            .map(|p| DVec2::new(p.x as f64 * grid, p.y as f64 * grid))
            .collect()
    };
    shapes
        .iter()
        .filter(|s| !s.is_empty())
        .map(|s| {
            let mut outer = back(&s[0]);
            if signed_area(&outer) < 0.0 {
                outer.reverse();
            }
            Polygon2 {
                outer,
                holes: s[1..].iter().map(back).collect(),
            }
        })
        .collect()
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
    let n = a
        .iter()
        .map(|p| p.outer.len() + p.holes.iter().map(Vec::len).sum::<usize>())
        .sum::<usize>()
        + b.iter().map(|r| r.as_ref().len()).sum::<usize>();
    let mut overlay = Overlay::<i64>::new(n);
    let mut add_turned = |r: &[DVec2], ccw: bool, shape: ShapeType| {
        if (signed_area(r) >= 0.0) == ccw {
            add(&mut overlay, r, grid, shape);
        } else {
            let mut r = r.to_vec();
            r.reverse();
            add(&mut overlay, &r, grid, shape);
        }
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
    let shapes = overlay.overlay(OverlayRule::Difference, FillRule::NonZero);
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
    let mut overlay = Overlay::<i64>::new(a.iter().map(|r| r.as_ref().len()).sum());
    for r in a {
        let mut r = r.as_ref().to_vec();
        if signed_area(&r) < 0.0 {
            r.reverse();
        }
        add(&mut overlay, &r, grid, ShapeType::Subject);
    }
    let shapes = overlay.overlay(OverlayRule::Subject, FillRule::NonZero);
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
}
