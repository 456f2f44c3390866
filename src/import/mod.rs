//! Importers: turn a file into a [`Scene`]. One module per format; each returns either a scene
//! plus the non-fatal diagnostics found while reading, or one fatal diagnostic that says why the
//! file cannot be read at all (the CLI maps that to exit code 2).
//!
//! Importers never panic on hostile input: sizes claimed by a file are checked against the bytes
//! actually present before anything is allocated.
//!
//! A big file is read a part per thread into one buffer (`read_file`: positioned reads, the same
//! bytes as `std::fs::read`).

use std::borrow::Cow;
use std::path::{Path, PathBuf};

use crate::diag::{Code, Diagnostic, Diagnostics, Location};
use crate::scene::{Format, Scene};

pub mod gltf;
pub mod map;
pub(crate) mod obj;
pub mod usd;

/// Options shared by the importers.
#[derive(Debug, Clone)]
pub struct ImportOptions {
    /// OBJ: treat `/` in object and group names as a hierarchy (`Level/room_a/Floor` becomes
    /// nodes `Level` > `room_a` > `Floor`), as exporters that flatten a scene tree write them.
    pub obj_split_paths: bool,
    /// USD: the Python venv holding usd-core (`--python-venv`); else `VIRTUAL_ENV`, else the
    /// project's own `.venv`. Unused by other formats and by builds without the `usd` feature.
    pub python_venv: Option<PathBuf>,
    /// Brush maps: metres per map unit (`[import] map_scale`); `None`: Quake's inch.
    pub map_scale: Option<f64>,
}

impl Default for ImportOptions {
    fn default() -> Self {
        ImportOptions {
            obj_split_paths: true,
            python_venv: None,
            map_scale: None,
        }
    }
}

/// A successfully read scene and what was noticed while reading it.
#[derive(Debug, Clone)]
pub struct Imported {
    /// The level as read.
    pub scene: Scene,
    /// What was noticed while reading (dropped triangles, unsupported features).
    pub diagnostics: Diagnostics,
}

/// The format implied by a path's extension.
pub(crate) fn format_from_path(path: &Path) -> Option<Format> {
    let ext = path.extension()?.to_str()?.to_ascii_lowercase();
    match ext.as_str() {
        "gltf" => Some(Format::Gltf),
        "glb" => Some(Format::Glb),
        "obj" => Some(Format::Obj),
        "usd" | "usda" | "usdc" | "usdz" => Some(Format::Usd),
        "map" => Some(Format::Map),
        _ => None,
    }
}

/// The format implied by the first bytes, for inputs without a telling extension (stdin).
pub fn sniff_format(bytes: &[u8]) -> Option<Format> {
    if crate::format::glb::is_glb(bytes) {
        return Some(Format::Glb);
    }
    if bytes.starts_with(b"#usda") || bytes.starts_with(b"PXR-USDC") {
        return Some(Format::Usd);
    }
    let head = &bytes[..bytes.len().min(64)];
    let first = head.iter().find(|b| !b.is_ascii_whitespace());
    if first == Some(&b'{') {
        return Some(Format::Gltf);
    }
    None
}

/// Reads a level file from disk.
/// The file's bytes, as `std::fs::read` gives them. A big file is read a part per thread with
/// positioned reads into one buffer: copying it out of the page cache, and the faults on the
/// new buffer's pages, are the first cost of a big import, and they split.
fn read_file(path: &Path) -> std::io::Result<Vec<u8>> {
    #[cfg(unix)]
    {
        use rayon::prelude::*;
        use std::io::{Read, Seek, SeekFrom};
        use std::os::unix::fs::FileExt;
        let mut f = std::fs::File::open(path)?;
        let len = f.metadata()?.len();
        let threads = rayon::current_num_threads();
        if len >= 16 << 20 && threads > 1 {
            let len = usize::try_from(len).map_err(std::io::Error::other)?;
            let mut bytes = vec![0u8; len];
            let part = len.div_ceil(threads);
            let read = bytes
                .par_chunks_mut(part)
                .enumerate()
                .try_for_each(|(k, p)| f.read_exact_at(p, (k * part) as u64));
            match read {
                Ok(()) => {
                    // A file that grew meanwhile keeps its tail, as a plain read would.
                    f.seek(SeekFrom::Start(len as u64))?;
                    f.read_to_end(&mut bytes)?;
                    return Ok(bytes);
                }
                // It shrank while being read: read it again whole.
                Err(e) if e.kind() == std::io::ErrorKind::UnexpectedEof => {}
                Err(e) => return Err(e),
            }
        }
    }
    std::fs::read(path)
}

/// Reads the level at `path`, its format told by the extension; the stages start here.
pub fn import_path(path: &Path, opts: &ImportOptions) -> Result<Imported, Diagnostic> {
    let is_prt = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("prt"));
    if is_prt {
        // A portal file is cells and portals without the level's geometry: nothing to build
        // cells from, to check against or to draw.
        return Err(Diagnostic::new(
            Code::INPUT_FORMAT_UNKNOWN,
            format!(
                "`{}` is a Quake portal file (.prt): it holds a level's cells and portals but not its geometry, so it cannot be converted, checked or viewed",
                path.display()
            ),
            Location::file(path),
        )
        .hint(format!(
            "`portcullis vis {0}` computes its PVS and `portcullis inspect {0}` summarises it; give the level it came from (the .map, or a glTF or OBJ) to the other commands",
            path.display()
        )));
    }
    let format = format_from_path(path).ok_or_else(|| {
        Diagnostic::new(
            Code::INPUT_FORMAT_UNKNOWN,
            format!(
                "cannot tell the format of `{}` from its extension",
                path.display()
            ),
            Location::file(path),
        )
        .hint("use a .gltf, .glb, .obj, .map, .usd, .usda, .usdc or .usdz file")
    })?;
    if format == Format::Usd {
        return usd::import(path, opts).map(|i| note_empty(i, path));
    }
    let bytes = read_file(path).map_err(|e| {
        Diagnostic::new(
            Code::IO_READ_FAILED,
            format!("cannot read `{}`: {e}", path.display()),
            Location::file(path),
        )
        .hint("check the path and the file's permissions")
    })?;
    let base_dir = path
        .parent()
        .map(Path::to_path_buf)
        .unwrap_or_else(|| PathBuf::from("."));
    // Owned: the importer lets the file go once it has the parts it keeps, before the level's
    // geometry is built (on a big level, the file is a fifth of the peak memory).
    let reread =
        std::fs::metadata(path).is_ok_and(|m| m.is_file() && m.len() == bytes.len() as u64);
    let mut imported = import_cow(Cow::Owned(bytes), path, format, &base_dir, opts, reread)?;
    if let (Some(src), Ok(meta)) = (imported.scene.gltf.as_mut(), std::fs::metadata(path)) {
        src.release_bin(&meta);
    }
    Ok(imported)
}

/// Reads a level from bytes already in memory; `path` is used for messages and `base_dir` to
/// resolve external files (glTF buffers, OBJ material libraries).
pub fn import_bytes(
    bytes: &[u8],
    path: &Path,
    format: Format,
    base_dir: &Path,
    opts: &ImportOptions,
) -> Result<Imported, Diagnostic> {
    import_cow(Cow::Borrowed(bytes), path, format, base_dir, opts, false)
}

/// `reread`: `bytes` are the whole of the regular file at `path` (the importer may let parts go
/// and read them again).
fn import_cow(
    bytes: Cow<'_, [u8]>,
    path: &Path,
    format: Format,
    base_dir: &Path,
    opts: &ImportOptions,
    reread: bool,
) -> Result<Imported, Diagnostic> {
    if bytes.is_empty() {
        return Err(Diagnostic::new(
            Code::INPUT_EMPTY,
            format!("`{}` is empty (0 bytes)", path.display()),
            Location::file(path),
        )
        .hint("the export may have failed; export the level again"));
    }
    let imported = match format {
        Format::Gltf | Format::Glb => gltf::import(bytes, path, base_dir, reread)?,
        Format::Obj => obj::import(&bytes, path, base_dir, opts)?,
        Format::Map => map::import(&bytes, path, opts.map_scale)?,
        Format::Usd => usd::import(path, opts)?,
    };
    Ok(note_empty(imported, path))
}

/// Adds a warning when a scene that was read holds no triangles.
fn note_empty(mut imported: Imported, path: &Path) -> Imported {
    if imported.scene.triangle_count() == 0 {
        imported.diagnostics.push(
            Diagnostic::new(
                Code::EMPTY_SCENE,
                "the scene holds no triangles",
                Location::file(path),
            )
            .hint("check that the export included the level's meshes"),
        );
    }
    imported
}

#[cfg(test)]
mod tests {
    /// A file big enough to be read a part per thread comes back byte for byte, each part at
    /// its place (every 4-byte word holds its own offset), as `std::fs::read` gives it.
    #[test]
    fn a_big_file_read_in_parts_is_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("big.bin");
        let len = (17 << 20) + 3;
        let bytes: Vec<u8> = (0..len)
            .map(|i| ((i / 4) as u32).to_le_bytes()[i % 4])
            .collect();
        std::fs::write(&path, &bytes).unwrap();
        let threads = rayon::ThreadPoolBuilder::new()
            .num_threads(3)
            .build()
            .unwrap();
        let read = threads.install(|| super::read_file(&path)).unwrap();
        assert!(read == bytes, "the parts came back out of place");
    }
}
