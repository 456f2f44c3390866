//! The surfaces of one generated room: floor, ceiling and walls facing into the room, with
//! door, window and stairwell holes cut as rectangles (a rectangle minus rectangles is split
//! along every hole edge, so the pieces meet edge to edge), the authored portal quads of its
//! doors, stairs, and furniture.

use glam::DVec3;

use super::layout::{Layout, Side};
use super::{Rng, DOOR_HEIGHT, DOOR_WIDTH, STOREY};

pub(crate) type Tri = [DVec3; 3];

pub(crate) struct RoomSurfaces {
    pub floor: Vec<Tri>,
    pub ceiling: Vec<Tri>,
    pub walls: Vec<Tri>,
    /// For each door this room owns: the target room and a quad facing out of this room.
    pub portals: Vec<(usize, Vec<Tri>)>,
    pub stairs: Vec<Tri>,
    /// A stairwell's volume, as a designer would give it: its floor and ceiling have holes,
    /// so its surfaces alone do not say the space above the opening is part of the room.
    pub bound: Vec<Tri>,
}

/// A rectangle `p0 + du*u + dv*v`, `u` in [0, lu], `v` in [0, lv], minus `holes` (rectangles
/// `(u0, u1, v0, v1)`), as triangles facing `normal`.
fn rect(
    p0: DVec3,
    du: DVec3,
    dv: DVec3,
    lu: f64,
    lv: f64,
    holes: &[[f64; 4]],
    normal: DVec3,
) -> Vec<Tri> {
    let mut us = vec![0.0, lu];
    let mut vs = vec![0.0, lv];
    for h in holes {
        us.extend([h[0], h[1]]);
        vs.extend([h[2], h[3]]);
    }
    us.sort_by(f64::total_cmp);
    us.dedup();
    vs.sort_by(f64::total_cmp);
    vs.dedup();
    let flip = du.cross(dv).dot(normal) < 0.0;
    let at = |u: f64, v: f64| p0 + du * u + dv * v;
    let mut out = Vec::new();
    for w in us.windows(2) {
        for x in vs.windows(2) {
            let (cu, cv) = ((w[0] + w[1]) * 0.5, (x[0] + x[1]) * 0.5);
            if holes
                .iter()
                .any(|h| h[0] < cu && cu < h[1] && h[2] < cv && cv < h[3])
            {
                continue;
            }
            let (a, b, c, d) = (
                at(w[0], x[0]),
                at(w[1], x[0]),
                at(w[1], x[1]),
                at(w[0], x[1]),
            );
            if flip {
                out.push([a, c, b]);
                out.push([a, d, c]);
            } else {
                out.push([a, b, c]);
                out.push([a, c, d]);
            }
        }
    }
    out
}

/// An outward-facing box.
fn boxed(lo: DVec3, hi: DVec3) -> Vec<Tri> {
    let s = hi - lo;
    let (x, y, z) = (DVec3::X, DVec3::Y, DVec3::Z);
    let mut out = Vec::new();
    out.extend(rect(lo, y, z, s.y, s.z, &[], -x));
    out.extend(rect(lo + x * s.x, y, z, s.y, s.z, &[], x));
    out.extend(rect(lo, x, z, s.x, s.z, &[], -y));
    out.extend(rect(lo + y * s.y, x, z, s.x, s.z, &[], y));
    out.extend(rect(lo, x, y, s.x, s.y, &[], -z));
    out.extend(rect(lo + z * s.z, x, y, s.x, s.y, &[], z));
    out
}

fn opposite(s: Side) -> Side {
    match s {
        Side::West => Side::East,
        Side::East => Side::West,
        Side::South => Side::North,
        Side::North => Side::South,
    }
}

/// The wall plane of a cell edge: origin, u axis (horizontal), length, inward normal.
fn edge(l: &Layout, (c, r): (usize, usize), side: Side, y0: f64) -> (DVec3, DVec3, f64, DVec3) {
    let (x0, x1, z0, z1) = (l.xs[c], l.xs[c + 1], l.zs[r], l.zs[r + 1]);
    match side {
        Side::West => (DVec3::new(x0, y0, z0), DVec3::Z, z1 - z0, DVec3::X),
        Side::East => (DVec3::new(x1, y0, z0), DVec3::Z, z1 - z0, -DVec3::X),
        Side::South => (DVec3::new(x0, y0, z0), DVec3::X, x1 - x0, DVec3::Z),
        Side::North => (DVec3::new(x0, y0, z1), DVec3::X, x1 - x0, -DVec3::Z),
    }
}

/// The stairwell opening in a cell's floor plane, as (u0, u1, v0, v1) along x and z.
fn stair_hole(l: &Layout) -> [f64; 4] {
    let w = l.xs[1] - l.xs[0];
    [0.5, w - 0.5, 0.5, 2.5]
}

pub fn room(l: &Layout, id: usize) -> RoomSurfaces {
    let p = &l.rooms[id];
    let y0 = p.storey as f64 * STOREY;
    let mut s = RoomSurfaces {
        floor: Vec::new(),
        ceiling: Vec::new(),
        walls: Vec::new(),
        portals: Vec::new(),
        stairs: Vec::new(),
        bound: Vec::new(),
    };
    let above = p.stair && p.storey + 1 < l.storeys && l.room_at(p.storey + 1, (0, 0)).is_some();
    let below = p.stair && p.storey > 0;
    for &cell in &p.cells {
        let (c, r) = cell;
        let origin = DVec3::new(l.xs[c], y0, l.zs[r]);
        let (lx, lz) = (l.xs[c + 1] - l.xs[c], l.zs[r + 1] - l.zs[r]);
        let hole = stair_hole(l);
        let fh: &[[f64; 4]] = if below {
            std::slice::from_ref(&hole)
        } else {
            &[]
        };
        let ch: &[[f64; 4]] = if above {
            std::slice::from_ref(&hole)
        } else {
            &[]
        };
        s.floor
            .extend(rect(origin, DVec3::X, DVec3::Z, lx, lz, fh, DVec3::Y));
        s.ceiling.extend(rect(
            origin + DVec3::Y * STOREY,
            DVec3::X,
            DVec3::Z,
            lx,
            lz,
            ch,
            -DVec3::Y,
        ));
        for side in Side::ALL {
            let n = side.neighbour(cell, l.cols, l.rows);
            if n.and_then(|n| l.room_at(p.storey, n)) == Some(id) {
                continue;
            }
            let (o, du, len, inward) = edge(l, cell, side, y0);
            let mid = len * 0.5;
            let mut holes = Vec::new();
            for d in &l.doors {
                let here = (d.a == id && d.cell == cell && d.side == side)
                    || (d.b == id
                        && opposite(d.side) == side
                        && d.side.neighbour(d.cell, l.cols, l.rows) == Some(cell));
                if here {
                    let h = [
                        mid - DOOR_WIDTH * 0.5,
                        mid + DOOR_WIDTH * 0.5,
                        0.0,
                        DOOR_HEIGHT,
                    ];
                    holes.push(h);
                    if d.a == id {
                        let q = rect(
                            o + du * h[0],
                            du,
                            DVec3::Y,
                            DOOR_WIDTH,
                            DOOR_HEIGHT,
                            &[],
                            -inward,
                        );
                        s.portals.push((d.b, q));
                    }
                }
            }
            if l.windows.contains(&(id, cell, side)) && len >= 2.0 {
                holes.push([mid - 0.6, mid + 0.6, 1.0, 2.2]);
            }
            s.walls
                .extend(rect(o, du, DVec3::Y, len, STOREY, &holes, inward));
        }
    }
    if p.stair {
        let (c, r) = p.cells[0];
        s.bound = boxed(
            DVec3::new(l.xs[c], y0, l.zs[r]),
            DVec3::new(l.xs[c + 1], y0 + STOREY, l.zs[r + 1]),
        );
    }
    if above {
        // Ten steps under the opening, climbing along x to the floor above.
        let h = stair_hole(l);
        let step = (h[1] - h[0]) / 10.0;
        for k in 0..10 {
            let lo = DVec3::new(l.xs[0] + h[0] + k as f64 * step, y0, l.zs[0] + h[2]);
            let hi = DVec3::new(
                lo.x + step,
                y0 + (k + 1) as f64 * STOREY / 10.0,
                l.zs[0] + h[3],
            );
            s.stairs.extend(boxed(lo, hi));
        }
    }
    s
}

/// A table with four legs and a chair with a back, somewhere in the room's first cell.
pub fn furniture(l: &Layout, id: usize, rng: &mut Rng) -> Vec<Tri> {
    let p = &l.rooms[id];
    if p.stair {
        return Vec::new();
    }
    let (c, r) = p.cells[0];
    let y0 = p.storey as f64 * STOREY;
    let (x0, x1, z0, z1) = (
        l.xs[c] + 1.2,
        l.xs[c + 1] - 2.4,
        l.zs[r] + 1.2,
        l.zs[r + 1] - 2.0,
    );
    let x = x0 + (x1 - x0).max(0.0) * rng.unit();
    let z = z0 + (z1 - z0).max(0.0) * rng.unit();
    let mut out = Vec::new();
    let v = |dx: f64, dy: f64, dz: f64| DVec3::new(x + dx, y0 + dy, z + dz);
    out.extend(boxed(v(0.0, 0.7, 0.0), v(1.2, 0.75, 0.8)));
    for (lx, lz) in [(0.0, 0.0), (1.15, 0.0), (0.0, 0.75), (1.15, 0.75)] {
        out.extend(boxed(v(lx, 0.0, lz), v(lx + 0.05, 0.7, lz + 0.05)));
    }
    let (cx, cz) = (0.4, 1.0);
    out.extend(boxed(v(cx, 0.45, cz), v(cx + 0.45, 0.5, cz + 0.45)));
    out.extend(boxed(v(cx, 0.5, cz + 0.4), v(cx + 0.45, 1.0, cz + 0.45)));
    for (lx, lz) in [(0.0, 0.0), (0.4, 0.0), (0.0, 0.4), (0.4, 0.4)] {
        out.extend(boxed(
            v(cx + lx, 0.0, cz + lz),
            v(cx + lx + 0.05, 0.45, cz + lz + 0.05),
        ));
    }
    out
}
