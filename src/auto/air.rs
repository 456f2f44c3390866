//! Where a camera can stand. From the middle of every voxel no surface touches, a ray along
//! each of the six axis directions meets a first triangle, from the front or from behind, or
//! nothing. Walls, floors and one-sided surfaces face the air they bound; a closed mesh
//! faces away from its inside, and a level's outer walls away from the void around it. So a
//! voxel is air when more of its six first hits are fronts than backs, and at least two are:
//! the inside of a room, a courtyard, the ground beside a house; never the inside of a
//! pillar, nor the void behind a level's outer walls, nor open sky with only the ground below
//! it. What is not air is the outside: the portal stage gives the faces that border it
//! openings to the exterior, and the PVS joins those through the outside. A level that is open
//! to the void somewhere (a sky left out, a missing wall) is judged voxel by voxel all the
//! same, which a flood from the outside could not do.
//!
//! The rays are cast along the grid's lines, all at once per axis: each triangle is
//! projected onto the lines it covers, and each line's hits are sorted once.

use glam::DVec3;
use rayon::prelude::*;

use super::voxels::Grid;

/// Pieces of air smaller than this many voxels are dropped: a pocket in a wall's cavity, too
/// small to stand in.
const SMALLEST: usize = 27;

/// The air voxels (`surface`: the voxels a triangle touches; `tris`: world).
pub fn find(grid: &Grid, surface: &[bool], tris: &[[DVec3; 3]]) -> Vec<bool> {
    let g: Vec<[DVec3; 3]> = tris.iter().map(|t| t.map(|p| grid.to_grid(p))).collect();
    let mut front = vec![0u8; grid.len()];
    let mut back = vec![0u8; grid.len()];
    for axis in 0..3 {
        sweep(grid, &g, axis, &mut front, &mut back);
    }
    let mut air: Vec<bool> = (0..grid.len())
        .map(|i| !surface[i] && by_first_hits(front[i].into(), back[i].into()))
        .collect();
    drop_small(grid, &mut air);
    air
}

/// The rule air is judged by, from the first surfaces met along the six axis directions: more
/// fronts than backs, and at least two fronts. The cells stage asks it of BSP leaves too
/// (`cells::interior`), so the voxels and the cells agree on what air is.
pub fn by_first_hits(front: usize, back: usize) -> bool {
    front > back && front >= 2
}

/// Counts, for every voxel, the fronts and backs first met along `axis` both ways.
fn sweep(grid: &Grid, g: &[[DVec3; 3]], axis: usize, front: &mut [u8], back: &mut [u8]) {
    let (b, c) = ((axis + 1) % 3, (axis + 2) % 3);
    let (nb, nc) = (grid.dims[b], grid.dims[c]);
    // (line, where along the axis, whether a ray going up the axis meets its front)
    let hits: Vec<Vec<(u32, f64, bool)>> = g
        .par_chunks(1024)
        .map(|chunk| {
            let mut out = Vec::new();
            for t in chunk {
                crossings(t, axis, (b, c), (nb, nc), &mut out);
            }
            out
        })
        .collect();
    let mut lines: Vec<Vec<(f64, bool)>> = vec![Vec::new(); nb * nc];
    for (line, at, up) in hits.into_iter().flatten() {
        lines[line as usize].push((at, up));
    }
    let na = grid.dims[axis];
    for (line, hits) in lines.iter_mut().enumerate() {
        sort_hits(hits);
        let (j, k) = (line % nb, line / nb);
        let mut next = 0;
        for i in 0..na {
            let x = i as f64 + 0.5;
            while next < hits.len() && hits[next].0 <= x {
                next += 1;
            }
            let mut v = [0usize; 3];
            (v[axis], v[b], v[c]) = (i, j, k);
            let at = grid.index(v);
            // Going up the axis: the next hit; going down: the one before.
            let seen = [
                hits.get(next).map(|h| h.1),
                next.checked_sub(1).map(|p| !hits[p].1),
            ];
            for s in seen.into_iter().flatten() {
                if s {
                    front[at] += 1;
                } else {
                    back[at] += 1;
                }
            }
        }
    }
}

/// Hits this close along a line (voxels) are one place: a two-sided wall's two faces.
const SAME_PLACE: f64 = 1e-6;

/// Sorts a line's hits along it. Hits at one place (within [`SAME_PLACE`] of the first of
/// them) are ordered fronts first: each way along the line, the face turned towards the ray
/// is the one it meets, whichever of the two the rounding of a turned level puts a hair
/// nearer (a two-sided wall of merged MAP01 made 30 voxels air only when turned).
fn sort_hits(hits: &mut [(f64, bool)]) {
    hits.sort_by(|x, y| x.0.total_cmp(&y.0));
    let mut i = 0;
    while i < hits.len() {
        let start = hits[i].0;
        let mut j = i + 1;
        while j < hits.len() && hits[j].0 - start <= SAME_PLACE {
            j += 1;
        }
        // Going up the axis the first of a place is met, going down the last: fronts for
        // the way up (`true`) first, fronts for the way down (`false`) last.
        hits[i..j].sort_by_key(|h| !h.1);
        i = j;
    }
}

/// Where triangle `t` (grid units) crosses the lines along `axis` through voxel middles.
fn crossings(
    t: &[DVec3; 3],
    axis: usize,
    (b, c): (usize, usize),
    (nb, nc): (usize, usize),
    out: &mut Vec<(u32, f64, bool)>,
) {
    let n = (t[1] - t[0]).cross(t[2] - t[0]);
    if !n.is_finite() || n[axis].abs() < 1e-12 * n.length() || n[axis] == 0.0 {
        return;
    }
    let p = t.map(|q| (q[b], q[c]));
    let lo = |n: usize, f: fn(&(f64, f64)) -> f64| {
        let m = p.iter().map(f).fold(f64::INFINITY, f64::min);
        ((m - 0.5).ceil().max(0.0) as usize).min(n)
    };
    let hi = |n: usize, f: fn(&(f64, f64)) -> f64| {
        let m = p.iter().map(f).fold(f64::NEG_INFINITY, f64::max);
        if m < 0.5 {
            return 0;
        }
        (((m - 0.5).floor() as usize) + 1).min(n)
    };
    let (j0, j1) = (lo(nb, |q| q.0), hi(nb, |q| q.0));
    let (k0, k1) = (lo(nc, |q| q.1), hi(nc, |q| q.1));
    let area = (p[1].0 - p[0].0) * (p[2].1 - p[0].1) - (p[2].0 - p[0].0) * (p[1].1 - p[0].1);
    let tol = 1e-9 * area.abs().max(1e-30);
    let up = n[axis] < 0.0;
    for k in k0..k1 {
        for j in j0..j1 {
            let (x, y) = (j as f64 + 0.5, k as f64 + 0.5);
            let edge =
                |a: (f64, f64), e: (f64, f64)| (e.0 - a.0) * (y - a.1) - (e.1 - a.1) * (x - a.0);
            let w = [edge(p[1], p[2]), edge(p[2], p[0]), edge(p[0], p[1])];
            // Inclusive of the edges: a line through a shared edge meets both triangles,
            // which face the same way, rather than slipping between them.
            let inside = w.iter().all(|&e| e * area.signum() >= -tol);
            if !inside {
                continue;
            }
            let at = t[0][axis] - (n[b] * (x - t[0][b]) + n[c] * (y - t[0][c])) / n[axis];
            out.push(((j + nb * k) as u32, at, up));
        }
    }
}

/// Clears the pieces of air (6-connected) smaller than [`SMALLEST`].
fn drop_small(grid: &Grid, air: &mut [bool]) {
    let mut seen = vec![false; grid.len()];
    let mut piece = Vec::new();
    for s in 0..grid.len() {
        if !air[s] || seen[s] {
            continue;
        }
        piece.clear();
        piece.push(s);
        seen[s] = true;
        let mut k = 0;
        while k < piece.len() {
            let i = piece[k];
            k += 1;
            for (j, _, _) in grid.neighbours(i) {
                if air[j] && !seen[j] {
                    seen[j] = true;
                    piece.push(j);
                }
            }
        }
        if piece.len() < SMALLEST {
            piece.iter().for_each(|&i| air[i] = false);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A two-sided wall: two faces at one place, rounding putting either a hair nearer.
    #[test]
    fn a_two_sided_wall_shows_its_front_both_ways() {
        for d in [-1e-9, 0.0, 1e-9] {
            for (a, b) in [(true, false), (false, true)] {
                let mut hits = vec![(7.5, true), (3.0, a), (3.0 + d, b), (1.0, false)];
                sort_hits(&mut hits);
                let at: Vec<f64> = hits.iter().map(|h| h.0).collect();
                assert!(at.windows(2).all(|w| w[0] <= w[1] + SAME_PLACE), "{hits:?}");
                // From below (going up) the first of the place is met: the front for rays
                // going up; from above (going down) the last: the front for rays going down.
                assert!(hits[1].1, "going up meets the front ({d}, {hits:?})");
                assert!(!hits[2].1, "going down meets the front ({d}, {hits:?})");
            }
        }
        // Hits further apart than the place keep their order along the line.
        let mut hits = vec![(3.0 + 1e-3, true), (3.0, false)];
        sort_hits(&mut hits);
        assert_eq!(hits, vec![(3.0, false), (3.0 + 1e-3, true)]);
    }
}
