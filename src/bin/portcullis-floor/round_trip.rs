//! The floor's one job, shared with `cargo bench --bench stages` (which includes this file).

use std::path::{Path, PathBuf};

/// Why the floor's round trip failed.
#[derive(Debug, thiserror::Error)]
pub enum FloorError {
    /// The input could not be read.
    #[error("cannot read {}: {source}", path.display())]
    Read {
        path: PathBuf,
        source: std::io::Error,
    },
    /// The gltf crate rejected the input, or could not frame the output.
    #[error("{0}")]
    Gltf(#[from] gltf::Error),
    /// The document could not be serialised.
    #[error("cannot serialise the document: {0}")]
    Json(#[from] gltf::json::Error),
    /// The output could not be written.
    #[error("cannot write {}: {source}", path.display())]
    Write {
        path: PathBuf,
        source: std::io::Error,
    },
}

/// Reads the .glb at `input` with the gltf crate (the JSON parsed into its document) and writes
/// it back to `out`.
pub fn read_write(input: &Path, out: &Path) -> Result<(), FloorError> {
    let bytes = std::fs::read(input).map_err(|source| FloorError::Read {
        path: input.to_path_buf(),
        source,
    })?;
    let gltf::Gltf { document, blob } = gltf::Gltf::from_slice(&bytes)?;
    // The document is consumed, not cloned: a program that only reads and writes needs no copy.
    let json = gltf::json::serialize::to_vec(&document.into_json())?;
    let glb = gltf::binary::Glb {
        header: gltf::binary::Header {
            magic: *b"glTF",
            version: 2,
            length: 0,
        },
        json: std::borrow::Cow::Owned(json),
        bin: blob.as_deref().map(std::borrow::Cow::Borrowed),
    };
    let written = glb.to_vec()?;
    std::fs::write(out, written).map_err(|source| FloorError::Write {
        path: out.to_path_buf(),
        source,
    })
}
