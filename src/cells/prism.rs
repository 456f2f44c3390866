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

use super::{plan_pieces, Frame};
use crate::geom::plane::Plane;
use crate::geom::polyhedron::{polygon_area, ConvexPolyhedron};

/// The cells of a room that is a prism along `frame.up`, or `None` when it is not one (or its
/// plan cannot be partitioned): then the 3D decomposition decides.
pub(crate) fn cells(
    tris: &[[DVec3; 3]],
    hull: &ConvexPolyhedron,
    eps: f64,
    extent: f64,
    frame: &Frame,
) -> Option<Vec<ConvexPolyhedron>> {
    let height = |p: &DVec3| p.dot(frame.up);
    // The flat triangles by level (within the tolerance of the first one there, in input
    // order); a prism has its floor on one level and perhaps its ceiling on another.
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
    let area = |ts: &[[DVec2; 3]]| -> f64 {
        ts.iter()
            .map(|t| 0.5 * (t[1] - t[0]).perp_dot(t[2] - t[0]).abs())
            .sum()
    };
    // The usual box room: floor and ceiling each fill the hull's face there, so the plan is
    // the hull's and the hull is the one cell (no plan partition needed).
    let fills = |ts: &[[DVec2; 3]], dir: DVec3| {
        hull.faces.iter().any(|f| {
            f.plane.normal.dot(dir) > 1.0 - 1e-9 && {
                let face = polygon_area(&f.points, f.plane.normal);
                (area(ts) - face).abs() <= 1e-9 * face + eps * face.sqrt()
            }
        })
    };
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
    let grid = (eps * 0.5).max(extent * 1e-9);
    let pieces = plan_pieces(plan, grid, eps).ok()?;
    let mut region = hull.clone();
    if let Some((f, c, top)) = slab {
        // The ceiling must cover the floor, no more and no less: a ceiling over part of the
        // floor (a soffit whose other part is missing) or beyond it is not a prism's.
        let plan_area = area(plan);
        let slack = eps * plan.iter().map(|t| t[0].distance(t[1])).sum::<f64>() + 1e-9 * plan_area;
        let inside = |q: DVec2| {
            pieces.iter().any(|piece| {
                piece.iter().enumerate().all(|(i, a)| {
                    let e = piece[(i + 1) % piece.len()] - *a;
                    e.perp_dot(q - *a) >= -eps * e.length()
                })
            })
        };
        if (area(top) - plan_area).abs() > slack
            || !top.iter().all(|t| inside((t[0] + t[1] + t[2]) / 3.0))
        {
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
    let mut out = Vec::new();
    for piece in &pieces {
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
    (!out.is_empty()).then_some(out)
}
