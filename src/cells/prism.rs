//! Rooms that really are prisms along the level's up: their cells come from their floor plan.
//!
//! A room whose triangles are all either walls (upright) or flat at the room's lowest or
//! highest level, with any ceiling covering exactly the floor, encloses its floor plan extruded
//! to its hull: a Doom sector, a box room, an L or a ring of walls around a pillar. For such a
//! room the plan partition gives the cells of its interior exactly, and it also knows what the
//! 3D BSP cannot see: where the floor stops at an opening with no wall (a walkway around a pit
//! whose ceiling is open above the pit too, a sky area whose wall to a lower sky area is not
//! modelled), the plan's edge is the room's edge, and the space over the neighbour stays the
//! neighbour's. Nothing of the room's own surface cuts along such an edge, so the BSP would
//! keep that space in a cell; the plan cuts there by construction.
//!
//! Anything else (a step, a soffit, a slab at mid height, a slope, a ceiling over only part of
//! the floor) goes to the 3D decomposition in [`super::interior`].

use glam::{DVec2, DVec3};

use super::plan::{plan_pieces, Frame};
use crate::geom::plane::Plane;
use crate::geom::polyhedron::{polygon_area, ConvexPolyhedron};
use crate::geom::tolerance::Tolerance;

/// The cells of a room that is a prism along `frame.up`, or `None` when it is not one (or its
/// plan cannot be partitioned): then the 3D decomposition decides.
pub(crate) fn cells(
    tris: &[[DVec3; 3]],
    hull: &ConvexPolyhedron,
    eps: f64,
    frame: &Frame,
) -> Option<Vec<ConvexPolyhedron>> {
    let height = |p: &DVec3| p.dot(frame.up);
    let levels = flat_levels(tris, eps, frame)?;
    let (lo, hi) = tris
        .iter()
        .flatten()
        .map(height)
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), y| {
            (l.min(y), h.max(y))
        });
    let (plan, slab) = match levels.as_slice() {
        // One level: the floor (or a ceiling over walls), at an end of the room's height.
        [(y, ts)] if (y - lo).abs() <= eps || (y - hi).abs() <= eps => (ts, None),
        [(f, floor), (c, top)] => (floor, Some((*f, *c, top))),
        _ => return None,
    };
    // The usual box room: floor and ceiling each fill the hull's face there, so the plan is
    // the hull's and the hull is the one cell (no plan partition needed).
    let fills = |ts: &[[DVec2; 3]], dir: DVec3| fills_hull_face(hull, ts, dir, eps);
    match slab {
        None if fills(
            plan,
            if (levels[0].0 - lo).abs() <= eps {
                -frame.up
            } else {
                frame.up
            },
        ) =>
        {
            return Some(vec![hull.clone()]);
        }
        Some((f, c, top))
            if (f - lo).abs() <= eps
                && (c - hi).abs() <= eps
                && fills(plan, -frame.up)
                && fills(top, frame.up) =>
        {
            return Some(vec![hull.clone()]);
        }
        _ => {}
    }
    let pieces = plan_pieces(plan, eps).ok()?;
    let mut region = hull.clone();
    if let Some((f, c, top)) = slab {
        if !ceiling_covers_floor(&pieces, plan, top, eps) {
            return None;
        }
        // Walls reaching past the floor or the ceiling (a Doom sector's walls up to its
        // neighbour's sky) enclose nothing there: the room is floor to ceiling.
        if f > lo + eps {
            region = region.clip(&Plane::from_point_normal(frame.up * f, -frame.up)?, eps)?;
        }
        if c < hi - eps {
            region = region.clip(&Plane::from_point_normal(frame.up * c, frame.up)?, eps)?;
        }
    }
    if pieces.len() <= 1 {
        return Some(vec![region]);
    }
    let out = cut_into_pieces(&region, &pieces, eps, frame);
    (!out.is_empty()).then_some(out)
}

/// The flat triangles by level (within the tolerance of the first one there, in input
/// order), lowest first; a prism has its floor on one level and perhaps its ceiling on another,
/// so a slope or a third level says the room is no prism (`None`).
fn flat_levels(
    tris: &[[DVec3; 3]],
    eps: f64,
    frame: &Frame,
) -> Option<Vec<(f64, Vec<[DVec2; 3]>)>> {
    let height = |p: &DVec3| p.dot(frame.up);
    let mut levels: Vec<(f64, Vec<[DVec2; 3]>)> = Vec::new();
    for t in tris {
        let flat = t.map(|p| frame.plan(p));
        let (a, b, c) = (flat[0], flat[1], flat[2]);
        let perimeter = a.distance(b) + b.distance(c) + c.distance(a);
        // Upright (its plan is a segment, mean width under the tolerance): a wall.
        if (b - a).perp_dot(c - a).abs() <= eps * perimeter {
            continue;
        }
        let y = height(&t[0]);
        if t.iter().any(|p| (height(p) - y).abs() > eps) {
            return None; // sloped
        }
        match levels.iter().position(|(h, _)| (h - y).abs() <= eps) {
            Some(k) => levels[k].1.push(flat),
            None if levels.len() < 2 => levels.push((y, vec![flat])),
            None => return None, // a third level: a step, a soffit, a slab
        }
    }
    levels.sort_by(|a, b| a.0.total_cmp(&b.0));
    Some(levels)
}

/// The area of plan triangles.
fn plan_area(ts: &[[DVec2; 3]]) -> f64 {
    ts.iter()
        .map(|t| 0.5 * (t[1] - t[0]).perp_dot(t[2] - t[0]).abs())
        .sum()
}

/// The f64 rounding of a sum of triangle areas, relative to it: two areas of one region, summed
/// from other triangles, differ by this much besides what the tolerance moves their edges.
const AREA_ROUNDING: f64 = 1e-9;

/// Whether the plan triangles `ts` fill the hull's face facing `dir`: then that face is the
/// room's floor or ceiling whole, and the hull needs no cutting there.
fn fills_hull_face(hull: &ConvexPolyhedron, ts: &[[DVec2; 3]], dir: DVec3, eps: f64) -> bool {
    hull.faces.iter().any(|f| {
        Tolerance::parallel(f.plane.normal, dir) && {
            let face = polygon_area(&f.points, f.plane.normal);
            (plan_area(ts) - face).abs() <= AREA_ROUNDING * face + eps * face.sqrt()
        }
    })
}

/// The ceiling must cover the floor, no more and no less: a ceiling over part of the
/// floor (a soffit whose other part is missing) or beyond it is not a prism's.
fn ceiling_covers_floor(
    pieces: &[Vec<DVec2>],
    plan: &[[DVec2; 3]],
    top: &[[DVec2; 3]],
    eps: f64,
) -> bool {
    let floor_area = plan_area(plan);
    let slack =
        eps * plan.iter().map(|t| t[0].distance(t[1])).sum::<f64>() + AREA_ROUNDING * floor_area;
    let inside = |q: DVec2| {
        pieces.iter().any(|piece| {
            piece.iter().enumerate().all(|(i, a)| {
                let e = piece[(i + 1) % piece.len()] - *a;
                e.perp_dot(q - *a) >= -eps * e.length()
            })
        })
    };
    if (plan_area(top) - floor_area).abs() > slack
        || !top.iter().all(|t| inside((t[0] + t[1] + t[2]) / 3.0))
    {
        return false;
    }
    true
}

/// The room's region cut along each plan piece's edges: one cell per piece (none for a piece
/// the cuts leave empty).
fn cut_into_pieces(
    region: &ConvexPolyhedron,
    pieces: &[Vec<DVec2>],
    eps: f64,
    frame: &Frame,
) -> Vec<ConvexPolyhedron> {
    let mut out = Vec::new();
    for piece in pieces {
        let mut cell = Some(region.clone());
        for (i, a) in piece.iter().enumerate() {
            let e = piece[(i + 1) % piece.len()] - *a;
            let n = frame.lift(DVec2::new(e.y, -e.x));
            let Some(pl) = Plane::from_point_normal(frame.lift(*a), n) else {
                continue;
            };
            cell = cell.and_then(|c| c.clip(&pl, eps));
        }
        out.extend(cell);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::hull::hull;

    /// The two triangles of the quad `a b c d` (counter-clockwise seen from its front).
    fn quad(a: DVec3, b: DVec3, c: DVec3, d: DVec3) -> [[DVec3; 3]; 2] {
        [[a, b, c], [a, c, d]]
    }

    /// An axis-aligned horizontal rectangle at height `y`.
    fn flat(x0: f64, z0: f64, x1: f64, z1: f64, y: f64) -> [[DVec3; 3]; 2] {
        quad(
            DVec3::new(x0, y, z0),
            DVec3::new(x1, y, z0),
            DVec3::new(x1, y, z1),
            DVec3::new(x0, y, z1),
        )
    }

    /// The four walls around [x0, x1] x [z0, z1], from `y0` to `y1`.
    fn walls(x0: f64, z0: f64, x1: f64, z1: f64, y0: f64, y1: f64) -> Vec<[DVec3; 3]> {
        let c = [(x0, z0), (x1, z0), (x1, z1), (x0, z1)];
        (0..4)
            .flat_map(|i| {
                let (a, b) = (c[i], c[(i + 1) % 4]);
                quad(
                    DVec3::new(a.0, y0, a.1),
                    DVec3::new(b.0, y0, b.1),
                    DVec3::new(b.0, y1, b.1),
                    DVec3::new(a.0, y1, a.1),
                )
            })
            .collect()
    }

    /// A 6 x 6 ring of floor and ceiling around a 2 x 2 hole through both, outer walls only:
    /// a Doom walkway around a pit whose own sector owns the pit's walls.
    fn walkway(ceiling: bool) -> Vec<[DVec3; 3]> {
        let mut t = walls(0.0, 0.0, 6.0, 6.0, 0.0, 3.0);
        for (x0, z0, x1, z1) in [
            (0.0, 0.0, 6.0, 2.0),
            (0.0, 4.0, 6.0, 6.0),
            (0.0, 2.0, 2.0, 4.0),
            (4.0, 2.0, 6.0, 4.0),
        ] {
            t.extend(flat(x0, z0, x1, z1, 0.0));
            if ceiling {
                t.extend(flat(x0, z0, x1, z1, 3.0));
            }
        }
        t
    }

    fn run(tris: &[[DVec3; 3]]) -> Option<Vec<ConvexPolyhedron>> {
        let pts: Vec<DVec3> = tris.iter().flatten().copied().collect();
        let h = hull(&pts, 1e-6).unwrap();
        cells(tris, &h, 1e-6, &Frame::new([0.0, 1.0, 0.0]))
    }

    #[test]
    fn a_walkway_around_a_pit_keeps_out_of_the_pit_column() {
        for ceiling in [true, false] {
            let cells = run(&walkway(ceiling)).expect("a prism");
            let volume: f64 = cells.iter().map(|c| c.volume()).sum();
            assert!((volume - 32.0 * 3.0).abs() < 1e-6, "{volume}");
            let pit = DVec3::new(3.0, 1.5, 3.0);
            assert!(cells.iter().all(|c| !c.contains(pit, 1e-6)));
            assert!(cells
                .iter()
                .any(|c| c.contains(DVec3::new(1.0, 1.5, 1.0), 1e-6)));
        }
    }

    #[test]
    fn a_box_room_is_its_hull() {
        let mut t = walls(0.0, 0.0, 4.0, 5.0, 0.0, 3.0);
        t.extend(flat(0.0, 0.0, 4.0, 5.0, 0.0));
        t.extend(flat(0.0, 0.0, 4.0, 5.0, 3.0));
        let cells = run(&t).expect("a prism");
        assert_eq!(cells.len(), 1);
        assert!((cells[0].volume() - 60.0).abs() < 1e-9);
    }

    #[test]
    fn the_ceiling_caps_walls_that_reach_past_it() {
        // Walls up to 5 m (a neighbour's sky), the ceiling at 3 m.
        let mut t = walls(0.0, 0.0, 4.0, 4.0, 0.0, 5.0);
        t.extend(flat(0.0, 0.0, 4.0, 4.0, 0.0));
        t.extend(flat(0.0, 0.0, 4.0, 4.0, 3.0));
        let cells = run(&t).expect("a prism");
        let volume: f64 = cells.iter().map(|c| c.volume()).sum();
        assert!((volume - 48.0).abs() < 1e-9, "{volume}");
    }

    #[test]
    fn steps_part_ceilings_and_slopes_are_not_prisms() {
        let base = || {
            let mut t = walls(0.0, 0.0, 4.0, 4.0, 0.0, 3.0);
            t.extend(flat(0.0, 0.0, 4.0, 4.0, 0.0));
            t
        };
        // A third level (a soffit's underside).
        let mut soffit = base();
        soffit.extend(flat(0.0, 0.0, 4.0, 2.0, 3.0));
        soffit.extend(flat(0.0, 2.0, 4.0, 4.0, 2.5));
        assert!(run(&soffit).is_none());
        // A ceiling over half the floor only.
        let mut half = base();
        half.extend(flat(0.0, 0.0, 4.0, 2.0, 3.0));
        assert!(run(&half).is_none());
        // A sloped ceiling.
        let mut slope = base();
        slope.extend(quad(
            DVec3::new(0.0, 3.0, 0.0),
            DVec3::new(4.0, 2.0, 0.0),
            DVec3::new(4.0, 2.0, 4.0),
            DVec3::new(0.0, 3.0, 4.0),
        ));
        assert!(run(&slope).is_none());
    }
}
