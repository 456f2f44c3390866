//! Any bytes as a .gltf or .glb, and when they import, the whole pipeline and the write-back
//! in both containers: the streamed JSON rewrite (and its fallback) must return bytes or an
//! error, never panic, whatever the document holds.
#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;

mod stages;
use portcullis::export::gltf_out::OutFormat;
use portcullis::import::{import_bytes, sniff_format, ImportOptions};
use portcullis::scene::Format;

fuzz_target!(|data: &[u8]| {
    let format = sniff_format(data).unwrap_or(Format::Gltf);
    let Ok(imported) = import_bytes(
        data,
        Path::new("fuzz.gltf"),
        format,
        Path::new("/nonexistent"),
        &ImportOptions::default(),
    ) else {
        return;
    };
    let Some((tagged, cells, portals)) = stages::run(imported) else {
        return;
    };
    for (out, f) in [("fuzz.glb", OutFormat::Glb), ("fuzz.gltf", OutFormat::Gltf)] {
        let _ = portcullis::pipeline::write(&tagged, &cells, &portals, &portcullis::pipeline::WriteOptions::memory(Path::new(out), f));
    }
});
