//! The `PORTCULLIS_portals` glTF extension: what an engine needs at run time, and nothing a
//! level does not need (no transform on plain portals, no rooms array when every room is one
//! cell, no empty arrays). Documented in schemas/PORTCULLIS_portals.md and checked against
//! schemas/PORTCULLIS_portals.schema.json.

use super::parallel::Source;
use rayon::prelude::*;
use serde::ser::{Serialize, SerializeMap, Serializer};
use serde_json::{json, Map, Value};

use crate::cells::CellSet;
use crate::portals::PortalSet;
use crate::scene::{NodeId, Scene};
use crate::tags::rules::PortalKind;
use crate::tags::Tagging;

pub const NAME: &str = "PORTCULLIS_portals";
pub const VERSION: u64 = 1;

/// Numbers are written rounded to 1e-9 of a metre (far below any tolerance), so the output
/// does not carry f64 noise that differs between platforms' last bits.
fn num(x: f64) -> Value {
    let r = (x * 1e9).round() / 1e9;
    Value::from(if r == 0.0 { 0.0 } else { r })
}

/// The hash of every input of the result, so a consumer can tell the annotation is stale:
/// each node's world transform, name and extras, its mesh's positions, triangles and
/// materials (names and extras), in walk order, then the settings that shape the cells and
/// portals ([`Tagging::settings`]). XXH3-64, written `xxh3v2:` + 16 hex digits.
pub fn input_hash(scene: &Scene, tagging: &Tagging) -> String {
    let mut h = xxhash_rust::xxh3::Xxh3::new();
    hashed_bytes(scene, tagging, Coverage::Everything, |b| h.update(b));
    format!("xxh3v2:{:016x}", h.digest())
}

/// [`input_hash`] by the definition a stored hash names: `xxh3v2:`, or, as earlier builds
/// wrote them, `xxh3:` (XXH3-64) and `fnv1a64:` (FNV-1a 64) over the geometry and the names of
/// the recognised rooms and portal nodes only. `None` for a name it does not know.
pub fn input_hash_like(stored: &str, scene: &Scene, tagging: &Tagging) -> Option<String> {
    match stored.split_once(':')?.0 {
        "xxh3v2" => Some(input_hash(scene, tagging)),
        "xxh3" => {
            let mut h = xxhash_rust::xxh3::Xxh3::new();
            hashed_bytes(scene, tagging, Coverage::GeometryAndTags, |b| h.update(b));
            Some(format!("xxh3:{:016x}", h.digest()))
        }
        "fnv1a64" => {
            let mut h: u64 = 0xcbf29ce484222325;
            hashed_bytes(scene, tagging, Coverage::GeometryAndTags, |bytes| {
                for b in bytes {
                    h ^= *b as u64;
                    h = h.wrapping_mul(0x100000001b3);
                }
            });
            Some(format!("fnv1a64:{h:016x}"))
        }
        _ => None,
    }
}

/// What a hash definition covers.
#[derive(Clone, Copy, PartialEq)]
enum Coverage {
    /// Earlier builds': geometry, room names and portal nodes.
    GeometryAndTags,
    /// Also names, extras, materials and the settings.
    Everything,
}

/// Feeds `eat` the bytes an input hash is over. Positions and triangles go a mesh at a time
/// (XXH3 is fast on long runs, slow on many short ones). Text is followed by a 0 byte, and an
/// absent name or extras by 0xff, so no two inputs run together into the same bytes.
fn hashed_bytes(scene: &Scene, tagging: &Tagging, what: Coverage, mut eat: impl FnMut(&[u8])) {
    let everything = what == Coverage::Everything;
    let text = |t: Option<&str>, eat: &mut dyn FnMut(&[u8])| match t {
        Some(t) => {
            eat(t.as_bytes());
            eat(&[0]);
        }
        None => eat(&[0xff]),
    };
    let json = |v: Option<&serde_json::Value>| v.map(|v| v.to_string());
    // In memory the bytes are the little-endian ones the hash is defined over only on a
    // little-endian machine; elsewhere they are converted one number at a time.
    let little = cfg!(target_endian = "little");
    for n in scene.walk() {
        let node = &scene.nodes[n];
        for x in node.world.to_cols_array() {
            eat(&x.to_bits().to_le_bytes());
        }
        if everything {
            text(node.name.as_deref(), &mut eat);
            text(json(node.extras.as_ref()).as_deref(), &mut eat);
        }
        if let Some(m) = node.mesh {
            let mesh = &scene.meshes[m];
            if everything {
                text(json(mesh.extras.as_ref()).as_deref(), &mut eat);
                for p in &mesh.primitives {
                    let material = p.material.map(|i| &scene.materials[i]);
                    text(material.and_then(|m| m.name.as_deref()), &mut eat);
                    text(
                        json(material.and_then(|m| m.extras.as_ref())).as_deref(),
                        &mut eat,
                    );
                    eat(&(p.first_triangle as u64).to_le_bytes());
                    eat(&(p.triangle_count as u64).to_le_bytes());
                }
            }
            if little {
                eat(bytemuck::cast_slice(&mesh.positions));
                eat(bytemuck::cast_slice(&mesh.triangles));
                continue;
            }
            for p in &mesh.positions {
                for x in p.to_array() {
                    eat(&x.to_bits().to_le_bytes());
                }
            }
            for t in &mesh.triangles {
                for i in t {
                    eat(&i.to_le_bytes());
                }
            }
        }
    }
    for r in &tagging.rooms {
        eat(r.name.as_bytes());
        eat(&[0]);
    }
    for p in &tagging.portals {
        eat(&(p.node as u64).to_le_bytes());
    }
    if everything {
        eat(&tagging.settings);
    }
}

/// The root extension object and, per glTF node index, the node extension object.
pub struct Annotation<'a> {
    /// The root object's members in order. `cells` and `portals`, when present, hold `null`
    /// here: they are serialized straight from the level ([`Annotation::json`]), since as a
    /// JSON tree they took ten times the room of their text on a big level.
    pub root: Value,
    pub nodes: Vec<(usize, Value)>,
    /// Bytes for a buffer view the root refers to (`visibility.bufferView`), appended by the
    /// writer, which sets the index.
    pub blob: Option<Vec<u8>>,
    pub(crate) lazy: Lazy<'a>,
}

/// What the `cells` and `portals` members are serialized from.
#[derive(Clone, Default)]
pub(crate) struct Lazy<'a> {
    level: Option<(&'a CellSet, &'a Tagging, &'a PortalSet)>,
    /// Per cell, the glTF nodes it renders.
    cell_nodes: Vec<Vec<usize>>,
    /// Per portal, the glTF node it was authored as.
    portal_nodes: Vec<Option<usize>>,
    /// The input hash, when the root's `inputHash` holds `null` until it is known.
    hash: Option<&'a (dyn HashOf + Sync + 'a)>,
}

/// What a root `inputHash` of `null` is serialized from (a trait object, so the lifetime of
/// what computes it does not pin the annotation's).
pub(crate) trait HashOf {
    /// The hash, waiting for it if it is still being computed.
    fn get(&self) -> Option<&str>;
}

/// An input hash computed on another thread while the output is written: it reads every
/// position of the level byte by byte (as long as a big level's whole JSON takes to render),
/// and the root extension object usually comes last in the document.
pub(crate) struct InputHash<'a> {
    value: std::sync::OnceLock<String>,
    pending: std::sync::Mutex<Option<PendingHash<'a>>>,
}

/// Waits for (or computes) the input hash.
pub(crate) type PendingHash<'a> = Box<dyn FnOnce() -> String + Send + 'a>;

impl<'a> InputHash<'a> {
    pub fn pending(f: PendingHash<'a>) -> InputHash<'a> {
        InputHash {
            value: std::sync::OnceLock::new(),
            pending: std::sync::Mutex::new(Some(f)),
        }
    }
}

impl HashOf for InputHash<'_> {
    fn get(&self) -> Option<&str> {
        // The first caller computes; any other waits for it (`get_or_init` blocks them).
        let v = self.value.get_or_init(|| {
            let pending = self.pending.lock().ok().and_then(|mut p| p.take());
            pending.map(|f| f()).unwrap_or_default()
        });
        // Empty only if the computation was lost (a poisoned lock): then the root's null.
        (!v.is_empty()).then_some(v.as_str())
    }
}

impl<'a> Annotation<'a> {
    /// An annotation of these members only (nothing serialized from a level).
    pub fn of(root: Value, nodes: Vec<(usize, Value)>, blob: Option<Vec<u8>>) -> Annotation<'a> {
        Annotation {
            root,
            nodes,
            blob,
            lazy: Lazy::default(),
        }
    }

    /// Stores the PVS (left out for a level of one cell).
    pub fn set_visibility(&mut self, pvs: &crate::vis::Pvs, method: crate::vis::Method) {
        if let Some(e) = super::visibility::encode(pvs, method) {
            if let Some(o) = self.root.as_object_mut() {
                o.insert("visibility".into(), e.json);
            }
            self.blob = e.blob;
        }
    }

    /// The root extension object, to serialize.
    pub fn json(&self) -> Json<'_> {
        Json {
            root: &self.root,
            lazy: &self.lazy,
        }
    }

    /// The root extension object as a JSON tree.
    pub fn to_value(&self) -> Value {
        serde_json::to_value(self.json()).unwrap_or(Value::Null)
    }
}

/// The root extension object: `root` with its `cells` and `portals` serialized from the level.
#[derive(Clone, Copy)]
pub struct Json<'r> {
    pub(crate) root: &'r Value,
    pub(crate) lazy: &'r Lazy<'r>,
}

impl Serialize for Json<'_> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let (Value::Object(members), Some((cells, tagging, portals))) =
            (self.root, self.lazy.level)
        else {
            return self.root.serialize(s);
        };
        let mut map = s.serialize_map(Some(members.len()))?;
        for (k, v) in members {
            match (k.as_str(), v) {
                ("cells", Value::Null) => map.serialize_entry(
                    k,
                    &Cells {
                        cells,
                        tagging,
                        nodes: &self.lazy.cell_nodes,
                    },
                )?,
                ("portals", Value::Null) => map.serialize_entry(
                    k,
                    &Portals {
                        portals,
                        nodes: &self.lazy.portal_nodes,
                    },
                )?,
                ("inputHash", Value::Null) => match self.lazy.hash.and_then(|h| h.get()) {
                    Some(h) => map.serialize_entry(k, h)?,
                    None => map.serialize_entry(k, v)?,
                },
                _ => map.serialize_entry(k, v)?,
            }
        }
        map.end()
    }
}

impl<'r> Json<'r> {
    /// The root extension object as sources of the parallel writer: `cells` and `portals` a
    /// run of elements at a time, the same bytes as serializing it.
    pub(crate) fn sources(self, out: &mut Vec<Source<'r>>) -> serde_json::Result<()> {
        let (Value::Object(members), Some((cells, tagging, portals))) =
            (self.root, self.lazy.level)
        else {
            out.push(Source::Job(Box::new(move |b| {
                serde_json::to_writer(b, &self)
            })));
            return Ok(());
        };
        out.push(Source::bytes(b"{"));
        for (i, (k, v)) in members.iter().enumerate() {
            out.push(Source::key(k, i == 0)?);
            match (k.as_str(), v) {
                ("cells", Value::Null) => {
                    let cells = Cells {
                        cells,
                        tagging,
                        nodes: &self.lazy.cell_nodes,
                    };
                    let len = cells.len();
                    items(out, len, move |i, b| {
                        serde_json::to_writer(b, &cells.cell(i))
                    });
                }
                ("portals", Value::Null) => {
                    let portals = Portals {
                        portals,
                        nodes: &self.lazy.portal_nodes,
                    };
                    let len = portals.len();
                    items(out, len, move |i, b| {
                        serde_json::to_writer(b, &portals.portal(i))
                    });
                }
                ("inputHash", Value::Null) => {
                    // Rendered when the writer reaches it, by then long computed.
                    let hash = self.lazy.hash;
                    out.push(Source::Deferred(Box::new(move || {
                        match hash.and_then(|h| h.get()) {
                            Some(h) => serde_json::to_vec(h),
                            None => serde_json::to_vec(v),
                        }
                    })));
                }
                _ => out.push(Source::value(v)),
            }
        }
        out.push(Source::bytes(b"}"));
        Ok(())
    }
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

/// A number as [`num`] writes it.
struct Num(f64);

impl Serialize for Num {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        num(self.0).serialize(s)
    }
}

struct Cells<'a> {
    cells: &'a CellSet,
    tagging: &'a Tagging,
    nodes: &'a [Vec<usize>],
}

impl<'a> Cells<'a> {
    fn len(&self) -> usize {
        self.cells.cells.len().min(self.nodes.len())
    }

    fn cell(&self, i: usize) -> CellJson<'a, impl Iterator<Item = [Num; 4]> + 'a> {
        let (c, nodes) = (&self.cells.cells[i], &self.nodes[i]);
        let planes = c.poly.faces.iter().map(|f| {
            let (n, d) = (f.plane.normal, f.plane.d);
            [Num(n.x), Num(n.y), Num(n.z), Num(d)]
        });
        let v3 = |v: glam::DVec3| [Num(v.x), Num(v.y), Num(v.z)];
        CellJson {
            room: &self.tagging.rooms[c.room].name,
            priority: self.tagging.rooms[c.room].priority,
            planes: Seq::new(planes),
            min: v3(c.bounds.min),
            max: v3(c.bounds.max),
            nodes,
        }
    }
}

impl Serialize for Cells<'_> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_seq((0..self.len()).map(|i| self.cell(i)))
    }
}

struct CellJson<'a, P> {
    room: &'a str,
    /// The room's priority where rooms nest; 0, the default, is left out.
    priority: i64,
    planes: Seq<P>,
    min: [Num; 3],
    max: [Num; 3],
    nodes: &'a [usize],
}

impl<P: Iterator<Item = [Num; 4]>> Serialize for CellJson<'_, P> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut o = s.serialize_map(None)?;
        o.serialize_entry("room", self.room)?;
        if self.priority != 0 {
            o.serialize_entry("priority", &self.priority)?;
        }
        o.serialize_entry("planes", &self.planes)?;
        o.serialize_entry(
            "bounds",
            &Bounds {
                min: &self.min,
                max: &self.max,
            },
        )?;
        if !self.nodes.is_empty() {
            o.serialize_entry("nodes", self.nodes)?;
        }
        o.end()
    }
}

struct Bounds<'a> {
    min: &'a [Num; 3],
    max: &'a [Num; 3],
}

impl Serialize for Bounds<'_> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut o = s.serialize_map(Some(2))?;
        o.serialize_entry("min", self.min)?;
        o.serialize_entry("max", self.max)?;
        o.end()
    }
}

struct Portals<'a> {
    portals: &'a PortalSet,
    nodes: &'a [Option<usize>],
}

impl<'a> Portals<'a> {
    fn len(&self) -> usize {
        self.portals.portals.len().min(self.nodes.len())
    }

    fn portal(&self, i: usize) -> PortalJson<'a> {
        PortalJson(&self.portals.portals[i], self.nodes[i])
    }
}

impl Serialize for Portals<'_> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_seq((0..self.len()).map(|i| self.portal(i)))
    }
}

struct PortalJson<'a>(&'a crate::portals::Portal, Option<usize>);

impl Serialize for PortalJson<'_> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let p = self.0;
        let mut o = s.serialize_map(None)?;
        o.serialize_entry(
            "polygon",
            &Seq::new(p.polygon.iter().map(|v| [Num(v.x), Num(v.y), Num(v.z)])),
        )?;
        match p.to {
            Some(t) => o.serialize_entry("cells", &[p.from, t])?,
            None => o.serialize_entry("cells", &[p.from])?,
        }
        match p.kind {
            PortalKind::Plain => {}
            PortalKind::Mirror => o.serialize_entry("kind", "mirror")?,
            PortalKind::Teleporter => o.serialize_entry("kind", "teleporter")?,
        }
        if p.one_way {
            o.serialize_entry("oneWay", &true)?;
        }
        if p.closed {
            o.serialize_entry("closed", &true)?;
        }
        if p.internal {
            o.serialize_entry("internal", &true)?;
        }
        if let Some(t) = p.transform {
            o.serialize_entry(
                "transform",
                &Seq::new(t.to_cols_array().into_iter().map(Num)),
            )?;
        }
        if let Some(q) = p.partner {
            o.serialize_entry("partner", &q)?;
        }
        if let Some(n) = self.1 {
            o.serialize_entry("node", &n)?;
        }
        o.end()
    }
}

/// An iterator serialized as a sequence (once: serializing takes it).
struct Seq<I>(std::cell::Cell<Option<I>>);

impl<I> Seq<I> {
    fn new(i: I) -> Seq<I> {
        Seq(std::cell::Cell::new(Some(i)))
    }
}

impl<I: Iterator<Item = T>, T: Serialize> Serialize for Seq<I> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self.0.take() {
            Some(i) => s.collect_seq(i),
            None => s.collect_seq(std::iter::empty::<T>()),
        }
    }
}

/// Builds the extension. `node_index` maps a scene node to its index in the written glTF.
pub fn build<'a>(
    scene: &Scene,
    tagging: &'a Tagging,
    cells: &'a CellSet,
    portals: &'a PortalSet,
    node_index: &(dyn Fn(NodeId) -> Option<usize> + Sync),
) -> Annotation<'a> {
    // The hash reads every position of the level byte by byte, as long as building the rest
    // takes on a big level: it runs alongside (or here, if no thread can be had).
    std::thread::scope(|s| {
        let hashing = std::thread::Builder::new().spawn_scoped(s, || input_hash(scene, tagging));
        let mut ann = build_with_hash(cells, tagging, portals, node_index);
        let hash = match hashing.map(|h| h.join()) {
            Ok(Ok(h)) => h,
            _ => input_hash(scene, tagging),
        };
        if let Some(root) = ann.root.as_object_mut() {
            root.insert("inputHash".into(), json!(hash));
        }
        ann
    })
}

/// [`build`] with the input hash still to come from `hash` (a thread computing it while the
/// output is written): the root's `inputHash` holds `null` and is serialized from `hash`.
pub(crate) fn build_deferred<'a>(
    hash: &'a (dyn HashOf + Sync + 'a),
    tagging: &'a Tagging,
    cells: &'a CellSet,
    portals: &'a PortalSet,
    node_index: &(dyn Fn(NodeId) -> Option<usize> + Sync),
) -> Annotation<'a> {
    let mut ann = build_with_hash(cells, tagging, portals, node_index);
    ann.lazy.hash = Some(hash);
    ann
}

/// [`build`] but the input hash, whose place it holds.
fn build_with_hash<'a>(
    cells: &'a CellSet,
    tagging: &'a Tagging,
    portals: &'a PortalSet,
    node_index: &(dyn Fn(NodeId) -> Option<usize> + Sync),
) -> Annotation<'a> {
    let mut root = Map::new();
    root.insert("version".into(), json!(VERSION));
    root.insert(
        "generator".into(),
        json!(format!("portcullis {}", env!("CARGO_PKG_VERSION"))),
    );
    root.insert("inputHash".into(), Value::Null);
    root.insert("tolerance".into(), num(cells.tolerance.distance));
    if cells.room_cells.iter().any(|c| c.len() > 1) {
        let rooms: Vec<Value> = tagging
            .rooms
            .iter()
            .zip(&cells.room_cells)
            .map(|(r, c)| json!({"name": r.name, "cells": c}))
            .collect();
        root.insert("rooms".into(), Value::Array(rooms));
    }
    // Each cell's glTF nodes, on every thread: on a big level that is a hundred thousand
    // node pointers to read.
    let cell_nodes: Vec<Vec<usize>> = cells
        .cells
        .par_iter()
        .map(|c| c.nodes.iter().filter_map(|&n| node_index(n)).collect())
        .collect();
    // Each node's cells, ascending, nodes in index order.
    let mut node_cell: Vec<(usize, usize)> = cell_nodes
        .iter()
        .enumerate()
        .flat_map(|(ci, ns)| ns.iter().map(move |&n| (n, ci)))
        .collect();
    node_cell.sort_by_key(|&(n, _)| n);
    let node_cells: Vec<(usize, Vec<usize>)> = node_cell
        .chunk_by(|a, b| a.0 == b.0)
        .map(|run| (run[0].0, run.iter().map(|&(_, c)| c).collect()))
        .collect();
    // Placeholders: serialized from the level (see `Annotation::root`).
    if !cells.cells.is_empty() {
        root.insert("cells".into(), Value::Null);
    }
    if !portals.portals.is_empty() {
        root.insert("portals".into(), Value::Null);
    }
    let portal_nodes = portals
        .portals
        .iter()
        .map(|p| p.authored.and_then(node_index))
        .collect();
    let nodes = node_cells
        .into_par_iter()
        .map(|(n, cs)| {
            let v = if cs.len() == 1 {
                json!({"cell": cs[0]})
            } else {
                json!({"cells": cs})
            };
            (n, v)
        })
        .collect();
    Annotation {
        root: Value::Object(root),
        nodes,
        blob: None,
        lazy: Lazy {
            level: Some((cells, tagging, portals)),
            cell_nodes,
            portal_nodes,
            hash: None,
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    fn level(name: &str) -> crate::pipeline::Tagged {
        let path = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("samples")
            .join(name);
        crate::pipeline::load_tagged(&path, &Default::default()).expect("a bundled sample")
    }

    /// The bytes hashed are the documented ones, number by number in little-endian order,
    /// whichever way they are fed (a mesh's positions go as one slice of memory).
    #[test]
    fn hashed_bytes_are_the_little_endian_numbers() {
        let t = level("door_window.gltf");
        let mut want = Vec::new();
        for n in t.scene.walk() {
            let node = &t.scene.nodes[n];
            for x in node.world.to_cols_array() {
                want.extend(x.to_le_bytes());
            }
            if let Some(m) = node.mesh {
                let mesh = &t.scene.meshes[m];
                for p in &mesh.positions {
                    want.extend(p.x.to_le_bytes());
                    want.extend(p.y.to_le_bytes());
                    want.extend(p.z.to_le_bytes());
                }
                for tri in &mesh.triangles {
                    for i in tri {
                        want.extend(i.to_le_bytes());
                    }
                }
            }
        }
        for r in &t.tagging.rooms {
            want.extend(r.name.as_bytes());
            want.push(0);
        }
        for p in &t.tagging.portals {
            want.extend((p.node as u64).to_le_bytes());
        }
        let mut got = Vec::new();
        hashed_bytes(&t.scene, &t.tagging, Coverage::GeometryAndTags, |b| {
            got.extend_from_slice(b)
        });
        assert!(want.len() > 1000);
        assert_eq!(got, want);
        let legacy = format!("xxh3:{:016x}", xxhash_rust::xxh3::xxh3_64(&want));
        assert_eq!(input_hash_like(&legacy, &t.scene, &t.tagging), Some(legacy));
    }

    /// Issue 29, item 12: the hash covers every input of the result. A tag set in extras, a
    /// renamed node, a material renamed, a `[cells]` setting or a tag rule changes it; the
    /// same level loaded twice does not.
    #[test]
    fn the_input_hash_covers_extras_names_materials_and_settings() {
        let t = level("two_rooms.gltf");
        let hash = |t: &crate::pipeline::Tagged| input_hash(&t.scene, &t.tagging);
        let base = hash(&t);
        assert!(base.starts_with("xxh3v2:"), "{base}");
        assert_eq!(base, hash(&level("two_rooms.gltf")));
        let retag = |scene: Scene, config: crate::config::Config| {
            let rules = crate::config::rule_set(&config, None).unwrap();
            let imported = crate::import::Imported {
                scene,
                diagnostics: Default::default(),
            };
            crate::pipeline::tag(imported, config, rules)
        };
        let table = t
            .scene
            .nodes
            .iter()
            .position(|n| n.name.as_deref() == Some("Table-detail"))
            .unwrap();
        let floor = t
            .scene
            .nodes
            .iter()
            .position(|n| n.name.as_deref() == Some("Floor"))
            .unwrap();
        let mut changed = Vec::new();
        let mut s = t.scene.clone();
        s.nodes[table].extras = Some(serde_json::json!({"ignore": true}));
        changed.push(("extras ignore", retag(s, Default::default())));
        let mut s = t.scene.clone();
        s.nodes[floor].extras = Some(serde_json::json!({"bound": true}));
        changed.push(("extras bound", retag(s, Default::default())));
        let mut s = t.scene.clone();
        s.nodes[floor].name = Some("Floor2".into());
        changed.push(("a node renamed", retag(s, Default::default())));
        let mut s = t.scene.clone();
        s.materials[0].name = Some("nodraw".into());
        changed.push(("a material renamed", retag(s, Default::default())));
        let mut config = crate::config::Config::default();
        config.cells.max_planes = 7;
        changed.push(("[cells] max_planes", retag(t.scene.clone(), config)));
        let mut config = crate::config::Config::default();
        config.tags.preset = Some("godot".into());
        changed.push(("the godot preset", retag(t.scene.clone(), config)));
        for (what, c) in &changed {
            assert_ne!(hash(c), base, "{what}");
        }
        // Unchanged tags and settings give the same hash through the same path.
        assert_eq!(hash(&retag(t.scene.clone(), Default::default())), base);
    }

    /// A hash stored by an earlier build (FNV-1a) is recomputed as FNV-1a: the sample's
    /// annotation, written by such a build from the same level, still matches; a different
    /// level's does not, and an unknown algorithm matches nothing.
    #[test]
    fn an_earlier_builds_fnv_hash_is_recomputed_as_fnv() {
        let stored = |name: &str| {
            let path = Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("samples/broken")
                .join(name);
            let v: Value = serde_json::from_slice(&std::fs::read(path).unwrap()).unwrap();
            v["extensions"][NAME]["inputHash"]
                .as_str()
                .unwrap()
                .to_string()
        };
        let fresh = stored("PORTAL_UNPAIRED.gltf");
        assert!(fresh.starts_with("fnv1a64:"), "{fresh}");
        let t = crate::pipeline::load_tagged(
            &Path::new(env!("CARGO_MANIFEST_DIR")).join("samples/broken/PORTAL_UNPAIRED.gltf"),
            &Default::default(),
        )
        .unwrap();
        assert_eq!(
            input_hash_like(&fresh, &t.scene, &t.tagging),
            Some(fresh.clone())
        );
        let other = level("door_window.gltf");
        assert_ne!(
            input_hash_like(&fresh, &other.scene, &other.tagging),
            Some(fresh)
        );
        assert_eq!(input_hash_like("md5:00", &t.scene, &t.tagging), None);
    }
}
