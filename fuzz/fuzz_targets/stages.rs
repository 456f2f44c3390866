//! The stages every whole-level target runs after import: tags with the default rules, cells,
//! portals. `None` when the default configuration does not give a rule set.

use portcullis::cells::CellSet;
use portcullis::import::Imported;
use portcullis::pipeline::{self, Tagged};
use portcullis::portals::PortalSet;

pub fn run(imported: Imported) -> Option<(Tagged, CellSet, PortalSet)> {
    let config = portcullis::config::Config::default();
    let rules = portcullis::config::rule_set(&config, None).ok()?;
    let mut tagged = pipeline::tag(imported, config, rules);
    let cells = pipeline::build_cells(&mut tagged);
    let portals = pipeline::build_portals(&mut tagged, &cells);
    Some((tagged, cells, portals))
}
