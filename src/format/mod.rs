//! The `PORTCULLIS_portals` glTF extension: what an engine needs at run time, and nothing a
//! level does not need (no transform on plain portals, no rooms array when every room is one
//! cell, no empty arrays). Documented in schemas/PORTCULLIS_portals.md and checked against
//! schemas/PORTCULLIS_portals.schema.json.
//!
//! This module owns the format: its records (`records`, one struct per schema object that
//! both reads and writes), how an annotation is built and serialized from a level
//! ([`mod@write`]), read back and validated ([`read`]), how the PVS is encoded ([`visibility`])
//! and the input hash that tells a stale annotation (`hash`). The exporters, the checks of
//! stored annotations and the runtime all go through it.

pub(crate) mod hash;
pub mod read;
pub(crate) mod records;
pub mod visibility;
pub mod write;

pub use hash::{input_hash, input_hash_like};
pub use read::{annotation, consistency};
pub use records::{Annotated, Bounds, CellRecord, PortalRecord, RoomRecord};
pub use write::{build, Annotation};
pub(crate) use write::{build_deferred, InputHash};

/// The extension's name, in `extensionsUsed` and as the key of its objects.
pub const NAME: &str = "PORTCULLIS_portals";
/// The format version written; readers refuse none, the schema pins it.
pub const VERSION: u64 = 1;
