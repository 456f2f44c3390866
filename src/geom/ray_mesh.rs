//! One BVH of triangles for ray casts (parry's `TriMesh`), built the one way: triangles with a
//! non-finite corner are left out, and a build parry refuses (or panics on) gives no mesh
//! instead of taking the run down.

use glam::DVec3;
use parry3d_f64::shape::TriMesh;

/// The mesh of `tris`, or `None` when there is nothing to hit.
pub(crate) fn ray_mesh(tris: &[[DVec3; 3]]) -> Option<TriMesh> {
    let verts: Vec<DVec3> = tris
        .iter()
        .filter(|t| t.iter().all(|p| p.is_finite()))
        .flatten()
        .copied()
        .collect();
    if verts.is_empty() {
        return None;
    }
    let idx: Vec<[u32; 3]> = (0..(verts.len() / 3) as u32)
        .map(|i| [3 * i, 3 * i + 1, 3 * i + 2])
        .collect();
    std::panic::catch_unwind(move || TriMesh::new(verts, idx).ok())
        .ok()
        .flatten()
}

#[cfg(test)]
mod tests {
    use super::*;
    use parry3d_f64::query::{Ray, RayCast};

    #[test]
    fn a_non_finite_triangle_is_left_out_and_the_rest_is_hit() {
        let floor = [DVec3::ZERO, DVec3::X, DVec3::Z];
        let bad = [DVec3::splat(f64::NAN), DVec3::X, DVec3::Y];
        let mesh = ray_mesh(&[bad, floor]).unwrap();
        let ray = Ray::new(DVec3::new(0.2, 1.0, 0.2), -DVec3::Y);
        assert_eq!(mesh.cast_local_ray(&ray, 10.0, false), Some(1.0));
        assert!(ray_mesh(&[bad]).is_none());
        assert!(ray_mesh(&[]).is_none());
    }
}
