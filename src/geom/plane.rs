//! Planes `n · p = d` with unit normal `n`.

use glam::DVec3;
use serde::Serialize;

/// A plane `normal · p = d`; the positive side is the one `normal` points to.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Plane {
    /// Unit length.
    pub normal: DVec3,
    /// Signed distance of the plane from the origin along `normal` (m).
    pub d: f64,
}

impl Plane {
    /// The plane through `p` with normal `n` (normalised here); `None` for a zero normal.
    pub fn from_point_normal(p: DVec3, n: DVec3) -> Option<Plane> {
        let n = n.try_normalize()?;
        Some(Plane {
            normal: n,
            d: n.dot(p),
        })
    }

    /// The plane of a polygon by Newell's method (robust for non-planar or nearly collinear
    /// input), facing the side from which the polygon is counter-clockwise.
    pub(crate) fn from_polygon(pts: &[DVec3]) -> Option<Plane> {
        if pts.len() < 3 {
            return None;
        }
        let c = pts.iter().copied().sum::<DVec3>() / pts.len() as f64;
        let mut n = DVec3::ZERO;
        for (i, a) in pts.iter().enumerate() {
            let b = pts[(i + 1) % pts.len()];
            let (a, b) = (*a - c, b - c);
            n += a.cross(b);
        }
        Plane::from_point_normal(c, n)
    }

    /// Positive in front (the side the normal points to), negative behind.
    pub fn distance(&self, p: DVec3) -> f64 {
        self.normal.dot(p) - self.d
    }

    /// The same plane facing the other way.
    pub(crate) fn flipped(&self) -> Plane {
        Plane {
            normal: -self.normal,
            d: -self.d,
        }
    }

    /// The plane moved by `t`.
    pub(crate) fn translated(&self, t: DVec3) -> Plane {
        Plane {
            normal: self.normal,
            d: self.d + self.normal.dot(t),
        }
    }

    /// Same plane and orientation: normals within `angle` radians, offsets within `dist`.
    /// (The chord between unit normals is compared, not the dot product, whose rounding near
    /// 1 would make tiny angles meaningless.) The geometry reaches it through the tolerance's
    /// rules, [`crate::geom::tolerance::Tolerance::coplanar`] and its kin.
    pub(crate) fn same_as(&self, o: &Plane, dist: f64, angle: f64) -> bool {
        (self.normal - o.normal).length_squared() <= angle * angle && (self.d - o.d).abs() <= dist
    }

    /// The reflection in this plane, as an affine transform (mirrors).
    pub(crate) fn reflection(&self) -> glam::DMat4 {
        let n = self.normal;
        let m = glam::DMat3::IDENTITY - 2.0 * glam::DMat3::from_cols(n * n.x, n * n.y, n * n.z);
        let mut out = glam::DMat4::from_mat3(m);
        out.w_axis = (n * (2.0 * self.d)).extend(1.0);
        out
    }

    /// Two unit vectors spanning the plane, with `u × v = normal`.
    pub(crate) fn basis(&self) -> (DVec3, DVec3) {
        let n = self.normal;
        let helper = if n.x.abs() < 0.6 {
            DVec3::X
        } else if n.y.abs() < 0.6 {
            DVec3::Y
        } else {
            DVec3::Z
        };
        let u = helper.cross(n).normalize();
        let v = n.cross(u);
        (u, v)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn polygon_plane_faces_its_ccw_side() {
        let q = [
            DVec3::new(0., 0., 0.),
            DVec3::new(1., 0., 0.),
            DVec3::new(1., 1., 0.),
            DVec3::new(0., 1., 0.),
        ];
        let p = Plane::from_polygon(&q).unwrap();
        assert!((p.normal - DVec3::Z).length() < 1e-12);
        assert!(p.distance(DVec3::new(0., 0., 2.)) > 0.0);
        let (u, v) = p.basis();
        assert!((u.cross(v) - p.normal).length() < 1e-12);
    }
}
