//! Wavefront OBJ import.

use std::path::Path;

use super::{ImportOptions, Imported};
use crate::diag::{Code, Diagnostic, Location};

pub fn import(
    _bytes: &[u8],
    path: &Path,
    _base_dir: &Path,
    _opts: &ImportOptions,
) -> Result<Imported, Diagnostic> {
    Err(Diagnostic::new(
        Code::OBJ_BAD_STATEMENT,
        "OBJ import is not written yet",
        Location::file(path),
    ))
}
