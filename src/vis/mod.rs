//! Visibility: the cell-to-cell potentially visible set (PVS).
//!
//! Four methods on one portal graph ([`graph::VisGraph`]), from loose to tight: `flood`
//! (reachability), `fast` (Quake's per-portal "might see"), `full` (portal flow with
//! separating-plane clipping, as Quake's vis), and `sampled` (random sightlines walked through
//! the portals, a lower bound). The conservative three nest: full ⊆ fast ⊆ flood, and every
//! sampled pair is in full. Transformed portals (mirrors, teleporters) are followed with their
//! transform applied, through at most [`VisOptions::transform_depth`] of them per sightline.
//!
//! Results never depend on the thread count: parallel work is split by source portal and
//! merged in a fixed order (see `full.rs` and `sampled.rs`).
//!
//! The files: `graph.rs`, the method-neutral input; `load.rs`, any input to a graph; `flood.rs`
//! (reachability, once per strongly connected part, parts in reverse topological order); `fast.rs`
//! (Quake's per-portal might-see: front tests, then a flood; behind a transform it floods
//! unfiltered); `full.rs` (the portal flow; a per-frame separator cache; one portal × portal matrix
//! holds the might-see rows and is overwritten by the results); `sampled.rs` (seeded random
//! segments from each directed portal, walked through the first portal crossed strictly inside; the
//! outside's openings are walls to it, since nothing there is known to be clear); `winding.rs`
//! (chop and separators into reused buffers; separators built only for the two extreme pass corners
//! per source edge); `bits.rs` (u64 rows); `pvs.rs` (`Pvs`: one bit row per cell, ordered pairs,
//! the `c: v1 v2 ...` text).
//!
//! Invariants: sampled ⊆ full ⊆ fast ⊆ flood; every cell sees itself; each sampler generator is
//! seeded by its portal; a transformed portal carries the whole stack into its target space, and
//! the default `transform_depth` is the loop check's `recursion_depth`, else `[vis]
//! transform_depth`.

pub(crate) use crate::format::bits;
mod fast;
mod flood;
mod full;
pub(crate) mod graph;
mod sampled;
pub(crate) mod winding;

use std::time::{Duration, Instant};

pub use crate::format::{Method, Pvs, DEFAULT_TRANSFORM_DEPTH};
use crate::portals::PortalSet;
pub use graph::{VisGraph, VisPortal};

/// Default sightlines per directed portal for `sampled`.
pub const DEFAULT_SAMPLES: usize = 2000;

/// Default portal tests the `full` flow may make in all (about a minute of one core at a
/// couple of microseconds a test): no shipped or shared level of rooms comes near half of it,
/// while open levels of thousands of small cells (an arena, a town) would otherwise take
/// hours. See `full.rs`.
pub const DEFAULT_FLOW_BUDGET: u64 = 1 << 25;

/// How to compute a PVS.
#[derive(Debug, Clone)]
pub struct VisOptions {
    /// Which algorithm.
    pub method: Method,
    /// Sightlines per directed portal (`sampled`).
    pub samples: usize,
    /// Worker threads; `None`: rayon's default (one per core).
    pub threads: Option<usize>,
    /// Transformed portals one sightline may pass through.
    pub transform_depth: usize,
    /// Seed of the sampler's generators.
    pub seed: u64,
    /// Portal tests the `full` flow may make in all; sources past it keep a conservative row.
    pub flow_budget: u64,
}

impl Default for VisOptions {
    fn default() -> Self {
        VisOptions {
            method: Method::Full,
            samples: DEFAULT_SAMPLES,
            threads: None,
            transform_depth: DEFAULT_TRANSFORM_DEPTH,
            seed: 1,
            flow_budget: DEFAULT_FLOW_BUDGET,
        }
    }
}

/// The PVS of a portal graph.
pub fn compute(g: &VisGraph, opts: &VisOptions) -> Pvs {
    computed(g, opts).pvs
}

/// A PVS and what bounded it.
#[derive(Debug, Clone)]
pub struct Computed {
    /// The result.
    pub pvs: Pvs,
    /// Directed portals whose `full` flow the budget cut short (their rows fall back towards
    /// `fast`); 0 for the other methods.
    pub cut_short: usize,
    /// Directed portals in the graph (the flow's sources).
    pub sources: usize,
}

/// The PVS of a portal graph, with how many sources the flow budget cut short.
pub fn computed(g: &VisGraph, opts: &VisOptions) -> Computed {
    let run = || match opts.method {
        Method::Flood => (flood::pvs(g), 0),
        Method::Fast => (fast::pvs(g, opts.transform_depth), 0),
        Method::Full => {
            let might = fast::might_see(g, opts.transform_depth);
            full::pvs(g, might, opts.transform_depth, opts.flow_budget)
        }
        Method::Sampled => {
            let might = fast::might_see(g, opts.transform_depth);
            let p = sampled::pvs(g, &might, opts.samples, opts.transform_depth, opts.seed);
            (p, 0)
        }
    };
    // A pool of our own: the requested size, and a deep stack for the flow's recursion
    // (one level per portal on a chain).
    let mut b = rayon::ThreadPoolBuilder::new().stack_size(64 << 20);
    if let Some(t) = opts.threads {
        b = b.num_threads(t.max(1));
    }
    let (pvs, cut_short) = match b.build() {
        Ok(pool) => pool.install(run),
        Err(_) => run(),
    };
    let pvs = match g.outside {
        Some(o) => pvs.first_cells(o),
        None => pvs,
    };
    Computed {
        pvs,
        cut_short,
        sources: g.portals.len(),
    }
}

/// [`compute`] and how long it took.
pub fn timed(g: &VisGraph, opts: &VisOptions) -> (Pvs, Duration) {
    let t = Instant::now();
    let p = compute(g, opts);
    (p, t.elapsed())
}

/// The note that sightlines through transformed portals stop at the depth bound.
pub fn transform_depth_note(file: &std::path::Path, depth: usize) -> crate::diag::Diagnostic {
    crate::diag::Diagnostic::new(
        crate::diag::Code::VIS_TRANSFORM_DEPTH,
        format!("sightlines through mirrors and teleporters were followed through at most {depth} of them"),
        crate::diag::Location::file(file),
    )
    .hint("set `[vis] transform_depth` in portcullis.toml (or `vis --transform-depth`) to follow them further")
}

/// The note that the flow budget cut `cut` of `sources` directed portals short.
pub fn flow_budget_note(
    file: &std::path::Path,
    cut: usize,
    sources: usize,
    budget: u64,
) -> crate::diag::Diagnostic {
    crate::diag::Diagnostic::new(
        crate::diag::Code::VIS_FLOW_BUDGET,
        format!(
            "the full PVS reached its budget of {budget} portal tests: the flow from {cut} of {sources} directed portals stopped early and took the rest of what they might see as seen (conservative, looser)"
        ),
        crate::diag::Location::file(file),
    )
    .hint("set `[vis] flow_budget` in portcullis.toml (or `vis --flow-budget`) higher for a tighter PVS at more time; fewer, larger cells cost far less")
}

/// The PVS of a level's cells and portals.
pub fn of_level(cells: usize, portals: &PortalSet, epsilon: f64, opts: &VisOptions) -> Pvs {
    compute(&VisGraph::from_portal_set(cells, portals, epsilon), opts)
}
