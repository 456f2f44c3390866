//! Atomic output: write a temporary file beside the target, flush it to disk, then rename it
//! over the target. A failure at any point leaves no half-written file (the temporary is
//! removed) and the target, if it existed, untouched.

use std::io::Write;
use std::path::Path;

/// The diagnostic for an output that could not be written (`OUTPUT_FAILED`): nothing was,
/// since every output goes through this module.
pub fn failed(path: &Path, e: impl std::fmt::Display) -> crate::diag::Diagnostic {
    crate::diag::Diagnostic::new(
        crate::diag::Code::OUTPUT_FAILED,
        format!("cannot write `{}`: {e}", path.display()),
        crate::diag::Location::file(path),
    )
    .hint("check that the folder exists and is writable; nothing was written")
}

/// Writes `bytes` to `path` atomically.
pub fn write(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    write_with(path, |f| f.write_all(bytes), |e| e)
}

/// Writes `path` atomically with `fill`, which gets the temporary file to write (and seek in):
/// a big output goes to disk as it is made instead of being held whole in memory first. Any
/// error of `fill`, or of the file (`io` turns those into `E`), leaves no file behind.
pub(crate) fn write_with<E>(
    path: &Path,
    fill: impl FnOnce(&mut std::fs::File) -> Result<(), E>,
    io: impl Fn(std::io::Error) -> E,
) -> Result<(), E> {
    let dir = path
        .parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let name = path.file_name().and_then(|n| n.to_str()).unwrap_or("out");
    let tmp = dir.join(format!(".{name}.{}.tmp", std::process::id()));
    let result = (|| {
        let mut f = std::fs::File::create(&tmp).map_err(&io)?;
        fill(&mut f)?;
        f.sync_all().map_err(&io)?;
        drop(f);
        std::fs::rename(&tmp, path).map_err(&io)
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_failed_write_leaves_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let ok = dir.path().join("a.glb");
        write(&ok, b"abc").unwrap();
        assert_eq!(std::fs::read(&ok).unwrap(), b"abc");
        // Renaming onto a directory fails after the temporary was written: it must be gone.
        let blocked = dir.path().join("sub");
        std::fs::create_dir(&blocked).unwrap();
        std::fs::write(blocked.join("x"), b"x").unwrap();
        assert!(write(&blocked, b"zzz").is_err());
        let left: Vec<_> = std::fs::read_dir(dir.path())
            .unwrap()
            .flatten()
            .map(|e| e.file_name())
            .collect();
        assert_eq!(left.len(), 2, "{left:?}");
        assert_eq!(std::fs::read(&ok).unwrap(), b"abc");
        // A fill that fails half-way leaves nothing either, and the old file as it was.
        let failed: Result<(), String> = write_with(
            &ok,
            |f| {
                f.write_all(b"half").map_err(|e| e.to_string())?;
                Err("the level could not be written".into())
            },
            |e| e.to_string(),
        );
        assert!(failed.is_err());
        assert_eq!(std::fs::read(&ok).unwrap(), b"abc");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 2);
    }
}
