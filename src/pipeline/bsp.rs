//! `vis MAP.bsp`: the .bsp and the portal file beside it read and matched
//! ([`load_bsp`]), the PVS computed on the portal file and written into the .bsp's bytes
//! ([`vis_bsp`]), and those bytes put in place of the .bsp in one atomic rename
//! ([`write_bsp`]), so a run that fails at any step leaves the .bsp as it was.

use std::path::{Path, PathBuf};

use super::graph::Loaded;
use super::LoadOptions;
use crate::bsp::{self, Ambient, Bsp, LeafMap};
use crate::diag::Diagnostic;
use crate::export::output::{self, Output};
use crate::export::Target;
use crate::prt::PrtFile;
use crate::vis::{self, Computed, Pvs, VisOptions};

/// A .bsp with its portal file, matched.
pub struct BspInput {
    /// The .bsp as read.
    pub bsp: Bsp,
    /// Where the portal file was read from.
    pub prt_path: PathBuf,
    /// The portal file.
    pub prt: PrtFile,
    /// Its cells in the .bsp's leafs or clusters.
    pub map: LeafMap,
    /// Its graph, configuration and what reading reported.
    pub loaded: Loaded,
}

/// The portal file vis reads for `bsp`: `prt` when given, else the .bsp's name with `.prt`.
pub fn prt_beside(bsp: &Path, prt: Option<&Path>) -> PathBuf {
    prt.map_or_else(|| bsp.with_extension("prt"), Path::to_path_buf)
}

/// Reads `path` (a .bsp) and its portal file (`prt`, or the one beside it) and matches them.
/// The .bsp is read first: a broken .bsp is reported as such whatever the portal file.
pub fn load_bsp(
    path: &Path,
    prt: Option<&Path>,
    opts: &LoadOptions,
) -> Result<BspInput, Diagnostic> {
    let bsp = bsp::read(path)?;
    let prt_path = prt_beside(path, prt);
    if !prt_path.exists() {
        return Err(bsp::error::prt_missing(path, &prt_path));
    }
    let config = super::config_for(path, opts)?;
    let (file, mut diags) = crate::prt::read(&prt_path)?;
    let map = bsp::match_prt(&bsp, &file, &prt_path)?;
    diags.extend(bsp::already_vised(&bsp));
    let loaded = Loaded::of_prt(&file, diags, config);
    Ok(BspInput {
        bsp,
        prt_path,
        prt: file,
        map,
        loaded,
    })
}

/// What [`vis_bsp`] made.
pub struct BspVised {
    /// The new file and its counts.
    pub written: bsp::Written,
    /// The PVS on the portal file's cells, and what bounded it.
    pub computed: Computed,
}

/// The PVS of `input`'s portal file by `opts`, written into its .bsp's bytes with the
/// `ambient` classes (Quake 1 family). Reads `MAP.texinfo.json` beside the .bsp when qbsp
/// wrote one, for the faces it marks `noambient`.
pub fn vis_bsp(
    input: &BspInput,
    opts: &VisOptions,
    ambient: Ambient,
) -> Result<BspVised, Diagnostic> {
    let computed = vis::computed(&input.loaded.graph, opts);
    let mut write = bsp::Options {
        ambient,
        noambient: Vec::new(),
    };
    let flags = input.bsp.path.with_extension("texinfo.json");
    if !input.bsp.format.has_clusters() && ambient.any() {
        if let Ok(text) = std::fs::read_to_string(&flags) {
            let n = input.bsp.texinfos()?;
            write.noambient = bsp::noambient_texinfos(&text, n).unwrap_or_default();
        }
    }
    let written = bsp::visited(&input.bsp, &input.map, &computed.pvs, &write)?;
    Ok(BspVised { written, computed })
}

/// Puts `bytes` in place of the .bsp at `path` atomically (a temporary beside it, renamed).
pub fn write_bsp(path: &Path, bytes: &[u8]) -> Result<(), Diagnostic> {
    output::bytes(&Output::file(path, Target::Bsp), bytes).map(drop)
}

/// One PVS of a .bsp beside the sampled lower bound, counted in the .bsp's terms (leaf
/// pairs for the Quake 1 family, cluster pairs for Quake 2).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Side {
    /// Visible ordered pairs, each leaf (or cluster) with itself included.
    pub pairs: usize,
    /// Pairs of the lower bound this PVS lacks (a sightline it misses; 0 for a sound PVS).
    pub missing: usize,
    /// Bytes of the visibility lump holding it.
    pub vis_bytes: usize,
}

/// `pvs` (of the portal file's cells) as [`vis_bsp`] would write it, beside `lower` (the
/// sampled lower bound, also of the cells).
pub fn side(input: &BspInput, pvs: &Pvs, lower: &Pvs) -> Result<Side, Diagnostic> {
    let write = bsp::Options {
        ambient: Ambient::none(),
        noambient: Vec::new(),
    };
    let w = bsp::visited(&input.bsp, &input.map, pvs, &write)?;
    let (pairs, missing) = bsp::readback::counted(&input.map, pvs, lower);
    Ok(Side {
        pairs,
        missing,
        vis_bytes: w.stats.vis_bytes,
    })
}

/// Visible pairs of `pvs` (of the portal file's cells) in the .bsp's terms.
pub fn pairs_in_bsp_terms(input: &BspInput, pvs: &Pvs) -> usize {
    bsp::readback::counted(&input.map, pvs, pvs).0
}

/// What the .bsp already holds (another vis's work, or ours), beside `lower` (a PVS of
/// `map`'s cells) when given; `None` when it holds no visibility.
pub fn stored_side(bsp: &Bsp, lower: Option<(&LeafMap, &Pvs)>) -> Option<(bsp::Stored, Side)> {
    let s = bsp::stored(bsp)?;
    let side = Side {
        pairs: s.pairs(),
        missing: lower.map_or(0, |(map, l)| s.missing(map, l)),
        vis_bytes: s.bytes,
    };
    Some((s, side))
}
