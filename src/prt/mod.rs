//! Quake-family portal files (.prt): the cell graph `qbsp` writes for `vis`. Reading one gives
//! a [`crate::vis::VisGraph`], so the PVS stage runs on classic maps; writing one lets the
//! Quake tools run on a portcullis level.
//!
//! Formats: PRT1 (cells), PRT2 (clusters of leaves; the portal lines name clusters), PRT1-AM
//! (clusters, with a leaf-to-cluster table). Each portal line is one two-way portal whose plane
//! through points 0, 1, 2 — normal (p0 − p1) × (p2 − p1) — faces into its first cell.
//!
//! `read.rs` parses the three formats into a `PrtFile` and a `VisGraph` (each line two directed
//! portals; the three-point normal faces into the first cell, Newell's normal oriented by it);
//! counts are checked before anything is sized by them, and every problem is a `PRT_*` diagnostic
//! with its line. `write.rs` writes PRT1 from a `PortalSet` (the polygon reversed so the file's
//! normal faces into the first cell); one-way, closed and transformed portals cannot be said in PRT
//! and are left out with `PRT_EXPORT_DROPPED`. Invariant: export then import gives the same graph
//! and PVS.

pub mod read;
pub mod write;

pub use read::{parse, read, PrtFile, PrtFormat, PrtPortal};
pub use write::write;
