//! The whole pipeline (tags, cells, portals, checks, the annotated glTF) on small levels made
//! from the input: bytes become a few named objects of triangles with coordinates on a coarse
//! grid (so coplanar faces, shared walls and doorways are common, as in real levels), written
//! as OBJ and run like `portcullis convert`.
#![no_main]

use std::fmt::Write;
use std::path::Path;

use libfuzzer_sys::fuzz_target;

mod stages;
use portcullis::import::{import_bytes, ImportOptions};
use portcullis::scene::Format;

const NAMES: [&str; 8] = [
    "a-room/Walls",
    "b-room/Walls",
    "c-room/Walls",
    "a-room/b-portal",
    "b-room/Crate-detail",
    "a-room/Mirror-portal",
    "c-room/a-portal",
    "Loose",
];

fn level(data: &[u8]) -> String {
    let mut obj = String::new();
    let mut vertices = 0usize;
    let mut chunks = data.chunks_exact(10);
    for c in chunks.by_ref() {
        // Byte 0 picks the object; 1..10 are three vertices on a 0.5 m grid in 0..8 m.
        let _ = writeln!(obj, "o Level/{}", NAMES[(c[0] & 7) as usize]);
        for v in c[1..10].chunks_exact(3) {
            let q = |b: u8| f64::from(b % 17) * 0.5;
            let _ = writeln!(obj, "v {} {} {}", q(v[0]), q(v[1]), q(v[2]));
        }
        let _ = writeln!(obj, "f {} {} {}", vertices + 1, vertices + 2, vertices + 3);
        vertices += 3;
    }
    obj
}

fuzz_target!(|data: &[u8]| {
    if data.len() > 4000 {
        return;
    }
    let text = level(data);
    let Ok(imported) = import_bytes(
        text.as_bytes(),
        Path::new("fuzz.obj"),
        Format::Obj,
        Path::new("/nonexistent"),
        &ImportOptions::default(),
    ) else {
        return;
    };
    let Some((mut tagged, cells, portals)) = stages::run(imported) else {
        return;
    };
    portcullis::pipeline::check_level(&mut tagged, &cells, &portals, true);
    let _ = portcullis::pipeline::write(
        &tagged, &cells, &portals, &portcullis::pipeline::WriteOptions::memory(Path::new("fuzz.glb"), portcullis::export::gltf_out::OutFormat::Glb));
});
