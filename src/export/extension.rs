//! The `PORTCULLIS_portals` glTF extension: what an engine needs at run time, and nothing a
//! level does not need (no transform on plain portals, no rooms array when every room is one
//! cell, no empty arrays). Documented in schemas/PORTCULLIS_portals.md and checked against
//! schemas/PORTCULLIS_portals.schema.json.

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

fn vec3(v: glam::DVec3) -> Value {
    Value::Array(vec![num(v.x), num(v.y), num(v.z)])
}

/// FNV-1a over the level's geometry (every node's world transform and mesh positions, in
/// walk order) and what the tags recognised, so a consumer can tell the annotation is stale.
pub fn input_hash(scene: &Scene, tagging: &Tagging) -> String {
    let mut h: u64 = 0xcbf29ce484222325;
    let mut eat = |bytes: &[u8]| {
        for b in bytes {
            h ^= *b as u64;
            h = h.wrapping_mul(0x100000001b3);
        }
    };
    for n in scene.walk() {
        let node = &scene.nodes[n];
        for x in node.world.to_cols_array() {
            eat(&x.to_bits().to_le_bytes());
        }
        if let Some(m) = node.mesh {
            for p in &scene.meshes[m].positions {
                for x in p.to_array() {
                    eat(&x.to_bits().to_le_bytes());
                }
            }
            for t in &scene.meshes[m].triangles {
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
    format!("fnv1a64:{h:016x}")
}

/// The root extension object and, per glTF node index, the node extension object.
pub struct Annotation {
    pub root: Value,
    pub nodes: Vec<(usize, Value)>,
    /// Bytes for a buffer view the root refers to (`visibility.bufferView`), appended by the
    /// writer, which sets the index.
    pub blob: Option<Vec<u8>>,
}

impl Annotation {
    /// Stores the PVS (left out for a level of one cell).
    pub fn set_visibility(&mut self, pvs: &crate::vis::Pvs, method: crate::vis::Method) {
        if let Some(e) = super::visibility::encode(pvs, method) {
            if let Some(o) = self.root.as_object_mut() {
                o.insert("visibility".into(), e.json);
            }
            self.blob = e.blob;
        }
    }
}

/// Builds the extension. `node_index` maps a scene node to its index in the written glTF.
pub fn build(
    scene: &Scene,
    tagging: &Tagging,
    cells: &CellSet,
    portals: &PortalSet,
    node_index: &dyn Fn(NodeId) -> Option<usize>,
) -> Annotation {
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

/// [`build`] but the input hash, whose place it holds.
fn build_with_hash(
    cells: &CellSet,
    tagging: &Tagging,
    portals: &PortalSet,
    node_index: &dyn Fn(NodeId) -> Option<usize>,
) -> Annotation {
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
    let mut node_cells: std::collections::BTreeMap<usize, Vec<usize>> = Default::default();
    let cells_json: Vec<Value> = cells
        .cells
        .iter()
        .enumerate()
        .map(|(ci, c)| {
            let mut o = Map::new();
            o.insert("room".into(), json!(tagging.rooms[c.room].name));
            let planes: Vec<Value> = c
                .poly
                .faces
                .iter()
                .map(|f| {
                    Value::Array(vec![
                        num(f.plane.normal.x),
                        num(f.plane.normal.y),
                        num(f.plane.normal.z),
                        num(f.plane.d),
                    ])
                })
                .collect();
            o.insert("planes".into(), Value::Array(planes));
            o.insert(
                "bounds".into(),
                Value::Object(Map::from_iter([
                    ("min".into(), vec3(c.bounds.min)),
                    ("max".into(), vec3(c.bounds.max)),
                ])),
            );
            let nodes: Vec<usize> = c.nodes.iter().filter_map(|&n| node_index(n)).collect();
            for &n in &nodes {
                node_cells.entry(n).or_default().push(ci);
            }
            if !nodes.is_empty() {
                o.insert("nodes".into(), Value::from(nodes));
            }
            Value::Object(o)
        })
        .collect();
    if !cells_json.is_empty() {
        root.insert("cells".into(), Value::Array(cells_json));
    }
    let portals_json: Vec<Value> = portals
        .portals
        .iter()
        .map(|p| {
            let mut o = Map::new();
            o.insert(
                "polygon".into(),
                Value::Array(p.polygon.iter().map(|v| vec3(*v)).collect()),
            );
            let mut cells = vec![json!(p.from)];
            if let Some(t) = p.to {
                cells.push(json!(t));
            }
            o.insert("cells".into(), Value::Array(cells));
            match p.kind {
                PortalKind::Plain => {}
                PortalKind::Mirror => {
                    o.insert("kind".into(), json!("mirror"));
                }
                PortalKind::Teleporter => {
                    o.insert("kind".into(), json!("teleporter"));
                }
            }
            if p.one_way {
                o.insert("oneWay".into(), json!(true));
            }
            if p.closed {
                o.insert("closed".into(), json!(true));
            }
            if p.internal {
                o.insert("internal".into(), json!(true));
            }
            if let Some(t) = p.transform {
                o.insert(
                    "transform".into(),
                    Value::Array(t.to_cols_array().iter().map(|x| num(*x)).collect()),
                );
            }
            if let Some(q) = p.partner {
                o.insert("partner".into(), json!(q));
            }
            if let Some(n) = p.authored.and_then(node_index) {
                o.insert("node".into(), json!(n));
            }
            Value::Object(o)
        })
        .collect();
    if !portals_json.is_empty() {
        root.insert("portals".into(), Value::Array(portals_json));
    }
    let nodes = node_cells
        .into_iter()
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
    }
}
