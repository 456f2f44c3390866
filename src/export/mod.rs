//! Files written from the pipeline's results, for people and for other tools.

pub mod debug;
pub mod svg;
