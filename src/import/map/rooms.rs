//! Which room each brush entity's brushes go in. The world's brushes (`worldspawn`,
//! `func_group`) make the rooms: `world`, or the `_portcullis_room` a `func_group` names. Every
//! other brush entity (a door, a lift, a `func_wall`, an area portal) stands in one of them, so
//! that a door stays a gate of the room whose air it fills: the room its own
//! `_portcullis_room` names, else the only room there is, else the smallest room whose
//! brushes' bounds hold its centre, else the nearest. A door left in an empty `world` while the
//! walls were grouped into `main` lost its cells and portals.

use std::borrow::Cow;

use glam::DVec3;

use super::brush;
use super::parse::{Brush, Entity};

/// The room of a map with no world brushes at all.
pub(super) const WORLD: &str = "world";

/// The rooms the world's brushes make, with their bounds (map units) when there are several.
pub(super) struct Rooms {
    names: Vec<String>,
    /// Per name: the bounds of its brushes; empty when there is one room or none.
    bounds: Vec<(DVec3, DVec3)>,
}

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
    /// The rooms of `entities`, in the order they first appear; bounds are read only when
    /// there is a choice to make.
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
            let empty = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
            boxes = vec![empty; names.len()];
            for e in entities.iter().filter(|e| !e.brushes.is_empty()) {
                let Some(n) = made_by(e) else { continue };
                let i = names.iter().position(|m| m == n).expect("named above");
                for b in &e.brushes {
                    if b.faces.len() > brush::MAX_BRUSH_FACES {
                        continue;
                    }
                    let b = placed(e, b);
                    if let Some((lo, hi)) =
                        brush::polygons(&b.faces).ok().as_deref().and_then(bounds)
                    {
                        boxes[i] = (boxes[i].0.min(lo), boxes[i].1.max(hi));
                    }
                }
            }
        }
        Rooms {
            names,
            bounds: boxes,
        }
    }

    /// The room of entity `e`, not part of the world, whose brushes' bounds are `at`.
    pub fn of(&self, e: &Entity, at: Option<(DVec3, DVec3)>) -> String {
        if let Some(n) = e.get("_portcullis_room") {
            return n.to_string();
        }
        let (Some((lo, hi)), false) = (at, self.bounds.is_empty()) else {
            return self.names.first().map_or(WORLD, String::as_str).to_string();
        };
        let c = (lo + hi) * 0.5;
        let volume = |(a, b): &(DVec3, DVec3)| (*b - *a).max(DVec3::ZERO).element_product();
        let gap = |(a, b): &(DVec3, DVec3)| (c - c.clamp(*a, *b)).length();
        let holding = (0..self.names.len())
            .filter(|&i| gap(&self.bounds[i]) == 0.0)
            .min_by(|&i, &j| volume(&self.bounds[i]).total_cmp(&volume(&self.bounds[j])));
        let i = holding.unwrap_or_else(|| {
            (0..self.names.len())
                .min_by(|&i, &j| gap(&self.bounds[i]).total_cmp(&gap(&self.bounds[j])))
                .expect("two rooms or more")
        });
        self.names[i].clone()
    }
}
