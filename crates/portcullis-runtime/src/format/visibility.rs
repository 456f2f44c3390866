//! The `visibility` property of the extension: the PVS in the smallest encoding that fits.
//!
//! - `lists`: per cell the ascending indices it sees (itself included), inline JSON; small
//!   levels, where a buffer view costs more than the numbers.
//! - `bits`: one row of `rowBytes = ceil(cells / 8)` bytes per cell in a buffer view, cell `j`
//!   in bit `j % 8` (least significant first) of byte `j / 8`.
//! - `bitsZeroRun`: the same rows, concatenated and zero-run compressed as Quake does: a
//!   non-zero byte stands for itself, a zero byte is followed by one byte counting the zero
//!   bytes it stands for (1–255). Chosen when it is at most 3/4 of `bits`.
//!
//! Left out when the level has one cell (it sees itself; nothing to store).
//!
//! `lists` is always used up to 16 cells; above that, whichever encoding is smallest. The writer
//! appends the buffer view last (in the BIN chunk of a .glb, as its own data: buffer in a .gltf).

use serde_json::{json, Value};

use super::{FormatError, Method, Pvs};

/// Cells up to which the lists are always used.
const LISTS_UP_TO: usize = 16;

/// What the glTF writer stores: the JSON object, and the bytes its `bufferView` points at.
pub struct Encoded {
    /// The `visibility` object as stored in the extension.
    pub json: Value,
    /// The bytes of its `bufferView`; `None` when the lists are inline.
    pub blob: Option<Vec<u8>>,
}

/// One PVS row as a little-endian bit string, `ceil(cells / 8)` bytes.
pub(crate) fn row_bytes(pvs: &Pvs, c: usize) -> Vec<u8> {
    let n = pvs.cells().div_ceil(8);
    let mut out = vec![0u8; n];
    for v in pvs.visible(c) {
        out[v / 8] |= 1 << (v % 8);
    }
    out
}

/// `bytes` with runs of zero bytes compressed (Quake's PVS row encoding).
pub(crate) fn zero_run(bytes: &[u8]) -> Vec<u8> {
    let mut out = Vec::new();
    zero_run_into(bytes, &mut out);
    out
}

/// Appends `bytes` compressed as Quake's `Mod_DecompressVis` reads a PVS row: a nonzero byte
/// is itself, a zero byte is followed by how many zero bytes it stands for (1 to 255). The
/// extension's `zeroRun` encoding and a .bsp's visibility lump are both written by it.
pub fn zero_run_into(bytes: &[u8], out: &mut Vec<u8>) {
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] != 0 {
            out.push(bytes[i]);
            i += 1;
            continue;
        }
        let mut run = 0;
        while i < bytes.len() && bytes[i] == 0 && run < 255 {
            run += 1;
            i += 1;
        }
        out.push(0);
        out.push(run as u8);
    }
}

/// Undoes `zero_run`; `None` if the data is cut short.
pub fn zero_run_decode(data: &[u8], expected: usize) -> Option<Vec<u8>> {
    let mut out = Vec::with_capacity(expected);
    let mut i = 0;
    while i < data.len() && out.len() < expected {
        if data[i] != 0 {
            out.push(data[i]);
            i += 1;
        } else {
            let run = *data.get(i + 1)? as usize;
            if run == 0 {
                return None;
            }
            out.resize(out.len() + run, 0);
            i += 2;
        }
    }
    (out.len() == expected).then_some(out)
}

/// The length of the lists written as compact JSON (`[[0,1],[0,1]]`), counted, not built: a
/// dense PVS of 4,000 cells as a JSON tree took over a gigabyte only to be measured.
fn lists_len(pvs: &Pvs) -> usize {
    let digits = |v: usize| v.checked_ilog10().map_or(1, |d| d as usize + 1);
    let n = pvs.cells();
    let rows: usize = (0..n)
        .map(|c| {
            let (count, width) = pvs
                .visible(c)
                .fold((0usize, 0usize), |(k, w), v| (k + 1, w + digits(v)));
            2 + width + count.saturating_sub(1)
        })
        .sum();
    2 + rows + n.saturating_sub(1)
}

/// The smallest encoding; `None` for a level of one cell or none.
pub fn encode(pvs: &Pvs, method: Method) -> Option<Encoded> {
    let n = pvs.cells();
    if n < 2 {
        return None;
    }
    let lists_len = lists_len(pvs);
    let mut bits = Vec::with_capacity(n * n.div_ceil(8));
    for c in 0..n {
        bits.extend(row_bytes(pvs, c));
    }
    let zr = zero_run(&bits);
    // A buffer view costs its JSON and padding; numbers inline cost their digits.
    let (bin_len, compressed) = if zr.len() * 4 <= bits.len() * 3 {
        (zr.len(), true)
    } else {
        (bits.len(), false)
    };
    if n <= LISTS_UP_TO || lists_len <= bin_len + 64 {
        let lists: Vec<Vec<usize>> = (0..n).map(|c| pvs.visible(c).collect()).collect();
        return Some(Encoded {
            json: json!({"method": method.name(), "encoding": "lists", "lists": lists}),
            blob: None,
        });
    }
    let encoding = if compressed { "bitsZeroRun" } else { "bits" };
    Some(Encoded {
        json: json!({
            "method": method.name(),
            "encoding": encoding,
            "rowBytes": n.div_ceil(8),
            "bufferView": 0,
        }),
        blob: Some(if compressed { zr } else { bits }),
    })
}

/// Reads an encoded PVS back (`blob`: the bytes of its buffer view). `Err` says what is wrong.
pub fn decode(json: &Value, cells: usize, blob: Option<&[u8]>) -> Result<Pvs, FormatError> {
    let enc = json.get("encoding").and_then(Value::as_str).unwrap_or("");
    let mut pvs = Pvs::identity(cells);
    pvs.bits = super::bits::BitMatrix::new(cells);
    match enc {
        "lists" => {
            let lists = json
                .get("lists")
                .and_then(Value::as_array)
                .ok_or(FormatError::ListsMissing)?;
            if lists.len() != cells {
                return Err(FormatError::ListCount {
                    lists: lists.len(),
                    cells,
                });
            }
            for (c, l) in lists.iter().enumerate() {
                for v in l.as_array().ok_or(FormatError::ListNotArray)? {
                    let v = v.as_u64().ok_or(FormatError::ListNonIndex)? as usize;
                    if v >= cells {
                        return Err(FormatError::ListCellMissing { row: c, cell: v });
                    }
                    pvs.bits.set(c, v);
                }
            }
        }
        "bits" | "bitsZeroRun" => {
            let rb = cells.div_ceil(8);
            if json.get("rowBytes").and_then(Value::as_u64) != Some(rb as u64) {
                return Err(FormatError::RowBytes {
                    row_bytes: rb,
                    cells,
                });
            }
            let data = blob.ok_or(FormatError::NoBlob)?;
            let raw = if enc == "bits" {
                (data.len() >= rb * cells).then(|| data[..rb * cells].to_vec())
            } else {
                zero_run_decode(data, rb * cells)
            }
            .ok_or(FormatError::FewerRows)?;
            for c in 0..cells {
                for v in 0..cells {
                    if raw[c * rb + v / 8] >> (v % 8) & 1 == 1 {
                        pvs.bits.set(c, v);
                    }
                }
            }
        }
        other => return Err(FormatError::UnknownEncoding(other.to_string())),
    }
    Ok(pvs)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_counted_length_is_the_written_one() {
        for (n, every) in [(1, 1), (2, 1), (11, 3), (120, 7), (1000, 1), (1001, 97)] {
            let p = sample(n, every);
            let lists: Vec<Vec<usize>> = (0..n).map(|c| p.visible(c).collect()).collect();
            assert_eq!(lists_len(&p), json!(lists).to_string().len(), "{n} cells");
        }
    }

    fn sample(n: usize, every: usize) -> Pvs {
        let mut p = Pvs::identity(n);
        for c in 0..n {
            for v in (0..n).step_by(every) {
                p.bits.set(c, v);
            }
        }
        p
    }

    #[test]
    fn every_encoding_round_trips() {
        for (n, every) in [(3, 1), (40, 1), (300, 97), (300, 3), (2000, 700)] {
            let p = sample(n, every);
            let e = encode(&p, Method::Full).unwrap();
            let back = decode(&e.json, n, e.blob.as_deref()).unwrap();
            assert_eq!(back, p, "{n} {every} {}", e.json["encoding"]);
        }
        assert_eq!(
            encode(&sample(300, 97), Method::Full).unwrap().json["encoding"],
            "bitsZeroRun"
        );
        assert_eq!(
            encode(&sample(300, 3), Method::Full).unwrap().json["encoding"],
            "bits"
        );
        assert_eq!(
            encode(&sample(3, 1), Method::Full).unwrap().json["encoding"],
            "lists"
        );
        assert!(encode(&Pvs::identity(1), Method::Full).is_none());
        assert_eq!(zero_run(&[0; 600]), vec![0, 255, 0, 255, 0, 90]);
    }
}
