//! Reading an annotated file back: the `PORTCULLIS_portals` extension as typed data, so an
//! engine's tools (and `inspect`) get the same level portcullis wrote.

use serde_json::Value;

use super::records::Annotated;
use super::{FormatError, NAME};

/// The annotation of a glTF document, if it has one. `Err` says why it does not parse.
pub fn annotation(doc: &Value) -> Option<Result<Annotated, FormatError>> {
    let ext = doc.get("extensions")?.get(NAME)?;
    Some(serde_json::from_value(ext.clone()).map_err(|e| FormatError::Parse(e.to_string())))
}

/// The stored PVS, decoded. `buffers`: the document's buffers as loaded (for a .glb, buffer 0
/// is the BIN chunk). `None` when the annotation stores no visibility.
pub fn visibility(
    a: &Annotated,
    doc: &Value,
    buffers: &[Vec<u8>],
) -> Option<Result<super::Pvs, FormatError>> {
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
                None => return Some(Err(FormatError::ViewUnreadable(i))),
            }
        }
    };
    Some(super::visibility::decode(v, a.cells.len(), blob))
}

/// Checks what the schema cannot: indices in range and partners mutual. One error per problem.
pub fn consistency(a: &Annotated, node_count: usize) -> Vec<FormatError> {
    let mut out = Vec::new();
    let cells = a.cells.len();
    for (i, r) in a.rooms.iter().enumerate() {
        for &c in &r.cells {
            if c >= cells {
                out.push(FormatError::RoomCellMissing {
                    room: i,
                    cell: c,
                    cells,
                });
            }
        }
    }
    for (i, c) in a.cells.iter().enumerate() {
        for &n in &c.nodes {
            if n >= node_count {
                out.push(FormatError::CellNodeMissing {
                    cell: i,
                    node: n,
                    nodes: node_count,
                });
            }
        }
    }
    for &node in &a.buried_occupants {
        if node >= node_count {
            out.push(FormatError::BuriedNodeMissing { node });
        }
    }
    for (i, p) in a.portals.iter().enumerate() {
        for &c in &p.cells {
            if c >= cells {
                out.push(FormatError::PortalCellMissing {
                    portal: i,
                    cell: c,
                    cells,
                });
            }
        }
        if let Some(j) = p.partner {
            match a.portals.get(j) {
                None => out.push(FormatError::PartnerMissing {
                    portal: i,
                    partner: j,
                }),
                Some(q) if q.partner != Some(i) => out.push(FormatError::PartnerNotMutual {
                    portal: i,
                    partner: j,
                }),
                Some(q)
                    if j != i
                        && (q.from() != p.to().unwrap_or(usize::MAX)
                            || q.to() != Some(p.from())) =>
                {
                    out.push(FormatError::PartnerCellsDiffer {
                        portal: i,
                        partner: j,
                    })
                }
                _ => {}
            }
        }
        if let Some(n) = p.node {
            if n >= node_count {
                out.push(FormatError::PortalNodeMissing { portal: i, node: n });
            }
        }
    }
    if let Some(v) = &a.visibility {
        if v.get("encoding").and_then(Value::as_str) == Some("lists") {
            if let Err(e) = super::visibility::decode(v, cells, None) {
                out.push(FormatError::StoredLists(Box::new(e)));
            }
        }
    }
    out
}
