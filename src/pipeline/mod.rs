//! The stages chained for one input file, as every subcommand runs them: [`load`] reads,
//! tags and builds a [`Level`]; [`check`], [`pvs`] and [`audit`] add to it what a subcommand
//! asks for; [`crate::export::output`] writes it. Library users call this too, or the stages
//! one by one ([`load_tagged`], [`build_cells`], [`build_portals`]).
//!
//! Each stage's diagnostics are appended in stage order. The transform depth a PVS follows
//! mirrors and teleporters to is decided here once ([`transform_depth`]), for `convert`,
//! `check`, `view` and `vis` alike.

use std::path::Path;

pub mod bsp;
mod gate;
pub mod graph;
mod load;

use crate::cells::{self, CellSet};
use crate::diag::Diagnostic;
use crate::export::output::{self, Output};
pub use crate::free::drop_elsewhere;
pub use crate::level::{Level, Tagged};
use crate::portals::PortalSet;
use crate::vis::{Method, Pvs};
pub use gate::{check_file, Checked, GateOptions};
pub use load::{config_for, load_tagged, tag, LoadOptions};

/// Reads, tags and builds one file (`-` reads standard input). `Err` means the file could not
/// be processed at all.
pub fn load(input: &Path, opts: &LoadOptions) -> Result<Level, Diagnostic> {
    load_tagged(input, opts).map(build)
}

/// The cells and portals of a tagged level.
pub fn build(mut tagged: Tagged) -> Level {
    let cells = build_cells(&mut tagged);
    let portals = build_portals(&mut tagged, &cells);
    Level::new(tagged, cells, portals)
}

/// The cells of a tagged level; their diagnostics are appended to `tagged.diagnostics`.
pub fn build_cells(tagged: &mut Tagged) -> CellSet {
    let mut set = cells::build_reaching(
        &tagged.scene,
        &tagged.tagging,
        &tagged.config.cells,
        tagged.config.portals.max_wall_thickness,
    );
    cells::drop_far_structure(
        &tagged.scene,
        &tagged.tagging,
        &mut set,
        tagged.config.portals.max_wall_thickness,
    );
    cells::split_areas(&mut tagged.tagging, &mut set);
    tagged.diagnostics.extend(set.diagnostics.iter().cloned());
    set
}

/// The portals of a tagged level with its cells; diagnostics are appended to
/// `tagged.diagnostics`.
pub fn build_portals(tagged: &mut Tagged, cells: &CellSet) -> PortalSet {
    let set = crate::portals::build(
        &tagged.scene,
        &tagged.tagging,
        cells,
        &tagged.config.portals,
    );
    tagged.diagnostics.extend(set.diagnostics.iter().cloned());
    set
}

/// `portcullis convert INPUT -o OUTPUT` with the defaults, for library users: cells, portals
/// and the full PVS, written atomically to a .glb or .gltf. Diagnostics are not checked (run
/// [`check`] for a gate); `Err` only when the level cannot be read or written.
pub fn convert_file(input: &Path, output: &Path) -> Result<(), Diagnostic> {
    let out = Output::gltf(output)?;
    let level = load(input, &LoadOptions::default())?;
    let pvs = pvs(&level, Method::Full);
    output::level(&level, Some((&pvs, Method::Full)), &out).map(drop)
}

/// The checks of a built level (see [`crate::check`]); findings are appended to
/// `level.diagnostics`, and the leak polylines returned for debug output. `sealed` adds to
/// the configuration's `[check] sealed`.
pub fn check(level: &mut Level, sealed: bool) -> Vec<Vec<glam::DVec3>> {
    let opts = crate::check::Options {
        sealed: sealed || level.config().check.sealed,
    };
    let found = crate::check::run(&crate::check::Subject::built(level), &opts);
    level.diagnostics.extend(found.diagnostics);
    found.leaks
}

/// How many transformed portals (mirrors, teleporters) one sightline of the level's PVS may
/// pass through: `[vis] transform_depth`, else the run-time bound the loop check gives.
pub fn transform_depth(level: &Level) -> usize {
    let bounds =
        (level.cells.cells.iter()).fold(crate::geom::aabb::Aabb::EMPTY, |b, c| b.union(&c.bounds));
    let extent = if bounds.is_empty() {
        1.0
    } else {
        bounds.size().length()
    };
    depth_bound(level.config(), &level.portals, extent)
}

/// The one rule for the depth bound, for a level built or stored: `[vis] transform_depth`,
/// else the bound the loop check gives renderers (`portals::loops::recursion_depth`), so the
/// PVS covers every view an engine will draw through mirrors and teleporters.
fn depth_bound(config: &crate::config::Config, portals: &PortalSet, extent: f64) -> usize {
    (config.vis.transform_depth)
        .unwrap_or_else(|| crate::portals::loops::recursion_depth(portals, extent))
}

/// The note `convert` and `vis` give when the level has open transformed portals: how deep
/// its PVS follows them.
pub fn transform_depth_note(level: &Level, input: &Path) -> Option<Diagnostic> {
    let transformed = level
        .portals
        .portals
        .iter()
        .any(|p| p.transform.is_some() && !p.closed && p.to.is_some());
    transformed.then(|| crate::vis::transform_depth_note(input, transform_depth(level)))
}

/// The level's PVS by `method`, through mirrors and teleporters as deep as
/// [`transform_depth`], with the configuration's `[vis] samples` and `[vis] flow_budget`.
pub fn pvs(level: &Level, method: Method) -> Pvs {
    computed(level, method).pvs
}

/// [`pvs`], with the note `convert` and `check` give when the flow budget cut it short.
pub fn pvs_noted(level: &Level, method: Method, input: &Path) -> (Pvs, Option<Diagnostic>) {
    let c = computed(level, method);
    let note = (c.cut_short > 0).then(|| {
        let budget = flow_budget(level.config());
        crate::vis::flow_budget_note(input, c.cut_short, c.sources, budget)
    });
    (c.pvs, note)
}

fn computed(level: &Level, method: Method) -> crate::vis::Computed {
    let vis = &level.config().vis;
    let opts = crate::vis::VisOptions {
        method,
        transform_depth: transform_depth(level),
        samples: vis.samples.unwrap_or(crate::vis::DEFAULT_SAMPLES),
        flow_budget: flow_budget(level.config()),
        ..Default::default()
    };
    let g = crate::vis::VisGraph::from_portal_set(
        level.cells.cells.len(),
        &level.portals,
        level.cells.tolerance.distance,
    );
    crate::vis::computed(&g, &opts)
}

/// `[vis] flow_budget`, else the default.
pub fn flow_budget(config: &crate::config::Config) -> u64 {
    (config.vis.flow_budget).unwrap_or(crate::vis::DEFAULT_FLOW_BUDGET)
}

/// `check --sightlines`: audits `pvs` against the level's triangles with `rays` rays per cell.
pub fn audit(level: &Level, pvs: &Pvs, rays: usize) -> crate::check::sightlines::Audit {
    let subject = crate::check::Subject::built(level);
    let triangles = crate::portals::blocking_triangles(
        level.scene(),
        level.tagging(),
        &level.cells.prop_nodes(),
    );
    crate::check::sightlines::audit(&subject, &triangles, pvs, rays, transform_depth(level))
}

/// `check --sightlines` on a stored annotation: its stored PVS (or, when it stores none, the
/// full PVS of its stored portals) against the level's triangles. Props are not known from an
/// annotation, so they block here (which only ever confirms fewer pairs).
pub(crate) fn audit_stored(
    tagged: &Tagged,
    annotated: &crate::format::Annotated,
    subject: &crate::check::Subject,
    rays: usize,
) -> crate::check::sightlines::Audit {
    let cells = annotated.cells.len();
    let stored = tagged.scene.gltf.as_ref().and_then(|src| {
        let buffers = src.buffer_data().ok()?;
        let doc = src.subset(&["bufferViews"]).ok()?;
        crate::format::read::visibility(annotated, &doc, &buffers)?.ok()
    });
    let depth = depth_bound(&tagged.config, subject.portals, subject.extent);
    let pvs = stored.unwrap_or_else(|| {
        let opts = crate::vis::VisOptions {
            transform_depth: depth,
            flow_budget: flow_budget(&tagged.config),
            ..Default::default()
        };
        crate::vis::of_level(cells, subject.portals, subject.eps, &opts)
    });
    let triangles = crate::portals::blocking_triangles(&tagged.scene, &tagged.tagging, &[]);
    crate::check::sightlines::audit(subject, &triangles, &pvs, rays, depth)
}
