//! Which cell holds a point, and which cells a box touches: a uniform grid over the cells'
//! bounds, each bucket listing the cells whose bounds reach into it.

use glam::DVec3;

use super::{clip, Level};

/// Where a point lies.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Location {
    /// More than the tolerance inside the cell.
    Inside(usize),
    /// Within the tolerance of the cell's boundary (a wall, or a portal into another cell).
    Boundary(usize),
    /// In no cell; `nearest` is the cell closest to the point.
    Outside {
        /// The closest cell (`None` only for a level without cells).
        nearest: Option<usize>,
    },
}

impl Default for Location {
    fn default() -> Location {
        Location::Outside { nearest: None }
    }
}

impl Location {
    /// The cell, inside or on its boundary.
    pub fn cell(&self) -> Option<usize> {
        match *self {
            Location::Inside(c) | Location::Boundary(c) => Some(c),
            Location::Outside { .. } => None,
        }
    }

    /// `inside`, `boundary` or `outside`, as `portcullis cull` prints it.
    pub fn name(&self) -> &'static str {
        match self {
            Location::Inside(_) => "inside",
            Location::Boundary(_) => "boundary",
            Location::Outside { .. } => "outside",
        }
    }
}

#[derive(Default)]
pub(super) struct Grid {
    min: DVec3,
    size: DVec3,
    dims: [usize; 3],
    start: Vec<u32>,
    items: Vec<u32>,
}

impl Grid {
    /// About one bucket per cell, shaped like the level's bounds.
    pub(super) fn build(level: &Level) -> Grid {
        let tol = level.tolerance;
        if level.cells.is_empty() {
            // A level without rooms: one empty bucket, and every point outside.
            return Grid {
                min: DVec3::ZERO,
                size: DVec3::ONE,
                dims: [1, 1, 1],
                start: vec![0, 0],
                items: Vec::new(),
            };
        }
        let mut min = DVec3::splat(f64::INFINITY);
        let mut max = DVec3::splat(f64::NEG_INFINITY);
        for c in &level.cells {
            min = min.min(c.min);
            max = max.max(c.max);
        }
        let (min, max) = (min - tol, max + tol);
        let extent = (max - min).max(DVec3::splat(tol));
        let n = level.cells.len() as f64;
        let k = (n / (extent.x * extent.y * extent.z)).cbrt();
        let dim = |e: f64| ((e * k).ceil() as usize).clamp(1, 256);
        let dims = [dim(extent.x), dim(extent.y), dim(extent.z)];
        let size = extent / DVec3::new(dims[0] as f64, dims[1] as f64, dims[2] as f64);
        let mut grid = Grid {
            min,
            size,
            dims,
            start: Vec::new(),
            items: Vec::new(),
        };
        let buckets = dims[0] * dims[1] * dims[2];
        let mut lists: Vec<Vec<u32>> = vec![Vec::new(); buckets];
        for (i, c) in level.cells.iter().enumerate() {
            let (lo, hi) = (grid.bucket(c.min - tol), grid.bucket(c.max + tol));
            for x in lo[0]..=hi[0] {
                for y in lo[1]..=hi[1] {
                    for z in lo[2]..=hi[2] {
                        lists[grid.index([x, y, z])].push(i as u32);
                    }
                }
            }
        }
        for l in lists {
            grid.start.push(grid.items.len() as u32);
            grid.items.extend(l);
        }
        grid.start.push(grid.items.len() as u32);
        grid
    }

    /// The bucket holding `p`, clamped to the grid.
    pub(super) fn bucket(&self, p: DVec3) -> [usize; 3] {
        let q = (p - self.min) / self.size;
        let at = |v: f64, d: usize| (v.floor().max(0.0) as usize).min(d - 1);
        [
            at(q.x, self.dims[0]),
            at(q.y, self.dims[1]),
            at(q.z, self.dims[2]),
        ]
    }

    fn index(&self, b: [usize; 3]) -> usize {
        (b[0] * self.dims[1] + b[1]) * self.dims[2] + b[2]
    }

    pub(super) fn items(&self, b: [usize; 3]) -> &[u32] {
        let i = self.index(b);
        &self.items[self.start[i] as usize..self.start[i + 1] as usize]
    }
}

/// Flags the cells whose bounds overlap another's by more than the tolerance on every axis:
/// a hint inside one of them may be a nested room's outer cell, so it is not trusted alone.
pub(super) fn mark_overlaps(level: &mut Level) {
    let tol = level.tolerance;
    let mut flags = vec![false; level.cells.len()];
    for (i, c) in level.cells.iter().enumerate() {
        let (lo, hi) = (level.grid.bucket(c.min), level.grid.bucket(c.max));
        'cell: for x in lo[0]..=hi[0] {
            for y in lo[1]..=hi[1] {
                for z in lo[2]..=hi[2] {
                    for &j in level.grid.items([x, y, z]) {
                        let o = &level.cells[j as usize];
                        let overlap = c.max.min(o.max) - c.min.max(o.min);
                        if j as usize != i && overlap.min_element() > tol {
                            flags[i] = true;
                            break 'cell;
                        }
                    }
                }
            }
        }
    }
    for (c, f) in level.cells.iter_mut().zip(flags) {
        c.overlapped = f;
    }
}

impl Level {
    /// How far `p` lies inside cell `c`: the least distance to its planes (negative outside).
    pub(super) fn margin(&self, c: usize, p: DVec3) -> f64 {
        self.cell_planes(c)
            .iter()
            .map(|h| -h.dist(p))
            .fold(f64::INFINITY, f64::min)
    }

    /// The cell holding `p`. `hint` (last frame's cell) is tried first and wins ties on a
    /// boundary. Where cells overlap (a nested room inside another), the cell of the highest
    /// room priority holding the point wins, then the smallest: the inner room.
    pub fn locate(&self, p: DVec3, hint: Option<usize>) -> Location {
        let tol = self.tolerance;
        let hint = hint.filter(|&h| h < self.cells.len());
        if let Some(h) = hint {
            if !self.cells[h].overlapped && self.margin(h, p) > tol {
                return Location::Inside(h);
            }
        }
        let mut inside: Option<usize> = None;
        let mut boundary: Option<usize> = None;
        if p.is_finite() {
            for &c in self.grid.items(self.grid.bucket(p)) {
                let c = c as usize;
                let m = self.margin(c, p);
                if m > tol {
                    let smaller = inside.is_none_or(|b| {
                        let (pc, pb) = (self.cells[c].priority, self.cells[b].priority);
                        let (vc, vb) = (self.cells[c].volume, self.cells[b].volume);
                        pc > pb || (pc == pb && (vc < vb || (vc == vb && c < b)))
                    });
                    if smaller {
                        inside = Some(c);
                    }
                } else if m >= -tol {
                    // Within the tolerance the distances say nothing (they move with the
                    // level's position): the hint, else the lowest index.
                    let better =
                        boundary.is_none_or(|b| Some(b) != hint && (Some(c) == hint || c < b));
                    if better {
                        boundary = Some(c);
                    }
                }
            }
        }
        if let Some(c) = inside {
            return Location::Inside(c);
        }
        if let Some(c) = boundary {
            return Location::Boundary(c);
        }
        Location::Outside {
            nearest: self.nearest(p).map(|(c, _)| c),
        }
    }

    /// The cell nearest to `p` (exact distance to its faces) and that distance, ties to the
    /// lower index.
    pub(super) fn nearest(&self, p: DVec3) -> Option<(usize, f64)> {
        if !p.is_finite() {
            return None;
        }
        let mut best: Option<(usize, f64)> = None;
        for (i, c) in self.cells.iter().enumerate() {
            let bound = (c.min - p).max(p - c.max).max(DVec3::ZERO).length();
            if best.is_some_and(|(_, d)| bound >= d) {
                continue;
            }
            let mut d = f64::INFINITY;
            for f in &self.faces[c.faces.start as usize..c.faces.end as usize] {
                if f.plane.dist(p) > 0.0 {
                    let pts = &self.points[f.points.start as usize..f.points.end as usize];
                    d = d.min(clip::distance_to_polygon(p, pts, f.plane.n));
                }
            }
            if d == f64::INFINITY {
                d = 0.0;
            }
            if best.is_none_or(|(_, b)| d < b) {
                best = Some((i, d));
            }
        }
        best
    }

    /// The cells an object with bounds `min`..`max` may reach into (to draw it from each), in
    /// ascending order, into `out` (cleared first). Conservative: a cell is left out only when
    /// the box lies beyond one of its planes or its bounds.
    pub fn cells_touching(&self, min: DVec3, max: DVec3, out: &mut Vec<usize>) {
        out.clear();
        let tol = self.tolerance;
        if !(min.is_finite() && max.is_finite()) {
            return;
        }
        let (lo, hi) = (self.grid.bucket(min - tol), self.grid.bucket(max + tol));
        for x in lo[0]..=hi[0] {
            for y in lo[1]..=hi[1] {
                for z in lo[2]..=hi[2] {
                    for &c in self.grid.items([x, y, z]) {
                        let c = c as usize;
                        let cell = &self.cells[c];
                        if (cell.min - tol).cmpgt(max).any() || (cell.max + tol).cmplt(min).any() {
                            continue;
                        }
                        let touches = self.cell_planes(c).iter().all(|h| {
                            let nearest = DVec3::select(h.n.cmpge(DVec3::ZERO), min, max);
                            h.dist(nearest) <= tol
                        });
                        if touches {
                            out.push(c);
                        }
                    }
                }
            }
        }
        out.sort_unstable();
        out.dedup();
    }
}
