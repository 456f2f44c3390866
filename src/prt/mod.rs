//! Quake-family portal files (.prt): the cell graph `qbsp` writes for `vis`. Reading one gives
//! a [`crate::vis::VisGraph`], so the PVS stage runs on classic maps; writing one lets the
//! Quake tools run on a portcullis level.
//!
//! Formats: PRT1 (cells), PRT2 (clusters of leaves; the portal lines name clusters), PRT1-AM
//! (clusters, with a leaf-to-cluster table). Each portal line is one two-way portal whose plane
//! through points 0, 1, 2 — normal (p0 − p1) × (p2 − p1) — faces into its first cell.

pub mod read;
pub mod write;

pub use read::{parse, read, PrtFile, PrtFormat, PrtPortal};
pub use write::write;

/// Whether a path names a portal file (by its extension, any case): inputs so named are read
/// as one, and an output so named is written as one.
pub fn is_prt(path: &std::path::Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("prt"))
}
