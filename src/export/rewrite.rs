//! The one glTF writer: a document written back from its JSON text, with the bytes the simple
//! way would give (`oracle.rs`, tests only: parse the document, change a few members, serialize
//! it all) without its cost.
//!
//! On a big level the parse, the copy and the drop cost more than the write, and the parsed
//! document is ten times the size of its text. Here the root's members stay text until a change needs one:
//! images and buffers are parsed (they are short), nodes and buffer views are streamed element
//! by element through the same edits, everything else is transcoded unparsed. Each step mirrors
//! the other path's, in the same order, so members land in the same places.

use std::collections::HashMap;
use std::fmt;
use std::io::{BufWriter, SeekFrom, Write};
use std::path::Path;

use serde::de::{self, Deserializer as _, SeqAccess, Visitor};
use serde::ser::{self, Serialize, SerializeMap, SerializeSeq, Serializer};
use serde_json::value::RawValue;
use serde_json::{json, Value};

use super::annotation::{Json, Member};
use super::container as out;
use super::parallel::{self, Failure, Render, RenderText, Source};
use super::parts;
use super::sink::{Counted, Sink};
use super::target::OutFormat;
use super::transcode::{self, Element, Transcode};
use super::Annotation;
use crate::format::{glb, NAME};
use crate::scene::json_text::{self, Elements};
use crate::scene::GltfSource;

/// The root object's members as [`GltfSource::members`] gives them.
pub(crate) type Members<'s> = Vec<(String, &'s str)>;

/// Why the streamed rewrite did not write a document: it declines it (a key repeated where it
/// must read the member; `gltf_out` then rewrites the parsed document), or the output failed.
#[derive(Debug)]
pub(crate) enum Failed {
    /// The document cannot be streamed; why, in words (the parser's or serializer's message,
    /// or what was not as the rewrite needs it), for the report that the parsed document
    /// could not be written either.
    Declined(String),
    Io(std::io::Error),
}

impl From<serde_json::Error> for Failed {
    /// A parser's or serializer's error: the output's (an I/O error), or a document it
    /// cannot stream, with the parser's message.
    fn from(e: serde_json::Error) -> Self {
        match e.io_error_kind() {
            Some(kind) => Failed::Io(std::io::Error::new(kind, e)),
            None => Failed::Declined(e.to_string()),
        }
    }
}

/// A declined document, for `what` the rewrite found not as it needs it.
fn declined(what: impl Into<String>) -> Failed {
    Failed::Declined(what.into())
}

/// A serializer's error: the output's, or a document it cannot stream.
fn written(r: serde_json::Result<()>) -> Result<(), Failed> {
    r.map_err(Failed::from)
}

/// Writes the output file into `sink` (from where it stands), or says why it did not; on
/// `Declined` the caller resets the sink and writes the parsed document instead.
pub(crate) fn write<'s>(
    src: &'s GltfSource,
    members: Option<Members<'s>>,
    ann: &mut Annotation,
    format: OutFormat,
    out_dir: &Path,
    sink: &mut dyn Sink,
) -> Result<(), Failed> {
    let Annotation {
        root: ours,
        nodes,
        blob,
        indices,
        parts,
        lazy,
    } = ann;
    let members = match members {
        Some(m) => m,
        None => (src.members().map_err(Failed::Io)?)
            .ok_or_else(|| declined("the document's root is not a JSON object"))?,
    };
    let lens = src.buffer_lens();
    let mut root = Root(
        members
            .into_iter()
            .map(|(k, v)| (k, Slot::Text(v)))
            .collect(),
    );

    if let Some(e) = src.earlier {
        for key in ["bufferViews", "accessors", "buffers"] {
            if root.parsed(key)?.is_some_and(|v| e.drop_from(key, v)) {
                root.remove(key);
            }
        }
    }
    let (base, mut bin_len) = out::glb_layout(&lens);
    let mut bin = container_change(&mut root, src, format, out_dir, &base, bin_len)?;
    let appended = out::Appended::of(blob.as_deref(), indices.as_ref());
    let made = match (parts.as_ref(), &appended) {
        (Some(plan), Some(app)) => Some(made_parts(&mut root, plan, &lazy.cell_nodes, app)?),
        _ => None,
    };
    lazy.part_nodes = made.as_ref().map(|m| m.cell_nodes.clone());
    let edits = NodeEdits::of(nodes, made.as_ref());
    let annotated = add_annotation(&mut root, &edits)?;
    if let Some(app) = &appended {
        bin |= format == OutFormat::Glb;
        let at = attach_blob(&mut root, &app.bytes, format, &mut bin_len)?;
        let views = (app.views(at).into_iter())
            .map(|v| root.push("bufferViews", v))
            .collect::<Result<Vec<usize>, Failed>>()?;
        let accessor = match &made {
            Some(m) => {
                for (key, v) in m.appended() {
                    root.push(key, v.clone())?;
                }
                None
            }
            None => (app.accessor(views.last().copied().unwrap_or(0)))
                .map(|a| root.push("accessors", a))
                .transpose()?,
        };
        if annotated {
            app.point(ours, &views, accessor);
        }
    }

    let doc = Document {
        root: &root,
        ours: annotated.then_some(Json { root: ours, lazy }),
    };
    match format {
        OutFormat::Gltf => {
            let mut w = BufWriter::with_capacity(1 << 20, sink);
            written(serde_json::to_writer_pretty(&mut w, &doc))?;
            w.write_all(b"\n").map_err(Failed::Io)?;
            w.flush().map_err(Failed::Io)
        }
        OutFormat::Glb => {
            let bin = bin.then_some(Bin {
                src,
                lens: &lens,
                base: &base,
                blob: appended.as_ref().map(|a| &a.bytes[..]),
                len: bin_len,
            });
            glb(&doc, bin, sink)
        }
    }
}

/// The container change (`oracle::from_gltf`): images re-pointed from the output's folder;
/// for .glb every buffer into the one BIN chunk (whose buffers start at `base`, `bin_len`
/// long), for .gltf a BIN chunk as a data: URI. Whether the output has a BIN chunk.
fn container_change<'a>(
    root: &mut Root<'a>,
    src: &'a GltfSource,
    format: OutFormat,
    out_dir: &Path,
    base: &'a [usize],
    bin_len: usize,
) -> Result<bool, Failed> {
    if let Some(images) = root.parsed("images")?.and_then(Value::as_array_mut) {
        for v in images {
            out::rebase_item(v, &src.base_dir, out_dir);
        }
    }
    match format {
        OutFormat::Gltf => {
            if let Some(buffers) = root.parsed("buffers")?.and_then(Value::as_array_mut) {
                let held = src.buffer_data().map_err(Failed::Io)?;
                for (i, b) in buffers.iter_mut().enumerate() {
                    let data: &[u8] = held.get(i).map_or(&[], |b| b.as_slice());
                    out::gltf_buffer(b, data, &src.base_dir, out_dir);
                }
            }
            Ok(false)
        }
        OutFormat::Glb => {
            root.stream("bufferViews", Edit::Views(base));
            // Parsed when an earlier annotation's views were dropped from them.
            if let Some(views) = root.parsed("bufferViews")?.and_then(Value::as_array_mut) {
                views.iter_mut().for_each(|v| out::rebase_view(v, base));
            }
            if base.is_empty() {
                root.swap_remove("buffers");
                return Ok(false);
            }
            let buffers = root.parsed("buffers")?;
            let first = buffers.and_then(|b| b.as_array()).and_then(|a| a.first());
            let one = out::glb_buffer(first, bin_len);
            root.set("buffers", Slot::Parsed(one));
            Ok(true)
        }
    }
}

/// The parts of the nodes drawn in part (`convert --split-by-cell`), to append after the
/// annotation's buffer views (`oracle::write_whole` makes them the same way).
fn made_parts(
    root: &mut Root<'_>,
    plan: &parts::Plan,
    cell_nodes: &[Vec<usize>],
    app: &out::Appended,
) -> Result<parts::Made, Failed> {
    let base = parts::Base {
        nodes: root.len("nodes")?,
        meshes: root.len("meshes")?,
        accessors: root.len("accessors")?,
        view: root.len("bufferViews")? + app.views((0, 0)).len() - 1,
        size: app.indices.map_or(4, |(_, size)| size),
    };
    let wanted: Vec<usize> = plan.nodes.iter().map(|n| n.node).collect();
    let found = root.elements("nodes", &wanted)?;
    let meshes = match root.parsed("meshes")? {
        Some(Value::Array(a)) => &a[..],
        _ => &[],
    };
    Ok(parts::make(
        plan,
        cell_nodes,
        &|i| found.get(&i).cloned(),
        meshes,
        base,
    ))
}

/// What happens to each of the document's nodes: an earlier annotation's object removed,
/// ours added, and the nodes drawn in part given up to their parts.
pub(crate) struct NodeEdits<'a> {
    ours: HashMap<usize, &'a Value>,
    parts: HashMap<usize, &'a [usize]>,
}

impl<'a> NodeEdits<'a> {
    fn of(nodes: &'a [(usize, Value)], made: Option<&'a parts::Made>) -> NodeEdits<'a> {
        let mut ours: HashMap<usize, &Value> = nodes.iter().map(|(i, v)| (*i, v)).collect();
        let mut given = HashMap::new();
        for (n, e) in made.iter().flat_map(|m| &m.edits) {
            ours.insert(*n, &e.ours);
            if let Some(p) = &e.parts {
                given.insert(*n, &p[..]);
            }
        }
        NodeEdits { ours, parts: given }
    }

    /// Node `i` edited.
    fn apply(&self, i: usize, v: &mut Value) {
        out::strip_ours(v);
        if let Some(p) = self.parts.get(&i) {
            parts::give_up_mesh(v, p);
        }
        if let Some(o) = self.ours.get(&i) {
            out::add_ours(v, (*o).clone());
        }
    }
}

/// The annotation (`oracle::annotate`): the extension declared, its root object a place
/// holder (serialized from the annotation, not copied), and each node's object. Whether the
/// document's `extensions` could take it.
fn add_annotation<'a>(root: &mut Root<'a>, per_node: &'a NodeEdits<'a>) -> Result<bool, Failed> {
    let used = root.entry("extensionsUsed", json!([]))?;
    if let Some(a) = used.as_array_mut() {
        if !a.iter().any(|v| v == NAME) {
            a.push(json!(NAME));
        }
    }
    let extensions = root.entry("extensions", json!({}))?;
    let annotated = match extensions.as_object_mut() {
        Some(e) => {
            e.insert(NAME.into(), Value::Null);
            true
        }
        None => false,
    };
    root.stream("nodes", Edit::Nodes(per_node));
    Ok(annotated)
}

/// The PVS blob (`oracle::attach`): at the end of the BIN chunk of a .glb (4-aligned), as a
/// buffer of its own in a .gltf. The index of its new buffer view.
fn attach_blob(
    root: &mut Root<'_>,
    blob: &[u8],
    format: OutFormat,
    bin_len: &mut usize,
) -> Result<(usize, usize), Failed> {
    let at = match format {
        OutFormat::Glb => {
            let offset = bin_len.next_multiple_of(4);
            *bin_len = offset + blob.len();
            match root.parsed("buffers")?.and_then(Value::as_array_mut) {
                Some(b) if !b.is_empty() => b[0]["byteLength"] = json!(*bin_len),
                _ => root.set("buffers", Slot::Parsed(json!([{ "byteLength": *bin_len }]))),
            }
            (0, offset)
        }
        OutFormat::Gltf => {
            let entry = json!({"byteLength": blob.len(), "uri": out::data_uri(blob)});
            match root.parsed("buffers")?.and_then(Value::as_array_mut) {
                Some(b) => {
                    b.push(entry);
                    (b.len() - 1, 0)
                }
                None => {
                    root.set("buffers", Slot::Parsed(json!([entry])));
                    (0, 0)
                }
            }
        }
    };
    Ok(at)
}

/// What goes in the BIN chunk, written straight from the buffers (a released BIN chunk from
/// the input file) rather than joined first.
struct Bin<'a> {
    src: &'a GltfSource,
    lens: &'a [usize],
    /// Where each buffer starts.
    base: &'a [usize],
    blob: Option<&'a [u8]>,
    /// The chunk's length before padding.
    len: usize,
}

/// The .glb container, as [`out::glb`] makes it, written as it is made: the chunk lengths
/// are patched into the headers once known.
fn glb(doc: &Document, bin: Option<Bin>, sink: &mut dyn Sink) -> Result<(), Failed> {
    let start = sink.stream_position().map_err(Failed::Io)?;
    let mut w = Counted {
        inner: BufWriter::with_capacity(1 << 20, &mut *sink),
        bytes: 0,
    };
    let io = Failed::Io;
    // The lengths are patched in once known.
    w.write_all(&glb::header(0)).map_err(io)?;
    w.write_all(&glb::chunk_header(0, glb::JSON_CHUNK))
        .map_err(io)?;
    match parallel::write(doc.sources()?, &mut w) {
        Ok(()) => {}
        Err(Failure::Io(e)) => return Err(Failed::Io(e)),
        Err(Failure::Render(e)) => written(Err(e))?,
    }
    while w.bytes % 4 != 0 {
        w.write_all(b" ").map_err(io)?;
    }
    let json_len = w.bytes - glb::JSON_START as u64;
    if let Some(Bin {
        src,
        lens,
        base,
        blob,
        len,
    }) = bin
    {
        let padded = len.next_multiple_of(4);
        w.write_all(&glb::chunk_header(padded as u32, glb::BIN_CHUNK))
            .map_err(io)?;
        let chunk = w.bytes;
        let mut at = 0usize;
        let zeros = |w: &mut Counted<_>, to: usize, at: &mut usize| {
            while *at < to {
                let n = (to - *at).min(ZEROS.len());
                w.write_all(&ZEROS[..n])?;
                *at += n;
            }
            Ok::<(), std::io::Error>(())
        };
        for (i, (n, from)) in lens.iter().zip(base).enumerate() {
            zeros(&mut w, *from, &mut at).map_err(io)?;
            match src.released_buffer(i) {
                // Straight from the input file into the output (see `Sink::copy_from`).
                Some(r) => {
                    let (mut r, want) = r.map_err(io)?;
                    w.flush().map_err(io)?;
                    let got = w.inner.get_mut().copy_from(&mut r).map_err(io)?;
                    if got != want {
                        return Err(io(std::io::Error::other("the input file was cut short")));
                    }
                    w.bytes += got;
                }
                None => src.write_buffer(i, &mut w).map_err(io)?,
            }
            at += n;
        }
        if let Some(blob) = blob {
            zeros(&mut w, at.next_multiple_of(4), &mut at).map_err(io)?;
            w.write_all(blob).map_err(io)?;
            at += blob.len();
        }
        zeros(&mut w, padded, &mut at).map_err(io)?;
        debug_assert_eq!(w.bytes - chunk, padded as u64);
    }
    let total = w.bytes;
    w.flush().map_err(io)?;
    drop(w);
    let mut patch = |offset: u64, value: u64| -> std::io::Result<()> {
        sink.seek(SeekFrom::Start(start + offset))?;
        sink.write_all(&(value as u32).to_le_bytes())
    };
    patch(8, total).map_err(io)?;
    patch(12, json_len).map_err(io)?;
    sink.seek(SeekFrom::Start(start + total)).map_err(io)?;
    Ok(())
}

/// Padding between buffers in the BIN chunk.
const ZEROS: [u8; 4096] = [0; 4096];

/// A root member: its text, parsed, or an array streamed through an edit.
enum Slot<'a> {
    Text(&'a str),
    Parsed(Value),
    Stream {
        text: &'a str,
        edit: Edit<'a>,
        /// Appended after the streamed elements.
        extra: Vec<Value>,
    },
}

/// What happens to each element of a streamed array.
#[derive(Clone, Copy)]
enum Edit<'a> {
    Copy,
    /// Buffer views re-pointed into the BIN chunk whose buffers start at these offsets.
    Views(&'a [usize]),
    /// Nodes: an earlier annotation removed, ours added, meshes given up to parts.
    Nodes(&'a NodeEdits<'a>),
}

/// The root object's members in order, with the operations of a `serde_json::Map` (an
/// `IndexMap`: an insert keeps a present key's place, a remove swaps the last member in).
struct Root<'a>(Vec<(String, Slot<'a>)>);

impl<'a> Root<'a> {
    fn find(&self, key: &str) -> Option<usize> {
        self.0.iter().position(|(k, _)| k == key)
    }

    /// The member, parsed first if still text. `None` if absent or streamed (no edit of the
    /// other path reads a streamed member's value).
    fn parsed(&mut self, key: &str) -> Result<Option<&mut Value>, Failed> {
        let Some(i) = self.find(key) else {
            return Ok(None);
        };
        let slot = &mut self.0[i].1;
        if let Slot::Text(t) = slot {
            *slot = Slot::Parsed(serde_json::from_str(t)?);
        }
        Ok(match slot {
            Slot::Parsed(v) => Some(v),
            _ => None,
        })
    }

    /// How many elements the array `key` has (0 if absent or not an array: a push makes it
    /// hold only what is pushed).
    fn len(&self, key: &str) -> Result<usize, Failed> {
        let count = |t: &str| {
            json_text::array_len(t)
                .ok_or_else(|| declined(format!("`{key}` is no array it can count")))
        };
        match self.find(key).map(|i| &self.0[i].1) {
            Some(Slot::Text(t)) if json_text::is_array(t) => count(t),
            Some(Slot::Parsed(Value::Array(a))) => Ok(a.len()),
            Some(Slot::Stream { text, extra, .. }) => Ok(count(text)? + extra.len()),
            _ => Ok(0),
        }
    }

    /// The elements at `wanted` (ascending) of the array `key`, parsed.
    fn elements(&self, key: &str, wanted: &[usize]) -> Result<HashMap<usize, Value>, Failed> {
        let mut out = HashMap::new();
        match self.find(key).map(|i| &self.0[i].1) {
            Some(Slot::Text(t) | Slot::Stream { text: t, .. }) => {
                let Some(mut e) = Elements::of(t) else {
                    return Ok(out);
                };
                let mut want = wanted.iter().peekable();
                while let (Some(&&w), Some((text, _))) = (want.peek(), e.run(0)) {
                    if e.count - 1 == w {
                        out.insert(w, serde_json::from_str(text)?);
                        want.next();
                    }
                }
            }
            Some(Slot::Parsed(Value::Array(a))) => {
                for &w in wanted {
                    if let Some(v) = a.get(w) {
                        out.insert(w, v.clone());
                    }
                }
            }
            _ => {}
        }
        Ok(out)
    }

    fn set(&mut self, key: &str, slot: Slot<'a>) {
        match self.find(key) {
            Some(i) => self.0[i].1 = slot,
            None => self.0.push((key.to_string(), slot)),
        }
    }

    /// `map.shift_remove(key)`: the members after it keep their order.
    fn remove(&mut self, key: &str) {
        if let Some(i) = self.find(key) {
            self.0.remove(i);
        }
    }

    fn swap_remove(&mut self, key: &str) {
        if let Some(i) = self.find(key) {
            self.0.swap_remove(i);
        }
    }

    /// `map.entry(key).or_insert(default)`, parsed.
    fn entry(&mut self, key: &str, default: Value) -> Result<&mut Value, Failed> {
        if self.find(key).is_none() {
            self.0.push((key.to_string(), Slot::Parsed(default)));
        }
        self.parsed(key)?
            .ok_or_else(|| declined(format!("`{key}` is streamed, where it must be read")))
    }

    /// Streams the member through `edit` if it is an array still in text.
    fn stream(&mut self, key: &str, edit: Edit<'a>) {
        if let Some(i) = self.find(key) {
            if let Slot::Text(text) = self.0[i].1 {
                if json_text::is_array(text) {
                    self.0[i].1 = Slot::Stream {
                        text,
                        edit,
                        extra: Vec::new(),
                    };
                }
            }
        }
    }

    /// Appends `value` to the root array `key` (or makes `key` hold only it, if it is not an
    /// array) and returns its index.
    fn push(&mut self, key: &str, value: Value) -> Result<usize, Failed> {
        self.stream(key, Edit::Copy);
        let Some(i) = self.find(key) else {
            self.0.push((key.into(), Slot::Parsed(json!([value]))));
            return Ok(0);
        };
        match &mut self.0[i].1 {
            Slot::Stream { text, extra, .. } => {
                let n = json_text::array_len(text)
                    .ok_or_else(|| declined(format!("`{key}` is no array it can count")))?;
                extra.push(value);
                Ok(n + extra.len() - 1)
            }
            Slot::Parsed(Value::Array(a)) => {
                a.push(value);
                Ok(a.len() - 1)
            }
            slot => {
                *slot = Slot::Parsed(json!([value]));
                Ok(0)
            }
        }
    }
}

/// The document to serialize: the root, and the annotation to put in the place held for it.
struct Document<'r, 'a> {
    root: &'r Root<'a>,
    ours: Option<Json<'r>>,
}

impl Serialize for Document<'_, '_> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut map = s.serialize_map(Some(self.root.0.len()))?;
        for (k, slot) in &self.root.0 {
            match (k.as_str(), slot, self.ours) {
                ("extensions", Slot::Parsed(Value::Object(e)), Some(ours)) => {
                    map.serialize_entry(k, &WithOurs(e, ours))?
                }
                (_, Slot::Text(t), _) => map.serialize_entry(k, &Transcode(t))?,
                (_, Slot::Parsed(v), _) => map.serialize_entry(k, v)?,
                (_, Slot::Stream { text, edit, extra }, _) => {
                    let stream = Stream {
                        text,
                        edit: *edit,
                        extra,
                    };
                    map.serialize_entry(k, &stream)?
                }
            }
        }
        map.end()
    }
}

impl<'r> Document<'r, '_> {
    /// The document as sources of the parallel writer ([`Document::serialize`] member by
    /// member, big arrays a run of elements at a time).
    fn sources(&self) -> serde_json::Result<Vec<Source<'r>>> {
        let mut v = vec![Source::bytes(b"{")];
        for (i, (k, slot)) in self.root.0.iter().enumerate() {
            v.push(Source::key(k, i == 0)?);
            match (k.as_str(), slot, self.ours) {
                ("extensions", Slot::Parsed(Value::Object(e)), Some(ours)) => {
                    v.push(Source::bytes(b"{"));
                    for (j, (k, x)) in e.iter().enumerate() {
                        v.push(Source::key(k, j == 0)?);
                        if k == NAME {
                            annotation_sources(ours, &mut v)?;
                        } else {
                            v.push(Source::value(x));
                        }
                    }
                    v.push(Source::bytes(b"}"));
                }
                (_, Slot::Text(t), _) => {
                    let text = *t;
                    v.extend(array(text, Edit::Copy, &[]).unwrap_or_else(|| {
                        vec![Source::Job(Box::new(move |b| {
                            serde_json::to_writer(b, &Transcode(text))
                        }))]
                    }));
                }
                (_, Slot::Parsed(x), _) => v.push(Source::value(x)),
                (_, Slot::Stream { text, edit, extra }, _) => {
                    let (text, edit, extra) = (*text, *edit, &extra[..]);
                    v.extend(array(text, edit, extra).unwrap_or_else(|| {
                        vec![Source::Job(Box::new(move |b| {
                            serde_json::to_writer(b, &Stream { text, edit, extra })
                        }))]
                    }));
                }
            }
        }
        v.push(Source::bytes(b"}"));
        Ok(v)
    }
}

/// An array's text as sources, each element through `edit` as [`StreamVisitor`] does it, then
/// `extra`; `None` if the text is not an array.
fn array<'r>(text: &'r str, edit: Edit<'r>, extra: &'r [Value]) -> Option<Vec<Source<'r>>> {
    let elements = Elements::of(text)?;
    let render: RenderText<'r> = match edit {
        Edit::Copy => Box::new(|_, e, b| transcode::write_compact(e, b)),
        Edit::Views(base) => Box::new(move |_, e, b| {
            if view_unchanged(e, base) {
                return transcode::write_compact(e, b);
            }
            let mut v: Value = serde_json::from_str(e)?;
            out::rebase_view(&mut v, base);
            serde_json::to_writer(b, &v)
        }),
        Edit::Nodes(ours) => Box::new(move |i, e, b| {
            // A node without ours to add and no `extensions` (the key cannot hide behind an
            // escape without a backslash) has nothing to strip.
            if !ours.ours.contains_key(&i) && !e.contains("extensions") && !e.contains('\\') {
                return transcode::write_compact(e, b);
            }
            let mut v: Value = serde_json::from_str(e)?;
            ours.apply(i, &mut v);
            serde_json::to_writer(b, &v)
        }),
    };
    Some(vec![
        Source::bytes(b"["),
        Source::Text {
            elements,
            render: std::sync::Arc::new(render),
            // The appended elements as one tail, commas between them.
            tail: (!extra.is_empty()).then(|| -> Render<'r> {
                Box::new(move |b| {
                    for (i, x) in extra.iter().enumerate() {
                        if i > 0 {
                            b.push(b',');
                        }
                        serde_json::to_writer(&mut *b, x)?;
                    }
                    Ok(())
                })
            }),
        },
        Source::bytes(b"]"),
    ])
}

/// Whether [`out::rebase_view`] leaves a buffer view's text as it parses: when the first
/// buffer starts the BIN chunk and the view is on it (`"buffer": 0` as written) with its
/// `byteOffset`, if any, a plain integer. Most views of a big .glb are; they are then
/// transcoded instead of parsed into a `Value` (a map per view, most of the export's
/// allocations).
fn view_unchanged(e: &str, base: &[usize]) -> bool {
    #[derive(serde::Deserialize)]
    struct Head<'a> {
        #[serde(borrow, default)]
        buffer: Option<&'a RawValue>,
        #[serde(borrow, default, rename = "byteOffset")]
        byte_offset: Option<&'a RawValue>,
    }
    let plain = |r: &RawValue| {
        let t = r.get();
        t.bytes().all(|c| c.is_ascii_digit())
            && (t == "0" || !t.starts_with('0'))
            && t.parse::<u64>().is_ok()
    };
    base.first().copied().unwrap_or(0) == 0
        && serde_json::from_str::<Head>(e).is_ok_and(|h| {
            h.buffer.is_some_and(|b| b.get() == "0") && h.byte_offset.is_none_or(plain)
        })
}

/// The root extension object as sources of the parallel writer: `cells` and `portals` a run
/// of elements at a time, the same bytes as serializing it.
fn annotation_sources<'r>(ours: Json<'r>, out: &mut Vec<Source<'r>>) -> serde_json::Result<()> {
    let Some(members) = ours.members() else {
        out.push(Source::Job(Box::new(move |b| {
            serde_json::to_writer(b, &ours)
        })));
        return Ok(());
    };
    out.push(Source::bytes(b"{"));
    for (i, (k, m)) in members.into_iter().enumerate() {
        out.push(Source::key(k, i == 0)?);
        match m {
            Member::Cells(cells) => items(out, cells.len(), move |i, b| {
                serde_json::to_writer(b, &cells.cell(i))
            }),
            Member::Portals(portals) => items(out, portals.len(), move |i, b| {
                serde_json::to_writer(b, &portals.portal(i))
            }),
            // Rendered when the writer reaches it, by then long computed.
            Member::Hash(hash, v) => out.push(Source::Deferred(Box::new(move || {
                match hash.and_then(|h| h.get()) {
                    Some(h) => serde_json::to_vec(h),
                    None => serde_json::to_vec(v),
                }
            }))),
            Member::Plain(v) => out.push(Source::value(v)),
        }
    }
    out.push(Source::bytes(b"}"));
    Ok(())
}

/// An array of `len` elements, each rendered by `render`, as sources of the parallel writer.
fn items<'r>(
    out: &mut Vec<Source<'r>>,
    len: usize,
    render: impl Fn(usize, &mut Vec<u8>) -> serde_json::Result<()> + Send + Sync + 'r,
) {
    out.push(Source::bytes(b"["));
    out.push(Source::Items {
        len,
        render: std::sync::Arc::new(Box::new(render)),
    });
    out.push(Source::bytes(b"]"));
}

/// The root's `extensions`, our member serialized from the annotation.
struct WithOurs<'r>(&'r serde_json::Map<String, Value>, Json<'r>);

impl Serialize for WithOurs<'_> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut map = s.serialize_map(Some(self.0.len()))?;
        for (k, v) in self.0 {
            if k == NAME {
                map.serialize_entry(k, &self.1)?;
            } else {
                map.serialize_entry(k, v)?;
            }
        }
        map.end()
    }
}

struct Stream<'r> {
    text: &'r str,
    edit: Edit<'r>,
    extra: &'r [Value],
}

impl Serialize for Stream<'_> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut de = serde_json::Deserializer::from_str(self.text);
        de.deserialize_seq(StreamVisitor { s, stream: self })
            .map_err(ser::Error::custom)
    }
}

struct StreamVisitor<'r, S> {
    s: S,
    stream: &'r Stream<'r>,
}

impl<'de, S: Serializer> Visitor<'de> for StreamVisitor<'_, S> {
    type Value = S::Ok;

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("a JSON array")
    }

    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<S::Ok, A::Error> {
        let mut out = self.s.serialize_seq(None).map_err(de::Error::custom)?;
        match self.stream.edit {
            Edit::Copy => while seq.next_element_seed(Element(&mut out))?.is_some() {},
            Edit::Views(base) => {
                while let Some(mut v) = seq.next_element::<Value>()? {
                    out::rebase_view(&mut v, base);
                    out.serialize_element(&v).map_err(de::Error::custom)?;
                }
            }
            Edit::Nodes(ours) => {
                let mut i = 0;
                while let Some(mut v) = seq.next_element::<Value>()? {
                    ours.apply(i, &mut v);
                    out.serialize_element(&v).map_err(de::Error::custom)?;
                    i += 1;
                }
            }
        }
        for e in self.stream.extra {
            out.serialize_element(e).map_err(de::Error::custom)?;
        }
        out.end().map_err(de::Error::custom)
    }
}

#[cfg(test)]
mod tests {
    use std::path::{Path, PathBuf};

    use serde_json::{json, Value};

    use crate::export::gltf_out;
    use crate::export::target::{OutFormat, Target};
    use crate::export::{self as extension, Annotation};
    use crate::scene::{Format, GltfSource, Scene};

    const FORMATS: [OutFormat; 2] = [OutFormat::Glb, OutFormat::Gltf];

    /// Both paths' bytes for `ann` written next to `out`; `None` from the streamed one if it
    /// declined.
    fn both(scene: &Scene, ann: &Annotation, format: OutFormat) -> (Option<Vec<u8>>, Vec<u8>) {
        let out = Path::new("/nonexistent/out/level.glb");
        let dir = out.parent().unwrap();
        let whole = crate::export::oracle::write_whole(scene, ann, out, dir, format).unwrap();
        let mut mine = ann_clone(ann);
        let src = scene.gltf.as_ref().unwrap();
        let mut bytes = std::io::Cursor::new(Vec::new());
        let written = super::write(src, None, &mut mine, format, dir, &mut bytes);
        let streamed = written.ok().map(|()| bytes.into_inner());
        // The root members found beforehand (as the pipeline finds them, on a thread of
        // their own) give the same bytes.
        let mut again = ann_clone(ann);
        let mut bytes = std::io::Cursor::new(Vec::new());
        let written = super::write(
            src,
            src.members().unwrap(),
            &mut again,
            format,
            dir,
            &mut bytes,
        );
        assert_eq!(written.ok().map(|()| bytes.into_inner()), streamed);
        (streamed, whole)
    }

    fn with_pvs(mut ann: Annotation<'_>) -> Annotation<'_> {
        ann.blob = Some(vec![7, 1, 2, 3, 4]);
        if let Some(o) = ann.root.as_object_mut() {
            o.insert(
                "visibility".into(),
                json!({"method": "full", "encoding": "bits"}),
            );
        }
        ann
    }

    fn assert_same(scene: &Scene, ann: &Annotation, what: &str) {
        for format in FORMATS {
            let (mine, whole) = both(scene, ann, format);
            let mine = mine.unwrap_or_else(|| panic!("{what}: declined"));
            assert!(
                mine == whole,
                "{what} ({format:?}): the streamed bytes differ"
            );
        }
    }

    #[test]
    fn same_bytes_as_the_whole_document_on_every_sample() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR"));
        let mut files: Vec<PathBuf> = Vec::new();
        for dir in ["samples", "samples/broken", "tests/fixtures/third_party"] {
            for e in std::fs::read_dir(root.join(dir)).unwrap() {
                let p = e.unwrap().path();
                if matches!(p.extension().and_then(|e| e.to_str()), Some("gltf" | "glb")) {
                    files.push(p);
                }
            }
        }
        files.sort();
        assert!(files.len() > 20);
        let mut split = 0;
        for f in &files {
            let Ok(level) = crate::pipeline::load(f, &Default::default()) else {
                continue;
            };
            let scene = level.scene();
            let ann = extension::build(&level, &|n| gltf_out::node_index(scene, n));
            let what = f.display().to_string();
            assert_same(scene, &with_pvs(ann_clone(&ann)), &what);
            assert_same(scene, &ann, &what);
            let parts = extension::build_as(
                &level,
                &|n| gltf_out::node_index(scene, n),
                extension::CellGeometry::SplitNodes,
            );
            split += usize::from(parts.parts.is_some());
            assert_same(
                scene,
                &with_pvs(ann_clone(&parts)),
                &format!("{what}, split"),
            );
            assert_same(scene, &parts, &format!("{what}, split"));
            // Written and read again: the earlier annotation's tail is dropped the same way.
            for format in FORMATS {
                let dir = tempfile::tempdir().unwrap();
                let out = dir.path().join(match format {
                    OutFormat::Glb => "level.glb",
                    OutFormat::Gltf => "level.gltf",
                });
                let ann = with_pvs(ann_clone(&ann));
                let bytes =
                    crate::export::oracle::write_whole(scene, &ann, &out, dir.path(), format);
                std::fs::write(&out, bytes.unwrap()).unwrap();
                let again = crate::pipeline::load(&out, &Default::default()).unwrap();
                let src = again.scene().gltf.as_ref().unwrap();
                assert!(
                    src.earlier.is_some(),
                    "{what} ({format:?}): no earlier tail found"
                );
                let ann = extension::build(&again, &|n| gltf_out::node_index(again.scene(), n));
                assert_same(
                    again.scene(),
                    &with_pvs(ann),
                    &format!("{what}, written again"),
                );
            }
        }
        assert!(split >= 5, "{split} files with nodes split by cell");
    }

    fn ann_clone<'a>(a: &Annotation<'a>) -> Annotation<'a> {
        Annotation {
            root: a.root.clone(),
            nodes: a.nodes.clone(),
            blob: a.blob.clone(),
            indices: a.indices.clone(),
            parts: a.parts.clone(),
            lazy: a.lazy.clone(),
        }
    }

    fn scene_of(doc: &str, buffers: Vec<Vec<u8>>) -> Scene {
        let mut scene = Scene::new(PathBuf::from("/nonexistent/in/level.gltf"), Format::Gltf);
        scene.gltf = Some(GltfSource {
            json: doc.to_string(),
            json_file: None,
            reloaded: Default::default(),
            buffers,
            base_dir: PathBuf::from("/nonexistent/in"),
            bin_file: None,
            members_at: None,
            earlier: None,
            parts: 0,
        });
        scene
    }

    fn annotation(nodes: Vec<(usize, Value)>) -> Annotation<'static> {
        Annotation::of(
            json!({"version": 1, "cells": [{"room": "a", "planes": [[0.5, 0, 0, 1e-9]]}]}),
            nodes,
            None,
        )
    }

    #[test]
    fn same_bytes_on_odd_documents() {
        let docs = [
            // Annotated before: our members replaced, neighbours kept in their order.
            r#"{"asset": {"version": "2.0"}, "extensionsUsed": ["X", "PORTCULLIS_portals"],
                "extensions": {"PORTCULLIS_portals": {"old": true}, "X": {}},
                "nodes": [{"name": "a", "extensions": {"PORTCULLIS_portals": {"cell": 3}}, "mesh": 0, "extras": {}},
                          {"extensions": {"A": 1, "PORTCULLIS_portals": {}, "B": 2}, "name": "b"},
                          {"name": "c"}, 5, {"extensions": "no"}],
                "bufferViews": [{"buffer": 1, "byteLength": 4}, {"buffer": 0, "byteOffset": 0, "byteLength": 4}, {"byteLength": 1, "byteOffset": 3}, [1]],
                "buffers": [{"byteLength": 4, "name": "first", "extras": {"k": [1, 2.5]}}, {"uri": "b.bin", "byteLength": 4}],
                "images": [{"uri": "tex/a b.png"}, {"uri": "data:image/png;base64,AAAA"}, {"bufferView": 0}, 3]}"#,
            // Nothing to extend or point into.
            r#"{"asset": {"version": "2.0"}}"#,
            r#"{"extensions": "not an object", "extensionsUsed": {}, "bufferViews": {}, "buffers": 3, "nodes": {}}"#,
            r#"{"nodes": [], "bufferViews": [], "buffers": [], "images": []}"#,
            // A repeated key inside an element that is parsed (nodes), and at the root.
            r#"{"nodes": [{"name": "a", "name": "b"}], "asset": {}, "asset": {"version": "2.0"}}"#,
            r#"{"scene": 0, "scenes": [{"nodes": [0]}], "accessors": [{"min": [1e-300, -0.0, 12345678901234567890], "max": [1.0, 2, 3]}], "materials": [{"name": "\u00e9\t\"q\""}]}"#,
        ];
        let nodes = vec![
            (1, json!({"cell": 0})),
            (0, json!({"cells": [1, 2]})),
            (9, json!({"cell": 4})),
            (3, json!({"cell": 5})),
            (1, json!({"cell": 6})),
        ];
        for (i, doc) in docs.iter().enumerate() {
            for buffers in [
                vec![vec![1u8, 2, 3, 4, 5], vec![9; 4]],
                vec![vec![1]],
                vec![],
            ] {
                let scene = scene_of(doc, buffers.clone());
                let what = format!("document {i}, {} buffer(s)", buffers.len());
                let ann = annotation(nodes.clone());
                assert_same(&scene, &ann, &what);
                assert_same(&scene, &with_pvs(ann), &what);
            }
        }
    }

    /// What `convert` writes (the parallel writer, the input hash computed alongside and put in
    /// when the writer reaches it) is what the whole-document path writes from an annotation
    /// built with its hash, for every sample, in both containers.
    #[test]
    fn the_pipeline_writes_what_the_whole_document_path_writes() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR"));
        let mut n = 0;
        for dir in ["samples", "tests/fixtures/third_party"] {
            for e in std::fs::read_dir(root.join(dir)).unwrap() {
                let f = e.unwrap().path();
                if !matches!(f.extension().and_then(|e| e.to_str()), Some("gltf" | "glb")) {
                    continue;
                }
                let level = crate::pipeline::load(&f, &Default::default()).unwrap();
                let scene = level.scene();
                let geometry = match n % 4 {
                    2 => extension::CellGeometry::SplitNodes,
                    _ => extension::CellGeometry::DrawLists,
                };
                let ann =
                    extension::build_as(&level, &|n| gltf_out::node_index(scene, n), geometry);
                assert!(ann.root["inputHash"].is_string());
                let out = Path::new("/nonexistent/out/level.glb");
                for format in FORMATS {
                    let whole = crate::export::oracle::write_whole(
                        scene,
                        &ann,
                        out,
                        out.parent().unwrap(),
                        format,
                    )
                    .unwrap();
                    let target = match format {
                        OutFormat::Glb => Target::Glb,
                        OutFormat::Gltf => Target::Gltf,
                    };
                    let to =
                        crate::export::output::Output::memory(out, target).with_geometry(geometry);
                    let mine = crate::export::output::level(&level, None, &to).unwrap();
                    assert!(mine == whole, "{} ({format:?})", f.display());
                    n += 1;
                }
            }
        }
        assert!(n >= 20, "{n} files");
    }

    /// A view taken as unchanged renders as the `Value` path renders it, and the common one
    /// (on buffer 0, a plain offset, the first buffer at 0) is taken.
    #[test]
    fn a_view_taken_as_unchanged_is_unchanged() {
        let views = [
            r#"{"buffer":0,"byteOffset":48,"byteLength":12,"target":34962}"#,
            r#"{"byteLength":12,"buffer":0}"#,
            r#"{"buffer":0,"byteOffset":0}"#,
            r#"{"buffer":0,"byteOffset":1.0}"#,
            r#"{"buffer":0,"byteOffset":1e2}"#,
            r#"{"buffer":0,"byteOffset":18446744073709551616}"#,
            r#"{"buffer":0,"byteOffset":-4}"#,
            r#"{"buffer":0.0,"byteOffset":4}"#,
            r#"{"buffer":1,"byteOffset":4}"#,
            r#"{"byteOffset":4}"#,
            r#"{"buffer":0,"buffer":1}"#,
            r#"{"buff\u0065r":0,"byteOffset":8}"#,
            r#"{"buffer":null}"#,
            r#"null"#,
            r#"[0]"#,
        ];
        let mut taken = 0;
        for base in [&[0usize, 100][..], &[0][..], &[16, 0][..], &[][..]] {
            for e in views {
                let mut v: Value = serde_json::from_str(e).unwrap();
                crate::export::container::rebase_view(&mut v, base);
                let slow = serde_json::to_string(&v).unwrap();
                if super::view_unchanged(e, base) {
                    taken += 1;
                    let fast = serde_json::to_string(&super::Transcode(e)).unwrap();
                    assert_eq!(fast, slow, "{e} with {base:?}");
                }
            }
        }
        assert!(super::view_unchanged(views[0], &[0, 100]));
        assert!(taken >= 8, "{taken}");
    }

    #[test]
    fn a_repeated_key_in_a_copied_member_is_written_from_the_parsed_document() {
        let scene = scene_of(
            r#"{"accessors": [{"count": 1, "count": 2}], "nodes": []}"#,
            vec![],
        );
        let ann = annotation(vec![]);
        let (mine, whole) = both(&scene, &ann, OutFormat::Glb);
        assert!(mine.is_none());
        let written = gltf_out::write(
            &scene,
            ann_clone(&ann),
            Path::new("out.glb"),
            OutFormat::Glb,
        )
        .unwrap();
        assert_eq!(written, whole);
        // Into a file, as convert writes: what the streamed path wrote before it declined is
        // gone, not left before or after the whole document.
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("out.glb");
        let mut f = std::fs::File::options()
            .read(true)
            .write(true)
            .create(true)
            .truncate(true)
            .open(&out)
            .unwrap();
        gltf_out::write_to(&scene, ann, &out, OutFormat::Glb, &mut f).unwrap();
        drop(f);
        assert_eq!(std::fs::read(&out).unwrap(), whole);
    }
}
