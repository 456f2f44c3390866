//! `portcullis gen --rooms N -o OUT.glb`: a generated building for benchmarks, scale tests and
//! trying the tool without a level of one's own (see `portcullis::buildings`).

use std::path::PathBuf;

use clap::Args;

use portcullis::buildings::{self, GenOptions};
use portcullis::export::gltf_out;

#[derive(Debug, Args)]
pub struct GenArgs {
    /// Rooms in the building.
    #[arg(long, default_value_t = 10)]
    pub rooms: usize,

    /// Seed of the layout (sizes, doors, windows, L shapes); the same seed gives the same bytes.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,

    /// Leave out the furniture.
    #[arg(long)]
    pub no_props: bool,

    /// Output file (.glb or .gltf).
    #[arg(short, long, value_name = "OUT")]
    pub output: PathBuf,
}

pub fn run(a: &GenArgs) -> i32 {
    let Some(format) = portcullis::export::Target::from_path(&a.output).and_then(|t| t.gltf())
    else {
        eprintln!(
            "error[OUTPUT_FORMAT_UNKNOWN]: cannot write `{}`: portcullis writes .gltf and .glb",
            a.output.display()
        );
        return 2;
    };
    let scene = buildings::generate(&GenOptions {
        rooms: a.rooms.max(1),
        seed: a.seed,
        props: !a.no_props,
    });
    let bytes = gltf_out::write_plain(&scene, format);
    if let Err(e) = portcullis::export::atomic::write(&a.output, &bytes) {
        eprintln!(
            "error[OUTPUT_FAILED]: cannot write `{}`: {e}",
            a.output.display()
        );
        return 2;
    }
    let tris: usize = scene.meshes.iter().map(|m| m.triangles.len()).sum();
    eprintln!(
        "{}: {} rooms, {} triangles, {} bytes",
        a.output.display(),
        a.rooms.max(1),
        tris,
        bytes.len()
    );
    0
}
