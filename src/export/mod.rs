//! Writing results: the annotated glTF with the `PORTCULLIS_portals` extension, written
//! atomically, reading it back, the debug outputs (a glTF of cells and portals, an SVG plan,
//! the HTML viewer), and the annotated level as a USD layer.

pub mod atomic;
pub mod bake;
pub mod debug;
pub mod gltf_out;
pub(crate) mod parallel;
pub(crate) mod rewrite;
pub mod sink;
pub mod svg;
pub(crate) mod transcode;
pub mod usd_out;
pub mod view;
