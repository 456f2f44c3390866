//! What the stages produce for one level, below every stage that reads it: the checks, the
//! PVS and the exporters take a [`Tagged`] level and its cells and portals from here, so none
//! of them depends on the [`crate::pipeline`] that chains the stages.

use crate::config::Config;
use crate::diag::Diagnostics;
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
