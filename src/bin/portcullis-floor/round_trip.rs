//! The floor's one job, shared with `cargo bench --bench stages` (which includes this file).

use std::path::Path;

/// Reads the .glb at `input` with the gltf crate (the JSON parsed into its document) and writes
/// it back to `out`.
pub fn read_write(input: &Path, out: &Path) -> Result<(), String> {
    let bytes = std::fs::read(input).map_err(|e| e.to_string())?;
    let gltf::Gltf { document, blob } =
        gltf::Gltf::from_slice(&bytes).map_err(|e| e.to_string())?;
    // The document is consumed, not cloned: a program that only reads and writes needs no copy.
    let json = gltf::json::serialize::to_vec(&document.into_json()).map_err(|e| e.to_string())?;
    let glb = gltf::binary::Glb {
        header: gltf::binary::Header {
            magic: *b"glTF",
            version: 2,
            length: 0,
        },
        json: std::borrow::Cow::Owned(json),
        bin: blob.as_deref().map(std::borrow::Cow::Borrowed),
    };
    let written = glb.to_vec().map_err(|e| e.to_string())?;
    std::fs::write(out, written).map_err(|e| e.to_string())
}
