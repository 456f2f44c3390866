//! The air split into rooms at its constrictions: a distance field (how far each air voxel is
//! from anything not air), then a watershed from its peaks down. Two basins meet at a saddle;
//! they stay apart, as two rooms, when the saddle is narrower than `ratio` of the lower
//! peak (a door in a wall, a window, a corridor's mouth into a hall) and join otherwise (a
//! pocket under a table, an alcove, the two ends of one corridor). Ties are broken by voxel
//! index, so the rooms do not depend on the order of the input.

use crate::disjoint::DisjointSets;

use super::voxels::Grid;

/// The depth of a basin that reaches the grid's border.
const OUTDOORS: u16 = u16::MAX;

/// Whether a voxel lies on the grid's outer layer.
fn on_border(grid: &Grid, i: usize) -> bool {
    let v = grid.coords(i);
    (0..3).any(|k| v[k] == 0 || v[k] + 1 == grid.dims[k])
}

/// Chamfer weights (3-4-5): face, edge and corner steps, about 3 times the voxel distance.
const STEPS: [u16; 3] = [3, 4, 5];

/// The distance (chamfer units, 3 per voxel) from each air voxel to the nearest voxel that is
/// not air; 0 off the air.
pub fn distance(grid: &Grid, air: &[bool]) -> Vec<u16> {
    let mut d: Vec<u16> = air.iter().map(|&a| if a { u16::MAX } else { 0 }).collect();
    let [nx, ny, nz] = grid.dims.map(|n| n as i64);
    // The 13 neighbours before a voxel in index order, with their weights.
    let mut back: Vec<(i64, i64, i64, u16)> = Vec::new();
    for dz in -1..=1i64 {
        for dy in -1..=1i64 {
            for dx in -1..=1i64 {
                let before = (dz, dy, dx) < (0, 0, 0);
                if before {
                    let w = STEPS[(dx.abs() + dy.abs() + dz.abs()) as usize - 1];
                    back.push((dx, dy, dz, w));
                }
            }
        }
    }
    let idx = |x: i64, y: i64, z: i64| (x + nx * (y + ny * z)) as usize;
    let mut pass = |order: &mut dyn Iterator<Item = (i64, i64, i64)>, sign: i64| {
        for (x, y, z) in order {
            let i = idx(x, y, z);
            if d[i] == 0 {
                continue;
            }
            let mut best = d[i];
            for &(dx, dy, dz, w) in &back {
                let (a, b, c) = (x + sign * dx, y + sign * dy, z + sign * dz);
                if a < 0 || b < 0 || c < 0 || a >= nx || b >= ny || c >= nz {
                    // Beyond the grid lies nothing: open air goes on.
                    continue;
                }
                best = best.min(d[idx(a, b, c)].saturating_add(w));
            }
            d[i] = best;
        }
    };
    let fwd = (0..nz).flat_map(|z| (0..ny).flat_map(move |y| (0..nx).map(move |x| (x, y, z))));
    pass(&mut fwd.into_iter(), 1);
    let rev = (0..nz).rev().flat_map(|z| {
        (0..ny)
            .rev()
            .flat_map(move |y| (0..nx).rev().map(move |x| (x, y, z)))
    });
    pass(&mut rev.into_iter(), -1);
    d
}

/// Labels each air voxel with its room (0..n, numbered in the order of their first voxel;
/// `u32::MAX` off the air) and returns the number of rooms.
pub fn watershed(grid: &Grid, dist: &[u16], ratio: f64) -> (Vec<u32>, usize) {
    // Highest first, ties by index: a bucket per distance.
    let top = dist.iter().copied().max().unwrap_or(0) as usize;
    let mut buckets: Vec<Vec<u32>> = vec![Vec::new(); top + 1];
    for (i, &d) in dist.iter().enumerate() {
        if d > 0 {
            buckets[d as usize].push(i as u32);
        }
    }
    let mut basin = vec![u32::MAX; dist.len()];
    let mut peak: Vec<u16> = Vec::new();
    let mut sets = DisjointSets::new(0);
    let mut roots: Vec<usize> = Vec::new();
    for d in (1..=top).rev() {
        for &i in &buckets[d] {
            let i = i as usize;
            roots.clear();
            // The voxel joins the basin of its deepest neighbour (steepest ascent, ties by
            // index): along a floor of equal depth a basin does not spread by voxel order
            // into the room beside its door.
            let mut steepest: Option<(u16, usize)> = None;
            for (j, _, _) in grid.neighbours(i) {
                if basin[j] != u32::MAX {
                    let r = sets.find(basin[j] as usize);
                    if !roots.contains(&r) {
                        roots.push(r);
                    }
                    if steepest.is_none_or(|(sd, sj)| dist[j] > sd || (dist[j] == sd && j < sj)) {
                        steepest = Some((dist[j], j));
                    }
                }
            }
            // Air reaching the grid's border goes on without end: the outdoors, as deep as
            // any room, so a window is judged by the room's depth alone.
            let depth = if on_border(grid, i) {
                OUTDOORS
            } else {
                d as u16
            };
            let Some((_, up)) = steepest else {
                basin[i] = peak.len() as u32;
                peak.push(depth);
                sets.push();
                continue;
            };
            let first = sets.find(basin[up] as usize);
            basin[i] = first as u32;
            peak[first] = peak[first].max(depth);
            for &r in roots.iter().filter(|&&r| r != first) {
                let low = peak[first].min(peak[r]) as f64;
                let both_outdoors = peak[first] == OUTDOORS && peak[r] == OUTDOORS;
                if both_outdoors || d as f64 >= ratio * low {
                    let top = peak[first].max(peak[r]);
                    sets.union(first, r);
                    let root = sets.find(first);
                    peak[root] = top;
                }
            }
        }
    }
    // Rooms numbered in the order of their first voxel.
    let mut number = vec![u32::MAX; peak.len()];
    let mut rooms = 0u32;
    let mut out = vec![u32::MAX; dist.len()];
    for i in 0..dist.len() {
        if basin[i] == u32::MAX {
            continue;
        }
        let r = sets.find(basin[i] as usize);
        if number[r] == u32::MAX {
            number[r] = rooms;
            rooms += 1;
        }
        out[i] = number[r];
    }
    (out, rooms as usize)
}
