//! The portal graph of any input the command line accepts: a .prt file directly, or a level
//! (glTF, OBJ, USD) through the same import, tags, cells and portals stages `convert` runs.

use std::path::Path;

use crate::diag::{Diagnostic, Diagnostics};
use crate::pipeline::{self, LoadOptions};

use super::VisGraph;

/// A graph ready for [`super::compute`] and what reading it reported.
pub struct Loaded {
    pub graph: VisGraph,
    pub diagnostics: Diagnostics,
    pub config: crate::config::Config,
    /// The transform depth bound for this input (configured, else the loop check's).
    pub transform_depth: usize,
    /// The level the graph was built from (none for a .prt file): what `vis --report` traces
    /// rays through.
    pub level: Option<Level>,
}

/// A level as built for its graph.
pub struct Level {
    pub tagged: crate::pipeline::Tagged,
    pub cells: crate::cells::CellSet,
    pub portals: crate::portals::PortalSet,
}

pub fn is_prt(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("prt"))
}

pub fn load(path: &Path, opts: &LoadOptions) -> Result<Loaded, Diagnostic> {
    if is_prt(path) {
        let config = pipeline::config_for(path, opts)?;
        let (file, diags) = crate::prt::read(path)?;
        return Ok(Loaded {
            graph: file.graph(None),
            diagnostics: Diagnostics(diags),
            transform_depth: config
                .vis
                .transform_depth
                .unwrap_or(super::DEFAULT_TRANSFORM_DEPTH),
            config,
            level: None,
        });
    }
    let mut t = pipeline::load_tagged(path, opts)?;
    let cells = pipeline::build_cells(&mut t);
    let portals = pipeline::build_portals(&mut t, &cells);
    Ok(Loaded {
        graph: VisGraph::from_portal_set(cells.cells.len(), &portals, cells.tolerance.distance),
        transform_depth: super::level_transform_depth(
            &cells,
            &portals,
            t.config.vis.transform_depth,
        ),
        diagnostics: std::mem::take(&mut t.diagnostics),
        config: t.config.clone(),
        level: Some(Level {
            tagged: t,
            cells,
            portals,
        }),
    })
}
