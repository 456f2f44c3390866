//! f64 geometry primitives. Orientation decisions use exact predicates (`robust`); distances
//! are judged with the one tolerance policy in [`tolerance`].

pub mod aabb;
pub mod boolean2;
pub mod cover;
pub mod grid;
pub mod hull;
pub mod partition;
pub mod plane;
pub mod polyhedron;
pub mod tolerance;
pub mod triangulate;
