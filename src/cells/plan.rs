//! The 2D plan toolkit of the readings that work on a floor plan (`prism.rs`, `footprint.rs`):
//! the level's ground frame, and the convex pieces of a plan, cut the same way whether the
//! level was moved, turned, scaled or mirrored (a canonical form on an exact grid).

use glam::{DVec2, DVec3};

use crate::geom::exact::ExactVertices;
use crate::geom::partition::{
    convex_partition, ring_mean_width, union_triangles, PartitionError, Polygon2,
};
use crate::geom::plane::Plane;

/// An up this close to +Y is +Y but for rounding (`[0, 1, 0]` normalised), which keeps the
/// usual plan's (x, z) exact; anything further is a turned frame.
const ROUNDED_Y: f64 = 1e-12;

/// The up direction and a ground-plane basis: plans are coordinates on (u, v).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Frame {
    pub up: DVec3,
    pub u: DVec3,
    pub v: DVec3,
}

impl Frame {
    pub fn new(up: [f64; 3]) -> Frame {
        let up = DVec3::from_array(up).try_normalize().unwrap_or(DVec3::Y);
        if (up - DVec3::Y).length() < ROUNDED_Y {
            // Keep (x, z) exactly for the usual case.
            return Frame {
                up,
                u: DVec3::X,
                v: DVec3::Z,
            };
        }
        // Same handedness as (x, z) under +Y (u × v = -up), so a turned level's plan is the
        // turned plan, not its mirror image.
        let (a, b) = Plane { normal: up, d: 0.0 }.basis();
        Frame { up, u: b, v: a }
    }
    pub(crate) fn plan(&self, p: DVec3) -> DVec2 {
        DVec2::new(p.dot(self.u), p.dot(self.v))
    }
    /// A ground-plane vector back in 3D.
    pub(crate) fn lift(&self, q: DVec2) -> DVec3 {
        self.u * q.x + self.v * q.y
    }
}

/// The convex pieces of the union of plan triangles.
///
/// Everything is done in a frame fixed to the triangles themselves, so a level that was moved,
/// turned or scaled gets the same pieces: origin at their area centroid, first axis along
/// their longest edge (ties within [`LENGTH_TIE`] to the earliest, by input order, a triangle's edge
/// opposite its first corner before the other two). The union snaps to
/// the grid of that frame, where a turned rectangle's corners are exactly cocircular again.
/// Each polygon of the union is then written in the one of its eight symmetries (quarter turns, mirrored or not) on that
/// grid whose rings, read from their least point, come first: a canonical form (exact, on
/// integers) that the same shape has whichever of its edges of equal length was picked and
/// wherever the union's rings started, so the partition sees the same input and breaks every
/// tie the same way. The pieces are mapped back and given the exact input coordinates.
///
/// The grid is the plan's own (2^-20 of its extent), not the tolerance's: a grid that moved
/// with the tolerance rounded the same plan to other integers, and a Doom sector's equal
/// lengths, tied on one grid, were settled by rounding on another (the same map was cut into
/// other pieces at half or twice the tolerance). What the tolerance decides is decided with it:
/// which vertices are on a straight edge, which T-junctions split an edge, which slivers and
/// cracks are noise.
pub(crate) fn plan_pieces(
    flat: &[[DVec2; 3]],
    eps: f64,
) -> Result<Vec<Vec<DVec2>>, PartitionError> {
    let Some(&first) = flat.first().map(|t| &t[0]) else {
        return Ok(Vec::new());
    };
    let (mut area, mut acc) = (0.0, DVec2::ZERO);
    let mut longest: Option<(f64, DVec2)> = None;
    for t in flat {
        let a = (t[1] - t[0]).perp_dot(t[2] - t[0]).abs();
        area += a;
        acc += a * ((t[0] - first) + (t[1] - first) + (t[2] - first)) / 3.0;
        // The edge opposite the first corner first: it is the same edge when a mirroring
        // node has turned the triangle's corners round (see `Scene::winding`).
        for (i, j) in [(1, 2), (0, 1), (2, 0)] {
            let e = t[j] - t[i];
            let len = e.length();
            if len > 0.0 && longest.is_none_or(|(l, _)| len > l * (1.0 + LENGTH_TIE)) {
                longest = Some((len, e / len));
            }
        }
    }
    let Some((_, dir)) = longest else {
        return Ok(Vec::new());
    };
    let o = if area > 0.0 {
        first + acc / area
    } else {
        first
    };
    let perp = dir.perp();
    let local: Vec<[DVec2; 3]> = flat
        .iter()
        .map(|t| {
            t.map(|p| {
                let d = p - o;
                DVec2::new(d.dot(dir), d.dot(perp))
            })
        })
        .collect();
    // The triangles' centroids in input order, which settle a tie between a plan's own
    // symmetries (see `canonical_turn`); a triangle's centroid does not depend on which
    // corner a mirroring node lists first.
    let marks: Vec<DVec2> = local.iter().map(|t| (t[0] + t[1] + t[2]) / 3.0).collect();
    let local = weld(local, PLAN_NOISE * eps);
    let mut bounds = (DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY));
    for p in local.iter().flatten() {
        bounds = (bounds.0.min(*p), bounds.1.max(*p));
    }
    let grid = (bounds.1 - bounds.0).length() * PLAN_GRID;
    if !(grid > 0.0 && grid.is_finite()) {
        return Ok(Vec::new());
    }
    let exact = ExactVertices::new(flat.iter().flatten().copied(), grid);
    let noise = |r: &[DVec2]| ring_mean_width(r) < PLAN_NOISE * eps;
    let mut pieces = Vec::new();
    for mut poly in union_triangles(&split_t_junctions(&local, eps.max(grid)), grid) {
        if noise(&poly.outer) {
            continue;
        }
        poly.holes.retain(|h| !noise(h));
        let (turn, canonical) = canonical_turn(&poly, grid, &marks);
        // The union snapped every vertex to the grid: a vertex on a straight edge can come
        // back up to half a step off it along each axis, and so can the two it is judged
        // against, a step in all (turned L-shaped rooms whose vertices came back just past the
        // tolerance, or a full step off, tests/cells_props.rs). Within the tolerance plus two
        // steps is straight.
        let straight = (eps + 2.0 * grid) / grid;
        let outer = simplify_ring(&canonical.outer, straight);
        if outer.len() < 3 {
            continue;
        }
        let local = Polygon2 {
            outer,
            holes: canonical
                .holes
                .iter()
                .map(|h| simplify_ring(h, straight))
                .collect(),
        };
        let back = |c: DVec2| {
            let c = symmetry_back(c, turn) * grid;
            o + dir * c.x + perp * c.y
        };
        let ps = convex_partition(&local)?;
        let mut keyed: Vec<(Vec<usize>, Vec<DVec2>)> = ps
            .into_iter()
            .map(|p| {
                let mut piece: Vec<DVec2> = p.into_iter().map(back).collect();
                if turn >= 4 {
                    // Mapped back through a reflection: turned the input's way again.
                    piece.reverse();
                }
                let piece = exact.restore(piece);
                let mut key: Vec<usize> = piece
                    .iter()
                    .map(|q| exact.index_of(*q).unwrap_or(usize::MAX))
                    .collect();
                key.sort_unstable();
                (key, piece)
            })
            .collect();
        // Input order, not position, orders the pieces: the same for a moved level.
        keyed.sort_by(|a, b| a.0.cmp(&b.0));
        pieces.extend(keyed.into_iter().map(|(_, p)| p));
    }
    Ok(pieces)
}

/// Edge lengths within this fraction of each other are equal: the same edge of a moved or
/// turned plan differs by f64 rounding, far less, and must be picked alike.
const LENGTH_TIE: f64 = 1e-9;

/// Plan vertices within this many tolerances of each other are one (f32 noise between the
/// corners of neighbouring tiles, [`weld`]), and a ring thinner than this on average is noise:
/// what the union's own grid dropped when it was the tolerance's, half a tolerance.
const PLAN_NOISE: f64 = 0.5;

/// The plan partition's grid step, relative to the plan's extent: integer coordinates up to
/// 2^20, whose squared distances and cross products stay exact in f64.
const PLAN_GRID: f64 = 1.0 / (1u64 << 20) as f64;

/// Every vertex within `tol` of another (transitively) moved onto the least of them (by x,
/// then y): f32 noise between the corners of neighbouring floor tiles is gone before the
/// union, whose grid is finer than the tolerance (`geom::weld`).
fn weld(tris: Vec<[DVec2; 3]>, tol: f64) -> Vec<[DVec2; 3]> {
    let pts: Vec<DVec3> = tris.iter().flatten().map(|p| p.extend(0.0)).collect();
    let out = crate::geom::weld::weld(&pts, tol);
    out.chunks_exact(3)
        .map(|t| [t[0].truncate(), t[1].truncate(), t[2].truncate()])
        .collect()
}

/// `q` turned `n` quarter turns counter-clockwise about the origin (exact).
fn quarter_turns(q: DVec2, n: usize) -> DVec2 {
    (0..n % 4).fold(q, |q, _| DVec2::new(-q.y, q.x))
}

/// One of the grid's eight symmetries: `n` quarter turns (`n % 4`), after a reflection in
/// the first axis when `n >= 4`. With the reflections, a mirrored room's plan has the same
/// canonical form as the original's, so it is cut into the mirror image of the same pieces.
fn symmetry(q: DVec2, n: usize) -> DVec2 {
    let q = if n >= 4 { DVec2::new(q.x, -q.y) } else { q };
    quarter_turns(q, n)
}

/// The inverse of [`symmetry`].
fn symmetry_back(q: DVec2, n: usize) -> DVec2 {
    let q = quarter_turns(q, 4 - n % 4);
    if n >= 4 {
        DVec2::new(q.x, -q.y)
    } else {
        q
    }
}

/// The symmetry (0 to 7, see [`symmetry`]) of a polygon on the grid whose rings, each read from its least
/// point (by x, then y) and the holes sorted by theirs, come first, and the polygon so turned,
/// in grid steps (integers, exact in f64): the partition then sees the same numbers for a
/// level scaled by any factor, and no tie between float areas can go another way.
///
/// A polygon symmetric in itself comes first under several symmetries, which map its pieces
/// back to different places (a sector's two halves swapped). The tie goes to the symmetry
/// that puts `marks` (points in input order) first, so the choice moves with the level: a
/// mirrored level picks the mirror of the original's symmetry and gets the mirror image of its
/// pieces, not their twin.
fn canonical_turn(p: &Polygon2, grid: f64, marks: &[DVec2]) -> (usize, Polygon2) {
    let steps = |q: &DVec2| ((q.x / grid).round() as i64, (q.y / grid).round() as i64);
    let ring = |r: &[DVec2], n: usize| -> Vec<(i64, i64)> {
        let mut r: Vec<(i64, i64)> = r.iter().map(|q| steps(&symmetry(*q, n))).collect();
        if n >= 4 {
            // A reflection reverses the ring's turn: read it the other way to keep it.
            r.reverse();
        }
        if let Some(at) = (0..r.len()).min_by_key(|&i| r[i]) {
            r.rotate_left(at);
        }
        r
    };
    type Ring = Vec<(i64, i64)>;
    let form = |n: usize| -> (Ring, Vec<Ring>) {
        let mut holes: Vec<Ring> = p.holes.iter().map(|h| ring(h, n)).collect();
        holes.sort();
        (ring(&p.outer, n), holes)
    };
    let forms: Vec<(Ring, Vec<Ring>)> = (0..8).map(form).collect();
    let least = forms.iter().min().cloned().unwrap_or_default();
    let turn = (0..8)
        .filter(|&n| forms[n] == least)
        .min_by_key(|&n| {
            marks
                .iter()
                .map(|m| steps(&symmetry(*m, n)))
                .collect::<Vec<_>>()
        })
        .unwrap_or(0);
    let (outer, holes) = least;
    let back = |r: Ring| -> Vec<DVec2> {
        r.into_iter()
            .map(|(x, y)| DVec2::new(x as f64, y as f64))
            .collect()
    };
    (
        turn,
        Polygon2 {
            outer: back(outer),
            holes: holes.into_iter().map(back).collect(),
        },
    )
}

/// Inserts every vertex that lies on another triangle's edge (a T-junction, as where a floor
/// tile meets the middle of a longer one) into that edge. Without it, rounding a turned
/// level's coordinates can open hairline gaps along such edges and the union falls apart.
fn split_t_junctions(flat: &[[DVec2; 3]], tol: f64) -> Vec<[DVec2; 3]> {
    let mut verts: Vec<DVec2> = flat.iter().flatten().copied().collect();
    verts.sort_by(|a, b| a.x.total_cmp(&b.x).then(a.y.total_cmp(&b.y)));
    verts.dedup_by(|a, b| a.distance_squared(*b) <= tol * tol);
    let mut out = Vec::with_capacity(flat.len());
    for t in flat {
        let mut ring: Vec<DVec2> = Vec::with_capacity(3);
        let mut split = false;
        for k in 0..3 {
            let (p, q) = (t[k], t[(k + 1) % 3]);
            ring.push(p);
            let d = q - p;
            let len2 = d.length_squared();
            if len2 <= tol * tol {
                continue;
            }
            let (lo, hi) = (p.x.min(q.x) - tol, p.x.max(q.x) + tol);
            let first = verts.partition_point(|v| v.x < lo);
            let mut on: Vec<(f64, DVec2)> = verts[first..]
                .iter()
                .take_while(|v| v.x <= hi)
                .filter_map(|v| {
                    let s = (*v - p).dot(d) / len2;
                    let off = (*v - p).perp_dot(d).abs() / len2.sqrt();
                    let inner = s * len2.sqrt() > tol && (1.0 - s) * len2.sqrt() > tol;
                    (inner && off <= tol).then_some((s, *v))
                })
                .collect();
            if !on.is_empty() {
                split = true;
                on.sort_by(|a, b| a.0.total_cmp(&b.0));
                ring.extend(on.into_iter().map(|(_, v)| v));
            }
        }
        if split {
            // A fan from the first corner covers the triangle; triangles that come out flat
            // (points on the corner's own edges) carry no area and are ignored by the union.
            for w in ring[1..].windows(2) {
                out.push([ring[0], w[0], w[1]]);
            }
        } else {
            out.push(*t);
        }
    }
    out
}

/// Drops ring vertices within `eps` of the line through their neighbours (walls that f32
/// noise bent by less than the tolerance are straight).
fn simplify_ring(ring: &[DVec2], eps: f64) -> Vec<DVec2> {
    let mut r = ring.to_vec();
    let mut changed = true;
    while changed && r.len() > 3 {
        changed = false;
        for i in 0..r.len() {
            let (a, p, b) = (r[(i + r.len() - 1) % r.len()], r[i], r[(i + 1) % r.len()]);
            let ab = b - a;
            let l = ab.length();
            let off = if l > 0.0 {
                (p - a).perp_dot(ab).abs() / l
            } else {
                p.distance(a)
            };
            if off <= eps {
                r.remove(i);
                changed = true;
                break;
            }
        }
    }
    r
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Corners within the tolerance of each other (transitively) become the least of them,
    /// in any triangle order; corners further apart stay.
    #[test]
    fn weld_moves_noise_apart_corners_onto_the_least() {
        let a = DVec2::new(1.0, 1.0);
        let b = DVec2::new(1.0 + 4e-7, 1.0 - 3e-7);
        let c = DVec2::new(1.0 + 8e-7, 1.0);
        let far = DVec2::new(3.0, 1.0);
        let tris = vec![[b, far, DVec2::new(2.0, 3.0)], [c, a, DVec2::new(0.0, 3.0)]];
        for order in [tris.clone(), tris.iter().rev().copied().collect()] {
            let out = weld(order, 6e-7);
            let corners: Vec<DVec2> = out.iter().flatten().copied().collect();
            for p in [b, c] {
                assert!(!corners.contains(&p), "{p} welded");
            }
            assert_eq!(corners.iter().filter(|&&p| p == a).count(), 3);
            assert!(corners.contains(&far));
        }
        // A tolerance of zero welds nothing.
        assert_eq!(weld(tris.clone(), 0.0), tris);
    }
}
