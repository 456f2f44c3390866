//! `convert --split-by-cell`: each node whose triangles lie in different sets of cells written
//! as child nodes, one per set (its *parts*), so that the cells' `nodes` alone say what to
//! draw, for engines and importers that can only show and hide nodes (Godot, Unity, Blender).
//!
//! A part's mesh holds, per primitive of the node's mesh, that set's triangles as an index
//! accessor over the split indices (the bytes the draw lists index), with the primitive's own
//! attributes, material, morph targets and extensions, so every vertex attribute is kept per
//! vertex. A primitive with no triangles to judge (points, lines) goes whole to the part of
//! the cells that list the node. The node keeps its transform and children and gives up its
//! mesh to its parts; its extension object names the mesh and the parts (`{mesh, parts}`), so a
//! reader of the file as a level (portcullis itself) reads the node whole, as it was authored.
//! A node with a skin, morph weights of its own or an extension of another's is left whole (its
//! parts would each need them): it is listed by every cell its triangles lie in.
//!
//! Both writers (the streamed one and the test oracle) take what they change and append from
//! here, so they agree.

use std::collections::BTreeMap;

use serde_json::{json, Map, Value};

use crate::format::NAME;

/// What the annotation asks for: per node drawn in part, ascending, its triangles by set of
/// cells.
#[derive(Clone, Debug, Default)]
pub(crate) struct Plan {
    pub(crate) nodes: Vec<NodePlan>,
}

/// One node's parts: per set of cells (ascending), `[primitive, first, count]` ranges of the
/// split indices, one per primitive.
#[derive(Clone, Debug)]
pub(crate) struct NodePlan {
    pub(crate) node: usize,
    pub(crate) parts: Vec<(Vec<u32>, Vec<[usize; 3]>)>,
}

/// Where the appended objects go: the document's lengths of `nodes`, `meshes` and
/// `accessors` before them, the split indices' buffer view and its index size.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Base {
    pub(crate) nodes: usize,
    pub(crate) meshes: usize,
    pub(crate) accessors: usize,
    pub(crate) view: usize,
    pub(crate) size: usize,
}

/// A change to one of the document's nodes.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct NodeEdit {
    /// Its extension object.
    pub(crate) ours: Value,
    /// Its parts, when it gives up its mesh to them.
    pub(crate) parts: Option<Vec<usize>>,
}

/// What the writers change and append.
#[derive(Clone, Debug, Default)]
pub(crate) struct Made {
    pub(crate) accessors: Vec<Value>,
    pub(crate) meshes: Vec<Value>,
    pub(crate) nodes: Vec<Value>,
    /// By node, ascending.
    pub(crate) edits: Vec<(usize, NodeEdit)>,
    /// Per cell, the nodes it draws, ascending.
    pub(crate) cell_nodes: Vec<Vec<usize>>,
}

impl Made {
    /// What is appended, in the order the writers append it: each object with the document
    /// array it goes into (their indices are `Base`'s lengths onward).
    pub(crate) fn appended(&self) -> impl Iterator<Item = (&'static str, &Value)> {
        [
            ("accessors", &self.accessors),
            ("meshes", &self.meshes),
            ("nodes", &self.nodes),
        ]
        .into_iter()
        .flat_map(|(key, items)| items.iter().map(move |v| (key, v)))
    }
}

/// A primitive of a part: a range of the split indices, or the node's primitive whole.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
enum Piece {
    Range {
        primitive: usize,
        first: usize,
        count: usize,
    },
    Whole {
        primitive: usize,
    },
}

impl Piece {
    fn primitive(&self) -> usize {
        match *self {
            Piece::Range { primitive, .. } | Piece::Whole { primitive } => primitive,
        }
    }
}

/// The mesh a node can give up to parts: its index, when the node has no skin, weights or
/// other extension and the mesh has primitives.
fn splittable(node: &Value, meshes: &[Value]) -> Option<usize> {
    let o = node.as_object()?;
    if o.contains_key("skin") || o.contains_key("weights") {
        return None;
    }
    let others = (o.get("extensions").and_then(Value::as_object))
        .is_some_and(|e| e.keys().any(|k| k != NAME));
    if others || o.get("extensions").is_some_and(|e| !e.is_object()) {
        return None;
    }
    let m = usize::try_from(o.get("mesh")?.as_u64()?).ok()?;
    meshes.get(m)?.get("primitives")?.as_array()?;
    Some(m)
}

/// The cells as a node extension object, or none for no cell.
fn cells_object(cells: &[u32]) -> Option<Value> {
    match cells {
        [] => None,
        [c] => Some(json!({"cell": c})),
        cs => Some(json!({"cells": cs})),
    }
}

/// A part's name: the node's, and the cells that draw it.
fn part_name(node: &Value, index: usize, cells: &[u32]) -> String {
    match node.get("name").and_then(Value::as_str) {
        Some(n) => format!("{n} {}", suffix(cells)),
        None => format!("node {index} {}", suffix(cells)),
    }
}

/// What the writers do for `plan`, given the cells' whole-node lists, the document's nodes
/// (looked up by index) and meshes, and where the appended objects go.
pub(crate) fn make(
    plan: &Plan,
    cell_nodes: &[Vec<usize>],
    node: &dyn Fn(usize) -> Option<Value>,
    meshes: &[Value],
    base: Base,
) -> Made {
    let mut out = Made {
        cell_nodes: cell_nodes.to_vec(),
        ..Made::default()
    };
    let mut whole_of: BTreeMap<usize, Vec<u32>> = BTreeMap::new();
    for (c, ns) in cell_nodes.iter().enumerate() {
        for &n in ns {
            whole_of.entry(n).or_default().push(c as u32);
        }
    }
    // Nodes that leave every cell's list, and what each cell gains.
    let mut gone: Vec<usize> = Vec::new();
    let mut gained: Vec<(u32, usize)> = Vec::new();
    for np in &plan.nodes {
        let whole = whole_of.get(&np.node).cloned().unwrap_or_default();
        let json = node(np.node).unwrap_or(Value::Null);
        let Some(m) = splittable(&json, meshes) else {
            // Left whole: drawn by every cell any of its triangles lies in.
            let mut all: Vec<u32> = whole.clone();
            all.extend(np.parts.iter().flat_map(|(cs, _)| cs.iter().copied()));
            all.sort_unstable();
            all.dedup();
            gained.extend(all.iter().map(|&c| (c, np.node)));
            if let Some(ours) = cells_object(&all) {
                let edit = NodeEdit { ours, parts: None };
                out.edits.push((np.node, edit));
            }
            continue;
        };
        let mesh = &meshes[m];
        let prims = mesh["primitives"].as_array().map_or(&[][..], |a| &a[..]);
        let mut groups: BTreeMap<Vec<u32>, Vec<Piece>> = BTreeMap::new();
        let mut covered = vec![false; prims.len()];
        for (cs, ranges) in &np.parts {
            for &[primitive, first, count] in ranges {
                if let Some(c) = covered.get_mut(primitive) {
                    *c = true;
                }
                let piece = Piece::Range {
                    primitive,
                    first,
                    count,
                };
                groups.entry(cs.clone()).or_default().push(piece);
            }
        }
        for (primitive, _) in covered.iter().enumerate().filter(|(_, c)| !**c) {
            let piece = Piece::Whole { primitive };
            groups.entry(whole.clone()).or_default().push(piece);
        }
        gone.push(np.node);
        let mut parts = Vec::new();
        for (cs, mut pieces) in groups {
            pieces.sort_by_key(|p| (p.primitive(), *p));
            let primitives: Vec<Value> = (pieces.into_iter())
                .filter_map(|p| Some(part_primitive(prims.get(p.primitive())?, p, base, &mut out)))
                .collect();
            let part_mesh = part_mesh(mesh, primitives, &cs);
            let at = base.nodes + out.nodes.len();
            let mut part = json!({
                "name": part_name(&json, np.node, &cs),
                "mesh": base.meshes + out.meshes.len(),
            });
            if let Some(ours) = cells_object(&cs) {
                part["extensions"] = json!({ NAME: ours });
            }
            gained.extend(cs.iter().map(|&c| (c, at)));
            out.meshes.push(part_mesh);
            out.nodes.push(part);
            parts.push(at);
        }
        let ours = json!({"mesh": m, "parts": parts});
        out.edits.push((
            np.node,
            NodeEdit {
                ours,
                parts: Some(parts),
            },
        ));
    }
    gone.sort_unstable();
    for list in &mut out.cell_nodes {
        list.retain(|n| gone.binary_search(n).is_err());
    }
    for (c, n) in gained {
        if let Some(list) = out.cell_nodes.get_mut(c as usize) {
            list.push(n);
        }
    }
    for list in &mut out.cell_nodes {
        list.sort_unstable();
        list.dedup();
    }
    out.edits.sort_by_key(|(n, _)| *n);
    out
}

/// Primitive `src` of a split node's mesh as piece `p` of a part: a range of the split indices
/// gets an accessor of its own over them (appended to `out`), a whole primitive is copied.
fn part_primitive(src: &Value, p: Piece, base: Base, out: &mut Made) -> Value {
    let mut prim = src.clone();
    if let (Piece::Range { first, count, .. }, Some(o)) = (p, prim.as_object_mut()) {
        o.shift_remove("indices");
        o.shift_remove("mode");
        let mut acc = json!({"bufferView": base.view});
        if first != 0 {
            acc["byteOffset"] = json!(first * base.size);
        }
        acc["componentType"] = json!(if base.size == 2 { 5123 } else { 5125 });
        acc["count"] = json!(count);
        acc["type"] = json!("SCALAR");
        o.insert(
            "indices".into(),
            json!(base.accessors + out.accessors.len()),
        );
        out.accessors.push(acc);
    }
    prim
}

/// A part's mesh: the node's mesh with every member kept, its `primitives` those given and
/// its name followed by the part's cells.
fn part_mesh(mesh: &Value, primitives: Vec<Value>, cells: &[u32]) -> Value {
    let mut primitives = Some(primitives);
    let mut part = Map::new();
    for (k, v) in mesh.as_object().into_iter().flatten() {
        let v = match k.as_str() {
            "primitives" => Value::Array(primitives.take().unwrap_or_default()),
            "name" => json!(format!(
                "{} {}",
                v.as_str().unwrap_or("mesh"),
                suffix(cells)
            )),
            _ => v.clone(),
        };
        part.insert(k.clone(), v);
    }
    Value::Object(part)
}

/// The cells of a part as its mesh's name ends: `[cell 3]`, `[cells 3 4]`, `[no cell]`.
fn suffix(cells: &[u32]) -> String {
    match cells {
        [] => "[no cell]".into(),
        [c] => format!("[cell {c}]"),
        cs => {
            let l: Vec<String> = cs.iter().map(u32::to_string).collect();
            format!("[cells {}]", l.join(" "))
        }
    }
}

/// A node given up to its parts: no mesh, the parts appended to its children.
pub(crate) fn give_up_mesh(node: &mut Value, parts: &[usize]) {
    let Some(o) = node.as_object_mut() else {
        return;
    };
    o.shift_remove("mesh");
    let children = o.entry("children").or_insert_with(|| json!([]));
    if let Some(c) = children.as_array_mut() {
        c.extend(parts.iter().map(|&p| json!(p)));
    }
}
