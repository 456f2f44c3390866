//! The level's own axes, so a level turned or moved is voxelised the same way: the direction
//! most of its surface area faces along (floors and ceilings, or walls), then the dominant
//! direction square to it, each refined to the area-weighted mean of the normals near it.
//! The grid is centred on the level's box in these axes, so a sign that flips maps the grid
//! onto itself.

use glam::DVec3;

/// Normals within this angle of an axis count for it (cos 3°).
const NEAR: f64 = 0.998_629_534_754_573_9;

/// An orthonormal frame: `axes[k]` is the world direction of frame coordinate `k`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Frame {
    /// Unit axes, right-handed.
    pub axes: [DVec3; 3],
}

impl Frame {
    /// Frame coordinates of a world point (relative to the same origin).
    pub fn to_frame(&self, p: DVec3) -> DVec3 {
        DVec3::new(
            p.dot(self.axes[0]),
            p.dot(self.axes[1]),
            p.dot(self.axes[2]),
        )
    }

    /// The world point of frame coordinates.
    pub fn to_world(&self, q: DVec3) -> DVec3 {
        self.axes[0] * q.x + self.axes[1] * q.y + self.axes[2] * q.z
    }

    /// The frame of `tris` (world points about the level's centre).
    pub fn of(tris: &[[DVec3; 3]]) -> Frame {
        let normals: Vec<(DVec3, f64)> = tris
            .iter()
            .filter_map(|t| {
                let n = (t[1] - t[0]).cross(t[2] - t[0]);
                let a = 0.5 * n.length();
                n.try_normalize().map(|n| (n, a))
            })
            .filter(|(n, a)| n.is_finite() && a.is_finite())
            .collect();
        let first = dominant(&normals, |_| true, |d, n| n.dot(d).abs() >= NEAR).unwrap_or(DVec3::Y);
        let square = |n: DVec3| n.dot(first).abs() < 1.0 - NEAR + 0.05;
        let second = dominant(&normals, square, |d, n| {
            let side = first.cross(d);
            n.dot(d).abs() >= NEAR || n.dot(side).abs() >= NEAR
        })
        .map(|d| (d - first * d.dot(first)).normalize_or_zero())
        .filter(|d| *d != DVec3::ZERO)
        .unwrap_or_else(|| any_square(first));
        let first = oriented(first, tris);
        let second = oriented(second, tris);
        Frame {
            axes: [first, second, first.cross(second)],
        }
    }
}

/// The direction (up to sign) that the most area of `normals` faces along, among the normals
/// of the largest triangles that pass `allowed`, refined to the mean of the normals counted.
fn dominant(
    normals: &[(DVec3, f64)],
    allowed: impl Fn(DVec3) -> bool,
    counts: impl Fn(DVec3, DVec3) -> bool + Sync,
) -> Option<DVec3> {
    let mut cand: Vec<&(DVec3, f64)> = normals.iter().filter(|(n, _)| allowed(*n)).collect();
    // Largest first; equal areas by direction, so the order of the input does not matter.
    cand.sort_by(|a, b| {
        b.1.total_cmp(&a.1)
            .then(a.0.x.total_cmp(&b.0.x))
            .then(a.0.y.total_cmp(&b.0.y))
            .then(a.0.z.total_cmp(&b.0.z))
    });
    cand.truncate(48);
    let score = |d: DVec3| -> f64 {
        let d = d.normalize_or_zero();
        normals
            .iter()
            .filter(|(n, _)| allowed(*n) && counts(d, *n))
            .map(|(_, a)| a)
            .sum()
    };
    let mut best: Option<(f64, DVec3)> = None;
    for (n, _) in cand {
        let refined = refine(normals, *n, &allowed, &counts);
        let s = score(refined);
        if best.is_none_or(|(bs, _)| s > bs * (1.0 + 1e-9)) {
            best = Some((s, refined));
        }
    }
    best.map(|(_, d)| d)
}

/// The area-weighted mean of the normals `counts` gives to `d`, each turned to `d`'s side
/// (for the square pair, folded onto `d`), so nearby candidates give one axis.
fn refine(
    normals: &[(DVec3, f64)],
    d: DVec3,
    allowed: &impl Fn(DVec3) -> bool,
    counts: &impl Fn(DVec3, DVec3) -> bool,
) -> DVec3 {
    let mut sum = DVec3::ZERO;
    for &(n, a) in normals.iter().filter(|(n, _)| allowed(*n) && counts(d, *n)) {
        if n.dot(d).abs() >= NEAR {
            sum += n * a * n.dot(d).signum();
        }
    }
    sum.try_normalize().unwrap_or(d)
}

/// A direction square to `d` when nothing else decides one.
fn any_square(d: DVec3) -> DVec3 {
    let pick = if d.x.abs() < 0.9 { DVec3::X } else { DVec3::Y };
    (pick - d * pick.dot(d)).normalize()
}

/// `d` turned so the level's area-weighted third moment along it is not negative: a sign
/// fixed by the level's shape, not by how it lies in the file.
fn oriented(d: DVec3, tris: &[[DVec3; 3]]) -> DVec3 {
    let m: f64 = tris
        .iter()
        .map(|t| {
            let a = 0.5 * (t[1] - t[0]).cross(t[2] - t[0]).length();
            let c = ((t[0] + t[1] + t[2]) / 3.0).dot(d);
            if a.is_finite() && c.is_finite() {
                a * c * c * c
            } else {
                0.0
            }
        })
        .sum();
    if m < 0.0 {
        -d
    } else {
        d
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DQuat;

    fn boxes() -> Vec<[DVec3; 3]> {
        // A floor 10 x 6 and two walls, one longer.
        let q = |a: DVec3, b: DVec3, c: DVec3, d: DVec3| vec![[a, b, c], [a, c, d]];
        let mut t = q(
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(0.0, 0.0, 6.0),
            DVec3::new(10.0, 0.0, 6.0),
            DVec3::new(10.0, 0.0, 0.0),
        );
        t.extend(q(
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(10.0, 0.0, 0.0),
            DVec3::new(10.0, 3.0, 0.0),
            DVec3::new(0.0, 3.0, 0.0),
        ));
        t.extend(q(
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(0.0, 3.0, 0.0),
            DVec3::new(0.0, 3.0, 6.0),
            DVec3::new(0.0, 0.0, 6.0),
        ));
        t
    }

    #[test]
    fn the_frame_turns_with_the_level() {
        let t = boxes();
        let f = Frame::of(&t);
        assert!(f.axes[0].dot(DVec3::Y).abs() > 0.999, "{:?}", f.axes);
        let rot = DQuat::from_axis_angle(DVec3::new(1.0, 2.0, 3.0).normalize(), 0.65);
        let turned: Vec<[DVec3; 3]> = t.iter().map(|t| t.map(|p| rot * p)).collect();
        let g = Frame::of(&turned);
        for k in 0..3 {
            assert!(
                (rot * f.axes[k] - g.axes[k]).length() < 1e-9,
                "{k}: {:?} {:?}",
                f.axes,
                g.axes
            );
        }
    }
}
