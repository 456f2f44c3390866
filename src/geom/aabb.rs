//! Axis-aligned bounds.

use glam::DVec3;
use serde::Serialize;

/// An axis-aligned box in world space (m).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Aabb {
    /// The least corner.
    pub min: DVec3,
    /// The greatest corner; below `min` on some axis means empty.
    pub max: DVec3,
}

impl Aabb {
    /// Contains nothing; the identity of `union` and `add`.
    pub const EMPTY: Aabb = Aabb {
        min: DVec3::splat(f64::INFINITY),
        max: DVec3::splat(f64::NEG_INFINITY),
    };

    /// The smallest box holding every point (`EMPTY` for none).
    pub fn from_points<'a>(points: impl IntoIterator<Item = &'a DVec3>) -> Aabb {
        let mut b = Aabb::EMPTY;
        for p in points {
            b.add(*p);
        }
        b
    }
    /// Grows the box to hold `p`.
    pub fn add(&mut self, p: DVec3) {
        self.min = self.min.min(p);
        self.max = self.max.max(p);
    }
    /// The smallest box holding both.
    pub fn union(&self, o: &Aabb) -> Aabb {
        Aabb {
            min: self.min.min(o.min),
            max: self.max.max(o.max),
        }
    }
    /// The box grown by `pad` on every side.
    pub(crate) fn grown(&self, pad: f64) -> Aabb {
        Aabb {
            min: self.min - DVec3::splat(pad),
            max: self.max + DVec3::splat(pad),
        }
    }
    /// The points in both boxes (empty if none).
    pub fn intersection(&self, o: &Aabb) -> Aabb {
        Aabb {
            min: self.min.max(o.min),
            max: self.max.min(o.max),
        }
    }
    /// Whether the two boxes share a point (touching counts; an empty box meets nothing).
    pub(crate) fn meets(&self, o: &Aabb) -> bool {
        (0..3).all(|k| self.min[k] <= o.max[k] && self.max[k] >= o.min[k])
    }
    /// Distance from `p` to the box (0 inside).
    pub fn distance_to(&self, p: DVec3) -> f64 {
        (self.min - p).max(p - self.max).max(DVec3::ZERO).length()
    }
    /// True for a box holding no point (such as `EMPTY`).
    pub fn is_empty(&self) -> bool {
        self.min.x > self.max.x || self.min.y > self.max.y || self.min.z > self.max.z
    }
    /// Extent on each axis (m).
    pub fn size(&self) -> DVec3 {
        if self.is_empty() {
            DVec3::ZERO
        } else {
            self.max - self.min
        }
    }
}
