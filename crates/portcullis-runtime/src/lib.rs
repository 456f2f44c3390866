#![warn(missing_docs)]
#![deny(unsafe_code)]
//! The engine side of portcullis: what an engine links to read a level that `portcullis convert`
//! wrote and cull with it each frame, without the converter's dependencies.
//!
//! [`format`](mod@format) is the `PORTCULLIS_portals` glTF extension (its records, reading them back, the
//! PVS and its encodings); [`runtime`] loads a level from it and answers the frame-time
//! queries (the camera's cell, the cells and portals it sees, each visible cell's draw list).
//! The converter (`portcullis`) and the engine plugins (`portcullis-bevy`, and the JavaScript
//! port in `js/portcullis-three`, which follows the same rules, schemas/PORTCULLIS_portals.md)
//! stand on this crate; it stands on nothing of theirs.

pub mod format;
pub mod runtime;
