//! glTF 2.0 import (.gltf and .glb).

use std::path::Path;

use super::Imported;
use crate::diag::{Code, Diagnostic, Location};

pub fn import(_bytes: &[u8], path: &Path, _base_dir: &Path) -> Result<Imported, Diagnostic> {
    Err(Diagnostic::new(
        Code::GLTF_INVALID_JSON,
        "glTF import is not written yet",
        Location::file(path),
    ))
}
