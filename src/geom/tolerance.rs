//! The one tolerance policy every geometric decision uses.
//!
//! A distance epsilon must never be finer than the input can express (an f32 position stored
//! 10 km from its node's origin is only good to about a millimetre, so two walls "1e-5 m apart"
//! there are the same wall; an OBJ written with six significant digits is good to its sixth
//! digit, whatever f64 reads it into; a node's translation loses nothing, its scale scales
//! the spacing) and never coarser than the user allows (`[cells] max_tolerance`, 1 mm by
//! default), or doors would silently close. Between those bounds we take the input precision
//! with a safety factor, and a floor of 1e-9 of the level's extent so f64 arithmetic noise of
//! the geometry itself is always absorbed. Angles are judged separately (normals within
//! `angle` radians are parallel) because a distance test alone over-trusts huge faces.
//!
//! The rules, each a function here so no module spells a threshold of its own:
//! - two features each within the tolerance of one place [touch](Tolerance::touching) within
//!   twice it ([`TOUCH`]);
//! - unit normals within [`ANGLE`] (1e-5 rad, compared as the chord between them) are
//!   [parallel](Tolerance::parallel), [aligned](Tolerance::aligned) either way, or
//!   [facing](Tolerance::facing) each other; a face's direction is [square](Tolerance::square)
//!   to another's within it; two edges in a plane lie [along](Tolerance::along) one line when
//!   their sine is under it; two planes are [coplanar](Tolerance::coplanar) when their normals
//!   are parallel and their offsets within a distance. The angle does not scale with the
//!   level: two walls that meet at a door and differ by half of it face each other and the door
//!   is found; by twice it they do not, and it is not, even where every point of one is within
//!   the distance tolerance of the other (tests/angle_tolerance.rs).
//! - one exception, [`RECOMPUTED`] (1e-9 rad, [`Tolerance::recomputed`]): where one of two
//!   planes is dropped for the other across a whole cell, only rounding may part them.
//! - any other small number in the geometry is a named constant saying why it is not a
//!   tolerance (a grid size, a budget, a margin over f64 rounding).

use glam::{DVec2, DVec3};
use serde::Serialize;

use crate::geom::plane::Plane;

/// Default cap on the distance tolerance, metres.
pub(crate) const DEFAULT_MAX_DISTANCE: f64 = 1e-3;
/// The floor of the distance tolerance as a share of the level's extent: f64 arithmetic on
/// the geometry itself (a plane through three points, a point turned by the world matrix)
/// loses a few ulps of the coordinates, about 1e-15 of them, and a factor of a million over
/// that is still far under any precision a file stores.
const NOISE_FLOOR: f64 = 1e-9;
/// How many epsilons of the largest world coordinate its f64 rounding may move a point (see
/// [`Tolerance::derive`]).
const WORLD_ULPS: f64 = 64.0;
/// The smallest distance tolerance, metres, for a level of no extent (one point): a zero
/// tolerance would make every comparison exact, and no two computations of one point agree
/// to the bit.
const SMALLEST_DISTANCE: f64 = 1e-12;
/// The extent (m) [`Tolerance::volume`] measures a level of no extent by, so its threshold
/// is never zero.
const SMALLEST_EXTENT: f64 = 1e-9;
/// Normals closer than this (radians) are parallel. The one angle every angle test reads,
/// through [`Tolerance::parallel`], [`Tolerance::coplanar`] and their kin; `Tolerance::angle`
/// reports it.
pub const ANGLE: f64 = 1e-5;
/// Normals closer than this (radians) are one plane computed twice (from other points of it,
/// or copied), which differ by rounding only. Not the angle tolerance: where one of two planes
/// is dropped for the other (a hull's face triangles, a cut's cap against a face already
/// there), planes [`ANGLE`] apart would leave or add a wedge `ANGLE` times the cell's size
/// thick, more than the distance tolerance on a cell tens of metres across, and the cells of
/// generated levels moved (issue 71). [`ANGLE`] judges whether faces are parallel (they face
/// each other, they pair), not whether one plane may stand for another across a whole cell.
pub const RECOMPUTED: f64 = 1e-9;
/// Two features each within the distance tolerance of one place are within twice it of each
/// other: the multiple for "touching" (a face on a plane another face lies on, a point on a
/// face of a cell built from other points).
pub const TOUCH: f64 = 2.0;

/// How close is "the same" for one level, from the precision its file stored.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Tolerance {
    /// Points closer than this are the same point; a point closer than this to a plane is on it.
    pub distance: f64,
    /// Normals closer than this (radians) are parallel.
    pub angle: f64,
    /// What the input's own precision asked for (before the cap), for reporting.
    pub input_precision: f64,
    /// True when the input was coarser than the cap allows (results may merge close features).
    pub capped: bool,
}

impl Tolerance {
    /// `extent`: the level's bounding-box diagonal; `spacing`: the spacing of the stored
    /// coordinates where they are largest (`scene::Precision::spacing`: an f32 ulp, the last
    /// digit of decimal text), each node's times its world scale (that is where the file lost
    /// precision: a translation the f64 world matrix holds exactly adds nothing), the
    /// largest over the level; `steps`: how many of those two stored copies of one point may
    /// be apart (`scene::Precision::steps`); `world_abs`: the largest world coordinate, whose
    /// f64 rounding is the last bound: 64 epsilons of it (32 to 64 ulps), as a point turned,
    /// scaled and moved far out, then measured against a plane as far out, comes within a few
    /// ulps of where it should, and two copies of one vertex must not fall either side of a
    /// plane (at four, a small room far out lost a corner of a face and part of a cell's
    /// volume; tests/cells_props.rs).
    pub(crate) fn derive(
        extent: f64,
        spacing: f64,
        steps: f64,
        world_abs: f64,
        max_distance: f64,
    ) -> Tolerance {
        let input_precision =
            (steps * spacing.max(0.0)).max(WORLD_ULPS * f64::EPSILON * world_abs.max(0.0));
        let floor = NOISE_FLOOR * extent.max(0.0);
        let wanted = input_precision.max(floor).max(SMALLEST_DISTANCE);
        let capped = wanted > max_distance;
        Tolerance {
            distance: wanted.min(max_distance),
            angle: ANGLE,
            input_precision,
            capped,
        }
    }

    /// Volumes below this are empty: a slab of tolerance thickness over the extent squared.
    pub fn volume(&self, extent: f64) -> f64 {
        self.distance * extent.max(SMALLEST_EXTENT).powi(2)
    }

    /// The distance within which two features, each within `eps` of one place, touch.
    pub fn touching(eps: f64) -> f64 {
        TOUCH * eps
    }

    /// Unit normals `a` and `b` point the same way within [`ANGLE`] (the chord between them
    /// is compared, not the dot product, whose rounding near 1 hides angles under 1e-8 rad).
    pub fn parallel(a: DVec3, b: DVec3) -> bool {
        (a - b).length_squared() <= ANGLE * ANGLE
    }

    /// Unit normals `a` and `b` point opposite ways within [`ANGLE`]: two faces that face each
    /// other (the two sides of a wall, of a portal).
    pub fn facing(a: DVec3, b: DVec3) -> bool {
        Tolerance::parallel(a, -b)
    }

    /// Unit normals `a` and `b` lie on one line, either way, within [`ANGLE`].
    pub fn aligned(a: DVec3, b: DVec3) -> bool {
        Tolerance::parallel(a, b) || Tolerance::parallel(a, -b)
    }

    /// Unit normals `a` and `b` are square to each other within [`ANGLE`].
    pub fn square(a: DVec3, b: DVec3) -> bool {
        a.dot(b).abs() <= ANGLE
    }

    /// `p` and `q` are one plane computed twice, facing one way: normals within
    /// [`RECOMPUTED`], offsets within `dist`. For dropping one plane for the other.
    pub fn recomputed(p: &Plane, q: &Plane, dist: f64) -> bool {
        p.same_as(q, dist, RECOMPUTED)
    }

    /// Directions `u` and `v` in a plane (any length, not zero) lie along one line, either way,
    /// within [`ANGLE`]: two edges along one wall, which cross nowhere that means anything.
    /// Their sine is compared, which (unlike the cosine) keeps its precision near 0.
    pub fn along(u: DVec2, v: DVec2) -> bool {
        u.perp_dot(v).abs() <= ANGLE * u.length() * v.length()
    }

    /// `p` and `q` are one plane, facing one way: normals within [`ANGLE`], offsets within
    /// `dist` (a distance tolerance or a named multiple of it).
    pub fn coplanar(p: &Plane, q: &Plane, dist: f64) -> bool {
        p.same_as(q, dist, ANGLE)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::scene::Precision;

    fn derive(extent: f64, max_abs: f64, world_abs: f64, p: Precision, cap: f64) -> Tolerance {
        Tolerance::derive(extent, p.spacing(max_abs), p.steps(), world_abs, cap)
    }

    #[test]
    fn f32_far_from_origin_is_coarse_and_capped() {
        // 10 km out, f32: about 1 mm per ulp.
        let f32 = Precision::Binary32;
        let t = derive(100.0, 10_000.0, 10_000.0, f32, DEFAULT_MAX_DISTANCE);
        assert!(t.input_precision > 1e-3);
        assert!(t.capped);
        assert_eq!(t.distance, DEFAULT_MAX_DISTANCE);
        // A room near the origin keeps a fine tolerance.
        let t = derive(20.0, 10.0, 10.0, f32, DEFAULT_MAX_DISTANCE);
        assert!(t.distance < 3e-5 && t.distance > 1e-6, "{}", t.distance);
        assert!(!t.capped);
        // Double precision is much finer.
        let t = derive(20.0, 10.0, 10.0, Precision::Binary64, DEFAULT_MAX_DISTANCE);
        assert!(t.distance < 1e-7);
    }

    #[test]
    fn decimal_text_is_as_good_as_its_last_digit() {
        // Six significant digits (`%g`) at coordinates up to 7.5: 1e-5 apart.
        assert_eq!(Precision::Decimal(6).spacing(7.5), 1e-5);
        assert_eq!(Precision::Decimal(6).spacing(10.0), 1e-4);
        assert_eq!(Precision::Decimal(6).spacing(0.5), 1e-6);
        // Seventeen digits hold what a double holds, and no more.
        let full = Precision::Decimal(17).spacing(7.5);
        assert_eq!(full, Precision::Binary64.spacing(7.5));
        let t = derive(20.0, 7.5, 7.5, Precision::Decimal(6), DEFAULT_MAX_DISTANCE);
        assert_eq!(t.distance, 8e-5);
        // f32 allows for the exporter's own f32 arithmetic: sixteen ulps.
        let t = derive(20.0, 8.0, 8.0, Precision::Binary32, DEFAULT_MAX_DISTANCE);
        assert_eq!(t.distance, 16.0 * 8.0 * f32::EPSILON as f64);
    }

    #[test]
    fn scales_with_the_level() {
        let f32 = Precision::Binary32;
        let a = derive(10.0, 10.0, 10.0, f32, 1.0);
        let b = derive(10_000.0, 10_000.0, 10_000.0, f32, 1.0);
        assert!((b.distance / a.distance - 1000.0).abs() < 1e-6);
    }

    #[test]
    fn a_far_translation_adds_only_f64_rounding() {
        // A 10 m f32 mesh placed 2^20 m out keeps its own precision.
        let near = derive(15.0, 10.0, 10.0, Precision::Binary32, 1e-3);
        let far = derive(15.0, 10.0, 1_048_586.0, Precision::Binary32, 1e-3);
        assert_eq!(near, far);
        assert!(!far.capped);
    }
}
