//! Writing results: the annotated glTF with the `PORTCULLIS_portals` extension, written
//! atomically, reading it back, the debug outputs (a glTF of cells and portals, an SVG plan,
//! the HTML viewer), and the annotated level as a USD layer.
//!
//! `extension.rs` builds the `PORTCULLIS_portals` root and node objects (numbers rounded to 1e-9 so
//! bytes repeat) and the input hash. `gltf_out.rs` writes a glTF input back from its original JSON
//! and buffer bytes, touching only what the container change needs, or builds a new glTF for OBJ
//! inputs (positions relative to each mesh's centre, the centre in the node's f64 translation);
//! `bake.rs` first puts node transforms into world-space mesh copies for a non-glTF input that
//! carries them (USD). For a glTF input `rewrite.rs` does the same without parsing the whole
//! document, copying through `transcode.rs` (parser straight to serializer); a document it declines
//! (a repeated key) is rewritten from its parsed form, and tests hold every output to the bytes of
//! `oracle.rs`, the simple whole-tree writer. The big
//! `cells` and `portals` arrays are serialized straight from the level (`format::write`), never
//! built as a JSON tree. A .glb's JSON chunk is rendered by `parallel.rs` (arrays a run of about 64
//! KB of elements at a time, `cells` and `portals` 256 elements at a time, a window of about 2 MB
//! at a time). Buffer views the rebase leaves as they are and nodes with nothing to strip or add
//! are transcoded, not parsed; an element whose text is already what its `Value` writes
//! (`transcode::is_compact_form`: no space, no escape, integers a `Value` keeps, floats the
//! serializer writes back the same, no repeated key) is copied as it is.
//!
//! The input hash (XXH3-64 over every input of the result: transforms, names, extras, materials,
//! positions and triangles as little-endian bytes, and the tag rules, `[cells]` and `[portals]`
//! carried in `Tagging::settings`, written `xxh3v2:`; an earlier build's `xxh3:` or `fnv1a64:` hash
//! is recomputed by its own narrower definition, so it does not read as stale) runs on a thread of
//! its own during the write and is put in by a deferred source when the writer reaches the root
//! extension object (`format::InputHash`); the input's root members are scanned while the
//! annotation is built when the importer did not keep where they lie; `format::build` alone
//! still computes the hash before returning.
//!
//! `atomic.rs`: temporary file, fsync, rename; a failure removes the temporary; `write_with` lets
//! the writer fill the temporary as it goes (`sink.rs`: a .glb's JSON chunk is streamed and its
//! length patched into the header afterwards; a released BIN chunk is copied file to file by the
//! kernel, `copy_file_range`, through `Sink::copy_from`), so an output is never held whole in
//! memory. `read.rs` reads an annotation back as typed data and checks what the schema cannot
//! (indices, partners). `visibility.rs` writes and reads the PVS. `debug.rs` writes the cells and
//! portals as a plain glTF (hand-written GLB, f32 bounds from the written values); `svg.rs` the
//! top-down map; `view/` the HTML page; `usd_out.rs` the `.usda` layer.
//!
//! Invariants: the extension is in `extensionsUsed` only; a re-annotated file replaces the earlier
//! annotation; everything not ours is kept; the `.usda` layer reads back through usd-core to the
//! same rooms, cells and portals, and output bytes repeat for the same input.

pub(crate) mod annotation;
pub mod atomic;
pub(crate) mod bake;
pub(crate) mod container;
pub mod debug;
pub mod gltf_out;
pub(crate) mod hash;
#[cfg(test)]
mod oracle;
pub mod output;
pub(crate) mod parallel;
pub(crate) mod parts;
pub(crate) mod rewrite;
pub(crate) mod sink;
pub mod svg;
pub mod target;
pub(crate) mod transcode;
pub(crate) mod usd_out;
pub mod view;

pub use annotation::{build, build_as, Annotation, CellGeometry};
pub(crate) use annotation::{build_deferred, InputHash};
pub use hash::{input_hash, input_hash_like};
pub use target::{OutFormat, Target};
