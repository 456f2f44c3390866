//! f64 geometry primitives. Orientation decisions use exact predicates (`robust`); distances
//! are judged with the one tolerance policy in [`tolerance`].
//!
//! The files: `tolerance.rs`, the one tolerance policy; `exact.rs`, the booleans' grid-snapped
//! vertices put back on the input vertices and edge crossings they came from; `plane.rs` (unit
//! normal and offset, the Newell plane of a polygon, the chord test for "same plane");
//! `polyhedron.rs`, convex polyhedra as outward planes plus counter-clockwise face polygons, built
//! only by clipping, with volume, containment, split, intersection and `simplified` (drops planes
//! whose removal moves no vertex more than the tolerance: f32 noise makes such facets); `hull.rs`
//! (parry's hull triangles, only their planes kept, each pushed out to the farthest input point,
//! rebuilt by clipping); `partition.rs`, 2D footprints: the union of projected triangles (i_overlay
//! on a fixed grid, so results repeat) and a near-optimal convex partition (spade CDT, two-corner
//! cuts, one cut per remaining reflex corner, merging with exact `orient2d` convexity tests; a ring
//! that is already convex is its own partition); `triangulate.rs`, ear clipping in a polygon's own
//! plane with `robust::orient2d`, so concave n-gons triangulate correctly and keep their winding;
//! `aabb.rs`, bounds; `grid.rs`, a uniform grid over boxes (about two buckets per box, never finer
//! than a typical box; `BoxGrid::index` keeps no boxes, for a million triangles whose boxes are
//! cheaper to recompute); `boolean2.rs`, i_overlay on a face's own grid, with its i32 engine when
//! every snapped point is within 2^29 grid steps and its i64 one beyond; `cover.rs`, "do these
//! convex covers leave any of this region uncovered?", used only one way: a region left with less
//! than eps² has no opening.

pub mod aabb;
pub(crate) mod boolean2;
pub(crate) mod cover;
pub mod crack;
pub(crate) mod exact;
pub(crate) mod grid;
pub(crate) mod hull;
pub mod partition;
pub mod plane;
pub mod polyhedron;
pub(crate) mod ray_mesh;
pub mod tolerance;
pub(crate) mod triangulate;
pub(crate) mod weld;

/// Shapes the geometry tests share.
#[cfg(test)]
pub(crate) mod shapes {
    use glam::DVec2;

    /// The axis-aligned rectangle (x0, y0)–(x1, y1), counter-clockwise.
    pub fn rect(x0: f64, y0: f64, x1: f64, y1: f64) -> Vec<DVec2> {
        vec![
            DVec2::new(x0, y0),
            DVec2::new(x1, y0),
            DVec2::new(x1, y1),
            DVec2::new(x0, y1),
        ]
    }
}
