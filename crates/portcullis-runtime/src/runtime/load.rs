//! Reading a converted level for the runtime: only the `PORTCULLIS_portals` extension and the
//! bytes of its PVS, never the meshes, so an engine's loader (or `portcullis cull`) pays for
//! the culling data alone.

use std::io::{Read, Seek, SeekFrom};
use std::path::Path;

use base64::Engine as _;
use serde::Deserialize;
use serde_json::Value;

use super::{LevelError, LoadError};
use crate::format::Annotated;
use crate::format::Pvs;

pub(super) const CONVERT_HINT: &str =
    "run `portcullis convert` on the level and load the file it writes";

#[derive(Deserialize)]
struct Doc {
    #[serde(default)]
    extensions: Option<Extensions>,
    #[serde(default, rename = "bufferViews")]
    buffer_views: Vec<Value>,
    #[serde(default)]
    buffers: Vec<Value>,
}

#[derive(Deserialize)]
struct Extensions {
    #[serde(default, rename = "PORTCULLIS_portals")]
    portals: Option<Annotated>,
}

/// The annotation of the .glb or .gltf at `path` and its decoded PVS (`None` when it stores
/// none, as a one-cell level does).
pub fn read(path: &Path) -> Result<(Annotated, Option<Pvs>), LoadError> {
    let err = |kind: LevelError| LoadError {
        path: path.to_path_buf(),
        kind,
        hint: CONVERT_HINT,
        unreadable: false,
    };
    let bytes = std::fs::read(path).map_err(|e| LoadError {
        path: path.to_path_buf(),
        kind: LevelError::Unreadable(e.to_string()),
        hint: "check the path and the file's permissions",
        unreadable: true,
    })?;
    parse(&bytes, path.parent()).map_err(err)
}

/// The annotation and PVS of a .glb's or .gltf's bytes; an external buffer is read relative to
/// `dir`, and refused without one (an engine's asset loader has the bytes, not always a folder).
pub fn parse(bytes: &[u8], dir: Option<&Path>) -> Result<(Annotated, Option<Pvs>), LevelError> {
    let (json, bin) = split(bytes)?;
    let doc: Doc = serde_json::from_slice(json).map_err(|e| LevelError::NotGltf(e.to_string()))?;
    let annotated = doc
        .extensions
        .and_then(|e| e.portals)
        .ok_or(LevelError::NoExtension)?;
    let Some(vis) = annotated.visibility.as_ref() else {
        return Ok((annotated, None));
    };
    let blob = match vis.get("bufferView").and_then(Value::as_u64) {
        None => None,
        Some(i) => Some(view_bytes(
            dir,
            &doc.buffer_views,
            &doc.buffers,
            bin,
            i as usize,
        )?),
    };
    let pvs = crate::format::visibility::decode(vis, annotated.cells.len(), blob.as_deref())
        .map_err(LevelError::Visibility)?;
    Ok((annotated, Some(pvs)))
}

/// The JSON text and the BIN chunk of a .glb, or the whole text of a .gltf.
pub(super) fn split(bytes: &[u8]) -> Result<(&[u8], Option<&[u8]>), LevelError> {
    use crate::format::glb;
    if !glb::is_glb(bytes) {
        return Ok((bytes, None));
    }
    glb::split(bytes)
        .map(|g| (g.json, g.bin))
        .map_err(LevelError::NotGlb)
}

/// The bytes of buffer view `i`, reading only its range of an external buffer file.
fn view_bytes(
    dir: Option<&Path>,
    views: &[Value],
    buffers: &[Value],
    bin: Option<&[u8]>,
    i: usize,
) -> Result<Vec<u8>, LevelError> {
    let view = views.get(i).ok_or(LevelError::ViewMissing(i))?;
    let field = |k: &str| view.get(k).and_then(Value::as_u64).map(|v| v as usize);
    let b = field("buffer").ok_or(LevelError::ViewNoBuffer(i))?;
    let off = field("byteOffset").unwrap_or(0);
    let len = field("byteLength").ok_or(LevelError::ViewNoLength(i))?;
    let buffer = buffers.get(b).ok_or(LevelError::ViewBufferMissing(i))?;
    let range = |data: &[u8]| -> Result<Vec<u8>, LevelError> {
        let end = off.checked_add(len).ok_or(LevelError::ViewOutOfRange(i))?;
        data.get(off..end)
            .map(<[u8]>::to_vec)
            .ok_or(LevelError::ViewBeyondBuffer(i))
    };
    match buffer.get("uri").and_then(Value::as_str) {
        None => range(bin.ok_or(LevelError::ViewNoBin(i))?),
        Some(uri) if uri.starts_with("data:") => {
            let data = uri
                .split_once(";base64,")
                .and_then(|(_, d)| base64::engine::general_purpose::STANDARD.decode(d).ok())
                .ok_or(LevelError::ViewBadDataUri(i))?;
            range(&data)
        }
        Some(uri) => {
            let file = match dir {
                Some(dir) => dir.join(uri),
                None => {
                    return Err(LevelError::ViewFileUnreadable {
                        view: i,
                        file: uri.into(),
                        error: "an external buffer, and no folder to read it from (write a .glb)"
                            .to_string(),
                    })
                }
            };
            let mut f = std::fs::File::open(&file).map_err(|e| LevelError::ViewFileUnreadable {
                view: i,
                file: file.clone(),
                error: e.to_string(),
            })?;
            let mut out = vec![0; len];
            f.seek(SeekFrom::Start(off as u64))
                .and_then(|_| f.read_exact(&mut out))
                .map_err(|e| LevelError::ViewFileShort {
                    view: i,
                    file: file.clone(),
                    error: e.to_string(),
                })?;
            Ok(out)
        }
    }
}
