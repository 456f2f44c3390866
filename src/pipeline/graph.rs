//! The portal graph of any input the command line accepts: a .prt file directly, or a level
//! (glTF, OBJ, USD) through the same import, tags, cells and portals stages `convert` runs.

use std::path::Path;

use crate::diag::{Diagnostic, Diagnostics};
use crate::vis::VisGraph;

use super::LoadOptions;

/// A graph ready for [`crate::vis::compute`] and what reading it reported.
pub struct Loaded {
    /// The cells and portals as the PVS methods read them.
    pub graph: VisGraph,
    /// What reading, tagging and building reported, in stage order.
    pub diagnostics: Diagnostics,
    /// The configuration that applies to the input (its `[vis]` settings above all).
    pub config: crate::config::Config,
    /// The transform depth bound for this input (configured, else the loop check's).
    pub transform_depth: usize,
    /// The level the graph was built from (none for a .prt file): what `vis --report` traces
    /// rays through.
    pub level: Option<crate::level::Level>,
}

impl Loaded {
    /// A portal file's graph, as read with `diags`, under `config`: no level behind it.
    pub(crate) fn of_prt(
        file: &crate::prt::PrtFile,
        diags: Vec<Diagnostic>,
        config: crate::config::Config,
    ) -> Loaded {
        Loaded {
            graph: file.graph(None),
            diagnostics: Diagnostics(diags),
            transform_depth: (config.vis.transform_depth)
                .unwrap_or(crate::vis::DEFAULT_TRANSFORM_DEPTH),
            config,
            level: None,
        }
    }
}

/// The portal graph of `path`, as `vis` reads it.
pub fn load(path: &Path, opts: &LoadOptions) -> Result<Loaded, Diagnostic> {
    if crate::export::Target::is_prt(path) {
        let config = super::config_for(path, opts)?;
        let (file, diags) = crate::prt::read(path)?;
        return Ok(Loaded::of_prt(&file, diags, config));
    }
    let mut level = super::load(path, opts)?;
    Ok(Loaded {
        graph: VisGraph::from_portal_set(
            level.cells.cells.len(),
            &level.portals,
            level.cells.tolerance.distance,
        ),
        transform_depth: super::transform_depth(&level),
        diagnostics: std::mem::take(&mut level.diagnostics),
        config: level.config().clone(),
        level: Some(level),
    })
}
