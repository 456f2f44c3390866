//! Portals: the openings between cells, merged with the portals designers authored.
//!
//! Derived portals come first (`derive.rs`): for two cells whose faces are coplanar with
//! opposite normals — or parallel and at most `max_wall_thickness` apart, facing each other
//! across a wall — the shared region of the two faces, minus every opaque triangle on that
//! plane (or inside the wall slab), is an opening; each opening becomes convex portal polygons.
//! What is left of a cell face that no other cell shares and no geometry covers is an exterior
//! opening. Authored portals (`authored.rs`) are then linked to the derived portal they cover
//! and lend it their name, kind and flags; mirrors and teleporters get their transforms.
//!
//! Invariants of [`PortalSet`]: a portal's polygon is convex and planar, counter-clockwise seen
//! from its source cell (its Newell normal points back into the source; `normal` is the
//! direction of travel); every two-way portal has a partner with the same polygon reversed and
//! the cells swapped, and partners point at each other; a transform is present only when it is
//! not the identity, and a partner's transform is the inverse.

use glam::{DMat4, DVec3};
use serde::Serialize;

use crate::cells::CellSet;
use crate::config::PortalsConfig;
use crate::diag::{Code, Diagnostic, Diagnostics, Location};
use crate::scene::{NodeId, Scene};
use crate::tags::rules::PortalKind;
use crate::tags::Tagging;

mod authored;
mod derive;
pub mod loops;
mod opaque;
pub use opaque::blocking_triangles;

/// A convex opening from one cell into another (or the outside), one way.
#[derive(Debug, Clone, Serialize)]
pub struct Portal {
    /// Source cell.
    pub from: usize,
    /// Target cell; `None` for an opening to the exterior.
    pub to: Option<usize>,
    /// Counter-clockwise seen from the source cell.
    pub polygon: Vec<DVec3>,
    /// Unit direction of travel, from the source into the target.
    pub normal: DVec3,
    /// Square metres.
    pub area: f64,
    /// Plain opening, mirror or teleporter.
    pub kind: PortalKind,
    /// Sight passes from `from` to `to` only; no partner the other way.
    pub one_way: bool,
    /// A closed door: passes nothing until the runtime opens it.
    pub closed: bool,
    /// A door's opening (a gate of kind door, see `cells::Gate`): the runtime closes it when
    /// the door, its `authored` node, closes; open unless `closed`.
    pub door: bool,
    /// Between two cells of one room (a split room's cells are joined by these).
    pub internal: bool,
    /// Maps the source side's space to the target side's (mirrors, teleporters).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub transform: Option<DMat4>,
    /// The authored portal node this portal carries, if any.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub authored: Option<NodeId>,
    /// The portal back the other way.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub partner: Option<usize>,
}

impl Portal {
    /// A plain (untransformed, open, two-way unless unpartnered) portal as derivation makes it.
    pub(crate) fn plain(
        from: usize,
        to: Option<usize>,
        polygon: Vec<DVec3>,
        normal: DVec3,
        area: f64,
        internal: bool,
        partner: Option<usize>,
    ) -> Portal {
        Portal {
            from,
            to,
            polygon,
            normal,
            area,
            kind: PortalKind::Plain,
            one_way: false,
            closed: false,
            door: false,
            internal,
            transform: None,
            authored: None,
            partner,
        }
    }
}

/// The portals stage's output: every portal between the cells, and what it reported.
#[derive(Debug, Clone, Default, Serialize)]
pub struct PortalSet {
    /// All portals; a portal's index is its id in the vis graph and the annotation.
    pub portals: Vec<Portal>,
    /// What the portals stage reported (unmatched, misplaced, non-convex portals).
    #[serde(skip)]
    pub diagnostics: Diagnostics,
    /// Each cell's place in an order that does not depend on the order the rooms were listed
    /// in (by room name; see `derive::name_rank`), for steps that must break ties without the
    /// cells' numbers (the PVS flow's waves). Empty when not known (a stored annotation).
    #[serde(skip)]
    pub cell_rank: Vec<u32>,
    /// The gaps between blockers narrower than the crack width that were closed: no portal.
    pub closed: crate::geom::crack::ClosedGaps,
}

impl PortalSet {
    /// Portals between two different cells, each pair counted once.
    pub fn pairs(&self) -> impl Iterator<Item = (usize, usize)> + '_ {
        self.portals
            .iter()
            .enumerate()
            .filter_map(|(i, p)| p.partner.filter(|&j| i < j).map(|j| (i, j)))
    }
}

/// Derives and links the portals of a level.
pub fn build(scene: &Scene, tagging: &Tagging, cells: &CellSet, cfg: &PortalsConfig) -> PortalSet {
    let mut set = PortalSet {
        cell_rank: derive::name_rank(cells, tagging),
        ..Default::default()
    };
    derive::derive(scene, tagging, cells, cfg, &mut set);
    authored::link(scene, tagging, cells, cfg, &mut set);
    lend_gates(cells, &mut set);
    if let Some(d) = cracks_closed(scene, cells, &set) {
        set.diagnostics.push(d);
    }
    set
}

/// `CRACKS_CLOSED`: what the crack width closed, among blocks and between the blockers of
/// openings, with the widest gap and where it is. A level modelled at the wrong scale, or a
/// crack width set too wide, loses openings as cracks; this says how many and how wide.
fn cracks_closed(scene: &Scene, cells: &CellSet, set: &PortalSet) -> Option<Diagnostic> {
    let all = cells.closed.merged(&set.closed);
    let (widest, at) = all.widest?;
    // Millimetres to three significant digits, however small.
    let mm = |m: f64| {
        let mm = m * 1e3;
        if mm == 0.0 || !mm.is_finite() {
            return format!("{mm} mm");
        }
        let digits = 2i32
            .saturating_sub(mm.abs().log10().floor() as i32)
            .clamp(0, 12) as usize;
        format!("{mm:.digits$} mm")
    };
    Some(
        Diagnostic::new(
            Code::CRACKS_CLOSED,
            format!(
                "the crack width ({}) closed {} gap(s) narrower than it ({} among solid blocks, {} between the blockers of openings); the widest, {} across, is here",
                crack_named(cells.crack, derive::NOISE_WIDTH * cells.tolerance.distance, mm),
                all.count,
                cells.closed.count,
                set.closed.count,
                mm(widest)
            ),
            Location::file(&scene.path).with_position(at.to_array()),
        )
        .hint("nothing to do if these are cracks; if one is an opening, the level's scale is off (a level modelled at a thousandth of its size turns doorways into cracks: scale it, or set [import] map_scale for a brush map) or [cells] crack_width is too wide"),
    )
}

/// The width that closed gaps: the crack width, or the float-noise floor of ten tolerances
/// under which no opening is kept (`portals/derive.rs`, `Limits`) where that is wider, so a
/// zero crack width does not read as closing a gap wider than itself.
fn crack_named(crack: f64, noise: f64, mm: impl Fn(f64) -> String) -> String {
    if crack >= noise {
        mm(crack)
    } else {
        format!("{}, raised to ten tolerances, {}", mm(crack), mm(noise))
    }
}

/// A portal on the boundary of a gate's volume (in a cell of the gate on one side only) is
/// the gate's: it takes the gate's node, unless authored otherwise, and a door's flag.
fn lend_gates(cells: &CellSet, set: &mut PortalSet) {
    for p in &mut set.portals {
        let inside = |c: Option<usize>| c.map_or(&[][..], |c| &cells.cells[c].gates[..]);
        let (a, b) = (inside(Some(p.from)), inside(p.to));
        let Some(g) = a
            .iter()
            .filter(|g| !b.contains(g))
            .chain(b.iter().filter(|g| !a.contains(g)))
            .min_by_key(|g| g.node)
        else {
            continue;
        };
        p.authored = p.authored.or(Some(g.node));
        p.door = a
            .iter()
            .chain(b)
            .any(|g| g.kind == crate::cells::GateKind::Door && (a.contains(g) != b.contains(g)));
    }
}

/// Reverses a portal polygon (the partner's view).
pub(crate) fn reversed(poly: &[DVec3]) -> Vec<DVec3> {
    let mut p = poly.to_vec();
    p.reverse();
    p
}
