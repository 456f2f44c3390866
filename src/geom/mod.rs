//! f64 geometry primitives. Orientation decisions use exact predicates (`robust`).

pub mod aabb;
pub mod partition;
pub mod triangulate;
