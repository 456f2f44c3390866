//! Reading an annotated file back: the `PORTCULLIS_portals` extension as typed data, so an
//! engine's tools (and `inspect`) get the same level portcullis wrote.

use serde::Deserialize;
use serde_json::Value;

use super::extension::NAME;

#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, rename_all = "camelCase")]
pub struct Annotated {
    pub version: u64,
    pub generator: String,
    pub input_hash: String,
    pub tolerance: f64,
    #[serde(default)]
    pub rooms: Vec<RoomRecord>,
    #[serde(default)]
    pub cells: Vec<CellRecord>,
    #[serde(default)]
    pub portals: Vec<PortalRecord>,
    /// The stored PVS, encoded (see [`super::visibility`]); [`visibility`] decodes it.
    #[serde(default)]
    pub visibility: Option<Value>,
}

#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RoomRecord {
    pub name: String,
    pub cells: Vec<usize>,
}

#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Bounds {
    pub min: [f64; 3],
    pub max: [f64; 3],
}

#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CellRecord {
    pub room: String,
    /// Where rooms nest, the higher wins a point both hold (absent: 0).
    #[serde(default)]
    pub priority: i64,
    pub planes: Vec<[f64; 4]>,
    pub bounds: Bounds,
    #[serde(default)]
    pub nodes: Vec<usize>,
}

#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, rename_all = "camelCase")]
pub struct PortalRecord {
    pub polygon: Vec<[f64; 3]>,
    pub cells: Vec<usize>,
    #[serde(default)]
    pub kind: Option<String>,
    #[serde(default)]
    pub one_way: bool,
    #[serde(default)]
    pub closed: bool,
    #[serde(default)]
    pub internal: bool,
    #[serde(default)]
    pub transform: Option<[f64; 16]>,
    #[serde(default)]
    pub partner: Option<usize>,
    #[serde(default)]
    pub node: Option<usize>,
}

impl PortalRecord {
    pub fn from(&self) -> usize {
        self.cells.first().copied().unwrap_or(0)
    }
    pub fn to(&self) -> Option<usize> {
        self.cells.get(1).copied()
    }
}

/// The annotation of a glTF document, if it has one. `Err` says why it does not parse.
pub fn annotation(doc: &Value) -> Option<Result<Annotated, String>> {
    let ext = doc.get("extensions")?.get(NAME)?;
    Some(serde_json::from_value(ext.clone()).map_err(|e| e.to_string()))
}

/// The stored PVS, decoded. `buffers`: the document's buffers as loaded (for a .glb, buffer 0
/// is the BIN chunk). `None` when the annotation stores no visibility.
pub fn visibility(
    a: &Annotated,
    doc: &Value,
    buffers: &[Vec<u8>],
) -> Option<Result<crate::vis::Pvs, String>> {
    let v = a.visibility.as_ref()?;
    let blob = match v.get("bufferView").and_then(Value::as_u64) {
        None => None,
        Some(i) => {
            let view = doc.get("bufferViews").and_then(|b| b.get(i as usize));
            let bytes = view.and_then(|view| {
                let b = view.get("buffer")?.as_u64()? as usize;
                let off = view.get("byteOffset").and_then(Value::as_u64).unwrap_or(0) as usize;
                let len = view.get("byteLength")?.as_u64()? as usize;
                buffers.get(b)?.get(off..off.checked_add(len)?)
            });
            match bytes {
                Some(b) => Some(b),
                None => return Some(Err(format!("visibility: buffer view {i} cannot be read"))),
            }
        }
    };
    Some(super::visibility::decode(v, a.cells.len(), blob))
}

/// Checks what the schema cannot: indices in range and partners mutual. One line per problem.
pub fn consistency(a: &Annotated, node_count: usize) -> Vec<String> {
    let mut out = Vec::new();
    let cells = a.cells.len();
    for (i, r) in a.rooms.iter().enumerate() {
        for &c in &r.cells {
            if c >= cells {
                out.push(format!(
                    "/rooms/{i}: cell {c} does not exist ({cells} cells)"
                ));
            }
        }
    }
    for (i, c) in a.cells.iter().enumerate() {
        for &n in &c.nodes {
            if n >= node_count {
                out.push(format!(
                    "/cells/{i}: node {n} does not exist ({node_count} nodes)"
                ));
            }
        }
    }
    for (i, p) in a.portals.iter().enumerate() {
        for &c in &p.cells {
            if c >= cells {
                out.push(format!(
                    "/portals/{i}: cell {c} does not exist ({cells} cells)"
                ));
            }
        }
        if let Some(j) = p.partner {
            match a.portals.get(j) {
                None => out.push(format!("/portals/{i}: partner {j} does not exist")),
                Some(q) if q.partner != Some(i) => {
                    out.push(format!("/portals/{i}: partner {j} does not name it back"))
                }
                Some(q)
                    if j != i
                        && (q.from() != p.to().unwrap_or(usize::MAX)
                            || q.to() != Some(p.from())) =>
                {
                    out.push(format!(
                        "/portals/{i}: partner {j} does not join the same cells the other way"
                    ))
                }
                _ => {}
            }
        }
        if let Some(n) = p.node {
            if n >= node_count {
                out.push(format!("/portals/{i}: node {n} does not exist"));
            }
        }
    }
    if let Some(v) = &a.visibility {
        if v.get("encoding").and_then(Value::as_str) == Some("lists") {
            if let Err(e) = super::visibility::decode(v, cells, None) {
                out.push(format!("/visibility: {e}"));
            }
        }
    }
    out
}
