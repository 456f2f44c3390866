//! f64 geometry primitives. Orientation decisions use exact predicates (`robust`); distances
//! are judged with the one tolerance policy in [`tolerance`].

pub mod aabb;
pub mod boolean2;
pub mod cover;
pub mod exact;
pub mod grid;
pub mod hull;
pub mod partition;
pub mod plane;
pub mod polyhedron;
pub mod ray_mesh;
pub mod tolerance;
pub mod triangulate;

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
