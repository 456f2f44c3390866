//! Which room each brush entity's brushes go in. The world's brushes (`worldspawn`,
//! `func_group`) make the rooms: `world`, or the `_portcullis_room` a `func_group` names. Every
//! other brush entity (a door, a lift, a `func_wall`, an area portal) stands in one of them, so
//! that a door stays a gate of the room whose air it fills: the room its own
//! `_portcullis_room` names, else the only room there is, else the room with the most brushes
//! touching it, then the nearest brush. A door left in an empty `world` while the
//! walls were grouped into `main` lost its cells and portals.

use std::borrow::Cow;

use glam::DVec3;

use super::brush;
use super::parse::{Brush, Entity};

/// The room of a map with no world brushes at all.
pub(super) const WORLD: &str = "world";

/// The rooms the world's brushes make, with their brushes' boxes (map units) when there are
/// several.
pub(super) struct Rooms {
    names: Vec<String>,
    /// Per name: the boxes of its brushes; empty when there is one room or none.
    boxes: Vec<Vec<(DVec3, DVec3)>>,
}

/// Map units within which a brush touches an entity's box (qbsp's tiny-portal epsilon).
const TOUCH: f64 = 0.2;

/// The room an entity's brushes make, when it is part of the world.
pub(super) fn made_by(e: &Entity) -> Option<&str> {
    match e.classname() {
        "worldspawn" => Some(WORLD),
        "func_group" => Some(e.get("_portcullis_room").unwrap_or(WORLD)),
        _ => None,
    }
}

/// Brush `b` of entity `e` where the world has it: id Tech 4 writes an entity's brushes about
/// its origin.
pub(super) fn placed<'b>(e: &Entity, b: &'b Brush) -> Cow<'b, Brush> {
    let offset = (e.classname() != "worldspawn")
        .then(|| e.get("origin").and_then(super::parse_vec3))
        .flatten()
        .unwrap_or(DVec3::ZERO);
    if !b.relative || offset == DVec3::ZERO {
        return Cow::Borrowed(b);
    }
    let mut m = b.clone();
    for f in &mut m.faces {
        f.dist += DVec3::from_array(f.normal).dot(offset);
    }
    Cow::Owned(m)
}

/// The bounds of a brush's corners; `None` when it encloses nothing (the import reports it).
pub(super) fn bounds(rings: &[(Vec<DVec3>, usize)]) -> Option<(DVec3, DVec3)> {
    let mut pts = rings.iter().flat_map(|(r, _)| r.iter().copied()).peekable();
    pts.peek()?;
    Some(pts.fold(
        (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
        |(lo, hi), p| (lo.min(p), hi.max(p)),
    ))
}

impl Rooms {
    /// The rooms of `entities`, in the order they first appear; their brushes' boxes are read
    /// only when there is a choice to make.
    pub fn read(entities: &[Entity]) -> Rooms {
        let mut names: Vec<String> = Vec::new();
        for e in entities.iter().filter(|e| !e.brushes.is_empty()) {
            if let Some(n) = made_by(e) {
                if !names.iter().any(|m| m == n) {
                    names.push(n.to_string());
                }
            }
        }
        let mut boxes = Vec::new();
        if names.len() > 1 {
            boxes = vec![Vec::new(); names.len()];
            for e in entities.iter().filter(|e| !e.brushes.is_empty()) {
                let Some(n) = made_by(e) else { continue };
                let i = names.iter().position(|m| m == n).expect("named above");
                for b in e
                    .brushes
                    .iter()
                    .filter(|b| b.faces.len() <= brush::MAX_BRUSH_FACES)
                {
                    let b = placed(e, b);
                    boxes[i].extend(brush::polygons(&b.faces).ok().as_deref().and_then(bounds));
                }
            }
        }
        Rooms { names, boxes }
    }

    /// The room of entity `e`, not part of the world, whose brushes' bounds are `at`: the room
    /// with the most brushes touching it (a door's jambs, lintel and sill are its wall's), then
    /// the one with the nearest brush, then the first. Only brushes at the entity count, so a
    /// block far away, a ground plane or a thicker wall elsewhere cannot move it.
    pub fn of(&self, e: &Entity, at: Option<(DVec3, DVec3)>) -> String {
        if let Some(n) = e.get("_portcullis_room") {
            return n.to_string();
        }
        let (Some((lo, hi)), false) = (at, self.boxes.is_empty()) else {
            return self.names.first().map_or(WORLD, String::as_str).to_string();
        };
        let gap = |(a, b): &(DVec3, DVec3)| (lo - *b).max(*a - hi).max(DVec3::ZERO).length();
        let score = |i: usize| {
            let touching = self.boxes[i].iter().filter(|b| gap(b) <= TOUCH).count();
            let nearest = self.boxes[i].iter().map(gap).fold(f64::INFINITY, f64::min);
            (touching, nearest)
        };
        let scores: Vec<(usize, f64)> = (0..self.names.len()).map(score).collect();
        let best = (0..self.names.len())
            .min_by(|&i, &j| {
                (scores[j].0.cmp(&scores[i].0)).then(scores[i].1.total_cmp(&scores[j].1))
            })
            .expect("two rooms or more");
        self.names[best].clone()
    }
}
