//! The .bsp with a new visibility lump, as ericw-tools vis writes it: Quake 1 family rows per
//! cell of the portal file (every leaf of a cluster points at its cluster's one row, leaf 0
//! at none), the leafs' `visofs` and ambient levels patched; Quake 2 rows per cluster, PVS
//! then PHS, the leafs untouched. Every other lump is copied byte for byte, in the file's
//! own order, each at a 4-byte boundary; only the lumps after the visibility lump move, by
//! as much as it grew or shrank. BSPX extension lumps after the last lump are kept, their
//! table rewritten for where they now lie.

use super::ambient::{self, Ambient};
use super::leafmap::LeafMap;
use super::read::{Bsp, Lump, Tail};
use super::visdata::{self, compress_row, row_bytes};
use crate::diag::Diagnostic;
use crate::vis::Pvs;

/// What to write besides the PVS.
#[derive(Debug, Clone, Default)]
pub struct Options {
    /// Quake 1 family: the ambient classes written (the others 0).
    pub ambient: Ambient,
    /// Texinfos whose faces emit no ambient sound (qbsp's `MAP.texinfo.json`).
    pub noambient: Vec<bool>,
}

/// The new file and what went into it.
#[derive(Debug, Clone)]
pub struct Written {
    /// The whole .bsp.
    pub bytes: Vec<u8>,
    /// Counts for the summary.
    pub stats: Stats,
}

/// What the new visibility says, in the numbers ericw-tools vis prints.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Stats {
    /// Quake 1 family: the world's visible leafs (0 for Quake 2).
    pub leafs: usize,
    /// Cells of the portal file (clusters, or leafs for PRT1).
    pub clusters: usize,
    /// Visible ordered pairs: of leafs (Quake 1 family) or clusters (Quake 2).
    pub pairs: usize,
    /// Quake 2: hearable ordered pairs of clusters.
    pub hearable: usize,
    /// The visibility lump's bytes.
    pub vis_bytes: usize,
    /// What its PVS rows would take uncompressed.
    pub uncompressed: usize,
    /// Quake 1 family: leafs given a nonzero water, sky, slime, lava level.
    pub ambient: [usize; 4],
}

/// The file `bsp` becomes with `pvs` (over `map`'s cells) written into it.
pub fn visited(bsp: &Bsp, map: &LeafMap, pvs: &Pvs, opts: &Options) -> Result<Written, Diagnostic> {
    let (vis, leafs, stats) = if bsp.format.has_clusters() {
        let (vis, stats) = quake2(map, pvs);
        (vis, None, stats)
    } else {
        let (vis, leafs, stats) = quake1(bsp, map, pvs, opts)?;
        (vis, Some(leafs), stats)
    };
    let bytes = assemble(bsp, &vis, leafs.as_deref());
    if bytes.len() > i32::MAX as usize {
        return Err(Diagnostic::new(
            crate::diag::Code::OUTPUT_FAILED,
            format!(
                "{}: the file would be {} bytes, more than a .bsp's offsets reach",
                bsp.path.display(),
                bytes.len()
            ),
            crate::diag::Location::file(&bsp.path),
        )
        .hint("nothing was written; a map this size needs fewer leafs"));
    }
    Ok(Written { bytes, stats })
}

/// Quake 1 family: the visibility lump and the patched leafs lump.
fn quake1(
    bsp: &Bsp,
    map: &LeafMap,
    pvs: &Pvs,
    opts: &Options,
) -> Result<(Vec<u8>, Vec<u8>, Stats), Diagnostic> {
    let n = bsp.vis_units;
    let cell_leafs = map.cell_leafs();
    let emit = ambient::emitters(bsp, opts.ambient, &opts.noambient)?;
    let cell_emit: Vec<u8> = cell_leafs
        .iter()
        .map(|ls| ls.iter().fold(0, |m, &j| m | emit[j]))
        .collect();
    let mut vis = Vec::new();
    let mut cell_ofs = vec![-1i32; map.cells];
    let mut cell_mask = vec![0u8; map.cells];
    let mut stats = Stats {
        leafs: n,
        clusters: map.cells,
        ..Default::default()
    };
    let mut row = vec![0u8; row_bytes(n)];
    for c in 0..map.cells.min(pvs.cells()) {
        if cell_leafs[c].is_empty() {
            continue;
        }
        row.iter_mut().for_each(|b| *b = 0);
        for v in pvs.visible(c).filter(|&v| v < map.cells) {
            for &j in &cell_leafs[v] {
                visdata::set(&mut row, j);
            }
            cell_mask[c] |= cell_emit[v];
        }
        stats.pairs += visdata::count(&row) * cell_leafs[c].len();
        stats.uncompressed += row.len() * cell_leafs[c].len();
        cell_ofs[c] = vis.len() as i32;
        compress_row(&row, &mut vis);
    }
    let size = bsp.format.leaf_size();
    let amb = bsp.format.ambient_offset();
    let mut leafs = bsp.lump(bsp.format.leafs_lump()).to_vec();
    leafs[4..8].copy_from_slice(&(-1i32).to_le_bytes());
    for (j, &c) in map.leaf_cell.iter().enumerate() {
        let at = (j + 1) * size;
        leafs[at + 4..at + 8].copy_from_slice(&cell_ofs[c].to_le_bytes());
        let levels = ambient::levels(cell_mask[c]);
        leafs[at + amb..at + amb + 4].copy_from_slice(&levels);
        for (n, l) in stats.ambient.iter_mut().zip(levels) {
            *n += usize::from(l > 0);
        }
    }
    stats.vis_bytes = vis.len();
    Ok((vis, leafs, stats))
}

/// Quake 2: the visibility lump (PVS and PHS per cluster).
fn quake2(map: &LeafMap, pvs: &Pvs) -> (Vec<u8>, Stats) {
    let first = pvs.first_cells(map.cells);
    let rows: Vec<Vec<u8>> = (0..map.cells)
        .map(|c| super::phs::pvs_row(&first, c))
        .collect();
    let phs = super::phs::phs(&first);
    let vis = visdata::quake2_lump(&rows, &phs);
    let stats = Stats {
        clusters: map.cells,
        pairs: first.pairs(),
        hearable: phs.iter().map(|r| visdata::count(r)).sum(),
        vis_bytes: vis.len(),
        uncompressed: rows.iter().map(Vec::len).sum(),
        ..Default::default()
    };
    (vis, stats)
}

fn pad4(out: &mut Vec<u8>) {
    out.resize(out.len().div_ceil(4) * 4, 0);
}

/// The file with `vis` as its visibility lump and `leafs` (if given) as its leafs lump.
/// Lumps go in their original order; empty ones other than visibility keep their entry.
fn assemble(bsp: &Bsp, vis: &[u8], leafs: Option<&[u8]>) -> Vec<u8> {
    let (vi, li) = (bsp.format.vis_lump(), bsp.format.leafs_lump());
    let mut order: Vec<usize> = (0..bsp.lumps.len())
        .filter(|&i| i == vi || bsp.lumps[i].len > 0)
        .collect();
    // An empty visibility lump shares its offset with the next lump; it goes first there.
    order.sort_by_key(|&i| (bsp.lumps[i].offset, bsp.lumps[i].len, i));
    let mut out = Vec::with_capacity(bsp.bytes.len() + vis.len());
    out.extend_from_slice(bsp.header());
    let mut table = bsp.lumps.clone();
    for i in order {
        pad4(&mut out);
        let data = match (i == vi, leafs) {
            (true, _) => vis,
            (false, Some(l)) if i == li => l,
            _ => bsp.lump(i),
        };
        table[i] = Lump {
            offset: out.len(),
            len: data.len(),
        };
        out.extend_from_slice(data);
    }
    pad4(&mut out);
    match &bsp.tail {
        Tail::None => {}
        Tail::Raw(r) => out.extend_from_slice(r),
        Tail::Bspx(lumps) => bspx(&mut out, lumps),
    }
    let first = if bsp.format.has_clusters() { 8 } else { 4 };
    for (i, l) in table.iter().enumerate() {
        let at = first + 8 * i;
        out[at..at + 4].copy_from_slice(&(l.offset as i32).to_le_bytes());
        out[at + 4..at + 8].copy_from_slice(&(l.len as i32).to_le_bytes());
    }
    out
}

/// A BSPX block at the (aligned) end of `out`: its table, then each lump 4-byte aligned.
fn bspx(out: &mut Vec<u8>, lumps: &[([u8; 24], Vec<u8>)]) {
    let start = out.len();
    out.extend_from_slice(b"BSPX");
    out.extend((lumps.len() as i32).to_le_bytes());
    out.resize(start + 8 + 32 * lumps.len(), 0);
    for (k, (name, data)) in lumps.iter().enumerate() {
        pad4(out);
        let ofs = out.len();
        out.extend_from_slice(data);
        let e = start + 8 + 32 * k;
        out[e..e + 24].copy_from_slice(name);
        out[e + 24..e + 28].copy_from_slice(&(ofs as i32).to_le_bytes());
        out[e + 28..e + 32].copy_from_slice(&(data.len() as i32).to_le_bytes());
    }
    pad4(out);
}
