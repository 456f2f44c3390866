//! Which cell of the portal file each leaf of the .bsp is. The PVS is computed on the .prt's
//! cells (Quake's leafs for PRT1, clusters of leafs for PRT2 and PRT1-AM, Quake 2's clusters),
//! and written per leaf or cluster of the .bsp, so the two must describe one compile: the
//! counts must agree exactly and the portals must lie where the leafs they join are.

use std::path::Path;

use super::error;
use super::read::Bsp;
use crate::diag::Diagnostic;
use crate::prt::{PrtFile, PrtFormat};

/// The .prt's cells in the .bsp's terms.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LeafMap {
    /// Cells of the portal graph (and of its PVS).
    pub cells: usize,
    /// Quake 1 family: the cell of each visible leaf (index j is leaf j + 1). Quake 2: empty,
    /// the cells are the .bsp's clusters.
    pub leaf_cell: Vec<usize>,
}

/// More than this share of portals outside the leafs they join reads as another map's
/// portal file. qbsp's own leaf boxes miss a few portals (at most 2.3% of e3m4's and
/// retrojam1's, none elsewhere), so the bar is well above that.
const FOREIGN_SHARE: f64 = 0.25;
/// Units the leaf boxes are widened by: they are stored rounded.
const SLACK: f32 = 1.0;

/// Matches `prt` (read from `prt_path`) to `bsp`.
pub fn match_prt(bsp: &Bsp, prt: &PrtFile, prt_path: &Path) -> Result<LeafMap, Diagnostic> {
    let mismatch = |what: String| error::prt_mismatch(&bsp.path, prt_path, what);
    let map = if bsp.format.has_clusters() {
        if prt.format != PrtFormat::Prt1 {
            return Err(mismatch(format!(
                "it is a {} file, and Quake 2's portal files are PRT1 (of clusters)",
                prt.format.header()
            )));
        }
        if prt.cells != bsp.vis_units {
            return Err(mismatch(format!(
                "it has {} clusters; the .bsp's leafs name {}",
                prt.cells, bsp.vis_units
            )));
        }
        LeafMap {
            cells: prt.cells,
            leaf_cell: Vec::new(),
        }
    } else {
        if prt.leaves != bsp.vis_units {
            return Err(mismatch(format!(
                "it has {} leafs; the .bsp's world has {} visible leafs",
                prt.leaves, bsp.vis_units
            )));
        }
        let leaf_cell = match prt.format {
            PrtFormat::Prt1 => (0..prt.cells).collect(),
            PrtFormat::Prt2 | PrtFormat::Prt1Am => prt.leaf_cluster.clone(),
        };
        if let Some(j) = leaf_cell.iter().position(|&c| c >= prt.cells) {
            return Err(mismatch(format!(
                "it puts leaf {j} (the .bsp's leaf {}) in no cluster",
                j + 1
            )));
        }
        LeafMap {
            cells: prt.cells,
            leaf_cell,
        }
    };
    let (outside, total) = map.portals_outside(bsp, prt);
    if total > 0 && outside as f64 > FOREIGN_SHARE * total as f64 {
        return Err(mismatch(format!(
            "{outside} of its {total} portals lie outside the leafs they join"
        )));
    }
    Ok(map)
}

impl LeafMap {
    /// The .bsp's units of every cell: its visible leafs (index j is leaf j + 1), or for
    /// Quake 2 the cluster itself.
    pub fn cell_units(&self) -> Vec<Vec<usize>> {
        if self.leaf_cell.is_empty() {
            return (0..self.cells).map(|c| vec![c]).collect();
        }
        self.cell_leafs()
    }

    /// The visible leafs of every cell (index j is the .bsp's leaf j + 1); none for Quake 2.
    pub fn cell_leafs(&self) -> Vec<Vec<usize>> {
        let mut out = vec![Vec::new(); self.cells];
        for (j, &c) in self.leaf_cell.iter().enumerate() {
            out[c].push(j);
        }
        out
    }

    /// Each cell's box: the union of its leafs' stored boxes.
    fn cell_boxes(&self, bsp: &Bsp) -> Vec<Option<([f32; 3], [f32; 3])>> {
        let mut boxes: Vec<Option<([f32; 3], [f32; 3])>> = vec![None; self.cells];
        let mut add = |c: usize, lo: [f32; 3], hi: [f32; 3]| {
            let b = boxes[c].get_or_insert((lo, hi));
            for k in 0..3 {
                b.0[k] = b.0[k].min(lo[k]);
                b.1[k] = b.1[k].max(hi[k]);
            }
        };
        if self.leaf_cell.is_empty() {
            for l in &bsp.leafs {
                if let Ok(c) = usize::try_from(l.cluster) {
                    if c < self.cells {
                        add(c, l.mins, l.maxs);
                    }
                }
            }
        } else {
            for (j, &c) in self.leaf_cell.iter().enumerate() {
                if let Some(l) = bsp.leafs.get(j + 1) {
                    add(c, l.mins, l.maxs);
                }
            }
        }
        boxes
    }

    /// Portals whose box misses the box of either cell they join, and all portals.
    fn portals_outside(&self, bsp: &Bsp, prt: &PrtFile) -> (usize, usize) {
        let boxes = self.cell_boxes(bsp);
        let mut outside = 0;
        for p in &prt.portals {
            let mut lo = [f32::MAX; 3];
            let mut hi = [f32::MIN; 3];
            for v in &p.points {
                for k in 0..3 {
                    lo[k] = lo[k].min(v[k] as f32);
                    hi[k] = hi[k].max(v[k] as f32);
                }
            }
            let touches = |c: usize| {
                boxes.get(c).copied().flatten().is_some_and(|(bl, bh)| {
                    (0..3).all(|k| hi[k] >= bl[k] - SLACK && lo[k] <= bh[k] + SLACK)
                })
            };
            if !(touches(p.a) && touches(p.b)) {
                outside += 1;
            }
        }
        (outside, prt.portals.len())
    }
}
