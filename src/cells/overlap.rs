//! Overlapping cells of different rooms. Rooms of different priority may nest (the higher one
//! wins the shared space); equal priorities overlapping is a modelling error.

use super::CellSet;
use crate::config::CellsConfig;
use crate::diag::{Code, Diagnostic, Location};
use crate::geom::polyhedron::ConvexPolyhedron;
use crate::scene::Scene;
use crate::tags::Tagging;

/// The overlaps of `set`'s cells: a diagnostic and the shared region of each (what
/// [`CellSet::overlaps`] holds).
pub(crate) fn find(
    scene: &Scene,
    tagging: &Tagging,
    cfg: &CellsConfig,
    set: &CellSet,
) -> (Vec<Diagnostic>, Vec<ConvexPolyhedron>) {
    let eps = set.tolerance.distance;
    // Only cells whose bounds overlap are compared (never all pairs), in the sweep's order.
    let (_, pairs) = set.pairs_in_order(0.0);
    let mut found = Vec::new();
    let mut regions = Vec::new();
    for (a, b) in pairs {
        let ca = &set.cells[a];
        {
            let cb = &set.cells[b];
            if cb.bounds.min.x >= ca.bounds.max.x - eps || cb.bounds.max.x <= ca.bounds.min.x + eps
            {
                continue;
            }
            if ca.room == cb.room
                || cb.bounds.min.y >= ca.bounds.max.y - eps
                || cb.bounds.max.y <= ca.bounds.min.y + eps
                || cb.bounds.min.z >= ca.bounds.max.z - eps
                || cb.bounds.max.z <= ca.bounds.min.z + eps
            {
                continue;
            }
            let (ra, rb) = (&tagging.rooms[ca.room], &tagging.rooms[cb.room]);
            if ra.priority != rb.priority {
                continue;
            }
            if let Some(x) = ca.poly.intersection(&cb.poly, eps) {
                let v = x.volume();
                if v > cfg.overlap_volume {
                    regions.push(x.clone());
                    found.push(
                        Diagnostic::new(
                            Code::CELL_OVERLAP,
                            format!(
                                "cells of rooms `{}` and `{}` overlap by {v:.4} m³",
                                ra.name, rb.name
                            ),
                            Location::file(&scene.path)
                                .with_node(ra.path.clone())
                                .with_position(x.interior_point().to_array()),
                        )
                        .hint(format!(
                            "move the geometry of one room out of the other, give the nested room a higher `priority`, or add bound meshes (room `{}` is at `{}`)",
                            rb.name, rb.path
                        )),
                    );
                }
            }
        }
    }
    (found, regions)
}
