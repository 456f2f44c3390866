//! Any bytes as a brush map (.map): a scene or a diagnostic, never a panic.
#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use portcullis::import::{import_bytes, ImportOptions};
use portcullis::scene::Format;

fuzz_target!(|data: &[u8]| {
    let _ = import_bytes(
        data,
        Path::new("fuzz.map"),
        Format::Map,
        Path::new("/nonexistent"),
        &ImportOptions::default(),
    );
});
