#![warn(missing_docs)]
#![deny(unsafe_code)]
//! portcullis: cells and portals for game levels.
//!
//! The pipeline runs one way, each stage a module with one input and one output type plus
//! [`diag::Diagnostic`]s: [`import`] → [`scene::Scene`] → [`tags`] → rooms → cells → portals →
//! check → vis → export. See ARCHITECTURE.md for the map and each module's invariants.
//!
//! [`pipeline`] runs the stages as `portcullis convert` does:
//!
//! ```
//! use portcullis::pipeline;
//!
//! let mut level = pipeline::load("samples/two_rooms.gltf".as_ref(), &Default::default())?;
//! pipeline::check(&mut level, false);
//! let pvs = pipeline::pvs(&level, portcullis::vis::Method::Full);
//! println!("{} rooms, {} cells, {} portals", level.tagging().rooms.len(),
//!     level.cells.cells.len(), level.portals.portals.len());
//! assert!(pvs.sees(0, 0));
//! for d in level.diagnostics.iter() {
//!     println!("{d}");
//! }
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! An engine needs none of this: [`runtime`] loads what `convert` wrote and answers the
//! frame-time queries (which cell the camera is in, which cells and portals it sees).

pub mod auto;
pub mod bsp;
pub mod buildings;
pub mod cells;
pub mod check;
pub mod config;
pub mod diag;
pub(crate) mod disjoint;
pub mod export;
pub(crate) mod free;
pub mod geom;
pub mod import;
pub mod level;
pub mod pipeline;
pub mod portals;
pub mod prt;
pub mod report;
pub(crate) mod rng;
pub(crate) mod scc;
pub mod scene;
pub mod schema;
pub mod tags;
pub mod vis;

/// The extension's records and the frame-time runtime live in their own crate, `portcullis-runtime`,
/// which an engine links without the converter; they are re-exported here so the converter's
/// paths (`portcullis::format`, `portcullis::runtime`) stay one library.
pub use portcullis_runtime::{format, runtime};

/// The guide's examples, compiled and run as doctests (its engine example above all).
#[cfg(doctest)]
#[doc = include_str!("../docs/guide.md")]
struct GuideDoctests;
