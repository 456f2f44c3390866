//! The annotation as it is written: the root extension object and each node's, serialized
//! straight from the level's cells and portals (as a JSON tree they took ten times the room
//! of their text on a big level), with the input hash filled in when it is ready.

use rayon::prelude::*;
use serde::ser::{Serialize, SerializeMap, Serializer};
use serde_json::{json, Map, Value};

use super::hash::input_hash;
use crate::cells::CellSet;
use crate::format::records::{Bounds, CellRecord, PortalRecord};
use crate::format::VERSION;
use crate::level::Level;
use crate::portals::PortalSet;
use crate::scene::NodeId;
use crate::tags::rules::PortalKind;
use crate::tags::Tagging;

/// Numbers are written rounded to 1e-9 of a metre (far below any tolerance), so the output
/// does not carry f64 noise that differs between platforms' last bits.
fn num(x: f64) -> Value {
    let r = (x * 1e9).round() / 1e9;
    Value::from(if r == 0.0 { 0.0 } else { r })
}

/// The tolerance as [`num`] writes it, but one below a billionth of a metre (a level of no
/// geometry, or one modelled in nanometres) to six significant digits: rounded it would read
/// as zero, which the schema forbids and no check can use.
fn tolerance(x: f64) -> Value {
    match num(x) {
        Value::Number(n) if n.as_f64() == Some(0.0) && x > 0.0 => {
            Value::from(format!("{x:.5e}").parse::<f64>().unwrap_or(x))
        }
        v => v,
    }
}

/// The root extension object and, per glTF node index, the node extension object.
pub struct Annotation<'a> {
    /// The root object's members in order. `cells` and `portals`, when present, hold `null`
    /// here: they are serialized straight from the level ([`Annotation::json`]), since as a
    /// JSON tree they took ten times the room of their text on a big level.
    pub root: Value,
    /// Per glTF node index, that node's extension object.
    pub nodes: Vec<(usize, Value)>,
    /// Bytes for a buffer view the root refers to (`visibility.bufferView`), appended by the
    /// writer, which sets the index.
    pub blob: Option<Vec<u8>>,
    /// The split primitives' indices, appended by the writer as an index buffer view and
    /// accessor, whose index it sets in `split.indices`.
    pub indices: Option<Indices>,
    /// The nodes to write as parts, one per set of cells (`convert --split-by-cell`).
    pub(crate) parts: Option<super::parts::Plan>,
    pub(crate) lazy: Lazy<'a>,
}

/// What the cells of the output name of the geometry they draw.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum CellGeometry {
    /// Whole nodes, and per cell its ranges of the nodes that reach into several cells (the
    /// extension's `split` and `cells[].draws`).
    #[default]
    DrawLists,
    /// Whole nodes only: each node that reaches into several cells written as child nodes,
    /// one per set of cells (`convert --split-by-cell`).
    SplitNodes,
    /// Whole nodes only, as the input has them (`convert --no-draw-lists`).
    WholeNodes,
}

/// Index bytes, little-endian, of `size` bytes each: 2 when every index fits below 65,535
/// (the primitive-restart value WebGL 2 reserves), else 4; half the bytes on most levels.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Indices {
    pub bytes: Vec<u8>,
    pub size: usize,
}

impl Indices {
    fn of(all: &[u32]) -> Indices {
        let size = if all.iter().all(|&i| i < u16::MAX as u32) {
            2
        } else {
            4
        };
        let mut bytes = Vec::with_capacity(all.len() * size);
        for &i in all {
            match size {
                2 => bytes.extend_from_slice(&(i as u16).to_le_bytes()),
                _ => bytes.extend_from_slice(&i.to_le_bytes()),
            }
        }
        Indices { bytes, size }
    }
}

/// What the `cells` and `portals` members are serialized from.
#[derive(Clone, Default)]
pub(crate) struct Lazy<'a> {
    level: Option<(&'a CellSet, &'a Tagging, &'a PortalSet)>,
    /// Per cell, the glTF nodes it renders.
    pub(crate) cell_nodes: Vec<Vec<usize>>,
    /// Per cell, the glTF nodes it renders once the writer has made the parts.
    pub(crate) part_nodes: Option<Vec<Vec<usize>>>,
    /// Per cell, its ranges of the split primitives (`[primitive, first, count]`).
    cell_draws: Vec<Vec<[usize; 3]>>,
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
    pub(crate) fn pending(f: PendingHash<'a>) -> InputHash<'a> {
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
    #[cfg(test)]
    pub(crate) fn of(
        root: Value,
        nodes: Vec<(usize, Value)>,
        blob: Option<Vec<u8>>,
    ) -> Annotation<'a> {
        Annotation {
            root,
            nodes,
            blob,
            indices: None,
            parts: None,
            lazy: Lazy::default(),
        }
    }

    /// Stores the PVS (left out for a level of one cell), with the cells that see the outside.
    pub(crate) fn set_visibility(&mut self, pvs: &crate::vis::Pvs, method: crate::vis::Method) {
        if let Some(mut e) = crate::format::visibility::encode(pvs, method) {
            let outside = self
                .lazy
                .level
                .map(|(_, _, portals)| sees_outside(pvs, portals));
            if let (Some(o), Some(outside)) = (e.json.as_object_mut(), outside) {
                if !outside.is_empty() {
                    o.insert("outside".into(), json!(outside));
                }
            }
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

/// A member of the root extension object, as the writers render it.
pub(crate) enum Member<'r> {
    /// `cells`, rendered a cell at a time.
    Cells(Cells<'r>),
    /// `portals`, rendered a portal at a time.
    Portals(Portals<'r>),
    /// `inputHash`, when it is still being computed (then `null` if it never comes).
    Hash(Option<&'r (dyn HashOf + Sync + 'r)>, &'r Value),
    /// Anything else, as it stands.
    Plain(&'r Value),
}

impl<'r> Json<'r> {
    /// The root's members in order, with what each is rendered from; `None` when the root is
    /// not built from a level (then it is serialized as it stands).
    pub(crate) fn members(self) -> Option<Vec<(&'r str, Member<'r>)>> {
        let (Value::Object(members), Some((cells, tagging, portals))) =
            (self.root, self.lazy.level)
        else {
            return None;
        };
        let lazy = self.lazy;
        let member = |k: &'r String, v: &'r Value| match (k.as_str(), v) {
            ("cells", Value::Null) => Member::Cells(Cells {
                cells,
                tagging,
                nodes: lazy.part_nodes.as_deref().unwrap_or(&lazy.cell_nodes),
                draws: &lazy.cell_draws,
            }),
            ("portals", Value::Null) => Member::Portals(Portals {
                portals,
                nodes: &lazy.portal_nodes,
            }),
            ("inputHash", Value::Null) => Member::Hash(lazy.hash, v),
            _ => Member::Plain(v),
        };
        Some(
            members
                .iter()
                .map(|(k, v)| (k.as_str(), member(k, v)))
                .collect(),
        )
    }
}

impl Serialize for Json<'_> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let Some(members) = self.members() else {
            return self.root.serialize(s);
        };
        let mut map = s.serialize_map(Some(members.len()))?;
        for (k, m) in members {
            match m {
                Member::Cells(c) => map.serialize_entry(k, &c)?,
                Member::Portals(p) => map.serialize_entry(k, &p)?,
                Member::Hash(h, v) => match h.and_then(|h| h.get()) {
                    Some(h) => map.serialize_entry(k, h)?,
                    None => map.serialize_entry(k, v)?,
                },
                Member::Plain(v) => map.serialize_entry(k, v)?,
            }
        }
        map.end()
    }
}

/// A number as [`num`] writes it.
pub(crate) struct Num(f64);

impl Serialize for Num {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        num(self.0).serialize(s)
    }
}

/// The `cells` member, from the level.
#[derive(Clone, Copy)]
pub(crate) struct Cells<'a> {
    cells: &'a CellSet,
    tagging: &'a Tagging,
    nodes: &'a [Vec<usize>],
    draws: &'a [Vec<[usize; 3]>],
}

/// A cell as it is written: the record over the level's own data.
type CellView<'a, P> = CellRecord<&'a str, Seq<P>, Num, &'a [usize], &'a [[usize; 3]]>;

impl<'a> Cells<'a> {
    /// How many cells are written.
    pub(crate) fn len(&self) -> usize {
        self.cells.cells.len().min(self.nodes.len())
    }

    /// Cell `i`, to serialize.
    pub(crate) fn cell(&self, i: usize) -> CellView<'a, impl Iterator<Item = [Num; 4]> + 'a> {
        let (c, nodes) = (&self.cells.cells[i], &self.nodes[i]);
        let planes = c.poly.faces.iter().map(|f| {
            let (n, d) = (f.plane.normal, f.plane.d);
            [Num(n.x), Num(n.y), Num(n.z), Num(d)]
        });
        let v3 = |v: glam::DVec3| [Num(v.x), Num(v.y), Num(v.z)];
        CellRecord {
            room: &self.tagging.rooms[c.room].name,
            priority: self.tagging.rooms[c.room].priority,
            planes: Seq::new(planes),
            bounds: Bounds {
                min: v3(c.bounds.min),
                max: v3(c.bounds.max),
            },
            nodes,
            draws: self.draws.get(i).map_or(&[][..], |d| &d[..]),
        }
    }
}

impl Serialize for Cells<'_> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_seq((0..self.len()).map(|i| self.cell(i)))
    }
}

/// The `portals` member, from the level.
#[derive(Clone, Copy)]
pub(crate) struct Portals<'a> {
    portals: &'a PortalSet,
    nodes: &'a [Option<usize>],
}

impl<'a> Portals<'a> {
    /// How many portals are written.
    pub(crate) fn len(&self) -> usize {
        self.portals.portals.len().min(self.nodes.len())
    }

    /// Portal `i`, to serialize.
    pub(crate) fn portal(&self, i: usize) -> PortalJson<'a> {
        PortalJson(&self.portals.portals[i], self.nodes[i])
    }
}

impl Serialize for Portals<'_> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_seq((0..self.len()).map(|i| self.portal(i)))
    }
}

/// A portal and the glTF node it was authored as, serialized as its [`PortalRecord`].
pub(crate) struct PortalJson<'a>(&'a crate::portals::Portal, Option<usize>);

impl Serialize for PortalJson<'_> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let p = self.0;
        let both = [p.from, p.to.unwrap_or(p.from)];
        let kind = match p.kind {
            PortalKind::Plain => None,
            PortalKind::Mirror => Some("mirror"),
            PortalKind::Teleporter => Some("teleporter"),
        };
        PortalRecord {
            polygon: Seq::new(p.polygon.iter().map(|v| [Num(v.x), Num(v.y), Num(v.z)])),
            cells: if p.to.is_some() {
                &both[..]
            } else {
                &both[..1]
            },
            kind,
            one_way: p.one_way,
            closed: p.closed,
            door: p.door,
            internal: p.internal,
            transform: p
                .transform
                .map(|t| Seq::new(t.to_cols_array().into_iter().map(Num))),
            partner: p.partner,
            node: self.1,
        }
        .serialize(s)
    }
}

/// An iterator serialized as a sequence (once: serializing takes it).
pub(crate) struct Seq<I>(std::cell::Cell<Option<I>>);

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

/// Builds the extension, with the cells' draw lists. `node_index` maps a scene node to its index in the written glTF.
pub fn build<'a>(
    level: &'a Level,
    node_index: &(dyn Fn(NodeId) -> Option<usize> + Sync),
) -> Annotation<'a> {
    build_as(level, node_index, CellGeometry::DrawLists)
}

/// [`build`], the cells' geometry as `geometry` says.
pub fn build_as<'a>(
    level: &'a Level,
    node_index: &(dyn Fn(NodeId) -> Option<usize> + Sync),
    geometry: CellGeometry,
) -> Annotation<'a> {
    let (scene, tagging) = (level.scene(), level.tagging());
    // The hash reads every position of the level byte by byte, as long as building the rest
    // takes on a big level: it runs alongside (or here, if no thread can be had).
    std::thread::scope(|s| {
        let hashing = std::thread::Builder::new().spawn_scoped(s, || input_hash(scene, tagging));
        let mut ann = build_with_hash(level, node_index, geometry);
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
    level: &'a Level,
    node_index: &(dyn Fn(NodeId) -> Option<usize> + Sync),
    geometry: CellGeometry,
) -> Annotation<'a> {
    let mut ann = build_with_hash(level, node_index, geometry);
    ann.lazy.hash = Some(hash);
    ann
}

/// The `generated` record: how `--tags auto` read the level.
fn generated(g: &crate::tags::Generated) -> Value {
    let axes: Vec<Value> = g.axes.iter().map(|a| json!(a.map(num))).collect();
    json!({
        "voxel": num(g.voxel),
        "splitRatio": num(g.split_ratio),
        "detailArea": num(g.detail_area),
        "grid": g.grid,
        "axes": axes,
        "rooms": g.boxes.len(),
    })
}

/// [`build`] but the input hash, whose place it holds; the cells' geometry as `geometry` says.
fn build_with_hash<'a>(
    level: &'a Level,
    node_index: &(dyn Fn(NodeId) -> Option<usize> + Sync),
    geometry: CellGeometry,
) -> Annotation<'a> {
    let (tagging, cells, portals) = (level.tagging(), &level.cells, &level.portals);
    let mut root = Map::new();
    root.insert("version".into(), json!(VERSION));
    root.insert(
        "generator".into(),
        json!(format!("portcullis {}", env!("CARGO_PKG_VERSION"))),
    );
    root.insert("inputHash".into(), Value::Null);
    root.insert("tolerance".into(), tolerance(cells.tolerance.distance));
    if tagging.preset != "default" {
        root.insert("tags".into(), json!(tagging.preset));
    }
    if let Some(g) = tagging.generated.as_deref() {
        root.insert("generated".into(), generated(g));
    }
    if cells.room_cells.iter().any(|c| c.len() > 1) {
        let rooms: Vec<Value> = tagging
            .rooms
            .iter()
            .zip(&cells.room_cells)
            // A room of no cells (a floor whose walls have no height) is no room of the file.
            .filter(|(_, c)| !c.is_empty())
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
    let mut buried: Vec<usize> = cells.buried.iter().filter_map(|&n| node_index(n)).collect();
    buried.sort_unstable();
    buried.dedup();
    if !buried.is_empty() {
        root.insert("buriedOccupants".into(), json!(buried));
    }
    let mut split = match geometry {
        CellGeometry::WholeNodes => Split::default(),
        _ => split_by_cell(level, node_index),
    };
    let parts = (geometry == CellGeometry::SplitNodes && !split.primitives.is_empty()).then(|| {
        super::parts::Plan {
            nodes: std::mem::take(&mut split.plan),
        }
    });
    if parts.is_some() {
        split.cells = Vec::new();
    } else if !split.primitives.is_empty() {
        root.insert(
            "split".into(),
            json!({"indices": null, "primitives": split.primitives}),
        );
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
        indices: (!split.primitives.is_empty()).then(|| Indices::of(&split.indices)),
        parts,
        lazy: Lazy {
            level: Some((cells, tagging, portals)),
            cell_nodes,
            part_nodes: None,
            cell_draws: split.cells,
            portal_nodes,
            hash: None,
        },
    }
}

/// The nodes split by cell, as written: the `split` member's primitives, the index bytes and
/// each cell's ranges.
#[derive(Default)]
struct Split {
    primitives: Vec<Value>,
    indices: Vec<u32>,
    cells: Vec<Vec<[usize; 3]>>,
    /// The same ranges by node and set of cells, for parts.
    plan: Vec<super::parts::NodePlan>,
}

/// What each cell draws of the nodes whose triangles lie in different cells
/// (`cells::draws`), in the written file's terms: glTF nodes, index offsets, and of a cell's
/// ranges of one primitive those that meet joined into one (one draw call).
fn split_by_cell(level: &Level, node_index: &(dyn Fn(NodeId) -> Option<usize> + Sync)) -> Split {
    let sealed = level.portals.portals.iter().all(|p| p.to.is_some());
    let draws = crate::cells::draws::of(level.scene(), &level.cells, sealed);
    let mut out = Split {
        primitives: Vec::new(),
        indices: Vec::new(),
        cells: vec![Vec::new(); level.cells.cells.len()],
        plan: Vec::new(),
    };
    let mut split: Vec<(usize, &crate::cells::draws::NodeDraws)> = (draws.split.iter())
        .filter_map(|d| Some((node_index(d.node)?, d)))
        .collect();
    split.sort_by_key(|&(n, _)| n);
    let mut first = 0usize;
    for (node, d) in split {
        let mut by_set: std::collections::BTreeMap<Vec<u32>, Vec<[usize; 3]>> = Default::default();
        for p in &d.primitives {
            let k = out.primitives.len();
            let count = 3 * p.triangles.len();
            out.primitives.push(
                json!({"node": node, "primitive": p.primitive, "first": first, "count": count}),
            );
            out.indices.extend(p.triangles.iter().flatten());
            for r in &p.runs {
                let (at, n) = (first + 3 * r.first as usize, 3 * r.count as usize);
                (by_set.entry(r.cells.clone()).or_default()).push([p.primitive, at, n]);
                for &c in &r.cells {
                    let list = &mut out.cells[c as usize];
                    match list.last_mut() {
                        Some(last) if last[0] == k && last[1] + last[2] == at => last[2] += n,
                        _ => list.push([k, at, n]),
                    }
                }
            }
            first += count;
        }
        out.plan.push(super::parts::NodePlan {
            node,
            parts: by_set.into_iter().collect(),
        });
    }
    out
}

/// The cells that may see the outside (the sky, the void past an opening): those whose PVS
/// holds a cell with an opening to the exterior, itself included. A superset, as the PVS is:
/// an engine may skip its sky pass for a cell not listed, never for one listed wrongly.
fn sees_outside(pvs: &crate::vis::Pvs, portals: &PortalSet) -> Vec<usize> {
    let cells = pvs.cells();
    let mut open = vec![false; cells];
    for p in &portals.portals {
        if p.to.is_none() && p.from < cells {
            open[p.from] = true;
        }
    }
    (0..cells)
        .filter(|&c| open[c] || pvs.visible(c).any(|v| open.get(v) == Some(&true)))
        .collect()
}
