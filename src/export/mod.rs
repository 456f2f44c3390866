//! Writing results: the annotated glTF with the `PORTCULLIS_portals` extension, written
//! atomically.

pub mod atomic;
pub mod extension;
pub mod gltf_out;
pub mod read;
