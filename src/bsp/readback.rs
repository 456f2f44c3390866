//! Reading a .bsp's visibility back, as an engine would, and setting it beside a PVS of
//! ours: what `inspect MAP.bsp` and `vis MAP.bsp --report` print, so a mapper can see what
//! another vis wrote and how far it is from the sampled lower bound.
//!
//! Everything is counted in the .bsp's terms (Quake 1 family: pairs of visible leafs;
//! Quake 2: pairs of clusters) without a leaf × leaf matrix, which a big BSP2 map would make
//! gigabytes of: the leafs of one cluster share one stored row, and a PVS of the portal
//! file's cells counts each cell pair as the product of the cells' leaf counts.

use super::leafmap::LeafMap;
use super::read::Bsp;
use super::visdata::{count, decompress_row, get, row_bytes, RowError};
use crate::vis::Pvs;

/// A .bsp's decoded visibility.
#[derive(Debug, Clone)]
pub struct Stored {
    /// The decoded PVS rows, each once (a cluster's leafs share theirs).
    pub rows: Vec<Vec<u8>>,
    /// Per visible leaf (Quake 1 family; index j is the .bsp's leaf j + 1) or cluster (Quake
    /// 2): its row in `rows`; `None` for no row (an engine then draws everything) or a broken one.
    pub row_of: Vec<Option<usize>>,
    /// Quake 2: hearable ordered pairs of clusters (the PHS).
    pub hearable: Option<usize>,
    /// The visibility lump's bytes.
    pub bytes: usize,
    /// Rows that would not decode: the leaf (or cluster) and why.
    pub broken: Vec<(usize, RowError)>,
    /// Leafs (or clusters) with no row at all (offset -1).
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
        rows: Vec::new(),
        row_of: vec![None; n],
        hearable: None,
        bytes: data.len(),
        broken: Vec::new(),
        without: 0,
    };
    let mut seen = std::collections::HashMap::new();
    let mut decode = |u: usize, ofs: Option<i32>, out: &mut Stored| match ofs.map(usize::try_from) {
        Some(Ok(o)) => {
            if let Some(&r) = seen.get(&o) {
                out.row_of[u] = Some(r);
                return;
            }
            match decompress_row(data, o, row_bytes(n)) {
                Ok(row) => {
                    seen.insert(o, out.rows.len());
                    out.row_of[u] = Some(out.rows.len());
                    out.rows.push(row);
                }
                Err(e) => out.broken.push((u, e)),
            }
        }
        Some(Err(_)) => out.without += 1,
        None => out.broken.push((u, RowError::Outside)),
    };
    if !bsp.format.has_clusters() {
        for j in 0..n {
            decode(j, Some(bsp.leafs[j + 1].visofs), &mut out);
        }
        return Some(out);
    }
    let i32_at = |at: usize| {
        data.get(at..at + 4)
            .map(|s| i32::from_le_bytes([s[0], s[1], s[2], s[3]]))
    };
    let listed = i32_at(0).and_then(|c| usize::try_from(c).ok()).unwrap_or(0);
    let table =
        |c: usize, kind: usize| (c < listed).then(|| i32_at(4 + 8 * c + 4 * kind)).flatten();
    for c in 0..n {
        decode(c, table(c, 0), &mut out);
    }
    let hearable = (0..n)
        .filter_map(|c| usize::try_from(table(c, 1)?).ok())
        .filter_map(|o| decompress_row(data, o, row_bytes(n)).ok())
        .map(|r| count(&r))
        .sum();
    out.hearable = Some(hearable);
    Some(out)
}

impl Stored {
    /// Visible ordered pairs, each leaf (or cluster) with itself included.
    pub fn pairs(&self) -> usize {
        self.row_of
            .iter()
            .flatten()
            .map(|&r| count(&self.rows[r]))
            .sum()
    }

    /// Pairs of `lower` (a PVS of `map`'s cells) this visibility lacks: sightlines it hides.
    /// A leaf without a row hides nothing (engines draw everything there); a broken row
    /// hides all.
    pub fn missing(&self, map: &LeafMap, lower: &Pvs) -> usize {
        let units = map.cell_units();
        let mut cache = std::collections::HashMap::new();
        let mut total = 0;
        for (c, us) in units.iter().enumerate().take(lower.cells()) {
            for &u in us {
                let row = self.row_of.get(u).copied().flatten();
                let broken = self.broken.iter().any(|&(b, _)| b == u);
                if row.is_none() && !broken {
                    continue;
                }
                total += *cache.entry((row, c)).or_insert_with(|| {
                    lower
                        .visible(c)
                        .filter_map(|v| units.get(v))
                        .flatten()
                        .filter(|&&k| row.is_none_or(|r| !get(&self.rows[r], k)))
                        .count()
                });
            }
        }
        total
    }
}

/// A PVS of `map`'s cells counted in the .bsp's terms: its visible ordered pairs of leafs
/// (or clusters), and the pairs of `lower` it lacks.
pub fn counted(map: &LeafMap, pvs: &Pvs, lower: &Pvs) -> (usize, usize) {
    let units = map.cell_units();
    let size = |c: usize| units.get(c).map_or(0, Vec::len);
    let (mut pairs, mut missing) = (0, 0);
    for c in 0..map.cells.min(pvs.cells()) {
        pairs += size(c) * pvs.visible(c).map(size).sum::<usize>();
        if c < lower.cells() {
            let lacks = lower
                .visible(c)
                .filter(|&v| v >= pvs.cells() || !pvs.sees(c, v));
            missing += size(c) * lacks.map(size).sum::<usize>();
        }
    }
    (pairs, missing)
}
