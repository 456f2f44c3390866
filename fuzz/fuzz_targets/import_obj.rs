//! Any bytes as an OBJ file: a scene or a diagnostic, never a panic.
#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use portcullis::import::{import_bytes, ImportOptions};
use portcullis::scene::Format;

fuzz_target!(|data: &[u8]| {
    let _ = import_bytes(
        data,
        Path::new("fuzz.obj"),
        Format::Obj,
        Path::new("/nonexistent"),
        &ImportOptions::default(),
    );
});
