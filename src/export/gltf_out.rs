//! Writing the annotated level as glTF (.gltf or .glb).
//!
//! A glTF input is written back as it was: the original JSON (key order kept) with our
//! extension added, and the original buffer bytes. Only what the container change requires is
//! touched: for .glb, all buffers become the one BIN chunk (buffer views re-pointed); for .gltf,
//! a GLB's BIN chunk becomes a data: URI; external URIs (buffers, images) are rewritten relative
//! to the output's folder so they still resolve. An OBJ input becomes a new glTF with one node
//! per scene node, names and materials kept.

use std::path::{Component, Path, PathBuf};

use base64::Engine;
use serde_json::{json, Map, Value};

use super::rewrite::Failed;
use super::sink::Sink;
use crate::diag::{Code, Diagnostic, Location};
use crate::format::{Annotation, NAME};
use crate::scene::{NodeId, Scene};

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OutFormat {
    Gltf,
    Glb,
}

impl OutFormat {
    pub fn from_path(p: &Path) -> Option<OutFormat> {
        match p.extension()?.to_str()?.to_ascii_lowercase().as_str() {
            "gltf" => Some(OutFormat::Gltf),
            "glb" => Some(OutFormat::Glb),
            _ => None,
        }
    }
}

/// The glTF node index a scene node is written as.
pub fn node_index(scene: &Scene, n: NodeId) -> Option<usize> {
    if scene.gltf.is_some() {
        scene.nodes[n]
            .source
            .pointer
            .as_deref()?
            .strip_prefix("/nodes/")?
            .parse()
            .ok()
    } else {
        Some(n)
    }
}

fn pad4(v: &mut Vec<u8>, byte: u8) {
    while v.len() % 4 != 0 {
        v.push(byte);
    }
}

/// A GLB container from a JSON document and a BIN chunk.
pub fn glb(json: &Value, bin: Option<&[u8]>) -> Vec<u8> {
    let mut j = serde_json::to_vec(json).unwrap_or_default();
    pad4(&mut j, b' ');
    let mut out = Vec::with_capacity(28 + j.len() + bin.map_or(0, |b| b.len() + 8));
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&0u32.to_le_bytes());
    out.extend_from_slice(&(j.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&j);
    if let Some(b) = bin {
        let mut b = b.to_vec();
        pad4(&mut b, 0);
        out.extend_from_slice(&(b.len() as u32).to_le_bytes());
        out.extend_from_slice(b"BIN\0");
        out.extend_from_slice(&b);
    }
    let len = out.len() as u32;
    out[8..12].copy_from_slice(&len.to_le_bytes());
    out
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

/// Writes the annotated level; returns the bytes of the one output file.
pub fn write(
    scene: &Scene,
    ann: Annotation,
    out: &Path,
    format: OutFormat,
) -> Result<Vec<u8>, Diagnostic> {
    let mut bytes = std::io::Cursor::new(Vec::new());
    write_to(scene, ann, out, format, &mut bytes)?;
    Ok(bytes.into_inner())
}

/// [`write`] into `sink` (the file of an atomic write, so a big output is not held in memory).
pub fn write_to(
    scene: &Scene,
    ann: Annotation,
    out: &Path,
    format: OutFormat,
    sink: &mut dyn Sink,
) -> Result<(), Diagnostic> {
    write_to_with(scene, None, ann, out, format, sink)
}

/// [`write_to`] with the input's root members (from [`crate::scene::GltfSource::members`]) found already:
/// on a big level that is a pass over tens of megabytes, which a caller can run while it
/// builds the annotation.
pub fn write_to_with<'s>(
    scene: &'s Scene,
    members: Option<super::rewrite::Members<'s>>,
    mut ann: Annotation,
    out: &Path,
    format: OutFormat,
    sink: &mut dyn Sink,
) -> Result<(), Diagnostic> {
    let out_dir = out
        .parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let failed = |e: std::io::Error| super::atomic::failed(out, e);
    if let Some(src) = &scene.gltf {
        // The streamed rewrite gives the same bytes as the whole-document path below, which
        // stays for the documents it declines (a repeated key).
        match super::rewrite::write(src, members, &mut ann, format, out_dir, sink) {
            Ok(()) => return Ok(()),
            Err(Failed::Io(e)) => return Err(failed(e)),
            Err(Failed::Declined) => sink.reset().map_err(failed)?,
        }
    }
    let bytes = write_whole(scene, &ann, out, out_dir, format)?;
    sink.write_all(&bytes).map_err(failed)
}

/// [`write`] by building the whole output document.
pub(super) fn write_whole(
    scene: &Scene,
    ann: &Annotation,
    out: &Path,
    out_dir: &Path,
    format: OutFormat,
) -> Result<Vec<u8>, Diagnostic> {
    let (mut doc, mut bin) = match &scene.gltf {
        Some(src) => {
            let buffers = src
                .buffer_data()
                .map_err(|e| super::atomic::failed(out, e))?;
            from_gltf(src, &buffers, format, out_dir).map_err(|e| super::atomic::failed(out, e))?
        }
        None => from_scene(&super::bake::world_space(scene), format),
    };
    annotate(&mut doc, ann);
    if let Some(blob) = &ann.blob {
        let view = attach(&mut doc, &mut bin, format, blob);
        if let Some(v) = doc
            .pointer_mut(&format!("/extensions/{NAME}/visibility"))
            .and_then(Value::as_object_mut)
        {
            v.insert("bufferView".into(), json!(view));
        }
    }
    match format {
        OutFormat::Glb => Ok(glb(&doc, bin.as_deref())),
        OutFormat::Gltf => {
            let mut v = serde_json::to_vec_pretty(&doc).map_err(|e| {
                Diagnostic::new(
                    Code::OUTPUT_FAILED,
                    format!("cannot serialise the glTF: {e}"),
                    Location::file(out),
                )
            })?;
            v.push(b'\n');
            Ok(v)
        }
    }
}

/// A scene portcullis built itself (generated levels), written as plain glTF without an
/// annotation. Meshes must be in world space, as importers of OBJ leave them.
pub fn write_plain(scene: &Scene, format: OutFormat) -> Vec<u8> {
    let (doc, bin) = from_scene(scene, format);
    match format {
        OutFormat::Glb => glb(&doc, bin.as_deref()),
        OutFormat::Gltf => {
            let mut v = serde_json::to_vec_pretty(&doc).unwrap_or_default();
            v.push(b'\n');
            v
        }
    }
}

/// Adds the extension to the document (replacing an earlier annotation by portcullis).
fn annotate(doc: &mut Value, ann: &Annotation) {
    let Some(obj) = doc.as_object_mut() else {
        return;
    };
    let used = obj.entry("extensionsUsed").or_insert_with(|| json!([]));
    if let Some(a) = used.as_array_mut() {
        if !a.iter().any(|v| v == NAME) {
            a.push(json!(NAME));
        }
    }
    let ext = obj.entry("extensions").or_insert_with(|| json!({}));
    if let Some(e) = ext.as_object_mut() {
        e.insert(NAME.into(), ann.to_value());
    }
    if let Some(nodes) = obj.get_mut("nodes").and_then(Value::as_array_mut) {
        nodes.iter_mut().for_each(strip_ours);
        for (i, v) in &ann.nodes {
            if let Some(node) = nodes.get_mut(*i) {
                add_ours(node, v.clone());
            }
        }
    }
}

/// Removes an earlier annotation from a node (and its `extensions` if that leaves it empty).
pub(super) fn strip_ours(node: &mut Value) {
    if let Some(e) = node.get_mut("extensions").and_then(Value::as_object_mut) {
        e.remove(NAME);
        if e.is_empty() {
            node.as_object_mut().map(|o| o.remove("extensions"));
        }
    }
}

/// Puts our node extension object on a node.
pub(super) fn add_ours(node: &mut Value, ours: Value) {
    if let Some(node) = node.as_object_mut() {
        let e = node.entry("extensions").or_insert_with(|| json!({}));
        if let Some(e) = e.as_object_mut() {
            e.insert(NAME.into(), ours);
        }
    }
}

/// Appends `blob` as a new buffer view and returns its index: in the BIN chunk (buffer 0) of a
/// .glb, as a buffer of its own with a data: URI in a .gltf.
fn attach(doc: &mut Value, bin: &mut Option<Vec<u8>>, format: OutFormat, blob: &[u8]) -> usize {
    let buffer = match format {
        OutFormat::Glb => {
            let data = bin.get_or_insert_with(Vec::new);
            while data.len() % 4 != 0 {
                data.push(0);
            }
            let offset = data.len();
            data.extend_from_slice(blob);
            let len = data.len();
            match doc.get_mut("buffers").and_then(Value::as_array_mut) {
                Some(b) if !b.is_empty() => b[0]["byteLength"] = json!(len),
                _ => doc["buffers"] = json!([{ "byteLength": len }]),
            }
            (0, offset)
        }
        OutFormat::Gltf => {
            let entry = json!({"byteLength": blob.len(), "uri": data_uri(blob)});
            match doc.get_mut("buffers").and_then(Value::as_array_mut) {
                Some(b) => {
                    b.push(entry);
                    (b.len() - 1, 0)
                }
                None => {
                    doc["buffers"] = json!([entry]);
                    (0, 0)
                }
            }
        }
    };
    let view = blob_view(buffer, blob.len());
    match doc.get_mut("bufferViews").and_then(Value::as_array_mut) {
        Some(v) => {
            v.push(view);
            v.len() - 1
        }
        None => {
            doc["bufferViews"] = json!([view]);
            0
        }
    }
}

/// The buffer view of a blob at `(buffer, offset)`.
pub(super) fn blob_view(at: (usize, usize), len: usize) -> Value {
    let mut view = json!({"buffer": at.0, "byteLength": len});
    if at.1 != 0 {
        view["byteOffset"] = json!(at.1);
    }
    view
}

pub(super) fn data_uri(bytes: &[u8]) -> String {
    format!(
        "data:application/octet-stream;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(bytes)
    )
}

/// Rewrites an item's external `uri` (an image, a buffer) to resolve from `out_dir`.
pub(super) fn rebase_item(v: &mut Value, in_dir: &Path, out_dir: &Path) {
    if let Some(uri) = v.get("uri").and_then(Value::as_str) {
        let new = rebase_uri(uri, in_dir, out_dir);
        v["uri"] = json!(new);
    }
}

/// A .gltf output's buffer `i`: an external file re-pointed, else its bytes as a data: URI.
pub(super) fn gltf_buffer(b: &mut Value, data: &[u8], in_dir: &Path, out_dir: &Path) {
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
pub(super) fn glb_layout(lens: &[usize]) -> (Vec<usize>, usize) {
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
pub(super) fn rebase_view(v: &mut Value, base: &[usize]) {
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
pub(super) fn glb_buffer(first: Option<&Value>, len: usize) -> Value {
    let mut one = Map::new();
    for (k, v) in first.and_then(Value::as_object).into_iter().flatten() {
        if k != "uri" && k != "byteLength" {
            one.insert(k.clone(), v.clone());
        }
    }
    one.insert("byteLength".into(), json!(len));
    json!([Value::Object(one)])
}

fn from_gltf(
    src: &crate::scene::GltfSource,
    held: &[Vec<u8>],
    format: OutFormat,
    out_dir: &Path,
) -> std::io::Result<(Value, Option<Vec<u8>>)> {
    let mut doc = src.document()?;
    if let Some(images) = doc.get_mut("images").and_then(Value::as_array_mut) {
        for v in images {
            rebase_item(v, &src.base_dir, out_dir);
        }
    }
    match format {
        OutFormat::Gltf => {
            if let Some(buffers) = doc.get_mut("buffers").and_then(Value::as_array_mut) {
                for (i, b) in buffers.iter_mut().enumerate() {
                    let data: &[u8] = held.get(i).map_or(&[], |b| b.as_slice());
                    gltf_buffer(b, data, &src.base_dir, out_dir);
                }
            }
            Ok((doc, None))
        }
        OutFormat::Glb => {
            let lens: Vec<usize> = held.iter().map(Vec::len).collect();
            let (base, len) = glb_layout(&lens);
            let mut bin = Vec::with_capacity(len);
            for (data, at) in held.iter().zip(&base) {
                bin.resize(*at, 0);
                bin.extend_from_slice(data);
            }
            if let Some(views) = doc.get_mut("bufferViews").and_then(Value::as_array_mut) {
                for v in views {
                    rebase_view(v, &base);
                }
            }
            if held.is_empty() {
                if let Some(o) = doc.as_object_mut() {
                    o.remove("buffers");
                }
                return Ok((doc, None));
            }
            let first = doc
                .get("buffers")
                .and_then(Value::as_array)
                .and_then(|a| a.first());
            doc["buffers"] = glb_buffer(first, bin.len());
            Ok((doc, Some(bin)))
        }
    }
}

/// A new glTF for a scene read from OBJ (or any importer without a glTF source).
fn from_scene(scene: &Scene, format: OutFormat) -> (Value, Option<Vec<u8>>) {
    let mut bin: Vec<u8> = Vec::new();
    let mut views = Vec::new();
    let mut accessors = Vec::new();
    let mut meshes = Vec::new();
    let mut mesh_centre = vec![glam::DVec3::ZERO; scene.meshes.len()];
    for (mi, m) in scene.meshes.iter().enumerate() {
        let b = crate::geom::aabb::Aabb::from_points(m.positions.iter());
        let c = if b.is_empty() {
            glam::DVec3::ZERO
        } else {
            (b.min + b.max) * 0.5
        };
        mesh_centre[mi] = c;
        // Positions relative to the mesh centre (the node carries the centre in f64 JSON),
        // so a level far from the origin keeps its precision in the f32 buffer.
        let pos: Vec<[f32; 3]> = m
            .positions
            .iter()
            .map(|p| (*p - c).as_vec3().to_array())
            .collect();
        let (mut lo, mut hi) = ([f32::MAX; 3], [f32::MIN; 3]);
        for p in &pos {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        let pos_off = bin.len();
        for p in &pos {
            for x in p {
                bin.extend_from_slice(&x.to_le_bytes());
            }
        }
        views.push(json!({"buffer": 0, "byteOffset": pos_off, "byteLength": pos.len() * 12, "target": 34962}));
        let pos_acc = accessors.len();
        if pos.is_empty() {
            (lo, hi) = ([0.0; 3], [0.0; 3]);
        }
        accessors.push(json!({"bufferView": views.len() - 1, "componentType": 5126, "count": pos.len(), "type": "VEC3", "min": lo, "max": hi}));
        let mut prims = Vec::new();
        for p in &m.primitives {
            let tris = m
                .triangles
                .get(p.first_triangle..p.first_triangle + p.triangle_count)
                .unwrap_or(&[]);
            if tris.is_empty() {
                continue;
            }
            let off = bin.len();
            for t in tris {
                for i in t {
                    bin.extend_from_slice(&i.to_le_bytes());
                }
            }
            views.push(json!({"buffer": 0, "byteOffset": off, "byteLength": tris.len() * 12, "target": 34963}));
            accessors.push(json!({"bufferView": views.len() - 1, "componentType": 5125, "count": tris.len() * 3, "type": "SCALAR"}));
            let mut prim =
                json!({"attributes": {"POSITION": pos_acc}, "indices": accessors.len() - 1});
            if let Some(mat) = p.material {
                prim["material"] = json!(mat);
            }
            prims.push(prim);
        }
        let mut mesh = json!({"primitives": prims});
        if let Some(n) = &m.name {
            mesh["name"] = json!(n);
        }
        meshes.push(mesh);
    }
    // Meshes are in world space with identity transforms (OBJ); a mesh node is placed at its
    // mesh's centre, every other node where its parent is, each written relative to its parent.
    let mut placed = vec![glam::DVec3::ZERO; scene.nodes.len()];
    for n in scene.walk() {
        let up = scene.nodes[n]
            .parent
            .map(|p| placed[p])
            .unwrap_or(glam::DVec3::ZERO);
        // A node without a mesh keeps its own place (a player start, a marker); a group with
        // an identity transform is where its parent is.
        let own = scene.nodes[n].world.w_axis.truncate();
        placed[n] = scene.nodes[n]
            .mesh
            .map(|m| mesh_centre[m])
            .unwrap_or(if own == glam::DVec3::ZERO { up } else { own });
    }
    let nodes: Vec<Value> = scene
        .nodes
        .iter()
        .enumerate()
        .map(|(i, n)| {
            let mut o = Map::new();
            if let Some(name) = &n.name {
                o.insert("name".into(), json!(name));
            }
            if !n.children.is_empty() {
                o.insert("children".into(), json!(n.children));
            }
            if let Some(m) = n.mesh {
                o.insert("mesh".into(), json!(m));
            }
            let up = n.parent.map(|p| placed[p]).unwrap_or(glam::DVec3::ZERO);
            let t = placed[i] - up;
            if t != glam::DVec3::ZERO {
                o.insert("translation".into(), json!([t.x, t.y, t.z]));
            }
            if let Some(e) = &n.extras {
                o.insert("extras".into(), e.clone());
            }
            Value::Object(o)
        })
        .collect();
    let materials: Vec<Value> = scene
        .materials
        .iter()
        .map(|m| match &m.name {
            Some(n) => json!({"name": n}),
            None => json!({}),
        })
        .collect();
    let mut doc = json!({
        "asset": {"version": "2.0", "generator": format!("portcullis {}", env!("CARGO_PKG_VERSION"))},
        "scene": 0,
        "scenes": [{"nodes": scene.roots}],
    });
    if !nodes.is_empty() {
        doc["nodes"] = json!(nodes);
    }
    if !meshes.is_empty() {
        doc["meshes"] = json!(meshes);
        doc["accessors"] = json!(accessors);
        doc["bufferViews"] = json!(views);
    }
    if !materials.is_empty() {
        doc["materials"] = json!(materials);
    }
    if bin.is_empty() {
        return (doc, None);
    }
    match format {
        OutFormat::Glb => {
            doc["buffers"] = json!([{"byteLength": bin.len()}]);
            (doc, Some(bin))
        }
        OutFormat::Gltf => {
            doc["buffers"] = json!([{"byteLength": bin.len(), "uri": data_uri(&bin)}]);
            (doc, None)
        }
    }
}
