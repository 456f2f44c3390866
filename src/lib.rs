#![warn(missing_docs)]
//! portcullis: cells and portals for game levels.
//!
//! The pipeline runs one way, each stage a module with one input and one output type plus
//! [`diag::Diagnostic`]s: [`import`] → [`scene::Scene`] → [`tags`] → rooms → cells → portals →
//! check → vis → export. See ARCHITECTURE.md for the map and each module's invariants.

pub mod cells;
pub mod check;
pub mod config;
pub mod diag;
pub mod export;
pub mod format;
pub mod free;
pub mod gen;
pub mod geom;
pub mod import;
pub mod level;
pub mod pipeline;
pub mod portals;
pub mod prt;
pub mod report;
pub(crate) mod rng;
pub mod runtime;
pub(crate) mod scc;
pub mod scene;
pub mod schema;
pub mod tags;
pub mod vis;

/// The guide's examples, compiled and run as doctests (its engine example above all).
#[cfg(doctest)]
#[doc = include_str!("../docs/guide.md")]
struct GuideDoctests;
