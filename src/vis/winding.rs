//! Convex polygon clipping for the flow, into caller-owned buffers so the inner loop never
//! allocates.
//!
//! The rule is Quake's: a point within `eps` of the plane is on it and kept; a polygon with no
//! point in front is gone; one with no point behind is kept whole. Cuts are made at the plane
//! itself, so an on-plane sliver is never manufactured from nothing.

use glam::DVec3;

use crate::geom::plane::Plane;

/// The margin, as a share, a bounding sphere's radius gets over the rounding of the distances
/// it was measured from (about 1e-16 of them), so every corner is inside it.
const RADIUS_MARGIN: f64 = 1e-12;

/// A separating plane's normal, the cross product of an edge and the direction to a corner,
/// shorter than 1e-10 of their lengths (this is its square) is rounding's, not a plane: its
/// direction would be off by a millionth of a radian or more. Not the angle tolerance: a
/// plane through a corner nearly on the edge's line, but clearly off it, still separates.
const DEGENERATE2: f64 = 1e-20;

/// What a chop left.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Chop {
    /// Nothing was left on the kept side.
    Gone,
    /// All of it was on the kept side.
    Whole,
    /// Part was cut away.
    Cut,
}

/// Keeps the part of `input` in front of `plane`, written to `out`. False: nothing is left.
pub(crate) fn chop(input: &[DVec3], plane: &Plane, eps: f64, out: &mut Vec<DVec3>) -> bool {
    chop_how(input, plane, eps, out) != Chop::Gone
}

/// [`chop`], saying whether anything was cut.
pub(crate) fn chop_how(input: &[DVec3], plane: &Plane, eps: f64, out: &mut Vec<DVec3>) -> Chop {
    let how = cut(input, plane, eps, out);
    if how == Chop::Whole {
        out.clear();
        out.extend_from_slice(input);
    }
    how
}

/// The work of [`chop_how`], writing `out` only for a cut: a polygon kept whole needs no
/// copy when the caller goes on with `input`.
fn cut(input: &[DVec3], plane: &Plane, eps: f64, out: &mut Vec<DVec3>) -> Chop {
    let mut front = false;
    let mut back = false;
    // Distances are kept for the cut, on the stack for the usual small polygon.
    let mut buf = [0.0f64; 32];
    let mut heap = Vec::new();
    let dists: &mut [f64] = if input.len() <= buf.len() {
        &mut buf[..input.len()]
    } else {
        heap.resize(input.len(), 0.0);
        &mut heap
    };
    for (p, d) in input.iter().zip(dists.iter_mut()) {
        *d = plane.distance(*p);
        front |= *d > eps;
        back |= *d < -eps;
    }
    if !front {
        return Chop::Gone;
    }
    if !back {
        return Chop::Whole;
    }
    out.clear();
    let n = input.len();
    for i in 0..n {
        let j = if i + 1 == n { 0 } else { i + 1 };
        let (a, b) = (input[i], input[j]);
        let (da, db) = (dists[i], dists[j]);
        let sa = side(da, eps);
        let sb = side(db, eps);
        if sa >= 0 {
            out.push(a);
        }
        if sa != 0 && sb != 0 && sa != sb {
            let t = da / (da - db);
            out.push(a + (b - a) * t);
        }
    }
    if out.len() >= 3 {
        Chop::Cut
    } else {
        Chop::Gone
    }
}

/// [`chop_how`] with a sphere around `input` (see [`sphere`]) deciding first: wholly in front
/// or wholly behind costs one distance instead of one per corner. Same answer.
pub(crate) fn chop_in_sphere(
    input: &[DVec3],
    (c, r): (DVec3, f64),
    plane: &Plane,
    eps: f64,
    out: &mut Vec<DVec3>,
) -> Chop {
    let dc = plane.distance(c);
    if dc + r <= eps {
        out.clear();
        return Chop::Gone;
    }
    if dc - r > eps {
        out.clear();
        out.extend_from_slice(input);
        return Chop::Whole;
    }
    chop_how(input, plane, eps, out)
}

fn side(d: f64, eps: f64) -> i8 {
    if d > eps {
        1
    } else if d < -eps {
        -1
    } else {
        0
    }
}

/// Clips `target` by every plane in turn. False: nothing is left.
pub(crate) fn clip_by(
    planes: &[Plane],
    target: &mut Vec<DVec3>,
    tmp: &mut Vec<DVec3>,
    eps: f64,
) -> bool {
    // A bounding sphere decides most planes with one distance instead of one per corner; the
    // outcome is the same as the corner test's.
    let (mut c, mut r) = sphere(target);
    for plane in planes {
        let dc = plane.distance(c);
        if dc > r + eps {
            continue;
        }
        if dc < -r - eps {
            return false;
        }
        match cut(target, plane, eps, tmp) {
            Chop::Gone => return false,
            Chop::Whole => {}
            Chop::Cut => {
                std::mem::swap(target, tmp);
                (c, r) = sphere(target);
            }
        }
    }
    true
}

/// A sphere around a polygon: its corners' centroid and the farthest corner.
pub fn sphere(poly: &[DVec3]) -> (DVec3, f64) {
    if poly.is_empty() {
        return (DVec3::ZERO, 0.0);
    }
    let c = poly.iter().copied().sum::<DVec3>() / poly.len() as f64;
    let r2 = poly
        .iter()
        .map(|v| v.distance_squared(c))
        .fold(0.0, f64::max);
    (c, r2.sqrt() * (1.0 + RADIUS_MARGIN))
}

/// The planes that separate `source` from `pass` (through an edge of `source` and a corner of
/// `pass`, with `source` wholly behind and `pass` wholly in front), appended to `out`:
/// whatever is seen from `source` through `pass` is in front of all of them. `flip` turns
/// them round, for planes built from the edges of `pass` (call with the two swapped). They
/// depend only on `source` and `pass`, so the flow computes them once per stack frame and
/// reuses them for every portal beyond.
///
/// This is the flow's hottest function. Per edge of `source`, of the planes through the edge
/// and a corner of `pass` only the two extreme ones (every other corner on one side) can have
/// all of `pass` on one side, so only those two are built and tested, on the unnormalised
/// normal against `eps` times its length. The side the source is on is read from its centre:
/// the source is planar and convex, so every corner off the edge is on the centre's side.
pub(crate) fn separators(
    source: &[DVec3],
    pass: &[DVec3],
    flip: bool,
    eps: f64,
    out: &mut Vec<Plane>,
) {
    let ns = source.len();
    if ns < 3 {
        return;
    }
    // Strictly inside the convex source, so off every edge's line; a convex combination of
    // the corners, so it is beyond `eps` of a plane only when some corner is.
    let centre = source.iter().copied().sum::<DVec3>() / ns as f64;
    for i in 0..ns {
        let l = if i + 1 == ns { 0 } else { i + 1 };
        let a = source[i];
        let v1 = source[l] - a;
        let v1l2 = v1.length_squared();
        if v1l2 == 0.0 {
            continue;
        }
        // The extreme corners about the edge: `lo` has every other corner on the positive
        // side of its plane, `hi` on the negative side (when `pass` allows such a plane).
        // Corners on the edge's line make no plane and never become extreme.
        let Some((k0, n0)) = pass
            .iter()
            .enumerate()
            .map(|(k, q)| (k, v1.cross(*q - a)))
            .find(|(_, n)| *n != DVec3::ZERO)
        else {
            continue;
        };
        let (mut lo, mut n_lo, mut hi, mut n_hi) = (k0, n0, k0, n0);
        for (k, q) in pass.iter().enumerate().skip(k0 + 1) {
            let r = *q - a;
            if n_lo.dot(r) < 0.0 {
                lo = k;
                n_lo = v1.cross(r);
            }
            if n_hi.dot(r) > 0.0 {
                hi = k;
                n_hi = v1.cross(r);
            }
        }
        // One extreme for both: every corner is on one plane with the edge, so none is in
        // front of it and nothing separates.
        if lo == hi {
            continue;
        }
        // `lo` can separate only with the source on its negative side, `hi` only with it on
        // the positive side.
        for (j, n, sign) in [(lo, n_lo, 1.0), (hi, n_hi, -1.0)] {
            if let Some(pl) = separating(pass, j, n, sign, a, centre, v1l2, eps) {
                out.push(if flip { pl.flipped() } else { pl });
            }
        }
    }
}

/// The plane through corner `j` of `pass` and the source edge from `a` (squared length
/// `v1l2`), with normal `n` (unnormalised), when it separates: the source (its `centre`)
/// beyond `eps` on the `-sign` side, every corner of `pass` on the `sign` side or within
/// `eps`, one beyond. It faces the `sign` side.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn separating(
    pass: &[DVec3],
    j: usize,
    n: DVec3,
    sign: f64,
    a: DVec3,
    centre: DVec3,
    v1l2: f64,
    eps: f64,
) -> Option<Plane> {
    let ds = sign * n.dot(centre - a);
    // The sign first, before the square root.
    if ds >= 0.0 {
        return None;
    }
    let pj = pass[j];
    let len2 = n.length_squared();
    // Degenerate edge/corner triples make no plane.
    if len2 < DEGENERATE2 * v1l2 * (pj - a).length_squared() {
        return None;
    }
    let len = len2.sqrt();
    let tol = eps * len;
    if ds >= -tol {
        return None; // planar with the source
    }
    let mut front = false;
    for (k, q) in pass.iter().enumerate() {
        if k == j {
            continue;
        }
        let d = sign * n.dot(*q - pj);
        if d < -tol {
            return None;
        }
        front |= d > tol;
    }
    if !front {
        return None;
    }
    let normal = n * (sign / len);
    Some(Plane {
        normal,
        d: normal.dot(pj),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Clips `target` by the planes that separate `source` from `pass` (through an edge of one and
    /// a vertex of the other, with `source` wholly behind and `pass` wholly in front): whatever of
    /// `target` is seen from `source` through `pass` is in front of all of them. `flip` swaps the
    /// roles, for planes built from an edge of `pass`. `tmp` is scratch. False: nothing is left.
    fn clip_to_separators(
        source: &[DVec3],
        pass: &[DVec3],
        target: &mut Vec<DVec3>,
        tmp: &mut Vec<DVec3>,
        flip: bool,
        eps: f64,
    ) -> bool {
        let mut planes = Vec::new();
        separators(source, pass, flip, eps, &mut planes);
        clip_by(&planes, target, tmp, eps)
    }

    fn square(x: f64) -> Vec<DVec3> {
        vec![
            DVec3::new(x, -1.0, -1.0),
            DVec3::new(x, 1.0, -1.0),
            DVec3::new(x, 1.0, 1.0),
            DVec3::new(x, -1.0, 1.0),
        ]
    }

    #[test]
    fn chop_keeps_front() {
        let p = Plane {
            normal: DVec3::Y,
            d: 0.0,
        };
        let mut out = Vec::new();
        assert!(chop(&square(0.0), &p, 1e-9, &mut out));
        assert_eq!(out.len(), 4);
        assert!(out.iter().all(|v| v.y >= -1e-12));
        assert!(!chop(
            &square(0.0),
            &Plane {
                normal: DVec3::Y,
                d: 2.0
            },
            1e-9,
            &mut out
        ));
    }

    #[test]
    fn separators_narrow_the_target() {
        // Source at x=0, pass at x=1 (both 2x2); a target at x=2 shifted far off to the side
        // is invisible, one straight ahead is kept.
        let (src, pass) = (square(0.0), square(1.0));
        let mut tmp = Vec::new();
        let mut t: Vec<DVec3> = square(2.0);
        assert!(clip_to_separators(
            &src, &pass, &mut t, &mut tmp, false, 1e-9
        ));
        let mut far: Vec<DVec3> = square(2.0)
            .iter()
            .map(|v| *v + DVec3::new(0.0, 10.0, 0.0))
            .collect();
        assert!(!clip_to_separators(
            &src, &pass, &mut far, &mut tmp, false, 1e-9
        ));
    }
}
