//! The test oracle of the glTF writer: the whole output document built as a JSON tree, the
//! simple way the streamed writer ([`super::rewrite`]) must match byte for byte. Tests only;
//! a tree takes ten times the room of its text on a big level.

use std::path::Path;

use serde_json::{json, Value};

use super::container::*;
use super::gltf_out::from_scene;
use super::target::OutFormat;
use super::Annotation;
use crate::diag::{Code, Diagnostic, Location};
use crate::format::NAME;
use crate::scene::Scene;

/// [`write`] by building the whole output document.
pub(crate) fn write_whole(
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
    let appended = Appended::of(ann.blob.as_deref(), ann.indices.as_ref());
    let made = match (&ann.parts, &appended) {
        (Some(plan), Some(app)) => Some(made_parts(&doc, plan, &ann.lazy.cell_nodes, app)),
        _ => None,
    };
    let mut lazy = ann.lazy.clone();
    lazy.part_nodes = made.as_ref().map(|m| m.cell_nodes.clone());
    annotate(&mut doc, ann, &lazy, made.as_ref());
    if let Some(app) = appended {
        let at = attach(&mut doc, &mut bin, format, &app.bytes);
        let views: Vec<usize> = (app.views(at).into_iter())
            .map(|v| push(&mut doc, "bufferViews", v))
            .collect();
        let accessor = match &made {
            Some(m) => {
                for (key, v) in m.appended() {
                    push(&mut doc, key, v.clone());
                }
                None
            }
            None => (app.accessor(views.last().copied().unwrap_or(0)))
                .map(|a| push(&mut doc, "accessors", a)),
        };
        if let Some(ours) = doc.pointer_mut(&format!("/extensions/{NAME}")) {
            app.point(ours, &views, accessor);
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

/// The parts of the nodes drawn in part, as `rewrite` makes them.
fn made_parts(
    doc: &Value,
    plan: &super::parts::Plan,
    cell_nodes: &[Vec<usize>],
    app: &Appended,
) -> super::parts::Made {
    let len = |k: &str| doc.get(k).and_then(Value::as_array).map_or(0, Vec::len);
    let base = super::parts::Base {
        nodes: len("nodes"),
        meshes: len("meshes"),
        accessors: len("accessors"),
        view: len("bufferViews") + app.views((0, 0)).len() - 1,
        size: app.indices.map_or(4, |(_, size)| size),
    };
    let nodes = doc.get("nodes").and_then(Value::as_array);
    let meshes = doc.get("meshes").and_then(Value::as_array);
    super::parts::make(
        plan,
        cell_nodes,
        &|i| nodes.and_then(|n| n.get(i)).cloned(),
        meshes.map_or(&[][..], |m| &m[..]),
        base,
    )
}

/// Adds the extension to the document (replacing an earlier annotation by portcullis).
fn annotate(
    doc: &mut Value,
    ann: &Annotation,
    lazy: &super::annotation::Lazy,
    made: Option<&super::parts::Made>,
) {
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
        let json = super::annotation::Json {
            root: &ann.root,
            lazy,
        };
        e.insert(
            NAME.into(),
            serde_json::to_value(json).unwrap_or(Value::Null),
        );
    }
    if let Some(nodes) = obj.get_mut("nodes").and_then(Value::as_array_mut) {
        let mut ours: std::collections::HashMap<usize, &Value> =
            ann.nodes.iter().map(|(i, v)| (*i, v)).collect();
        let mut parts = std::collections::HashMap::new();
        for (i, e) in made.iter().flat_map(|m| &m.edits) {
            ours.insert(*i, &e.ours);
            if let Some(p) = &e.parts {
                parts.insert(*i, p);
            }
        }
        for (i, node) in nodes.iter_mut().enumerate() {
            strip_ours(node);
            if let Some(p) = parts.get(&i) {
                super::parts::give_up_mesh(node, p);
            }
            if let Some(v) = ours.get(&i) {
                add_ours(node, (*v).clone());
            }
        }
    }
}

/// Appends `blob` to the buffers and returns where it starts (buffer, offset): in the BIN chunk
/// (buffer 0) of a .glb, as a buffer of its own with a data: URI in a .gltf.
fn attach(
    doc: &mut Value,
    bin: &mut Option<Vec<u8>>,
    format: OutFormat,
    blob: &[u8],
) -> (usize, usize) {
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
    buffer
}

/// Appends `v` to the root array `key` (making it if absent) and returns its index.
fn push(doc: &mut Value, key: &str, v: Value) -> usize {
    match doc.get_mut(key).and_then(Value::as_array_mut) {
        Some(a) => {
            a.push(v);
            a.len() - 1
        }
        None => {
            doc[key] = json!([v]);
            0
        }
    }
}

fn from_gltf(
    src: &crate::scene::GltfSource,
    held: &[Vec<u8>],
    format: OutFormat,
    out_dir: &Path,
) -> std::io::Result<(Value, Option<Vec<u8>>)> {
    let mut doc = src.document()?;
    if let (Some(e), Some(o)) = (src.earlier, doc.as_object_mut()) {
        for key in ["bufferViews", "accessors", "buffers"] {
            if o.get_mut(key).is_some_and(|v| e.drop_from(key, v)) {
                o.shift_remove(key);
            }
        }
    }
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
