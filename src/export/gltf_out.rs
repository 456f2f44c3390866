//! Writing the annotated level as glTF (.gltf or .glb).
//!
//! A glTF input is written back as it was: the original JSON (key order kept) with our
//! extension added, and the original buffer bytes. Only what the container change requires is
//! touched: for .glb, all buffers become the one BIN chunk (buffer views re-pointed); for .gltf,
//! a GLB's BIN chunk becomes a data: URI; external URIs (buffers, images) are rewritten relative
//! to the output's folder so they still resolve. An OBJ input becomes a new glTF with one node
//! per scene node, names and materials kept.

use std::path::Path;

use serde_json::{json, Map, Value};

use super::container::{data_uri, glb};
use super::rewrite::Failed;
use super::sink::Sink;
use super::target::OutFormat;
use super::Annotation;
use crate::diag::{Code, Diagnostic, Location};
use crate::scene::{GltfSource, NodeId, Scene};

/// The glTF node index a scene node is written as.
pub(crate) fn node_index(scene: &Scene, n: NodeId) -> Option<usize> {
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

/// [`write()`] into `sink` (the file of an atomic write, so a big output is not held in memory).
pub(crate) fn write_to(
    scene: &Scene,
    ann: Annotation,
    out: &Path,
    format: OutFormat,
    sink: &mut dyn Sink,
) -> Result<(), Diagnostic> {
    let made;
    let src = match &scene.gltf {
        Some(src) => src,
        None => {
            made = new_document(scene, out)?;
            &made
        }
    };
    write_to_with(src, None, ann, out, format, sink)
}

/// The folder an output's relative URIs start from.
fn out_dir(out: &Path) -> &Path {
    out.parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."))
}

/// The glTF document a level read from OBJ or USD is written as: meshes in world space
/// (`bake`), one BIN buffer. It is made once, then hashed (what a reader of the written file
/// imports) and written from.
pub(crate) fn new_document(scene: &Scene, out: &Path) -> Result<GltfSource, Diagnostic> {
    let (doc, bin) = from_scene(&super::bake::world_space(scene), OutFormat::Glb);
    let text = serde_json::to_string(&doc)
        .map_err(|e| super::atomic::failed(out, std::io::Error::from(e)))?;
    Ok(GltfSource::in_memory(
        text,
        bin.into_iter().collect(),
        out_dir(out),
    ))
}

/// [`write_to`] from the document `src` (the input's, or a [`new_document`]), with its root
/// members (from [`crate::scene::GltfSource::members`]) found already: on a big level that is
/// a pass over tens of megabytes, which a caller can run while it builds the annotation.
///
/// One writer writes every output, the streamed rewrite of a glTF document; a document the
/// rewrite declines (a key repeated where it must read the member) is rewritten from its
/// parsed form, where the last of a repeated key wins, as any JSON reader sees it.
pub(crate) fn write_to_with<'s>(
    src: &'s GltfSource,
    members: Option<super::rewrite::Members<'s>>,
    mut ann: Annotation,
    out: &Path,
    format: OutFormat,
    sink: &mut dyn Sink,
) -> Result<(), Diagnostic> {
    let out_dir = out_dir(out);
    let failed = |e: std::io::Error| super::atomic::failed(out, e);
    let streamed = match super::rewrite::write(src, members, &mut ann, format, out_dir, sink) {
        Ok(()) => return Ok(()),
        Err(Failed::Io(e)) => return Err(failed(e)),
        Err(Failed::Declined(why)) => {
            sink.reset().map_err(failed)?;
            why
        }
    };
    let text =
        serde_json::to_string(&src.document().map_err(failed)?).map_err(|e| failed(e.into()))?;
    let buffers = src.buffer_data().map_err(failed)?.into_owned();
    let parsed = GltfSource::in_memory(text, buffers, &src.base_dir);
    match super::rewrite::write(&parsed, None, &mut ann, format, out_dir, sink) {
        Ok(()) => Ok(()),
        Err(Failed::Io(e)) => Err(failed(e)),
        Err(Failed::Declined(why)) => Err(Diagnostic::new(
            Code::OUTPUT_FAILED,
            format!(
                "cannot write the glTF: its JSON could not be rewritten ({why}; streamed, it was declined: {streamed})"
            ),
            Location::file(out),
        )
        .hint("re-export the level from its tool, so its JSON has no repeated keys")),
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

/// A new glTF for a scene read from OBJ (or any importer without a glTF source).
pub(crate) fn from_scene(scene: &Scene, format: OutFormat) -> (Value, Option<Vec<u8>>) {
    let mut buffers = Buffers::default();
    let mut mesh_centre = vec![glam::DVec3::ZERO; scene.meshes.len()];
    for (mi, m) in scene.meshes.iter().enumerate() {
        mesh_centre[mi] = buffers.add_mesh(m);
    }
    let Buffers {
        bin,
        views,
        accessors,
        meshes,
    } = buffers;
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
        .map(|m| {
            let mut v = match &m.name {
                Some(n) => json!({"name": n}),
                None => json!({}),
            };
            // A face the source draws from both sides (an OBJ's, a liquid's) stays so.
            if m.double_sided {
                v["doubleSided"] = json!(true);
            }
            v
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

/// The buffer, views, accessors and meshes of a new glTF, filled a mesh at a time.
#[derive(Default)]
struct Buffers {
    bin: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
    meshes: Vec<Value>,
}

impl Buffers {
    /// Adds mesh `m` (positions, and each primitive's indices) and returns its centre, where
    /// its node is placed.
    fn add_mesh(&mut self, m: &crate::scene::Mesh) -> glam::DVec3 {
        let b = crate::geom::aabb::Aabb::from_points(m.positions.iter());
        let c = if b.is_empty() {
            glam::DVec3::ZERO
        } else {
            (b.min + b.max) * 0.5
        };
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
        let pos_off = self.bin.len();
        for p in &pos {
            for x in p {
                self.bin.extend_from_slice(&x.to_le_bytes());
            }
        }
        self.views.push(json!({"buffer": 0, "byteOffset": pos_off, "byteLength": pos.len() * 12, "target": 34962}));
        let pos_acc = self.accessors.len();
        if pos.is_empty() {
            (lo, hi) = ([0.0; 3], [0.0; 3]);
        }
        self.accessors.push(json!({"bufferView": self.views.len() - 1, "componentType": 5126, "count": pos.len(), "type": "VEC3", "min": lo, "max": hi}));
        let mut prims = Vec::new();
        for p in &m.primitives {
            let tris = m
                .triangles
                .get(p.first_triangle..p.first_triangle + p.triangle_count)
                .unwrap_or(&[]);
            if tris.is_empty() {
                continue;
            }
            let off = self.bin.len();
            for t in tris {
                for i in t {
                    self.bin.extend_from_slice(&i.to_le_bytes());
                }
            }
            self.views.push(json!({"buffer": 0, "byteOffset": off, "byteLength": tris.len() * 12, "target": 34963}));
            self.accessors.push(json!({"bufferView": self.views.len() - 1, "componentType": 5125, "count": tris.len() * 3, "type": "SCALAR"}));
            let mut prim =
                json!({"attributes": {"POSITION": pos_acc}, "indices": self.accessors.len() - 1});
            if let Some(mat) = p.material {
                prim["material"] = json!(mat);
            }
            prims.push(prim);
        }
        let mut mesh = json!({"primitives": prims});
        if let Some(n) = &m.name {
            mesh["name"] = json!(n);
        }
        self.meshes.push(mesh);
        c
    }
}
