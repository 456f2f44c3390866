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
    pub level: Option<Built>,
}

/// A level as built for its graph.
pub struct Built {
    /// The level read and tagged.
    pub tagged: crate::level::Tagged,
    /// Its cells.
    pub cells: crate::cells::CellSet,
    /// Its portals, which the graph was made from.
    pub portals: crate::portals::PortalSet,
}

/// The portal graph of `path`, as `vis` reads it.
pub fn load(path: &Path, opts: &LoadOptions) -> Result<Loaded, Diagnostic> {
    if crate::export::Target::is_prt(path) {
        let config = super::config_for(path, opts)?;
        let (file, diags) = crate::prt::read(path)?;
        return Ok(Loaded {
            graph: file.graph(None),
            diagnostics: Diagnostics(diags),
            transform_depth: config
                .vis
                .transform_depth
                .unwrap_or(crate::vis::DEFAULT_TRANSFORM_DEPTH),
            config,
            level: None,
        });
    }
    let mut t = super::load_tagged(path, opts)?;
    let cells = super::build_cells(&mut t);
    let portals = super::build_portals(&mut t, &cells);
    Ok(Loaded {
        graph: VisGraph::from_portal_set(cells.cells.len(), &portals, cells.tolerance.distance),
        transform_depth: crate::vis::level_transform_depth(
            &cells,
            &portals,
            t.config.vis.transform_depth,
        ),
        diagnostics: std::mem::take(&mut t.diagnostics),
        config: t.config.clone(),
        level: Some(Built {
            tagged: t,
            cells,
            portals,
        }),
    })
}
