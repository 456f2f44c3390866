//! A uniform grid over axis-aligned boxes, for "which boxes meet this one" queries in time
//! proportional to the answer. A sweep along one axis degrades to all pairs when a level is
//! wide in the other two (a building's storeys all share the same x range); a grid does not.
//! Results are always in ascending index order, so callers stay deterministic.

use glam::DVec3;

use super::aabb::Aabb;

/// The smallest side (m) the grid gives the boxes' bounds, so a flat or empty extent still
/// divides into buckets: a grid size, not a tolerance.
const SMALLEST_EXTENT: f64 = 1e-9;
/// The finest bucket as a share of the extent: a million a side at most, so a level of many
/// tiny boxes and one far away does not ask for more buckets than memory holds.
const FINEST_CELL: f64 = 1e-6;

pub(crate) struct BoxGrid {
    boxes: Vec<Aabb>,
    origin: DVec3,
    cell: f64,
    dims: [usize; 3],
    buckets: Vec<Vec<u32>>,
}

impl BoxGrid {
    /// Indexes `boxes` (empty boxes are never found).
    pub fn new(boxes: Vec<Aabb>) -> BoxGrid {
        let mut g = BoxGrid::index(boxes.len(), |i| boxes[i]);
        g.boxes = boxes;
        g
    }

    /// Indexes `count` boxes given by `box_of` without keeping them: for millions of small boxes
    /// (a level's triangles) that are cheaper to recompute than to store; query with
    /// [`BoxGrid::query_by`].
    pub(crate) fn index(count: usize, box_of: impl Fn(usize) -> Aabb) -> BoxGrid {
        let count = u32::try_from(count).expect("a grid indexes at most 2^32 boxes");
        BoxGrid::index_ids(0..count, |i| box_of(i as usize))
    }

    /// [`BoxGrid::index`] of some of the boxes only, `ids`: queries offer these ids, so several
    /// grids over parts of one list answer in the list's numbering.
    pub(crate) fn index_ids(
        ids: impl Iterator<Item = u32> + Clone,
        box_of: impl Fn(u32) -> Aabb,
    ) -> BoxGrid {
        let mut all = Aabb::EMPTY;
        let mut sizes: Vec<f64> = Vec::with_capacity(ids.size_hint().0);
        for b in ids.clone().map(&box_of).filter(|b| !b.is_empty()) {
            all = all.union(&b);
            sizes.push(b.size().max_element());
        }
        if all.is_empty() {
            return BoxGrid {
                boxes: Vec::new(),
                origin: DVec3::ZERO,
                cell: 1.0,
                dims: [1, 1, 1],
                buckets: vec![Vec::new()],
            };
        }
        let extent = all.size().max(DVec3::splat(SMALLEST_EXTENT));
        // About two buckets per box, but no smaller than a typical box, so most boxes sit in
        // a handful of buckets.
        let n = sizes.len().max(1) as f64;
        let by_count = (extent.x * extent.y * extent.z / (2.0 * n)).cbrt();
        let mid = sizes.len() / 2;
        let median = if sizes.is_empty() {
            0.0
        } else {
            *sizes.select_nth_unstable_by(mid, f64::total_cmp).1
        };
        let mut cell = by_count.max(median).max(extent.max_element() * FINEST_CELL);
        let dims_for = |cell: f64| {
            [0, 1, 2].map(|k| ((extent[k] / cell).floor() as usize + 1).clamp(1, 1 << 20))
        };
        let mut dims = dims_for(cell);
        // Never more than a few buckets per box.
        while dims.iter().product::<usize>() > 4 * sizes.len().max(1) + 64 {
            cell *= 1.5;
            dims = dims_for(cell);
        }
        let mut g = BoxGrid {
            boxes: Vec::new(),
            origin: all.min,
            cell,
            dims,
            buckets: vec![Vec::new(); dims.iter().product()],
        };
        for i in ids {
            let b = box_of(i);
            if b.is_empty() {
                continue;
            }
            let (lo, hi) = g.range(&b);
            for z in lo[2]..=hi[2] {
                for y in lo[1]..=hi[1] {
                    for x in lo[0]..=hi[0] {
                        let k = g.bucket(x, y, z);
                        g.buckets[k].push(i);
                    }
                }
            }
        }
        g
    }

    fn bucket(&self, x: usize, y: usize, z: usize) -> usize {
        (z * self.dims[1] + y) * self.dims[0] + x
    }

    /// Bucket coordinates covered by `b`, clamped to the grid.
    fn range(&self, b: &Aabb) -> ([usize; 3], [usize; 3]) {
        let to = |v: f64, k: usize| {
            (((v - self.origin[k]) / self.cell).floor().max(0.0) as usize).min(self.dims[k] - 1)
        };
        (
            [0, 1, 2].map(|k| to(b.min[k], k)),
            [0, 1, 2].map(|k| to(b.max[k], k)),
        )
    }

    /// Indices of the boxes that meet `b` grown by `pad` on every side, ascending.
    pub fn query(&self, b: &Aabb, pad: f64) -> Vec<usize> {
        self.query_by(b, pad, |i| self.boxes[i])
    }

    /// [`BoxGrid::query`] of a grid made by [`BoxGrid::index`], with the same `box_of`.
    pub(crate) fn query_by(
        &self,
        b: &Aabb,
        pad: f64,
        box_of: impl Fn(usize) -> Aabb,
    ) -> Vec<usize> {
        let mut out = Vec::new();
        self.query_into(b, pad, box_of, &mut out, &mut Marks::default());
        out.into_iter().map(|i| i as usize).collect()
    }

    /// [`BoxGrid::query_by`] into buffers the caller reuses (`out` is cleared first): an inner
    /// loop that queries per face pair allocates nothing.
    pub(crate) fn query_into(
        &self,
        b: &Aabb,
        pad: f64,
        box_of: impl Fn(usize) -> Aabb,
        out: &mut Vec<u32>,
        marks: &mut Marks,
    ) {
        out.clear();
        if b.is_empty() {
            return;
        }
        let q = b.grown(pad);
        self.visit(b, pad, marks, |i| {
            if box_of(i as usize).meets(&q) {
                out.push(i);
            }
        });
        out.sort_unstable();
    }

    /// Calls `f` once for every box index in a bucket that `b` grown by `pad` covers, in no
    /// particular order: a superset of the boxes meeting it, for callers that test each one
    /// themselves and sort only what they keep. A box in several buckets is offered once;
    /// `marks` (left empty afterwards) remembers which were.
    pub(crate) fn visit(&self, b: &Aabb, pad: f64, marks: &mut Marks, mut f: impl FnMut(u32)) {
        if b.is_empty() {
            return;
        }
        let (lo, hi) = self.range(&b.grown(pad));
        marks.seen.clear();
        for z in lo[2]..=hi[2] {
            for y in lo[1]..=hi[1] {
                for x in lo[0]..=hi[0] {
                    for &i in &self.buckets[self.bucket(x, y, z)] {
                        if marks.set(i) {
                            f(i);
                        }
                    }
                }
            }
        }
        marks.clear_seen();
    }

    /// Every pair `(i, j)`, `i < j`, of boxes within `pad` of each other, in ascending order.
    pub fn pairs(&self, pad: f64) -> Vec<(usize, usize)> {
        let mut out = Vec::new();
        for (i, b) in self.boxes.iter().enumerate() {
            for j in self.query(b, pad) {
                if j > i {
                    out.push((i, j));
                }
            }
        }
        out
    }
}

/// A set of box indices as bits, grown as needed and left empty after each query (the indices
/// set are listed, so clearing costs what setting did).
#[derive(Default)]
pub(crate) struct Marks {
    bits: Vec<u64>,
    seen: Vec<u32>,
}

impl Marks {
    /// Sets `i`; false if it was set already.
    fn set(&mut self, i: u32) -> bool {
        let w = i as usize / 64;
        if w >= self.bits.len() {
            self.bits.resize(w + 1, 0);
        }
        let bit = 1 << (i % 64);
        if self.bits[w] & bit != 0 {
            return false;
        }
        self.bits[w] |= bit;
        self.seen.push(i);
        true
    }

    fn clear_seen(&mut self) {
        for &i in &self.seen {
            self.bits[i as usize / 64] &= !(1 << (i % 64));
        }
        self.seen.clear();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn b(x: f64, y: f64, z: f64, s: f64) -> Aabb {
        Aabb {
            min: DVec3::new(x, y, z),
            max: DVec3::new(x + s, y + s, z + s),
        }
    }

    #[test]
    fn answers_like_all_pairs() {
        // A deterministic scatter of boxes of mixed sizes, some huge.
        let mut boxes = Vec::new();
        let mut s = 7u64;
        for k in 0..400 {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let f = |sh: u32| ((s >> sh) & 0xffff) as f64 / 65536.0;
            let size = if k % 50 == 0 { 30.0 } else { 0.2 + f(48) };
            boxes.push(b(f(0) * 40.0, f(16) * 10.0, f(32) * 40.0, size));
        }
        boxes.push(Aabb::EMPTY);
        let g = BoxGrid::new(boxes.clone());
        let meets = |a: &Aabb, c: &Aabb, pad: f64| {
            !a.is_empty()
                && !c.is_empty()
                && (0..3).all(|k| c.min[k] <= a.max[k] + pad && c.max[k] >= a.min[k] - pad)
        };
        for pad in [0.0, 0.5] {
            let mut brute = Vec::new();
            for i in 0..boxes.len() {
                for j in i + 1..boxes.len() {
                    if meets(&boxes[i], &boxes[j], pad) {
                        brute.push((i, j));
                    }
                }
            }
            assert_eq!(g.pairs(pad), brute, "pad {pad}");
        }
    }
}
