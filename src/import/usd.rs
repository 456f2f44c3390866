//! USD import (.usd, .usda, .usdc, .usdz).
//!
//! Built only with the `usd` cargo feature: USD's composition rules (references, payloads,
//! variants, instancing, layer formats) are far too large to re-implement, so portcullis embeds
//! Python with pyo3 and lets Pixar's own `usd-core` package compose the stage. The Python side
//! ([`usd/helper.py`](usd/helper.py)) only walks the composed stage and returns flat arrays;
//! every geometric decision (units, up axis, triangulation, holes, winding) is made in Rust
//! (`stage`) so that USD levels go through the same exact predicates as OBJ and glTF.
//!
//! Without the feature, a USD input gets one sentence on how to get support, so a plain build
//! never needs Python.
//!
//! `usd/python.rs` picks the venv (`--python-venv`, `VIRTUAL_ENV`, the repository's `.venv`), runs
//! `helper.py` (`include_str!`) and copies the result out through the buffer protocol. `helper.py`
//! only walks the stage: instance proxies included, a PointInstancer's prototypes once per visible
//! instance and never where they are defined, shading prims, lights, invisible and guide/proxy
//! subtrees left out; per prim it returns its path, name, nearest kept ancestor, world matrix, tags
//! as JSON (authored customData, not `GetCustomData()`, which adds schema docs; custom attributes)
//! and, once per prototype, the raw mesh arrays. `usd/stage.rs` makes every geometric decision:
//! Z-up to Y-up rotation, the unit scale put into positions and translations (so coordinates and
//! tolerances are metres), n-gons ear-clipped with the exact predicates, holes skipped, left-handed
//! faces flipped.
//!
//! Invariants: a Python exception is a diagnostic carrying its message, never a traceback or a
//! panic; one prim is one node, with its prim path as the source; a UsdLuxPortalLight never becomes
//! a node (it is a light, not a visibility portal).

use std::path::Path;

use super::{ImportOptions, Imported};
use crate::diag::{Code, Diagnostic, Location};

#[cfg(feature = "usd")]
mod python;
#[cfg(feature = "usd")]
pub(crate) mod stage;

/// The usd-core release the project tests against; the install hint names it, and
/// scripts/test.sh installs the same.
pub const USD_CORE_VERSION: &str = "26.11";

/// The command that makes the project's own venv, quoted in hints.
pub(crate) fn install_command() -> String {
    format!("python3 -m venv .venv && .venv/bin/pip install usd-core=={USD_CORE_VERSION}")
}

/// What a build without the `usd` feature says about a USD input.
#[cfg_attr(feature = "usd", allow(dead_code))]
fn unsupported_build(path: &Path) -> Diagnostic {
    Diagnostic::new(
        Code::USD_UNSUPPORTED_BUILD,
        format!(
            "`{}` is a USD file, and this portcullis was built without USD support",
            path.display()
        ),
        Location::file(path),
    )
    .hint(format!(
        "rebuild with `cargo build --features usd` (add `--release` for speed) after `{}`, or \
         export the level as glTF",
        install_command()
    ))
}

/// Without the `usd` feature: an error saying how to get USD support.
#[cfg(not(feature = "usd"))]
pub fn import(path: &Path, _opts: &ImportOptions) -> Result<Imported, Diagnostic> {
    Err(unsupported_build(path))
}

/// Reads a USD layer (.usd, .usda, .usdc, .usdz) through usd-core in the embedded Python:
/// composed, with instances expanded and units and up axis applied.
#[cfg(feature = "usd")]
pub fn import(path: &Path, opts: &ImportOptions) -> Result<Imported, Diagnostic> {
    if path == Path::new("-") {
        // usd-core opens layers by path (and resolves sublayers relative to it).
        return Err(Diagnostic::new(
            Code::USD_OPEN_FAILED,
            "USD cannot be read from standard input",
            Location::file(path),
        )
        .hint("pass the .usd/.usda/.usdc/.usdz file by its path"));
    }
    if let Err(e) = std::fs::metadata(path) {
        return Err(Diagnostic::new(
            Code::IO_READ_FAILED,
            format!("cannot read `{}`: {e}", path.display()),
            Location::file(path),
        )
        .hint("check the path and the file's permissions"));
    }
    let raw = python::read_stage(path, opts.python_venv.as_deref())?;
    Ok(stage::build(path, raw))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_build_without_usd_says_how_to_build_with_it() {
        let d = unsupported_build(Path::new("level.usda"));
        assert_eq!(d.code, Code::USD_UNSUPPORTED_BUILD);
        let hint = d.hint.unwrap();
        assert!(hint.contains("`cargo build --features usd`"), "{hint}");
        assert!(
            hint.contains(&format!("usd-core=={USD_CORE_VERSION}")),
            "{hint}"
        );
    }
}
