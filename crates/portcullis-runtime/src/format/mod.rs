//! The `PORTCULLIS_portals` glTF extension: what an engine needs at run time, and nothing a
//! level does not need (no transform on plain portals, no rooms array when every room is one
//! cell, no empty arrays). Documented in schemas/PORTCULLIS_portals.md and checked against
//! schemas/PORTCULLIS_portals.schema.json.
//!
//! This module is the floor an engine's runtime stands on, below everything else but the leaf
//! helpers: the records (`records`, one struct per schema object that both reads and writes),
//! reading an annotation back and validating what the schema cannot ([`read`]), the PVS
//! ([`Pvs`], [`Method`]) and its encodings ([`visibility`]), the GLB container ([`glb`]), and
//! [`FormatError`], why any of them cannot be read.
//! How an annotation is built from a level and written, and the input hash that tells a
//! stale one, are the exporter's (`portcullis::export`); the runtime depends on this module alone.

pub mod bits;
mod error;
pub mod glb;
pub(crate) mod pvs;
pub mod read;
pub mod records;
pub mod visibility;

pub use error::FormatError;
pub use pvs::{Method, Pvs, DEFAULT_TRANSFORM_DEPTH};
pub use read::{annotation, consistency};
pub use records::{
    Annotated, Bounds, CellRecord, GeneratedRecord, PortalRecord, RoomRecord, SplitPrimitive,
    SplitRecord,
};

/// The extension's name, in `extensionsUsed` and as the key of its objects.
pub const NAME: &str = "PORTCULLIS_portals";
/// The format version written; readers refuse none, the schema pins it.
pub const VERSION: u64 = 1;
