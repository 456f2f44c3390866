//! Any bytes as a .gltf (JSON) or .glb (by their first bytes): the importer must return a
//! scene or a diagnostic, never panic, and never allocate what the input only claims.
#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use portcullis::import::{import_bytes, sniff_format, ImportOptions};
use portcullis::scene::Format;

fuzz_target!(|data: &[u8]| {
    let format = sniff_format(data).unwrap_or(Format::Gltf);
    let _ = import_bytes(
        data,
        Path::new("fuzz.gltf"),
        format,
        Path::new("/nonexistent"),
        &ImportOptions::default(),
    );
});
