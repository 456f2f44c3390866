//! USD import. Built only with the `usd` cargo feature (through Pixar's usd-core via pyo3);
//! without it, a USD input gets one clear sentence on how to get support.

use std::path::Path;

use super::{ImportOptions, Imported};
use crate::diag::{Code, Diagnostic, Location};

pub fn import(path: &Path, _opts: &ImportOptions) -> Result<Imported, Diagnostic> {
    Err(Diagnostic::new(
        Code::USD_UNSUPPORTED_BUILD,
        format!(
            "`{}` is a USD file, and this portcullis was built without USD support",
            path.display()
        ),
        Location::file(path),
    )
    .hint("rebuild with `cargo build --release --features usd`, or export the level as glTF"))
}
