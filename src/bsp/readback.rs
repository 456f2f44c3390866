//! Reading a .bsp's visibility back, as an engine would, and setting it beside a PVS of
//! ours: what `inspect MAP.bsp` and `vis MAP.bsp --report` print, so a mapper can see what
//! another vis wrote and how far it is from the sampled lower bound.

use super::leafmap::LeafMap;
use super::read::Bsp;
use super::visdata::{decompress_row, row_bytes, RowError};
use crate::format::bits::BitMatrix;
use crate::vis::Pvs;

/// A .bsp's decoded visibility.
#[derive(Debug, Clone)]
pub struct Stored {
    /// Quake 1 family: row j is visible leaf j (the .bsp's leaf j + 1). Quake 2: per cluster.
    pub pvs: BitMatrix,
    /// Quake 2: the PHS per cluster.
    pub phs: Option<BitMatrix>,
    /// The visibility lump's bytes.
    pub bytes: usize,
    /// Rows that would not decode: the leaf (or cluster) and why.
    pub broken: Vec<(usize, RowError)>,
    /// Leafs (or clusters) with no row at all (offset -1): an engine draws everything there.
    pub without: usize,
}

/// The visibility stored in `bsp`, `None` when its lump is empty (the map was never vised).
pub fn stored(bsp: &Bsp) -> Option<Stored> {
    let data = bsp.lump(bsp.format.vis_lump());
    if data.is_empty() {
        return None;
    }
    let n = bsp.vis_units;
    let mut out = Stored {
        pvs: BitMatrix::new(n),
        phs: None,
        bytes: data.len(),
        broken: Vec::new(),
        without: 0,
    };
    if bsp.format.has_clusters() {
        let i32_at = |at: usize| {
            data.get(at..at + 4)
                .map(|s| i32::from_le_bytes([s[0], s[1], s[2], s[3]]))
        };
        let listed = i32_at(0).and_then(|c| usize::try_from(c).ok()).unwrap_or(0);
        let mut phs = BitMatrix::new(n);
        for c in 0..n {
            for (kind, m) in [&mut out.pvs, &mut phs].into_iter().enumerate() {
                let ofs = if c < listed {
                    i32_at(4 + 8 * c + 4 * kind)
                } else {
                    None
                };
                match ofs.map(usize::try_from) {
                    Some(Ok(o)) => {
                        fill(m, c, decompress_row(data, o, row_bytes(n)), &mut out.broken)
                    }
                    Some(Err(_)) => out.without += usize::from(kind == 0),
                    None => out.broken.push((c, RowError::Outside)),
                }
            }
        }
        out.phs = Some(phs);
        return Some(out);
    }
    for j in 0..n {
        match usize::try_from(bsp.leafs[j + 1].visofs) {
            Ok(o) => fill(
                &mut out.pvs,
                j,
                decompress_row(data, o, row_bytes(n)),
                &mut out.broken,
            ),
            Err(_) => out.without += 1,
        }
    }
    Some(out)
}

/// Row `r` of `m` from a decoded byte row (bits past the matrix ignored), or the error noted.
fn fill(
    m: &mut BitMatrix,
    r: usize,
    row: Result<Vec<u8>, RowError>,
    broken: &mut Vec<(usize, RowError)>,
) {
    match row {
        Ok(bytes) => {
            for c in 0..m.len() {
                if bytes[c >> 3] >> (c & 7) & 1 == 1 {
                    m.set(r, c);
                }
            }
        }
        Err(e) => broken.push((r, e)),
    }
}

/// A PVS of the portal file's cells in the .bsp's terms: per visible leaf (Quake 1 family)
/// or per cluster (Quake 2), so it counts on the same basis as [`Stored::pvs`].
pub fn in_bsp_terms(map: &LeafMap, pvs: &Pvs) -> BitMatrix {
    if map.leaf_cell.is_empty() {
        return pvs.first_cells(map.cells).bits;
    }
    let n = map.leaf_cell.len();
    let cell_leafs = map.cell_leafs();
    let mut m = BitMatrix::new(n);
    for (j, &c) in map.leaf_cell.iter().enumerate() {
        for v in pvs.visible(c).filter(|&v| v < map.cells) {
            for &k in &cell_leafs[v] {
                m.set(j, k);
            }
        }
    }
    m
}

/// Pairs of `lower` (in .bsp terms) that `m` lacks.
pub fn missing(lower: &BitMatrix, m: &BitMatrix) -> usize {
    (0..lower.len().min(m.len()))
        .map(|r| {
            lower
                .row(r)
                .iter()
                .zip(m.row(r))
                .map(|(a, b)| (a & !b).count_ones() as usize)
                .sum::<usize>()
        })
        .sum()
}
