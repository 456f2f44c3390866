//! What the visible cells draw: the nodes drawn whole and the ranges of the split nodes'
//! primitives (the extension's `split` and `cells[].draws`), joined so each triangle lying in
//! a visible cell is submitted once, in one draw call per joined range.

use super::{Level, LevelError};
use crate::format::Annotated;

/// The draw data of a level, as its extension has it.
#[derive(Default)]
pub(super) struct Draws {
    /// Per cell, its `nodes`.
    listed: Vec<Vec<u32>>,
    /// Every node some cell names, ascending: the level's geometry (not its portals' or
    /// bounds' meshes).
    named: Vec<u32>,
    /// Per cell, its `nodes` that are not split, ascending.
    whole: Vec<Vec<u32>>,
    /// Per cell, its ranges (`[primitive, first, count]`).
    ranges: Vec<Vec<[u32; 3]>>,
    /// The split primitives: glTF node, primitive index in its mesh.
    primitives: Vec<(u32, u32)>,
    /// The accessor of the split indices.
    indices: Option<usize>,
}

impl Draws {
    /// Every node some cell names, ascending.
    pub(super) fn named(&self) -> &[u32] {
        &self.named
    }

    /// Cell `c`'s `nodes` as the file lists them (empty for a cell out of range).
    pub(super) fn listed(&self, c: usize) -> &[u32] {
        self.listed.get(c).map_or(&[], Vec::as_slice)
    }

    pub(super) fn read(a: &Annotated) -> Result<Draws, LevelError> {
        let split = a.split.as_ref();
        let prims = split.map_or(&[][..], |s| &s.primitives[..]);
        let mut split_nodes: Vec<usize> = prims.iter().map(|p| p.node).collect();
        split_nodes.sort_unstable();
        let mut out = Draws {
            primitives: prims
                .iter()
                .map(|p| (p.node as u32, p.primitive as u32))
                .collect(),
            indices: split.map(|s| s.indices),
            ..Default::default()
        };
        for (c, cell) in a.cells.iter().enumerate() {
            let whole = (cell.nodes.iter())
                .filter(|n| split_nodes.binary_search(n).is_err())
                .map(|&n| n as u32);
            out.whole.push(whole.collect());
            out.listed
                .push(cell.nodes.iter().map(|&n| n as u32).collect());
            let mut ranges = Vec::with_capacity(cell.draws.len());
            for (i, &[k, first, count]) in cell.draws.iter().enumerate() {
                let bad = LevelError::DrawOutOfRange {
                    cell: c,
                    draw: i,
                    primitive: k,
                };
                let p = prims.get(k).ok_or_else(|| bad.clone())?;
                let end = first.checked_add(count).ok_or_else(|| bad.clone())?;
                if first < p.first || end > p.first + p.count || end > u32::MAX as usize {
                    return Err(bad);
                }
                ranges.push([k as u32, first as u32, count as u32]);
            }
            out.ranges.push(ranges);
        }
        out.named = out.listed.iter().flatten().copied().collect();
        out.named.sort_unstable();
        out.named.dedup();
        Ok(out)
    }
}

/// A range of the split indices to draw: `count` indices from `first` of the accessor
/// [`Level::split_indices`], as triangles over the vertex attributes of primitive
/// `primitive` of glTF node `node`'s mesh (with its material and the node's transform).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct DrawRange {
    /// The glTF node.
    pub node: usize,
    /// The primitive's index in the node's mesh.
    pub primitive: usize,
    /// The first index in the accessor.
    pub first: usize,
    /// How many indices (three per triangle).
    pub count: usize,
}

/// What a set of cells draws: the glTF nodes drawn whole (ascending, each once) and the
/// ranges of the split primitives (each index once, ranges that overlap or meet joined).
/// Reused across frames, it allocates nothing once grown.
#[derive(Debug, Clone, Default)]
pub struct DrawList {
    /// The nodes drawn whole.
    pub nodes: Vec<usize>,
    /// The ranges drawn of the split nodes, by split primitive, then first index.
    pub ranges: Vec<DrawRange>,
    scratch: Vec<[u32; 3]>,
}

impl DrawList {
    /// Draw calls: one per node drawn whole (a node of several primitives is one per
    /// primitive to an engine, counted here as one) and one per range.
    pub fn calls(&self) -> usize {
        self.nodes.len() + self.ranges.len()
    }
}

impl Level {
    /// What cells `cells` draw (for example, a trace's visible cells), into `out`. Cells out
    /// of range are skipped.
    pub fn draw_list(&self, cells: impl IntoIterator<Item = usize>, out: &mut DrawList) {
        let d = &self.draw;
        out.nodes.clear();
        out.ranges.clear();
        out.scratch.clear();
        for c in cells {
            if let (Some(w), Some(r)) = (d.whole.get(c), d.ranges.get(c)) {
                out.nodes.extend(w.iter().map(|&n| n as usize));
                out.scratch.extend_from_slice(r);
            }
        }
        out.nodes.sort_unstable();
        out.nodes.dedup();
        out.scratch.sort_unstable();
        let mut joined: Option<[u32; 3]> = None;
        let push = |r: [u32; 3], out: &mut Vec<DrawRange>| {
            let (node, primitive) = d.primitives[r[0] as usize];
            out.push(DrawRange {
                node: node as usize,
                primitive: primitive as usize,
                first: r[1] as usize,
                count: r[2] as usize,
            });
        };
        for &[k, first, count] in &out.scratch {
            match &mut joined {
                Some(j) if j[0] == k && first <= j[1] + j[2] => {
                    j[2] = j[2].max(first + count - j[1]);
                }
                _ => {
                    if let Some(j) = joined.take() {
                        push(j, &mut out.ranges);
                    }
                    joined = Some([k, first, count]);
                }
            }
        }
        if let Some(j) = joined {
            push(j, &mut out.ranges);
        }
    }

    /// Every glTF node some cell names, ascending: the level's geometry, whose drawing the
    /// cells govern (an engine leaves other nodes, its lights or props, as they are).
    pub fn named_nodes(&self) -> &[u32] {
        self.draw.named()
    }

    /// The accessor holding the split primitives' indices (the extension's `split.indices`),
    /// `None` when no node is split.
    pub fn split_indices(&self) -> Option<usize> {
        self.draw.indices
    }
}
