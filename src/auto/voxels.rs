//! The voxel grid in the level's frame and the surface on it: every voxel a triangle touches
//! (a separating-axis test, with a margin so a triangle on a voxel face marks both sides).
//! A gap narrower than a voxel is never open through surface voxels, so the voxel is the
//! crack width of the air search.

use glam::DVec3;
use rayon::prelude::*;

use super::frame::Frame;

/// A box of voxels in the level's frame.
#[derive(Debug, Clone, Default)]
pub struct Grid {
    /// The level's frame.
    pub frame: Frame,
    /// The world point frame coordinates are measured from.
    pub centre: DVec3,
    /// Frame coordinates of the least corner of voxel (0, 0, 0).
    pub origin: DVec3,
    /// Edge of a voxel (m).
    pub h: f64,
    /// Voxels along each frame axis.
    pub dims: [usize; 3],
}

impl Grid {
    /// A grid of voxels of edge `h` over the frame box `lo..hi`, one voxel of air beyond it
    /// on every side, centred on the box (so an axis whose sign flips maps it onto itself).
    pub fn around(frame: Frame, centre: DVec3, lo: DVec3, hi: DVec3, h: f64) -> Grid {
        let mid = (lo + hi) * 0.5;
        let dims = ((hi - lo) / h)
            .to_array()
            .map(|s| s.ceil().max(1.0) as usize + 2);
        let size = DVec3::new(dims[0] as f64, dims[1] as f64, dims[2] as f64) * h;
        Grid {
            frame,
            centre,
            origin: mid - size * 0.5,
            h,
            dims,
        }
    }

    /// How many voxels.
    pub fn len(&self) -> usize {
        self.dims[0] * self.dims[1] * self.dims[2]
    }

    /// The index of voxel `(x, y, z)`.
    pub fn index(&self, v: [usize; 3]) -> usize {
        v[0] + self.dims[0] * (v[1] + self.dims[1] * v[2])
    }

    /// The voxel of an index.
    pub fn coords(&self, i: usize) -> [usize; 3] {
        let (a, b) = (self.dims[0], self.dims[0] * self.dims[1]);
        [i % a, (i / a) % self.dims[1], i / b]
    }

    /// The six face neighbours of a voxel inside the grid, as (index, axis, sign).
    pub fn neighbours(&self, i: usize) -> impl Iterator<Item = (usize, usize, i64)> + '_ {
        let v = self.coords(i);
        let strides = [1, self.dims[0], self.dims[0] * self.dims[1]];
        (0..6).filter_map(move |k| {
            let (axis, up) = (k / 2, k % 2 == 1);
            if up && v[axis] + 1 < self.dims[axis] {
                Some((i + strides[axis], axis, 1))
            } else if !up && v[axis] > 0 {
                Some((i - strides[axis], axis, -1))
            } else {
                None
            }
        })
    }

    /// Frame coordinates of a world point, in voxel units from the grid's corner.
    pub fn to_grid(&self, p: DVec3) -> DVec3 {
        (self.frame.to_frame(p - self.centre) - self.origin) / self.h
    }
}

/// Marks the voxels `tris` (world) touch; `pad`: the margin in voxel units.
pub fn surface(grid: &Grid, tris: &[[DVec3; 3]], pad: f64) -> Vec<bool> {
    let hits: Vec<Vec<u32>> = tris
        .par_chunks(1024)
        .map(|chunk| {
            let mut out = Vec::new();
            for t in chunk {
                let g = t.map(|p| grid.to_grid(p));
                if g.iter().all(|p| p.is_finite()) {
                    touched(grid, &g, pad, &mut out);
                }
            }
            out
        })
        .collect();
    let mut mark = vec![false; grid.len()];
    for i in hits.into_iter().flatten() {
        mark[i as usize] = true;
    }
    mark
}

/// Pushes every voxel the triangle `g` (grid units) touches.
pub(super) fn touched(grid: &Grid, g: &[DVec3; 3], pad: f64, out: &mut Vec<u32>) {
    let lo = g[0].min(g[1]).min(g[2]) - pad;
    let hi = g[0].max(g[1]).max(g[2]) + pad;
    let clamp = |v: f64, k: usize| (v.floor().max(0.0) as usize).min(grid.dims[k] - 1);
    let (a, b) = (
        [clamp(lo.x, 0), clamp(lo.y, 1), clamp(lo.z, 2)],
        [clamp(hi.x, 0), clamp(hi.y, 1), clamp(hi.z, 2)],
    );
    for z in a[2]..=b[2] {
        for y in a[1]..=b[1] {
            for x in a[0]..=b[0] {
                let c = DVec3::new(x as f64, y as f64, z as f64) + 0.5;
                if overlaps([g[0] - c, g[1] - c, g[2] - c], 0.5 + pad) {
                    out.push(grid.index([x, y, z]) as u32);
                }
            }
        }
    }
}

/// Whether a triangle (relative to a cube's centre) meets the cube of half-edge `r`: the
/// separating-axis test of Akenine-Möller (the box's axes, the triangle's normal, and the
/// nine edge cross products).
fn overlaps(v: [DVec3; 3], r: f64) -> bool {
    let e = [v[1] - v[0], v[2] - v[1], v[0] - v[2]];
    for ax in [DVec3::X, DVec3::Y, DVec3::Z] {
        for ed in e {
            let a = ax.cross(ed);
            if a.length_squared() < 1e-24 {
                continue;
            }
            let p = v.map(|q| q.dot(a));
            let rad = r * (a.x.abs() + a.y.abs() + a.z.abs());
            if p[0].min(p[1]).min(p[2]) > rad || p[0].max(p[1]).max(p[2]) < -rad {
                return false;
            }
        }
    }
    let (lo, hi) = (v[0].min(v[1]).min(v[2]), v[0].max(v[1]).max(v[2]));
    if lo.max_element() > r || hi.min_element() < -r {
        return false;
    }
    let n = e[0].cross(e[1]);
    let d = n.dot(v[0]);
    let rad = r * (n.x.abs() + n.y.abs() + n.z.abs());
    d.abs() <= rad
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_triangle_marks_the_voxels_it_crosses_and_one_on_a_face_marks_both_sides() {
        let f = Frame {
            axes: [DVec3::X, DVec3::Y, DVec3::Z],
        };
        let g = Grid::around(f, DVec3::ZERO, DVec3::splat(-2.0), DVec3::splat(2.0), 1.0);
        assert_eq!(g.dims, [6, 6, 6]);
        // A floor exactly on the plane between two layers of voxels (y = 0).
        let t = [
            DVec3::new(-2.0, 0.0, -2.0),
            DVec3::new(2.0, 0.0, -2.0),
            DVec3::new(-2.0, 0.0, 2.0),
        ];
        let m = surface(&g, &[t], 1e-6);
        let marked: Vec<[usize; 3]> = (0..g.len())
            .filter(|&i| m[i])
            .map(|i| g.coords(i))
            .collect();
        assert!(marked.iter().all(|v| v[1] == 2 || v[1] == 3), "{marked:?}");
        let layer = |y: usize| marked.iter().filter(|v| v[1] == y).count();
        assert!(layer(2) >= 10 && layer(2) == layer(3), "{marked:?}");
        assert!(!overlaps(
            [
                DVec3::new(2.0, 2.0, 2.0),
                DVec3::new(3.0, 2.0, 2.0),
                DVec3::new(2.0, 3.0, 2.0)
            ],
            0.5
        ));
    }
}
