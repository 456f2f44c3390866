//! The room builder: one room's cells from whichever source gives its volume first (a bound
//! mesh, a footprint, a level-wide reading of solid blocks or generated rooms, else its
//! structure read as a prism or as a 3D interior), built for every room in parallel from what
//! the whole level shares. Also the room's props by the box rule and its degenerate cases (no
//! geometry, only floor, a floor whose walls have no height), each reported to the designer.
//!
//! The level-wide readings come first and are handed in ([`BlockCells`], [`GeneratedCells`]):
//! `block_rooms.rs` and `generated.rs` produce them and use the builder, never the reverse.

use std::collections::HashMap;

use glam::DVec3;
use rayon::prelude::*;

use super::footprint;
use super::gather::{canonical_triangles, node_triangles};
use super::interior;
use super::plan::Frame;
use super::prism;
use super::{Cell, CellSource, Gate, Prop, PropReason};
use crate::config::CellsConfig;
use crate::diag::{Code, Diagnostic, Location};
use crate::geom::aabb::Aabb;
use crate::geom::hull::{hull, HullError};
use crate::geom::polyhedron::ConvexPolyhedron;
use crate::scene::{NodeId, Scene};
use crate::tags::rules::VolumeHint;
use crate::tags::{Room, RoomId, Tagging};

/// The highest point of the level along up, over its vertices: the corners of the
/// world-axis box overshoot when the level is turned off its axes, which raised outdoor
/// footprints higher on a turned level (tests/metamorphic.rs, panda3d_culling).
pub(super) fn level_top(scene: &Scene, origin: DVec3, frame: &Frame) -> f64 {
    scene
        .walk()
        .into_par_iter()
        .map(|n| {
            scene
                .world_positions_used_iter(n)
                .map(|p| (p - origin).dot(frame.up))
                .fold(f64::NEG_INFINITY, f64::max)
        })
        .reduce(|| f64::NEG_INFINITY, f64::max)
}

/// The nodes that are no obstacle to a rising footprint, and the nodes that will be extruded:
/// what the footprint context needs to know before any room is built.
pub(super) fn footprint_nodes(
    scene: &Scene,
    tagging: &Tagging,
    origin: DVec3,
    frame: &Frame,
) -> (std::collections::HashSet<NodeId>, Vec<NodeId>) {
    // Structure of rooms made only of floor: extruded like footprints (see `floor_only`).
    let floors: Vec<NodeId> = tagging
        .rooms
        .par_iter()
        .filter(|r| r.bounds.is_empty() && r.footprints.is_empty())
        .filter(|r| floor_only(&node_triangles(scene, &r.structure, origin), frame.up))
        .flat_map_iter(|r| r.structure.iter().copied())
        .collect();
    // Footprints (tagged, or rooms made only of floor) are where cells start, not what they
    // rise to; portals, bounds and ignored nodes block nothing.
    let skip: std::collections::HashSet<NodeId> = tagging
        .footprints
        .iter()
        .map(|f| f.node)
        .chain(floors.iter().copied())
        .chain(tagging.portals.iter().map(|p| p.node))
        .chain(tagging.bounds.iter().map(|b| b.node))
        .chain(tagging.ignored.iter().map(|n| n.node))
        .collect();
    let extruded: Vec<NodeId> = tagging
        .footprints
        .iter()
        .map(|f| f.node)
        .chain(floors.iter().copied())
        .collect();
    (skip, extruded)
}

/// What building any one room reads, shared by every room built in parallel.
pub(super) struct RoomBuilder<'a> {
    pub(super) scene: &'a Scene,
    pub(super) cfg: &'a CellsConfig,
    pub(super) ctx: &'a footprint::Context<'a>,
    /// The level's centre: rooms are built about it and moved back at the end.
    pub(super) origin: DVec3,
    pub(super) eps: f64,
    /// The level's diagonal, what the prop test's touching distance is relative to.
    pub(super) extent: f64,
    pub(super) frame: Frame,
    /// Gaps narrower than this are cracks (m).
    pub(super) crack: f64,
    /// The cells of each room read as solid blocks (`None`: read otherwise), found for the
    /// whole level at once before any room is built.
    pub(super) blocks: Vec<Option<BlockCells>>,
    /// The cells of the rooms `--tags auto` generated, read once for all of them.
    pub(super) generated: Option<GeneratedCells>,
    /// What a room's structure is read as: when rooms were generated, the one room read from
    /// its structure is the whole level (`interior::Scope::Level`).
    pub(super) scope: interior::Scope,
}

/// One room's cells from the level-wide reading of solid blocks (`block_rooms.rs`).
pub(super) struct BlockCells {
    pub(super) polys: Vec<(ConvexPolyhedron, Vec<Gate>)>,
    pub(super) source: CellSource,
    pub(super) props: Vec<Prop>,
    pub(super) diags: Vec<Diagnostic>,
}

/// The generated rooms' cells (recentred) by generated room, and what reading the level found
/// (`generated.rs`).
pub(super) struct GeneratedCells {
    pub(super) first_room: usize,
    pub(super) per_room: Vec<Vec<(ConvexPolyhedron, CellSource)>>,
    pub(super) props: Vec<Prop>,
    pub(super) diags: Vec<Diagnostic>,
}

impl GeneratedCells {
    /// Room `ri`'s cells, if the generator made the room.
    pub(super) fn of(&self, ri: usize) -> Option<&[(ConvexPolyhedron, CellSource)]> {
        let k = ri.checked_sub(self.first_room)?;
        self.per_room.get(k).map(Vec::as_slice)
    }
}

impl RoomBuilder<'_> {
    pub(super) fn loc(&self, n: NodeId) -> Location {
        Location::file(&self.scene.path)
            .with_source(self.scene.nodes[n].source.clone())
            .with_node(self.scene.node_path(n))
    }

    /// Room `ri`'s cells, in world coordinates, from whichever source gives its volume first:
    /// bounds, then footprints, then its structure.
    pub(super) fn room(&self, ri: RoomId, room: &Room) -> RoomCells {
        let mut diags: Vec<Diagnostic> = Vec::new();
        let mut props: Vec<Prop> = Vec::new();
        let mut cells: Vec<Cell> = Vec::new();
        let mut polys: Vec<(ConvexPolyhedron, CellSource)> = Vec::new();
        // The gates of each of `polys` (only a block room has any).
        let mut gates: Vec<Vec<Gate>> = Vec::new();
        if let Some((g, made)) = (self.generated.as_ref()).and_then(|g| Some((g, g.of(ri)?))) {
            polys.extend(made.iter().cloned());
            if ri == g.first_room {
                props.extend(g.props.iter().copied());
                diags.extend(g.diags.iter().cloned());
            }
        } else if !room.bounds.is_empty() {
            self.bound_polys(room, &mut polys, &mut diags);
        } else if room.volume == VolumeHint::Footprint || !room.footprints.is_empty() {
            self.extrude_all(room, &room.footprints, "footprint", &mut polys, &mut diags);
        } else {
            self.structure_polys(ri, room, &mut polys, &mut gates, &mut props, &mut diags);
        }
        gates.resize(polys.len(), Vec::new());
        for ((p, source), gates) in polys.into_iter().zip(gates) {
            let world = p.translated(self.origin);
            let volume = world.volume();
            if world.faces.len() > self.cfg.max_planes {
                diags.push(
                    Diagnostic::new(
                        Code::CELL_TOO_MANY_PLANES,
                        format!(
                            "a cell of room `{}` has {} planes (more than {})",
                            room.name,
                            world.faces.len(),
                            self.cfg.max_planes
                        ),
                        self.loc(room.node).with_position(world.interior_point().to_array()),
                    )
                    .hint("simplify the room's outline or give it a simpler bound mesh; raise [cells] max_planes if the engine copes"),
                );
            }
            cells.push(Cell {
                room: ri,
                source,
                bounds: world.bounds(),
                poly: world,
                volume,
                nodes: Vec::new(),
                gates,
            });
        }
        RoomCells {
            cells,
            diags,
            props,
        }
    }

    /// One cell per bound mesh, its convex hull; a bound that is not convex is reported,
    /// since the hull then claims more than the mesh drew.
    fn bound_polys(
        &self,
        room: &Room,
        polys: &mut Vec<(ConvexPolyhedron, CellSource)>,
        diags: &mut Vec<Diagnostic>,
    ) {
        let (scene, origin, eps) = (self.scene, self.origin, self.eps);
        for &b in &room.bounds {
            let tris = node_triangles(scene, &[b], origin);
            let pts: Vec<DVec3> = tris.iter().flatten().copied().collect();
            match hull(&pts, eps) {
                Ok(h) => {
                    if let Some(bad) = tris
                        .iter()
                        .position(|t| !on_hull_boundary(&h, t, BOUND_SLACK * eps))
                    {
                        let c = (tris[bad][0] + tris[bad][1] + tris[bad][2]) / 3.0 + origin;
                        diags.push(
                            Diagnostic::new(
                                Code::CELL_BOUND_NOT_CONVEX,
                                format!(
                                    "bound mesh `{}` of room `{}` is not convex; its convex hull is used",
                                    scene.node_label(b),
                                    room.name
                                ),
                                self.loc(b).with_position(c.to_array()),
                            )
                            .hint("model the bound as a convex mesh, or split it into several convex bound meshes"),
                        );
                    }
                    polys.push((h, CellSource::Bound));
                }
                Err(e) => diags.push(degenerate(scene, room.name.as_str(), b, &e, &|n| {
                    self.loc(n)
                })),
            }
        }
    }

    /// Extrudes each of `nodes` (the room's footprints or floors, called `what` in what is
    /// reported) upward into cells.
    fn extrude_all(
        &self,
        room: &Room,
        nodes: &[NodeId],
        what: &str,
        polys: &mut Vec<(ConvexPolyhedron, CellSource)>,
        diags: &mut Vec<Diagnostic>,
    ) {
        let scene = self.scene;
        for &f in nodes {
            match self
                .ctx
                .extrude(f, footprint::extras_height(scene, &[f, room.node]))
            {
                Ok(ps) => polys.extend(ps.into_iter().map(|p| (p, CellSource::Footprint))),
                Err(msg) => diags.push(
                    Diagnostic::new(
                        Code::CELL_ROOM_DEGENERATE,
                        format!(
                            "{what} `{}` of room `{}`: {msg}",
                            scene.node_label(f),
                            room.name
                        ),
                        self.loc(f),
                    )
                    .hint("a footprint must be a floor polygon with area, not vertical"),
                ),
            }
        }
    }

    /// The cells of the air the room's structure encloses (props set aside first): its hull
    /// when convex, else its convex pieces; a room of only floor is extruded instead.
    fn structure_polys(
        &self,
        ri: RoomId,
        room: &Room,
        polys: &mut Vec<(ConvexPolyhedron, CellSource)>,
        gates: &mut Vec<Vec<Gate>>,
        props: &mut Vec<Prop>,
        diags: &mut Vec<Diagnostic>,
    ) {
        let out = (polys, gates, props, diags);
        self.structure_polys_with(ri, room, &[], out);
    }

    /// [`Self::structure_polys`], with `extra` surfaces (recentred, facing the air) read as
    /// part of the structure: the open faces of tagged cells, which generated cells end on.
    pub(super) fn structure_polys_with(
        &self,
        ri: RoomId,
        room: &Room,
        extra: &[[DVec3; 3]],
        (polys, gates, props, diags): StructureOut,
    ) {
        if let Some(bc) = self.blocks.get(ri).and_then(Option::as_ref) {
            for (c, g) in &bc.polys {
                polys.push((c.clone(), bc.source));
                gates.push(g.clone());
            }
            props.extend(bc.props.iter().copied());
            diags.extend(bc.diags.iter().cloned());
            return;
        }
        let (scene, origin, eps, frame) = (self.scene, self.origin, self.eps, &self.frame);
        let mut structure: Vec<NodeId> = room.structure.clone();
        if self.cfg.detect_props && structure.len() >= 2 {
            let mut found = detect_props(scene, &structure, origin, self.extent, frame);
            found.retain(|&n| !extras_flag(scene, n, "structure"));
            structure.retain(|n| !found.contains(n));
            props.extend(found.into_iter().map(|node| Prop {
                node,
                reason: PropReason::LooseInRoom,
            }));
        }
        if structure.is_empty() {
            diags.push(
                Diagnostic::new(
                    Code::CELL_ROOM_EMPTY,
                    format!("room `{}` has no geometry, bound or footprint to give it a volume", room.name),
                    self.loc(room.node),
                )
                .hint("put the room's floor, walls and ceiling under the room node, or add a bound mesh"),
            );
            return;
        }
        let mut tris = canonical_triangles(scene, &structure, origin);
        tris.extend_from_slice(extra);
        if floor_only(&tris, frame.up) && walls_of_no_height(&tris, eps) {
            diags.push(
                Diagnostic::new(
                    Code::CELL_ROOM_ZERO_HEIGHT,
                    format!(
                        "room `{}` is a floor whose walls have no height (a closed door or a lift at rest: floor and ceiling at one height); it has no air, so no cell",
                        room.name
                    ),
                    self.loc(room.node).with_position((mean(tris.iter().flatten()) + origin).to_array()),
                )
                .hint("nothing to do for a closed door; if the room has air, give its walls their height"),
            );
            return;
        }
        if floor_only(&tris, frame.up) {
            // Only floor (no wall, no ceiling): the room is its footprint, as Panda3D's
            // `cellN` meshes are even without the panda3d preset.
            diags.push(
                Diagnostic::new(
                    Code::CELL_ROOM_FROM_FLOOR,
                    format!(
                        "room `{}` has only upward-facing geometry; it was extruded upward as a footprint",
                        room.name
                    ),
                    self.loc(room.node).with_position((mean(tris.iter().flatten()) + origin).to_array()),
                )
                .hint("tag the floor as a footprint (extras `\"footprint\"`, or --tags panda3d for cellN) to say so"),
            );
            self.extrude_all(room, &structure, "floor", polys, diags);
            return;
        }
        let pts: Vec<DVec3> = tris.iter().flatten().copied().collect();
        match hull(&pts, eps) {
            Ok(h) => {
                let cells = prism::cells(&tris, &h, eps, frame)
                    .unwrap_or_else(|| interior::decompose(&tris, &h, eps, self.scope));
                let source = if cells.len() == 1 && cells[0] == h {
                    CellSource::Hull
                } else {
                    CellSource::Split
                };
                polys.extend(cells.into_iter().map(|c| (c, source)));
            }
            Err(e) => {
                let mut d = degenerate(scene, room.name.as_str(), room.node, &e, &|n| self.loc(n));
                if !pts.is_empty() {
                    d.location.position = Some((mean(pts.iter()) + origin).to_array());
                }
                diags.push(d)
            }
        }
    }
}

/// Whether a node's extras set `key` (`"solid"`, `"structure"`) to a true flag, spelt any way
/// the tags schema allows (`true`, `1`, `"yes"`, under `portcullis` or not).
pub(super) fn extras_flag(scene: &Scene, n: NodeId, key: &str) -> bool {
    crate::tags::extras::read_bool(scene.nodes[n].extras.as_ref(), key).unwrap_or(false)
}

/// Where [`RoomBuilder::structure_polys`] puts what it finds: cells, each cell's gates, props,
/// diagnostics.
pub(super) type StructureOut<'o> = (
    &'o mut Vec<(ConvexPolyhedron, CellSource)>,
    &'o mut Vec<Vec<Gate>>,
    &'o mut Vec<Prop>,
    &'o mut Vec<Diagnostic>,
);

/// One room's cells, with what building them reported and the props found in it.
pub(super) struct RoomCells {
    pub(super) cells: Vec<Cell>,
    pub(super) diags: Vec<Diagnostic>,
    pub(super) props: Vec<Prop>,
}

/// The mean of some points (the origin for none), for diagnostic positions.
fn mean<'a>(pts: impl Iterator<Item = &'a DVec3>) -> DVec3 {
    let (sum, n) = pts.fold((DVec3::ZERO, 0usize), |(s, n), p| (s + *p, n + 1));
    sum / n.max(1) as f64
}

fn degenerate(
    scene: &Scene,
    room: &str,
    node: NodeId,
    e: &HullError,
    loc: &dyn Fn(NodeId) -> Location,
) -> Diagnostic {
    Diagnostic::new(
        Code::CELL_ROOM_DEGENERATE,
        format!("room `{room}` (`{}`) has no volume: {e}", scene.node_label(node)),
        loc(node),
    )
    .hint("a room needs geometry in three dimensions (walls, not only a floor); tag flat floors as footprints")
}

/// Whether every triangle with area faces up: a floor, a ramp or stairs treads, no walls.
fn floor_only(tris: &[[DVec3; 3]], up: DVec3) -> bool {
    let mut any = false;
    for t in tris {
        let n = (t[1] - t[0]).cross(t[2] - t[0]);
        let len = n.length();
        if len <= 0.0 {
            continue;
        }
        if n.dot(up) / len < 0.05 {
            return false;
        }
        any = true;
    }
    any
}

/// Whether a floor's outline has walls of no height: zero-area triangles along its edges, as
/// a Doom sector whose floor and ceiling meet (a closed door, a lift at rest) is written, its
/// one-sided lines walls from the floor to a ceiling at the floor's height. Such a room has
/// no air; a floor alone (Panda3D's footprints) has no walls and is extruded.
fn walls_of_no_height(tris: &[[DVec3; 3]], eps: f64) -> bool {
    let corners: Vec<DVec3> = tris.iter().flatten().copied().collect();
    let welded = crate::geom::weld::weld(&corners, eps);
    let key = |p: DVec3| [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()];
    let edge = |a: DVec3, b: DVec3| {
        let (ka, kb) = (key(a), key(b));
        if ka < kb {
            (ka, kb)
        } else {
            (kb, ka)
        }
    };
    let mut floor: HashMap<([u64; 3], [u64; 3]), (usize, f64)> = HashMap::new();
    // Edges of the walls of no height.
    let mut flat: std::collections::HashSet<([u64; 3], [u64; 3])> = Default::default();
    for t in welded.chunks_exact(3) {
        let area2 = (t[1] - t[0]).cross(t[2] - t[0]).length();
        let longest = (0..3)
            .map(|i| t[i].distance(t[(i + 1) % 3]))
            .fold(0.0, f64::max);
        if area2 > eps * longest {
            for i in 0..3 {
                let (a, b) = (t[i], t[(i + 1) % 3]);
                floor.entry(edge(a, b)).or_insert((0, a.distance(b))).0 += 1;
            }
        } else {
            for i in 0..3 {
                let (a, b) = (t[i], t[(i + 1) % 3]);
                if key(a) != key(b) {
                    flat.insert(edge(a, b));
                }
            }
        }
    }
    floor
        .iter()
        .any(|(e, (count, len))| *count == 1 && *len > eps && flat.contains(e))
}

/// How far, in tolerances, a bound mesh's triangle may lie off its hull's face and still be on
/// it: the hull's planes are fitted through points each good to the tolerance, so a large face
/// tilts by a few tolerances across its width, and a bound off by that much is convex as drawn.
const BOUND_SLACK: f64 = 10.0;

/// Whether a triangle lies on one face of the hull.
fn on_hull_boundary(h: &ConvexPolyhedron, t: &[DVec3; 3], eps: f64) -> bool {
    h.faces
        .iter()
        .any(|f| t.iter().all(|p| f.plane.distance(*p).abs() <= eps))
}

/// A mesh within this fraction of the level's diagonal of a side of the box around the rest
/// of its room touches that side: a wall modelled a hair short of the floor still stands on it,
/// whatever the level's unit.
const PROP_TOUCH: f64 = 1e-4;

/// The least diagonal [`PROP_TOUCH`] is a fraction of (a millimetre in metres), so a level of
/// no size still has a touching distance.
const LEAST_EXTENT: f64 = 1e-3;

/// Room meshes that touch fewer than two sides of the box around the rest of the room: a
/// crate on the floor touches one, a lamp none, a wall at least two.
///
/// The boxes are taken in the level's frame (plan axes and up), not in world axes: a wall
/// standing on the floor reaches the room's bottom and top along up whichever way the level is
/// turned, while world-axis boxes of a level turned off its axes made walls look like props and
/// changed its cells (found by tests/metamorphic.rs on lportal_tutorial_simple).
pub(super) fn detect_props(
    scene: &Scene,
    structure: &[NodeId],
    origin: DVec3,
    extent: f64,
    frame: &Frame,
) -> Vec<NodeId> {
    let boxes: Vec<Aabb> = structure
        .iter()
        .map(|&n| {
            let mut b = Aabb::EMPTY;
            for p in scene.world_positions_used_iter(n) {
                let q = p - origin;
                b.add(DVec3::new(q.dot(frame.u), q.dot(frame.up), q.dot(frame.v)));
            }
            b
        })
        .collect();
    let touch = PROP_TOUCH * extent.max(LEAST_EXTENT);
    // The union of every box but one, from the unions before and after it (linear, not all
    // pairs: a brush map's one room has thousands of nodes).
    let mut after = vec![Aabb::EMPTY; boxes.len() + 1];
    for i in (0..boxes.len()).rev() {
        after[i] = after[i + 1].union(&boxes[i]);
    }
    let mut before = Aabb::EMPTY;
    let mut props = Vec::new();
    for (i, &n) in structure.iter().enumerate() {
        let others = before.union(&after[i + 1]);
        before = before.union(&boxes[i]);
        let b = &boxes[i];
        if others.is_empty() || b.is_empty() {
            continue;
        }
        let sides = [
            b.min.x <= others.min.x + touch,
            b.max.x >= others.max.x - touch,
            b.min.y <= others.min.y + touch,
            b.max.y >= others.max.y - touch,
            b.min.z <= others.min.z + touch,
            b.max.z >= others.max.z - touch,
        ];
        if sides.iter().filter(|s| **s).count() < 2 {
            props.push(n);
        }
    }
    // Never call everything a prop.
    if props.len() == structure.len() {
        props.clear();
    }
    props
}
