//! What the stages produce for one level, below every stage that reads it: the checks, the
//! PVS and the exporters take a built [`Level`] from here, so none of them depends on the
//! [`crate::pipeline`] that chains the stages.

use crate::cells::CellSet;
use crate::config::Config;
use crate::diag::Diagnostics;
use crate::portals::PortalSet;
use crate::scene::Scene;
use crate::tags::{rules::RuleSet, Tagging};

/// A level read and tagged.
#[derive(Debug, Clone)]
pub struct Tagged {
    /// The level as imported.
    pub scene: Scene,
    /// The configuration that applied (file or defaults).
    pub config: Config,
    /// The tag rules in force (preset plus the config's own).
    pub rules: RuleSet,
    /// What the rules found: rooms, portals, volumes and the rest.
    pub tagging: Tagging,
    /// Everything reported so far (import, then tags), in stage order.
    pub diagnostics: Diagnostics,
}

/// A level built: tagged, cut into cells, its portals derived. What every subcommand asks
/// [`crate::pipeline`] for, and what the checks, the PVS and the exporters read.
#[derive(Debug)]
pub struct Level {
    /// The level read and tagged. Its diagnostics have moved to [`Level::diagnostics`].
    pub tagged: Tagged,
    /// The convex cells of its rooms.
    pub cells: CellSet,
    /// The portals between them.
    pub portals: PortalSet,
    /// Everything reported so far (import, tags, cells, portals, then any check), in stage
    /// order.
    pub diagnostics: Diagnostics,
}

impl Level {
    /// The level of `tagged` with its cells and portals; the diagnostics gathered so far
    /// (import, tags, cells, portals) move to the level.
    pub fn new(mut tagged: Tagged, cells: CellSet, portals: PortalSet) -> Level {
        let diagnostics = std::mem::take(&mut tagged.diagnostics);
        Level {
            tagged,
            cells,
            portals,
            diagnostics,
        }
    }
    /// The level as imported.
    pub fn scene(&self) -> &Scene {
        &self.tagged.scene
    }
    /// What the tag rules found.
    pub fn tagging(&self) -> &Tagging {
        &self.tagged.tagging
    }
    /// The configuration that applied.
    pub fn config(&self) -> &Config {
        &self.tagged.config
    }
}
