//! The one door out of portcullis: every file it writes, and standard output, goes through
//! here. An [`Output`] names the path, what it is written as (its [`Target`], from the path's
//! extension or chosen) and where the bytes go ([`Destination`]); writing a file is always
//! atomic (`atomic.rs`), so a failed write leaves nothing.
//!
//! A level from OBJ or USD is written as a glTF document made once (`gltf_out::new_document`);
//! its input hash is of that document as a reader imports it, or the annotation would read
//! back as stale.

use std::io::Write as _;
use std::path::Path;

use super::target::{OutFormat, Target};
use crate::diag::{Code, Diagnostic, Location};
use crate::level::Level;
use crate::scene::GltfSource;
use crate::vis::{Method, Pvs};

/// Where an output's bytes go.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Destination {
    /// The file at the output's path, written atomically as it is made (a big level's output
    /// is never held whole in memory; a failed write leaves no file).
    File,
    /// Returned, for callers that send them elsewhere (a test, a library caller).
    Memory,
    /// Standard output, once made whole.
    Stdout,
}

/// One output: its path, what it is written as, and where the bytes go.
#[derive(Debug, Clone, Copy)]
pub struct Output<'a> {
    /// The output file. Its folder decides the relative URIs of images and external buffers,
    /// also when the bytes are kept in memory or sent to standard output.
    pub path: &'a Path,
    /// What the bytes are.
    pub target: Target,
    /// Where they go.
    pub to: Destination,
    /// What a glTF output's cells name of the geometry they draw: draw lists (the default),
    /// nodes split by cell (`convert --split-by-cell`) or whole nodes (`--no-draw-lists`).
    pub geometry: super::CellGeometry,
}

impl<'a> Output<'a> {
    /// `path` written as `target`.
    pub fn file(path: &'a Path, target: Target) -> Output<'a> {
        Output {
            path,
            target,
            to: Destination::File,
            geometry: super::CellGeometry::DrawLists,
        }
    }

    /// The bytes `path` would hold as `target`, kept in memory.
    pub fn memory(path: &'a Path, target: Target) -> Output<'a> {
        Output {
            to: Destination::Memory,
            ..Output::file(path, target)
        }
    }

    /// `target` written to standard output (`-`).
    pub fn stdout(target: Target) -> Output<'static> {
        Output {
            path: Path::new("-"),
            target,
            to: Destination::Stdout,
            geometry: super::CellGeometry::DrawLists,
        }
    }

    /// The same output, its cells naming `geometry`.
    pub fn with_geometry(self, geometry: super::CellGeometry) -> Output<'a> {
        Output { geometry, ..self }
    }

    /// `path` as an annotated glTF, refused unless it is named .glb or .gltf.
    pub fn gltf(path: &'a Path) -> Result<Output<'a>, Diagnostic> {
        match Target::from_path(path) {
            Some(t @ (Target::Glb | Target::Gltf)) => Ok(Output::file(path, t)),
            _ => Err(Diagnostic::new(
                Code::OUTPUT_FORMAT_UNKNOWN,
                "the output is neither .glb nor .gltf",
                Location::file(path),
            )
            .hint("name the output file .glb or .gltf")),
        }
    }
}

/// The annotated level with `pvs` stored, as `out.target` (.glb, .gltf or .usda): the input
/// glTF with the `PORTCULLIS_portals` extension added and nothing else changed, a new glTF for
/// a level read from OBJ or USD, or a USD layer. Returns the bytes with
/// [`Destination::Memory`], nothing otherwise.
pub fn level(
    level: &Level,
    pvs: Option<(&Pvs, Method)>,
    out: &Output,
) -> Result<Vec<u8>, Diagnostic> {
    match out.target {
        Target::Usda => {
            let text = super::usd_out::write_usda(level, pvs);
            bytes(out, text.as_bytes())
        }
        Target::Glb | Target::Gltf => {
            let format = out.target.gltf().unwrap_or(OutFormat::Glb);
            match out.to {
                Destination::File => super::atomic::write_with(
                    out.path,
                    |f| gltf_to(level, pvs, out, format, f),
                    |e| super::atomic::failed(out.path, e),
                )
                .map(|()| Vec::new()),
                Destination::Memory | Destination::Stdout => {
                    let mut made = std::io::Cursor::new(Vec::new());
                    gltf_to(level, pvs, out, format, &mut made)?;
                    bytes(out, &made.into_inner())
                }
            }
        }
        other => Err(Diagnostic::new(
            Code::OUTPUT_FORMAT_UNKNOWN,
            format!("a level is not written as {}", other.name()),
            Location::file(out.path),
        )
        .hint("name the output .glb, .gltf or .usda")),
    }
}

/// Bytes made whole (a portal file, a debug glTF, an SVG map, an HTML page) to their
/// destination: atomically to a file, to standard output, or returned.
pub fn bytes(out: &Output, bytes: &[u8]) -> Result<Vec<u8>, Diagnostic> {
    let failed = |e| super::atomic::failed(out.path, e);
    match out.to {
        Destination::File => super::atomic::write(out.path, bytes)
            .map(|()| Vec::new())
            .map_err(failed),
        Destination::Stdout => {
            let mut so = std::io::stdout().lock();
            so.write_all(bytes)
                .and_then(|_| so.flush())
                .map(|()| Vec::new())
                .map_err(failed)
        }
        Destination::Memory => Ok(bytes.to_vec()),
    }
}

/// The annotated glTF into `sink`.
fn gltf_to(
    level: &Level,
    pvs: Option<(&Pvs, Method)>,
    output: &Output,
    format: OutFormat,
    sink: &mut dyn super::sink::Sink,
) -> Result<(), Diagnostic> {
    use super::gltf_out;
    let out = output.path;
    let scene = level.scene();
    let tagging = level.tagging();
    if let Some(src) = scene.gltf.as_ref().filter(|s| s.parts > 0) {
        return Err(Diagnostic::new(
            Code::CONVERT_SPLIT_INPUT,
            format!(
                "`{}` was written by `convert --split-by-cell` ({} nodes are parts of others); written again, its parts would be lost or drawn twice",
                scene.path.display(),
                src.parts
            ),
            Location::file(&scene.path),
        )
        .hint("convert the level it was made from; `check` and `cull` read this file as it is"));
    }
    let made = match &scene.gltf {
        Some(_) => None,
        None => Some(gltf_out::new_document(scene, out)?),
    };
    // The input hash is a pass over every position: it runs on a thread of its own while the
    // output is written, and is waited for when the writer reaches it.
    std::thread::scope(|s| {
        let hashing = std::thread::Builder::new()
            .spawn_scoped(s, || match &made {
                Some(doc) => written_hash(level, doc, out),
                None => super::input_hash(scene, tagging),
            })
            .ok();
        // So are the input's root members while the annotation is built, when the importer
        // did not keep where they lie (then they are a pass over the JSON text).
        let members = scene.gltf.as_ref().and_then(|src| {
            std::thread::Builder::new()
                .spawn_scoped(s, || src.members().ok().flatten())
                .ok()
        });
        let hash = super::InputHash::pending(Box::new(move || {
            hashing
                .and_then(|h| h.join().ok())
                .unwrap_or_else(|| super::input_hash(scene, tagging))
        }));
        let node_index = |n| gltf_out::node_index(scene, n);
        let mut ann = super::build_deferred(&hash, level, &node_index, output.geometry);
        if let Some((p, m)) = pvs {
            ann.set_visibility(p, m);
        }
        let members = members.and_then(|m| m.join().ok()).flatten();
        let src = match (&made, &scene.gltf) {
            (Some(doc), _) => doc,
            (None, Some(src)) => src,
            (None, None) => unreachable!("a level without a glTF source gets a new document"),
        };
        gltf_out::write_to_with(src, members, ann, out, format, sink)
    })
}

/// The input hash of the new document `doc` a non-glTF level is written as: the document read
/// back as a reader of the file will, and tagged with the level's rules.
fn written_hash(level: &Level, doc: &GltfSource, out: &Path) -> String {
    let hash_of = |scene: &crate::scene::Scene| {
        let mut tagging = crate::tags::recognise(scene, &level.tagged.rules);
        tagging.settings = level.tagging().settings.clone();
        super::input_hash(scene, &tagging)
    };
    let Ok(text) = doc.text() else {
        return super::input_hash(level.scene(), level.tagging());
    };
    let glb = crate::format::glb::frame(text.as_bytes(), doc.buffers.first().map(Vec::as_slice));
    let dir = out.parent().unwrap_or(Path::new("."));
    let options = crate::import::ImportOptions::default();
    match crate::import::import_bytes(&glb, out, crate::scene::Format::Glb, dir, &options) {
        Ok(back) => hash_of(&back.scene),
        // What portcullis writes it reads; should it not, the hash is of the level as it is.
        Err(_) => super::input_hash(level.scene(), level.tagging()),
    }
}
