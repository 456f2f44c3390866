//! `portcullis inspect MAP.bsp`: what a Quake-family .bsp holds for vis — its dialect, its
//! leafs or clusters, the visibility stored in it (decoded as an engine reads it) — and, when
//! its .prt is beside it, that visibility set beside ours and the sampled lower bound, so a
//! mapper sees how tight another vis's (or our) result is and whether it misses a sightline.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use serde::Serialize;

use portcullis::diag::Diagnostic;
use portcullis::pipeline::{self, bsp as job};
use portcullis::report::style::Style;
use portcullis::vis::{self, Method, VisOptions};

/// What a .bsp holds for vis.
#[derive(Debug, Serialize)]
pub struct BspView {
    format: &'static str,
    /// Leafs in the leafs lump, leaf 0 included.
    leafs: usize,
    /// "leafs" (Quake 1 family: visible leafs) or "clusters" (Quake 2).
    unit: &'static str,
    /// The world's visible leafs, or the clusters.
    units: usize,
    /// The visibility stored; `None`: the map was never vised.
    visibility: Option<StoredView>,
    /// Ours and the lower bound from the .prt beside the .bsp, when there is one that fits.
    #[serde(skip_serializing_if = "Option::is_none")]
    compared: Option<ComparedView>,
}

#[derive(Debug, Serialize)]
struct StoredView {
    /// Visible ordered pairs of leafs (or clusters), each with itself.
    pairs: usize,
    bytes: usize,
    /// Quake 2: hearable ordered pairs of clusters.
    #[serde(skip_serializing_if = "Option::is_none")]
    hearable: Option<usize>,
    /// Leafs (or clusters) whose row would not decode.
    broken: usize,
    /// Leafs (or clusters) without a row, which engines treat as seeing everything.
    without: usize,
    /// Lower-bound pairs the stored PVS lacks (missed sightlines), when compared.
    #[serde(skip_serializing_if = "Option::is_none")]
    lower_bound_missing: Option<usize>,
}

#[derive(Debug, Serialize)]
struct ComparedView {
    #[serde(serialize_with = "portcullis::diag::lossy_path")]
    prt: PathBuf,
    /// The sampled lower bound's pairs, and its sightlines per directed portal.
    lower_bound: usize,
    samples: usize,
    /// Ours (`full`): pairs and visibility lump bytes.
    full: usize,
    full_bytes: usize,
}

/// The view of `path`, and what reading its .prt reported (a portal file that does not fit
/// is reported, not fatal: the .bsp itself was read).
pub fn view(
    path: &Path,
    opts: &pipeline::LoadOptions,
) -> Result<(BspView, Vec<Diagnostic>), Diagnostic> {
    let bsp = portcullis::bsp::read(path)?;
    let mut diags = Vec::new();
    let prt = job::prt_beside(path, None);
    let input = if prt.exists() {
        job::load_bsp(path, None, opts)
            .map_err(|d| diags.push(d))
            .ok()
    } else {
        None
    };
    let mut compared = None;
    let mut lower_pvs = None;
    if let Some(input) = &input {
        // Inspecting replaces nothing: the stored visibility is the subject here, not news.
        let notes = input.loaded.diagnostics.0.iter();
        diags.extend(
            notes
                .filter(|d| d.code != portcullis::diag::Code::BSP_ALREADY_VISED)
                .cloned(),
        );
        let base = VisOptions {
            samples: input
                .loaded
                .config
                .vis
                .samples
                .unwrap_or(vis::DEFAULT_SAMPLES),
            transform_depth: input.loaded.transform_depth,
            flow_budget: pipeline::flow_budget(&input.loaded.config),
            ..Default::default()
        };
        let sampled = VisOptions {
            method: Method::Sampled,
            ..base.clone()
        };
        let lower = vis::compute(&input.loaded.graph, &sampled);
        let full = vis::compute(&input.loaded.graph, &base);
        let ours = job::side(input, &full, &lower)?;
        compared = Some(ComparedView {
            prt: input.prt_path.clone(),
            lower_bound: job::pairs_in_bsp_terms(input, &lower),
            samples: base.samples,
            full: ours.pairs,
            full_bytes: ours.vis_bytes,
        });
        lower_pvs = Some(lower);
    }
    let against = input
        .as_ref()
        .zip(lower_pvs.as_ref())
        .map(|(i, l)| (&i.map, l));
    let visibility = job::stored_side(&bsp, against).map(|(s, side)| StoredView {
        pairs: side.pairs,
        bytes: side.vis_bytes,
        hearable: s.hearable,
        broken: s.broken.len(),
        without: s.without,
        lower_bound_missing: against.map(|_| side.missing),
    });
    let unit = if bsp.format.has_clusters() {
        "clusters"
    } else {
        "leafs"
    };
    let view = BspView {
        format: bsp.format.name(),
        leafs: bsp.leafs.len(),
        unit,
        units: bsp.vis_units,
        visibility,
        compared,
    };
    Ok((view, diags))
}

/// The human lines of a [`BspView`].
pub fn render(out: &mut String, v: &BspView, style: &Style) {
    let _ = writeln!(
        out,
        "  Quake .bsp ({}): {} leafs; PVS rows per {}: {}",
        v.format,
        v.leafs,
        v.unit.trim_end_matches('s'),
        v.units
    );
    let over = |pairs: usize| {
        v.compared.as_ref().map_or(String::new(), |c| {
            format!(
                " ({:+.1}% over the lower bound)",
                (pairs as f64 / c.lower_bound.max(1) as f64 - 1.0) * 100.0
            )
        })
    };
    match &v.visibility {
        None => {
            let _ = writeln!(
                out,
                "  visibility: {}",
                style.dim("none (not vised: run `portcullis vis` on it)")
            );
        }
        Some(s) => {
            let _ = writeln!(
                out,
                "  visibility stored: {} {} pairs{}, {} bytes{}",
                s.pairs,
                v.unit.trim_end_matches('s'),
                over(s.pairs),
                s.bytes,
                s.hearable
                    .map_or(String::new(), |h| format!(", {h} hearable pairs (PHS)"))
            );
            if s.broken > 0 || s.without > 0 {
                let _ = writeln!(
                    out,
                    "    {} {} with a row that does not decode, {} with none (drawn as seeing everything)",
                    s.broken, v.unit, s.without
                );
            }
            if let Some(m) = s.lower_bound_missing.filter(|&m| m > 0) {
                let _ = writeln!(
                    out,
                    "    {m} pairs of the lower bound are missing: sightlines the stored PVS hides"
                );
            }
        }
    }
    if let Some(c) = &v.compared {
        let _ = writeln!(
            out,
            "  from {}: ours (full) {} pairs{}, {} bytes; sampled lower bound {} pairs ({} samples per portal)",
            c.prt.display(),
            c.full,
            over(c.full),
            c.full_bytes,
            c.lower_bound,
            c.samples
        );
    }
}
