//! Boxes grown out to the walls. A box of air voxels stops up to a voxel short of the surface
//! it faces, and that gap narrows every opening by up to a voxel on each side: a ray past a
//! door's jamb could see through a portal smaller than the door. So each face of each box,
//! in a fixed order, moves out into the layer of surface voxels beyond it until it meets the
//! first triangle there (a wall square to the axis is met over the whole face: the face then
//! lies on the wall). A voxel is grown into by one face at most, so cells never overlap, and
//! a grown box holds no triangle, so no cell reaches through a wall.

use glam::DVec3;

use super::boxes::VoxelBox;
use super::voxels::{touched, Grid};

/// A box in voxel units (from the grid's corner): least and greatest corner.
pub type GridBox = [DVec3; 2];

/// The boxes of every room grown to the walls (`g`: the triangles in voxel units).
pub fn grow(
    grid: &Grid,
    surface: &[bool],
    g: &[[DVec3; 3]],
    rooms: &[Vec<VoxelBox>],
) -> Vec<Vec<GridBox>> {
    let index = TriangleIndex::new(grid, g);
    let mut owner = vec![u32::MAX; grid.len()];
    let mut next = 0u32;
    let mut scratch = Vec::new();
    rooms
        .iter()
        .map(|boxes| {
            boxes
                .iter()
                .map(|&(lo, hi)| {
                    let id = next;
                    next += 1;
                    let to = |v: [usize; 3]| DVec3::new(v[0] as f64, v[1] as f64, v[2] as f64);
                    let mut b = [to(lo), to(hi)];
                    for axis in 0..3 {
                        for up in [false, true] {
                            let cx = Face { axis, up, id };
                            grow_face(
                                grid,
                                surface,
                                g,
                                &index,
                                &mut owner,
                                &cx,
                                &mut b,
                                &mut scratch,
                            );
                        }
                    }
                    b
                })
                .collect()
        })
        .collect()
}

/// Which face of which box grows.
struct Face {
    axis: usize,
    up: bool,
    id: u32,
}

/// Moves one face of `b` out to the first triangle in the layer of voxels beyond it, if the
/// whole layer is surface no other box has grown into.
#[allow(clippy::too_many_arguments)]
fn grow_face(
    grid: &Grid,
    surface: &[bool],
    g: &[[DVec3; 3]],
    index: &TriangleIndex,
    owner: &mut [u32],
    f: &Face,
    b: &mut GridBox,
    tris: &mut Vec<u32>,
) {
    let (a, p, q) = (f.axis, (f.axis + 1) % 3, (f.axis + 2) % 3);
    let layer = if f.up { b[1][a] } else { b[0][a] - 1.0 };
    if layer < 0.0 || layer + 1.0 > grid.dims[a] as f64 || layer.fract() != 0.0 {
        return;
    }
    let span = |k: usize| {
        (
            b[0][k].floor() as usize,
            (b[1][k].ceil() as usize).min(grid.dims[k]),
        )
    };
    let ((p0, p1), (q0, q1)) = (span(p), span(q));
    let mut cells = Vec::with_capacity((p1 - p0) * (q1 - q0));
    for y in q0..q1 {
        for x in p0..p1 {
            let mut v = [0usize; 3];
            (v[a], v[p], v[q]) = (layer as usize, x, y);
            let i = grid.index(v);
            if !surface[i] || (owner[i] != u32::MAX && owner[i] != f.id) {
                return;
            }
            cells.push(i);
        }
    }
    tris.clear();
    for &i in &cells {
        tris.extend_from_slice(index.at(i));
    }
    tris.sort_unstable();
    tris.dedup();
    // The prism the face sweeps through the layer, a hair inside its sides so a floor
    // under a wall's face does not stop it.
    let hair = 1e-7;
    let mut lo = b[0];
    let mut hi = b[1];
    lo[p] += hair;
    hi[p] -= hair;
    lo[q] += hair;
    hi[q] -= hair;
    (lo[a], hi[a]) = (layer, layer + 1.0);
    let mut reach: f64 = 1.0;
    for &t in tris.iter() {
        if let Some((near, far)) = extent_in(&g[t as usize], lo, hi, a) {
            let d = if f.up {
                near - layer
            } else {
                layer + 1.0 - far
            };
            reach = reach.min(d.max(0.0));
        }
    }
    if reach <= 0.0 {
        return;
    }
    for &i in &cells {
        owner[i] = f.id;
    }
    if f.up {
        b[1][a] += reach;
    } else {
        b[0][a] -= reach;
    }
}

/// The least and greatest coordinate along `axis` of the part of triangle `t` inside the box
/// `lo..hi`, if any.
fn extent_in(t: &[DVec3; 3], lo: DVec3, hi: DVec3, axis: usize) -> Option<(f64, f64)> {
    let mut poly: Vec<DVec3> = t.to_vec();
    for k in 0..3 {
        for (n, d) in [(-1.0, -lo[k]), (1.0, hi[k])] {
            let mut normal = DVec3::ZERO;
            normal[k] = n;
            poly = crate::geom::polyhedron::clip_polygon(&poly, normal, d);
            if poly.len() < 3 {
                return None;
            }
        }
    }
    let near = poly.iter().map(|p| p[axis]).fold(f64::INFINITY, f64::min);
    let far = poly
        .iter()
        .map(|p| p[axis])
        .fold(f64::NEG_INFINITY, f64::max);
    Some((near, far))
}

/// The triangles touching each voxel (indices, in a flat list per voxel).
struct TriangleIndex {
    start: Vec<u32>,
    tris: Vec<u32>,
}

impl TriangleIndex {
    fn new(grid: &Grid, g: &[[DVec3; 3]]) -> TriangleIndex {
        let mut pairs: Vec<(u32, u32)> = Vec::new();
        let mut out = Vec::new();
        for (k, t) in g.iter().enumerate() {
            if !t.iter().all(|p| p.is_finite()) {
                continue;
            }
            out.clear();
            touched(grid, t, 1e-6, &mut out);
            pairs.extend(out.iter().map(|&v| (v, k as u32)));
        }
        pairs.sort_unstable();
        let mut start = vec![0u32; grid.len() + 1];
        for &(v, _) in &pairs {
            start[v as usize + 1] += 1;
        }
        for i in 0..grid.len() {
            start[i + 1] += start[i];
        }
        TriangleIndex {
            start,
            tris: pairs.into_iter().map(|(_, t)| t).collect(),
        }
    }

    fn at(&self, voxel: usize) -> &[u32] {
        &self.tris[self.start[voxel] as usize..self.start[voxel + 1] as usize]
    }
}
