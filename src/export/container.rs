//! The container change of a glTF written back: what the output's format (.glb or .gltf) and
//! folder require of the document, and nothing else. For .glb all buffers become the one BIN
//! chunk (buffer views re-pointed); for .gltf a GLB's BIN chunk becomes a data: URI; external
//! URIs (buffers, images) are rewritten relative to the output's folder so they still resolve.

use std::path::{Component, Path, PathBuf};

use base64::Engine;
use serde_json::{json, Map, Value};

use super::annotation::Indices;
use crate::format::NAME;

/// A GLB container from a JSON document and a BIN chunk.
pub(crate) fn glb(json: &Value, bin: Option<&[u8]>) -> Vec<u8> {
    let j = serde_json::to_vec(json).unwrap_or_default();
    crate::format::glb::frame(&j, bin)
}

/// `target` relative to `from_dir`, with `/` separators (both absolute or both relative to
/// the same directory).
fn relative(target: &Path, from_dir: &Path) -> PathBuf {
    let t: Vec<Component> = target.components().collect();
    let f: Vec<Component> = from_dir.components().collect();
    let common = t.iter().zip(&f).take_while(|(a, b)| a == b).count();
    let mut out = PathBuf::new();
    for _ in common..f.len() {
        out.push("..");
    }
    for c in &t[common..] {
        out.push(c.as_os_str());
    }
    out
}

fn absolute(p: &Path) -> PathBuf {
    std::fs::canonicalize(p).unwrap_or_else(|_| {
        std::env::current_dir()
            .map(|d| d.join(p))
            .unwrap_or_else(|_| p.to_path_buf())
    })
}

/// Rewrites an external (non-data:) URI written for `in_dir` so it resolves from `out_dir`.
fn rebase_uri(uri: &str, in_dir: &Path, out_dir: &Path) -> String {
    if uri.starts_with("data:") || uri.contains("://") || uri.starts_with('/') {
        return uri.to_string();
    }
    let (ai, ao) = (absolute(in_dir), absolute(out_dir));
    if ai == ao {
        return uri.to_string();
    }
    let rel = relative(&ai, &ao);
    let prefix: Vec<String> = rel
        .components()
        .map(|c| {
            c.as_os_str()
                .to_string_lossy()
                .replace('%', "%25")
                .replace(' ', "%20")
        })
        .collect();
    if prefix.is_empty() {
        uri.to_string()
    } else {
        format!("{}/{uri}", prefix.join("/"))
    }
}

/// Removes an earlier annotation from a node (and its `extensions` if that leaves it empty).
pub(crate) fn strip_ours(node: &mut Value) {
    if let Some(e) = node.get_mut("extensions").and_then(Value::as_object_mut) {
        e.remove(NAME);
        if e.is_empty() {
            node.as_object_mut().map(|o| o.remove("extensions"));
        }
    }
}

/// Puts our node extension object on a node.
pub(crate) fn add_ours(node: &mut Value, ours: Value) {
    if let Some(node) = node.as_object_mut() {
        let e = node.entry("extensions").or_insert_with(|| json!({}));
        if let Some(e) = e.as_object_mut() {
            e.insert(NAME.into(), ours);
        }
    }
}

/// The buffer view of a blob at `(buffer, offset)`.
pub(crate) fn blob_view(at: (usize, usize), len: usize) -> Value {
    let mut view = json!({"buffer": at.0, "byteLength": len});
    if at.1 != 0 {
        view["byteOffset"] = json!(at.1);
    }
    view
}

/// What an annotation appends to the buffers, one run of bytes: the PVS blob, then the split
/// primitives' indices (4-aligned), with each part's offset and length in it.
pub(crate) struct Appended {
    pub bytes: Vec<u8>,
    pub pvs: Option<(usize, usize)>,
    /// Offset, length and index size.
    pub indices: Option<((usize, usize), usize)>,
}

impl Appended {
    /// `None` when there is nothing to append.
    pub(crate) fn of(pvs: Option<&[u8]>, indices: Option<&Indices>) -> Option<Appended> {
        if pvs.is_none() && indices.is_none() {
            return None;
        }
        let mut bytes = Vec::new();
        let mut part = |b: Option<&[u8]>| {
            b.map(|b| {
                bytes.resize(bytes.len().next_multiple_of(4), 0);
                let at = bytes.len();
                bytes.extend_from_slice(b);
                (at, b.len())
            })
        };
        let (pvs, at) = (part(pvs), part(indices.map(|i| &i.bytes[..])));
        Some(Appended {
            bytes,
            pvs,
            indices: at.zip(indices.map(|i| i.size)),
        })
    }

    /// The buffer views of the parts, the bytes at `at` (buffer, offset), in order: the PVS's,
    /// then the indices' (an index buffer view).
    pub(crate) fn views(&self, at: (usize, usize)) -> Vec<Value> {
        let view = |(off, len): (usize, usize)| blob_view((at.0, at.1 + off), len);
        let mut out: Vec<Value> = self.pvs.map(view).into_iter().collect();
        if let Some((p, _)) = self.indices {
            let mut v = view(p);
            v["target"] = json!(34963);
            out.push(v);
        }
        out
    }

    /// The indices' accessor, over buffer view `view`.
    pub(crate) fn accessor(&self, view: usize) -> Option<Value> {
        self.indices.map(|((_, len), size)| {
            let kind = if size == 2 { 5123 } else { 5125 };
            json!({"bufferView": view, "componentType": kind, "count": len / size, "type": "SCALAR"})
        })
    }

    /// Points the root extension object `ours` at what was appended: the PVS's view, the
    /// indices' accessor.
    pub(crate) fn point(&self, ours: &mut Value, views: &[usize], accessor: Option<usize>) {
        let mut views = views.iter();
        if self.pvs.is_some() {
            if let (Some(v), Some(&i)) = (
                ours.get_mut("visibility").and_then(Value::as_object_mut),
                views.next(),
            ) {
                v.insert("bufferView".into(), json!(i));
            }
        }
        if let (Some(s), Some(a)) = (
            ours.get_mut("split").and_then(Value::as_object_mut),
            accessor,
        ) {
            s.insert("indices".into(), json!(a));
        }
    }
}

pub(crate) fn data_uri(bytes: &[u8]) -> String {
    format!(
        "data:application/octet-stream;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(bytes)
    )
}

/// Rewrites an item's external `uri` (an image, a buffer) to resolve from `out_dir`.
pub(crate) fn rebase_item(v: &mut Value, in_dir: &Path, out_dir: &Path) {
    if let Some(uri) = v.get("uri").and_then(Value::as_str) {
        let new = rebase_uri(uri, in_dir, out_dir);
        v["uri"] = json!(new);
    }
}

/// A .gltf output's buffer `i`: an external file re-pointed, else its bytes as a data: URI.
pub(crate) fn gltf_buffer(b: &mut Value, data: &[u8], in_dir: &Path, out_dir: &Path) {
    match b.get("uri").and_then(Value::as_str) {
        Some(_) => rebase_item(b, in_dir, out_dir),
        None => {
            if b.is_object() || b.is_null() {
                b["uri"] = json!(data_uri(data));
            }
        }
    }
}

/// Where each buffer starts in a .glb's BIN chunk (8-aligned, in order), and the chunk's
/// length before padding.
pub(crate) fn glb_layout(lens: &[usize]) -> (Vec<usize>, usize) {
    let mut len = 0usize;
    let base = lens
        .iter()
        .map(|n| {
            let at = len.next_multiple_of(8);
            len = at + n;
            at
        })
        .collect();
    (base, len)
}

/// A buffer view re-pointed into the one BIN chunk, whose buffers start at `base`.
pub(crate) fn rebase_view(v: &mut Value, base: &[usize]) {
    if !(v.is_object() || v.is_null()) {
        return;
    }
    let b = v.get("buffer").and_then(Value::as_u64).unwrap_or(0) as usize;
    let off = v.get("byteOffset").and_then(Value::as_u64).unwrap_or(0) as usize;
    v["buffer"] = json!(0);
    let new = off.wrapping_add(base.get(b).copied().unwrap_or(0));
    if new != 0 || v.get("byteOffset").is_some() {
        v["byteOffset"] = json!(new);
    }
}

/// The one buffer of a .glb output: the first buffer's members but its uri, and `len`.
pub(crate) fn glb_buffer(first: Option<&Value>, len: usize) -> Value {
    let mut one = Map::new();
    for (k, v) in first.and_then(Value::as_object).into_iter().flatten() {
        if k != "uri" && k != "byteLength" {
            one.insert(k.clone(), v.clone());
        }
    }
    one.insert("byteLength".into(), json!(len));
    json!([Value::Object(one)])
}
