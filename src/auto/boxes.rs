//! A room's voxels as few boxes: from each voxel not yet taken (in index order), the longest
//! run along the first axis, grown along the second while every run beside it is the room's
//! and free, then along the third while every layer is. Each box is a convex cell.

use super::voxels::Grid;

/// A box of voxels: least and one-past-greatest voxel coordinates.
pub type VoxelBox = ([usize; 3], [usize; 3]);

/// The boxes of every room (`label`: room per voxel, `u32::MAX` for none), per room.
pub fn boxes(grid: &Grid, label: &[u32], rooms: usize) -> Vec<Vec<VoxelBox>> {
    let mut taken = vec![false; label.len()];
    let mut out = vec![Vec::new(); rooms];
    let [nx, ny, nz] = grid.dims;
    for start in 0..label.len() {
        let room = label[start];
        if room == u32::MAX || taken[start] {
            continue;
        }
        let free = |v: [usize; 3], taken: &[bool]| {
            let i = grid.index(v);
            label[i] == room && !taken[i]
        };
        let lo = grid.coords(start);
        let mut hi = [lo[0] + 1, lo[1] + 1, lo[2] + 1];
        while hi[0] < nx && free([hi[0], lo[1], lo[2]], &taken) {
            hi[0] += 1;
        }
        while hi[1] < ny && (lo[0]..hi[0]).all(|x| free([x, hi[1], lo[2]], &taken)) {
            hi[1] += 1;
        }
        while hi[2] < nz
            && (lo[1]..hi[1]).all(|y| (lo[0]..hi[0]).all(|x| free([x, y, hi[2]], &taken)))
        {
            hi[2] += 1;
        }
        for z in lo[2]..hi[2] {
            for y in lo[1]..hi[1] {
                for x in lo[0]..hi[0] {
                    taken[grid.index([x, y, z])] = true;
                }
            }
        }
        out[room as usize].push((lo, hi));
    }
    out
}
