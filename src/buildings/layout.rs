//! The building's plan: a grid of cells per storey (the same grid on every storey), rooms made
//! of one cell or of three cells of a 2x2 block (an L), a stairwell in the first cell of every
//! storey, doors between neighbouring rooms (a random spanning tree, so every room is reached,
//! plus some extra doors that make loops) and windows in outer walls.

use glam::DVec3;

use super::{Rng, STOREY};

/// A room: its storey and grid cells `(col, row)`.
#[derive(Debug, Clone)]
pub struct RoomPlan {
    pub storey: usize,
    pub cells: Vec<(usize, usize)>,
    /// The stairwell of its storey (joined to the stairwells above and below).
    pub stair: bool,
}

/// A grid edge between cell `cell` and its neighbour on `side`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Side {
    West,
    East,
    South,
    North,
}

/// A door in the wall between two rooms, on the edge of `cell` (a cell of room `a`).
#[derive(Debug, Clone, Copy)]
pub struct Door {
    pub a: usize,
    pub b: usize,
    pub cell: (usize, usize),
    pub side: Side,
}

/// A generated building: a grid of rooms on storeys, with doors and windows.
#[derive(Debug, Clone)]
pub struct Layout {
    /// Floors stacked `STOREY` apart.
    pub storeys: usize,
    /// Grid cells along x.
    pub cols: usize,
    /// Grid cells along z.
    pub rows: usize,
    /// Grid lines (m): `cols + 1` in x, `rows + 1` in z.
    pub xs: Vec<f64>,
    /// Grid lines (m) in z: `rows + 1` of them.
    pub zs: Vec<f64>,
    /// The rooms, each a rectangle of grid cells on one storey.
    pub rooms: Vec<RoomPlan>,
    /// Per storey, the room of each cell (`row * cols + col`), if any.
    pub cell_room: Vec<Vec<Option<usize>>>,
    /// Doors between neighbouring rooms (each becomes a portal pair).
    pub doors: Vec<Door>,
    /// Outer-wall edges with a window: (room, cell, side).
    pub windows: Vec<(usize, (usize, usize), Side)>,
}

impl Side {
    pub const ALL: [Side; 4] = [Side::West, Side::East, Side::South, Side::North];

    /// The neighbouring cell, if inside the grid.
    pub(crate) fn neighbour(
        self,
        (c, r): (usize, usize),
        cols: usize,
        rows: usize,
    ) -> Option<(usize, usize)> {
        match self {
            Side::West => c.checked_sub(1).map(|c| (c, r)),
            Side::East => (c + 1 < cols).then_some((c + 1, r)),
            Side::South => r.checked_sub(1).map(|r| (c, r)),
            Side::North => (r + 1 < rows).then_some((c, r + 1)),
        }
    }
}

impl Layout {
    /// A layout of `rooms` rooms; the same `seed` gives the same building.
    pub fn new(rooms: usize, seed: u64) -> Layout {
        let mut rng = Rng::new(seed);
        // Storeys grow slowly with the room count: 2 for 10 rooms, 4 for 100, 8 for 1 000,
        // 16 for 10 000; the grid holds a storey's share with room for L shapes.
        let storeys_hint = if rooms < 2 {
            1
        } else {
            ((rooms as f64).powf(0.3)).round().max(2.0) as usize
        };
        let per = rooms.div_ceil(storeys_hint);
        let cells = (per as f64 * 1.25).ceil() as usize + 1;
        let cols = (cells as f64).sqrt().ceil().max(1.0) as usize;
        let rows = cells.div_ceil(cols).max(1);
        let mut xs = vec![0.0];
        for _ in 0..cols {
            xs.push(xs.last().unwrap() + 4.0 + (3.0 * rng.unit() * 4.0).round() / 4.0);
        }
        let mut zs = vec![0.0];
        for _ in 0..rows {
            zs.push(zs.last().unwrap() + 4.0 + (2.0 * rng.unit() * 4.0).round() / 4.0);
        }
        let mut plans: Vec<RoomPlan> = Vec::new();
        let mut cell_room: Vec<Vec<Option<usize>>> = Vec::new();
        let mut s = 0;
        while plans.len() < rooms {
            let mut grid: Vec<Option<usize>> = vec![None; cols * rows];
            'fill: for r in 0..rows {
                for c in 0..cols {
                    if plans.len() >= rooms {
                        break 'fill;
                    }
                    if grid[r * cols + c].is_some() {
                        continue;
                    }
                    let id = plans.len();
                    let stair = (c, r) == (0, 0);
                    let free = |grid: &Vec<Option<usize>>, c: usize, r: usize| {
                        c < cols && r < rows && grid[r * cols + c].is_none()
                    };
                    let l_shape = !stair
                        && free(&grid, c + 1, r)
                        && free(&grid, c, r + 1)
                        && rng.chance(0.12);
                    let mut cells = vec![(c, r)];
                    if l_shape {
                        cells.push((c + 1, r));
                        cells.push((c, r + 1));
                    }
                    for &(cc, rr) in &cells {
                        grid[rr * cols + cc] = Some(id);
                    }
                    plans.push(RoomPlan {
                        storey: s,
                        cells,
                        stair,
                    });
                }
            }
            cell_room.push(grid);
            s += 1;
        }
        let mut layout = Layout {
            storeys: s,
            cols,
            rows,
            xs,
            zs,
            rooms: plans,
            cell_room,
            doors: Vec::new(),
            windows: Vec::new(),
        };
        layout.place_doors(&mut rng);
        layout.place_windows(&mut rng);
        layout
    }

    /// The room at a cell of a storey.
    pub(crate) fn room_at(&self, storey: usize, (c, r): (usize, usize)) -> Option<usize> {
        self.cell_room
            .get(storey)?
            .get(r * self.cols + c)
            .copied()
            .flatten()
    }

    /// A room's tag name, `s2_r15` (storey, index); the stairwell is `s2_stair`.
    pub fn name(&self, room: usize) -> String {
        let p = &self.rooms[room];
        if p.stair {
            format!("s{}_stair", p.storey)
        } else {
            format!("s{}_r{room}", p.storey)
        }
    }

    /// The centre of a cell's floor.
    pub(crate) fn cell_centre(&self, (c, r): (usize, usize), storey: usize) -> DVec3 {
        DVec3::new(
            (self.xs[c] + self.xs[c + 1]) * 0.5,
            storey as f64 * STOREY,
            (self.zs[r] + self.zs[r + 1]) * 0.5,
        )
    }

    /// Spanning tree over neighbouring rooms of a storey (edges in random order, union-find),
    /// plus each remaining neighbour pair with some chance: every room is reachable, and the
    /// graph has loops like real buildings.
    fn place_doors(&mut self, rng: &mut Rng) {
        for s in 0..self.storeys {
            let mut edges: Vec<(u64, Door)> = Vec::new();
            for r in 0..self.rows {
                for c in 0..self.cols {
                    let Some(a) = self.room_at(s, (c, r)) else {
                        continue;
                    };
                    for side in [Side::East, Side::North] {
                        let Some(n) = side.neighbour((c, r), self.cols, self.rows) else {
                            continue;
                        };
                        match self.room_at(s, n) {
                            Some(b) if b != a => edges.push((
                                rng.next_u64(),
                                Door {
                                    a,
                                    b,
                                    cell: (c, r),
                                    side,
                                },
                            )),
                            _ => {}
                        }
                    }
                }
            }
            edges.sort_by_key(|(k, d)| (*k, d.a, d.b));
            let mut parts = crate::disjoint::DisjointSets::new(self.rooms.len());
            let mut joined: std::collections::BTreeSet<(usize, usize)> = Default::default();
            for (_, d) in edges {
                let pair = (d.a.min(d.b), d.a.max(d.b));
                if joined.contains(&pair) {
                    continue;
                }
                // A door between parts joins them; one within a part makes a loop.
                if parts.union(d.a, d.b) || rng.chance(0.25) {
                    joined.insert(pair);
                    self.doors.push(d);
                }
            }
        }
    }

    fn place_windows(&mut self, rng: &mut Rng) {
        for (id, p) in self.rooms.iter().enumerate() {
            for &cell in &p.cells {
                for side in Side::ALL {
                    let outside = match side.neighbour(cell, self.cols, self.rows) {
                        None => true,
                        Some(n) => self.room_at(p.storey, n).is_none(),
                    };
                    if outside && rng.chance(0.35) {
                        self.windows.push((id, cell, side));
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_room_is_placed_and_joined() {
        for n in [1, 10, 100, 1000] {
            let l = Layout::new(n, 7);
            assert_eq!(l.rooms.len(), n);
            // Per storey, doors make the rooms one connected set; stairwells join storeys.
            let mut parent: Vec<usize> = (0..n).collect();
            fn root(p: &mut [usize], mut a: usize) -> usize {
                while p[a] != a {
                    a = p[a];
                }
                a
            }
            for d in &l.doors {
                let (a, b) = (root(&mut parent, d.a), root(&mut parent, d.b));
                parent[a] = b;
            }
            let stairs: Vec<usize> = (0..n).filter(|&r| l.rooms[r].stair).collect();
            for w in stairs.windows(2) {
                let (a, b) = (root(&mut parent, w[0]), root(&mut parent, w[1]));
                parent[a] = b;
            }
            let r0 = root(&mut parent, 0);
            assert!((0..n).all(|r| root(&mut parent, r) == r0), "{n} rooms");
        }
    }
}
