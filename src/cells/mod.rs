//! Cells: tagged rooms become convex polyhedra.
//!
//! A room's volume comes from, in order: its bound meshes (each one cell, their convex hull);
//! its footprints (floor polygons extruded along up); the air its structural surface encloses:
//! for a room that is a prism along up, its floor plan's convex pieces (`prism`), else a 3D
//! decomposition into convex cells (`interior`: a BSP over the room's own planes, leaves
//! classified by the surface, air leaves merged into maximal convex unions). A convex room is
//! its hull, one cell; an L is 2, a U 3, a ring around a pillar 4, a soffit hall 2, a four-step
//! stair hall 4, and no cell reaches into the solid under a platform or inside a slab.
//!
//! All geometry is computed about the level's centre (recentred) and moved back at the end, so
//! a level 100 km from the origin gets the same cells as one at the origin.
//!
//! Invariants of [`CellSet`]: every cell is convex with outward planes and at least four faces;
//! the cells of one room do not overlap; `room_cells[r]` lists room `r`'s cells in order.
//!
//! A room built of solid blocks (closed, outward-facing meshes: slabs, CSG boxes, brushes, kit
//! pieces) is the air around them (`solids.rs` finds them and the props among them, `blocks.rs`
//! keeps the inside of what they enclose), tried before the surface reading below; a room whose
//! only mesh is one closed outward mesh stays the volume it models unless tagged `solid`.
//!
//! Room meshes touching fewer than two sides of the box around the rest of the room are props (a
//! crate, a lamp): rendered by the cell containing them, never shaping it. Footprints
//! (`footprint.rs`): each planar part partitioned into convex pieces, every piece vertex raised to
//! the geometry above it by a ray cast against the level, or to the level's top outdoors. Triangles
//! are taken in an order fixed by node path and vertex indices, so shuffling nodes or triangles
//! breaks no tie differently. Rooms are built in parallel and their cells numbered in room order
//! afterwards, so the result does not depend on the thread count.
//!
//! `overlap.rs` reports cells of different rooms of equal priority that overlap (pairs from a grid
//! over their boxes in the order of their numbers, never all pairs); it and `assign.rs` only read
//! the cells, so they run side by side and their findings are applied in a fixed order. `assign.rs`
//! (rooms in parallel, joined in room order) lists for each cell the nodes it renders and reports
//! geometry in no cell; `split.rs` (`--split-geometry`) cuts meshes listed by several cells along
//! the cell planes, a part on a shared face going to the cell it faces.
//!
//! Further invariants: the union of a room's cells is the room's air within the tolerance
//! (tests/cells_3d.rs holds this against rays cast at the room's own triangles and the divergence
//! theorem); a cell never carries a plane its shape does not need. A thick wall is bridged only
//! where no other cell lies in the gap (a reveal cell already joins the two sides).

use std::collections::{BTreeMap, HashMap};

use glam::{DVec2, DVec3};
use rayon::prelude::*;
use serde::Serialize;

use crate::config::CellsConfig;
use crate::diag::{Code, Diagnostic, Diagnostics, Location};
use crate::geom::aabb::Aabb;
use crate::geom::exact::ExactVertices;
use crate::geom::grid::BoxGrid;
use crate::geom::hull::{hull, HullError};
use crate::geom::partition::{
    convex_partition, ring_mean_width, union_triangles, PartitionError, Polygon2,
};
use crate::geom::plane::Plane;
use crate::geom::polyhedron::ConvexPolyhedron;
use crate::geom::tolerance::Tolerance;
use crate::scene::{NodeId, Scene};
use crate::tags::rules::VolumeHint;
use crate::tags::{Room, RoomId, Tagging};

mod air;
mod assign;
pub use assign::drop_far_structure;
mod areas;
pub use areas::split as split_areas;
mod block_rooms;
use block_rooms::BlockCells;
mod blocks;
mod bsp;
pub mod draws;
mod footprint;
mod generated;
mod interior;
mod overlap;
pub use overlap::Overlap;
mod prism;
mod props;
mod solids;
pub(crate) mod split;

pub use split::{split_geometry, SplitPiece};

/// Where a cell's volume came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum CellSource {
    /// The convex hull of the room's structure (the room is convex).
    Hull,
    /// A convex piece of a non-convex room's interior.
    Split,
    /// A bound mesh.
    Bound,
    /// An extruded footprint.
    Footprint,
}

/// What a gate is: a volume of air something can close (see `blocks`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum GateKind {
    /// A door's or a lift's brush (extras `"door": true`; a brush map's `func_door*`,
    /// `func_plat`): its portals start open and close when the door does.
    Door,
    /// An area portal (extras `"area_portal": true`; a Quake 2 `func_areaportal`, an id Tech 4
    /// visportal or Quake 3 areaportal brush): the designer's portal between two areas.
    AreaPortal,
}

/// A gate a cell lies in: the node that closes it and what it is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize)]
pub struct Gate {
    /// The gate's node: the door's (or area portal's) block, or for a door of several blocks
    /// (a brush entity's brushes, which share extras `entity`) the first of them, so the air
    /// of one door is one gate whose cells merge across its blocks.
    pub node: NodeId,
    /// Door or area portal.
    pub kind: GateKind,
}

/// Why a room mesh was taken for a prop: it is rendered by the cell around it but does not
/// shape cells. Extras `"structure": true` or `[cells] detect_props = false` keeps it in.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum PropReason {
    /// It touches fewer than two sides of the box around the rest of the room (a crate on the
    /// floor touches one, a lamp none).
    LooseInRoom,
    /// A solid block nothing holds (not pressed between two structural blocks from opposite
    /// sides, not spanning two that do not touch) and that separates no air: a crate on the
    /// floor, a stack of crates, a shelf on a wall, a crate pushed into a wall.
    LooseBlock,
}

impl PropReason {
    /// In words, for reports.
    pub fn describe(self) -> &'static str {
        match self {
            PropReason::LooseInRoom => {
                "touches fewer than two sides of the box around the rest of the room"
            }
            PropReason::LooseBlock => {
                "a solid block nothing holds (not pressed between two blocks from opposite sides, not spanning two) that separates no air"
            }
        }
    }
}

/// One convex cell of a room: what the runtime locates the eye in and portals join.
#[derive(Debug, Clone, Serialize)]
pub struct Cell {
    /// The room (index into the tagging's rooms) the cell belongs to.
    pub room: RoomId,
    /// What the cell's volume was built from.
    pub source: CellSource,
    /// World coordinates.
    pub poly: ConvexPolyhedron,
    /// Cubic metres.
    pub volume: f64,
    /// World-space bounding box of `poly`.
    pub bounds: Aabb,
    /// Nodes this cell renders: structure that intersects it, props and loose geometry inside.
    pub nodes: Vec<NodeId>,
    /// The gates (doors, area portals) whose volume this cell lies in; its portals are theirs.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub gates: Vec<Gate>,
}

/// The cells stage's output: every room's convex cells and what building them reported.
#[derive(Debug, Clone, Serialize)]
pub struct CellSet {
    /// All cells; a cell's index is its id in portals, the PVS and the annotation.
    pub cells: Vec<Cell>,
    /// For each room of the tagging, its cells.
    pub room_cells: Vec<Vec<usize>>,
    /// The distance and angle tolerances the cells were built with (from the input's precision).
    pub tolerance: Tolerance,
    /// Room meshes recognised as props (they do not shape cells).
    pub props: Vec<NodeId>,
    /// Why each of `props` is one, in the same order (what `inspect` shows the designer, who
    /// can override it with a tag).
    pub prop_reasons: Vec<PropReason>,
    /// Where cells of different rooms overlapped before one was cut around the other (those
    /// of equal priority reported as `CELL_OVERLAP`).
    pub overlaps: Vec<Overlap>,
    /// The crack width (m): gaps narrower than this were closed here, and are not openings
    /// to the portal stage either (`[cells] crack_width`, else the format's).
    pub crack: f64,
    /// Occupants standing inside a solid block: they seed nothing (qbsp skips them too).
    pub buried: Vec<NodeId>,
    /// The gaps among solid blocks the crack width closed.
    pub closed: crate::geom::crack::ClosedGaps,
    /// Every room was read as solid blocks (as qbsp reads a brush map, in any format): what
    /// no cell holds is solid, or void an occupant's fill or a sealed region's reading left
    /// out, so geometry there borders no cell's air.
    #[serde(skip)]
    pub solid_beyond: bool,
    /// What the cells stage reported (overlaps, unplaced geometry, degenerate rooms).
    #[serde(skip)]
    pub diagnostics: Diagnostics,
}

impl CellSet {
    /// A grid over the cells' bounds, and every pair of cells within `pad` of each other, in
    /// the order of their indices (the lower first). The overlap check and portal derivation
    /// number what they find in this order; cells are numbered by room and input order, so a
    /// level moved or turned gets the same numbers (a sweep along world x, as before, put the
    /// pairs of a turned level in another order and renumbered its portals).
    pub(crate) fn pairs_in_order(&self, pad: f64) -> (BoxGrid, Vec<(usize, usize)>) {
        let grid = BoxGrid::new(self.cells.iter().map(|c| c.bounds).collect());
        let mut pairs: Vec<(usize, usize)> = grid
            .pairs(pad)
            .into_iter()
            .map(|(i, j)| (i.min(j), i.max(j)))
            .collect();
        pairs.sort_unstable();
        (grid, pairs)
    }
}

/// World-space triangles of a set of nodes, recentred by `-origin`.
pub(crate) fn node_triangles(scene: &Scene, nodes: &[NodeId], origin: DVec3) -> Vec<[DVec3; 3]> {
    let mut out = Vec::new();
    for &n in nodes {
        let node = &scene.nodes[n];
        let Some(m) = node.mesh else { continue };
        let mesh = &scene.meshes[m];
        let world: Vec<DVec3> = mesh
            .positions
            .iter()
            .map(|p| node.world.transform_point3(*p) - origin)
            .collect();
        let winding = scene.winding(n);
        for &t in &mesh.triangles {
            let t = winding.order(t);
            if let (Some(a), Some(b), Some(c)) = (
                world.get(t[0] as usize),
                world.get(t[1] as usize),
                world.get(t[2] as usize),
            ) {
                out.push([*a, *b, *c]);
            }
        }
    }
    out
}

/// A room's triangles in an order that does not depend on how the file lists them: nodes by
/// path (then mesh), each triangle started at its lowest vertex index, triangles by their
/// indices. Shuffling nodes or triangles, or rotating a triangle's corners, changes nothing
/// here, so the 3D decomposition breaks its ties the same way (tests/metamorphic.rs).
pub(crate) fn canonical_triangles(
    scene: &Scene,
    nodes: &[NodeId],
    origin: DVec3,
) -> Vec<[DVec3; 3]> {
    canonical_node_triangles(scene, nodes, origin)
        .into_iter()
        .flat_map(|(_, t)| t)
        .collect()
}

/// [`canonical_triangles`] node by node, nodes in the same canonical order.
pub(crate) fn canonical_node_triangles(
    scene: &Scene,
    nodes: &[NodeId],
    origin: DVec3,
) -> Vec<(NodeId, Vec<[DVec3; 3]>)> {
    let mut order: Vec<(String, usize, NodeId)> = nodes
        .iter()
        .map(|&n| {
            (
                scene.node_path(n),
                scene.nodes[n].mesh.unwrap_or(usize::MAX),
                n,
            )
        })
        .collect();
    order.sort();
    let mut out = Vec::new();
    for (_, _, n) in order {
        let node = &scene.nodes[n];
        let Some(m) = node.mesh else { continue };
        let mesh = &scene.meshes[m];
        let mut tris: Vec<[u32; 3]> = mesh
            .triangles
            .iter()
            .filter(|t| t.iter().all(|&i| (i as usize) < mesh.positions.len()))
            .map(|t| {
                let k = (0..3).min_by_key(|&k| t[k]).unwrap_or(0);
                [t[k], t[(k + 1) % 3], t[(k + 2) % 3]]
            })
            .collect();
        // Sorted as stored, then turned for a mirroring node: a mirrored instance lists its
        // triangles in the same order as the original, so its cells are the mirror image.
        tris.sort_unstable();
        let winding = scene.winding(n);
        out.push((
            n,
            tris.into_iter()
                .map(|t| winding.order(t))
                .map(|t| {
                    t.map(|i| node.world.transform_point3(mesh.positions[i as usize]) - origin)
                })
                .collect(),
        ));
    }
    out
}

/// The level's box, what its precision is measured from (the spacing of each node's stored
/// coordinates at their largest, times the node's world scale, its largest axis stretch), and
/// the largest world coordinate.
///
/// Per node, because that is where a file loses precision: an f32 mesh is good to its own
/// ulps wherever its node puts it, and an exactly representable translation (any the f64
/// world matrix holds) adds nothing but f64 rounding; a node scaled by 1e-3 makes its ulps a
/// thousand times finer.
fn level_frame(scene: &Scene) -> (Aabb, f64, f64) {
    // Per node on every thread: boxes and maxima combine exactly in any order.
    scene
        .walk()
        .into_par_iter()
        .map(|n| {
            let mut b = Aabb::EMPTY;
            for p in scene.world_positions_used_iter(n) {
                b.add(p);
            }
            let node = &scene.nodes[n];
            let mut stored: f64 = 0.0;
            if let Some(m) = node.mesh {
                for p in &scene.meshes[m].positions {
                    stored = stored.max(p.abs().max_element());
                }
            }
            let w = node.world;
            let stretch = [w.x_axis, w.y_axis, w.z_axis]
                .iter()
                .map(|c| c.truncate().length())
                .fold(0.0, f64::max);
            let world = if b.is_empty() {
                0.0
            } else {
                b.min.abs().max(b.max.abs()).max_element()
            };
            (b, scene.precision.spacing(stored) * stretch, world)
        })
        .reduce(
            || (Aabb::EMPTY, 0.0, 0.0),
            |(a, x, u), (b, y, v)| (a.union(&b), x.max(y), u.max(v)),
        )
}

/// The crack width: `[cells] crack_width`, else the format's own (a brush map's), else the
/// default. Gaps narrower than this are closed.
pub(crate) fn crack_width(cfg: &CellsConfig, scene: &Scene) -> f64 {
    cfg.crack_width
        .or(scene.crack_width)
        .unwrap_or(crate::config::DEFAULT_CRACK_WIDTH)
}

/// Builds the cells of every tagged room, with walls up to the default
/// `[portals] max_wall_thickness` thick (see [`build_reaching`]).
pub fn build(scene: &Scene, tagging: &Tagging, cfg: &CellsConfig) -> CellSet {
    let reach = crate::config::PortalsConfig::default().max_wall_thickness;
    build_reaching(scene, tagging, cfg, reach)
}

/// Builds the cells of every tagged room. Geometry in no cell that lies in a wall at most
/// `reach` thick, in front of a cell's face (a jamb in a door's reveal), is rendered by the
/// cells it faces.
pub fn build_reaching(scene: &Scene, tagging: &Tagging, cfg: &CellsConfig, reach: f64) -> CellSet {
    let (level, spacing, world_abs) = level_frame(scene);
    let extent = level.size().length();
    let steps = scene.precision.steps();
    let mut tol = Tolerance::derive(extent, spacing, steps, world_abs, cfg.max_tolerance);
    tol.distance *= cfg.tolerance_factor;
    let origin = if level.is_empty() {
        DVec3::ZERO
    } else {
        (level.min + level.max) * 0.5
    };
    let eps = tol.distance;
    let mut diags = Diagnostics::default();
    if tol.capped {
        diags.push(
            Diagnostic::new(
                Code::TOLERANCE_CAPPED,
                format!(
                    "the input's precision ({:.3e} m) is coarser than the largest tolerance allowed ({:.3e} m): its coordinates are stored {:.1e} m apart where they are largest, {:.0} m from the origin, so blocks and walls meant to meet may miss by that much, and leaks, overlapping cells and unreachable cells can come from rounding alone",
                    tol.input_precision, cfg.max_tolerance, spacing, world_abs
                ),
                Location::file(&scene.path),
            )
            .hint("keep the vertices near the origin: store the geometry near its node's origin and place it with the node's translation (a node transform keeps the precision), or store the coordinates nearer the origin; else raise [cells] max_tolerance"),
        );
    }
    let mut cells: Vec<Cell> = Vec::new();
    let mut room_cells = vec![Vec::new(); tagging.rooms.len()];
    let mut props = Vec::new();
    let mut prop_reasons = Vec::new();
    let frame = Frame::new(cfg.up);
    let top = level_top(scene, origin, &frame);
    let (skip, extruded) = footprint_nodes(scene, tagging, origin, &frame);
    let ctx = footprint::Context::new(scene, &skip, &extruded, origin, cfg, eps, (frame, top));
    let crack = crack_width(cfg, scene);
    let mut b = RoomBuilder {
        scene,
        cfg,
        ctx: &ctx,
        origin,
        eps,
        extent,
        frame,
        crack,
        blocks: Vec::new(),
        generated: None,
        reading: match tagging.generated.as_deref() {
            Some(g) => interior::Reading::Level {
                detail_area: g.detail_area,
                axes: g.axes.map(DVec3::from_array),
            },
            None => interior::Reading::Room,
        },
    };
    let (blocks, buried, gaps) = b.read_blocks(tagging, &mut diags);
    let solid_beyond = !blocks.is_empty() && blocks.iter().all(Option::is_some);
    b.blocks = blocks;
    // Rooms are built on their own, in parallel, and their cells numbered in room order
    // afterwards, so the result does not depend on the thread count. Tagged rooms come
    // first: the generated rooms' reading ends on their cells (`generated.rs`).
    let first_generated = tagging
        .generated
        .as_deref()
        .map_or(tagging.rooms.len(), |g| {
            g.first_room.min(tagging.rooms.len())
        });
    let (tagged, untagged) = tagging.rooms.split_at(first_generated);
    let mut built: Vec<RoomCells> = tagged
        .par_iter()
        .enumerate()
        .map(|(ri, room)| b.room(ri, room))
        .collect();
    let closed: Vec<(ConvexPolyhedron, RoomId)> = (built.iter().flat_map(|r| &r.cells))
        .map(|c| (c.poly.translated(-origin), c.room))
        .collect();
    b.generated = generated::build(&b, tagging, &closed);
    built.extend(
        untagged
            .par_iter()
            .enumerate()
            .map(|(k, room)| b.room(first_generated + k, room))
            .collect::<Vec<_>>(),
    );
    for (ri, room) in built.into_iter().enumerate() {
        for c in room.cells {
            room_cells[ri].push(cells.len());
            cells.push(c);
        }
        diags.extend(room.diags);
        for (n, why) in room.props {
            props.push(n);
            prop_reasons.push(why);
        }
    }
    let mut set = CellSet {
        cells,
        room_cells,
        tolerance: tol,
        props,
        prop_reasons,
        overlaps: Vec::new(),
        crack,
        closed: gaps.moved(origin),
        buried,
        solid_beyond,
        diagnostics: diags,
    };
    let took = overlap::resolve(scene, tagging, cfg, &mut set, origin);
    let (lists, outside) = assign::find(scene, tagging, &set, &took, reach);
    set.diagnostics.extend(outside);
    for (c, l) in set.cells.iter_mut().zip(lists) {
        c.nodes = l;
    }
    set
}

/// The highest point of the level along up, over its vertices: the corners of the
/// world-axis box overshoot when the level is turned off its axes, which raised outdoor
/// footprints higher on a turned level (tests/metamorphic.rs, panda3d_culling).
fn level_top(scene: &Scene, origin: DVec3, frame: &Frame) -> f64 {
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
fn footprint_nodes(
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
struct RoomBuilder<'a> {
    scene: &'a Scene,
    cfg: &'a CellsConfig,
    ctx: &'a footprint::Context<'a>,
    /// The level's centre: rooms are built about it and moved back at the end.
    origin: DVec3,
    eps: f64,
    /// The level's diagonal, what the prop test's touching distance is relative to.
    extent: f64,
    frame: Frame,
    /// Gaps narrower than this are cracks (m).
    crack: f64,
    /// The cells of each room read as solid blocks (`None`: read otherwise), found for the
    /// whole level at once before any room is built.
    blocks: Vec<Option<BlockCells>>,
    /// The cells of the rooms `--tags auto` generated, read once for all of them.
    generated: Option<generated::GeneratedCells>,
    /// How structure is read: when rooms were generated, the one room read from its structure
    /// is the whole level (`interior::Reading::Level`).
    reading: interior::Reading,
}

impl RoomBuilder<'_> {
    fn loc(&self, n: NodeId) -> Location {
        Location::file(&self.scene.path)
            .with_source(self.scene.nodes[n].source.clone())
            .with_node(self.scene.node_path(n))
    }

    /// Room `ri`'s cells, in world coordinates, from whichever source gives its volume first:
    /// bounds, then footprints, then its structure.
    fn room(&self, ri: RoomId, room: &Room) -> RoomCells {
        let mut diags: Vec<Diagnostic> = Vec::new();
        let mut props: Vec<(NodeId, PropReason)> = Vec::new();
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
                        .position(|t| !on_hull_boundary(&h, t, eps * 10.0))
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
        props: &mut Vec<(NodeId, PropReason)>,
        diags: &mut Vec<Diagnostic>,
    ) {
        let out = (polys, gates, props, diags);
        self.structure_polys_with(ri, room, &[], out);
    }

    /// [`Self::structure_polys`], with `extra` surfaces (recentred, facing the air) read as
    /// part of the structure: the open faces of tagged cells, which generated cells end on.
    fn structure_polys_with(
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
            props.extend(found.into_iter().map(|n| (n, PropReason::LooseInRoom)));
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
                    .unwrap_or_else(|| interior::decompose(&tris, &h, eps, self.reading));
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

impl RoomBuilder<'_> {
    /// A block room's gates: its detail and the nodes under it flagged `door` or `area_portal`
    /// in extras, each with its convex hull (recentred), in node order.
    fn gates(&self, room: &Room) -> (Vec<Gate>, Vec<ConvexPolyhedron>) {
        let scene = self.scene;
        let mut nodes: Vec<NodeId> = room.detail.clone();
        nodes.extend((0..scene.nodes.len()).filter(|&n| scene.nodes[n].parent == Some(room.node)));
        nodes.sort_unstable();
        nodes.dedup();
        let mut out = (Vec::new(), Vec::new());
        // The first node of each entity (extras `entity`, a brush map's entity number).
        let mut first: BTreeMap<String, NodeId> = BTreeMap::new();
        for n in nodes {
            let kind = if extras_flag(scene, n, "door") {
                GateKind::Door
            } else if extras_flag(scene, n, "area_portal") {
                GateKind::AreaPortal
            } else {
                continue;
            };
            let pts: Vec<DVec3> = node_triangles(scene, &[n], self.origin)
                .into_iter()
                .flatten()
                .collect();
            if let Ok(h) = hull(&pts, self.eps) {
                let entity = scene.nodes[n].extras.as_ref().and_then(|e| e.get("entity"));
                let node = match entity {
                    Some(e) => *first.entry(format!("{kind:?} {e}")).or_insert(n),
                    None => n,
                };
                out.0.push(Gate { node, kind });
                out.1.push(h);
            }
        }
        out
    }
}

/// Whether a node's extras set `key` (`"solid"`, `"structure"`) to a true flag, spelt any way
/// the tags schema allows (`true`, `1`, `"yes"`, under `portcullis` or not).
fn extras_flag(scene: &Scene, n: NodeId, key: &str) -> bool {
    crate::tags::extras::read_bool(scene.nodes[n].extras.as_ref(), key).unwrap_or(false)
}

/// Where [`RoomBuilder::structure_polys`] puts what it finds: cells, each cell's gates, props,
/// diagnostics.
type StructureOut<'o> = (
    &'o mut Vec<(ConvexPolyhedron, CellSource)>,
    &'o mut Vec<Vec<Gate>>,
    &'o mut Vec<(NodeId, PropReason)>,
    &'o mut Vec<Diagnostic>,
);

/// One room's cells, with what building them reported and the props found in it.
struct RoomCells {
    cells: Vec<Cell>,
    diags: Vec<Diagnostic>,
    props: Vec<(NodeId, PropReason)>,
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

/// Whether a triangle lies on one face of the hull.
fn on_hull_boundary(h: &ConvexPolyhedron, t: &[DVec3; 3], eps: f64) -> bool {
    h.faces
        .iter()
        .any(|f| t.iter().all(|p| f.plane.distance(*p).abs() <= eps))
}

/// Room meshes that touch fewer than two sides of the box around the rest of the room: a
/// crate on the floor touches one, a lamp none, a wall at least two.
///
/// The boxes are taken in the level's frame (plan axes and up), not in world axes: a wall
/// standing on the floor reaches the room's bottom and top along up whichever way the level is
/// turned, while world-axis boxes of a level turned off its axes made walls look like props and
/// changed its cells (found by tests/metamorphic.rs on lportal_tutorial_simple).
fn detect_props(
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
    let touch = 1e-4 * extent.max(1e-3);
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

/// The up direction and a ground-plane basis: plans are coordinates on (u, v).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Frame {
    pub up: DVec3,
    pub u: DVec3,
    pub v: DVec3,
}

impl Frame {
    pub fn new(up: [f64; 3]) -> Frame {
        let up = DVec3::from_array(up).try_normalize().unwrap_or(DVec3::Y);
        if (up - DVec3::Y).length() < 1e-12 {
            // Keep (x, z) exactly for the usual case.
            return Frame {
                up,
                u: DVec3::X,
                v: DVec3::Z,
            };
        }
        // Same handedness as (x, z) under +Y (u × v = -up), so a turned level's plan is the
        // turned plan, not its mirror image.
        let (a, b) = Plane { normal: up, d: 0.0 }.basis();
        Frame { up, u: b, v: a }
    }
    pub(crate) fn plan(&self, p: DVec3) -> DVec2 {
        DVec2::new(p.dot(self.u), p.dot(self.v))
    }
    /// A ground-plane vector back in 3D.
    pub(crate) fn lift(&self, q: DVec2) -> DVec3 {
        self.u * q.x + self.v * q.y
    }
}

/// The convex pieces of the union of plan triangles.
///
/// Everything is done in a frame fixed to the triangles themselves, so a level that was moved,
/// turned or scaled gets the same pieces: origin at their area centroid, first axis along
/// their longest edge (ties within 1e-9 to the earliest, by input order, a triangle's edge
/// opposite its first corner before the other two). The union snaps to
/// the grid of that frame, where a turned rectangle's corners are exactly cocircular again.
/// Each polygon of the union is then written in the one of its eight symmetries (quarter turns, mirrored or not) on that
/// grid whose rings, read from their least point, come first: a canonical form (exact, on
/// integers) that the same shape has whichever of its edges of equal length was picked and
/// wherever the union's rings started, so the partition sees the same input and breaks every
/// tie the same way. The pieces are mapped back and given the exact input coordinates.
///
/// The grid is the plan's own (2^-20 of its extent), not the tolerance's: a grid that moved
/// with the tolerance rounded the same plan to other integers, and a Doom sector's equal
/// lengths, tied on one grid, were settled by rounding on another (E1M2 was cut into other
/// pieces at half or twice the tolerance). What the tolerance decides is decided with it:
/// which vertices are on a straight edge, which T-junctions split an edge, which slivers and
/// cracks are noise.
pub(crate) fn plan_pieces(
    flat: &[[DVec2; 3]],
    eps: f64,
) -> Result<Vec<Vec<DVec2>>, PartitionError> {
    let Some(&first) = flat.first().map(|t| &t[0]) else {
        return Ok(Vec::new());
    };
    let (mut area, mut acc) = (0.0, DVec2::ZERO);
    let mut longest: Option<(f64, DVec2)> = None;
    for t in flat {
        let a = (t[1] - t[0]).perp_dot(t[2] - t[0]).abs();
        area += a;
        acc += a * ((t[0] - first) + (t[1] - first) + (t[2] - first)) / 3.0;
        // The edge opposite the first corner first: it is the same edge when a mirroring
        // node has turned the triangle's corners round (see `Scene::winding`).
        for (i, j) in [(1, 2), (0, 1), (2, 0)] {
            let e = t[j] - t[i];
            let len = e.length();
            if len > 0.0 && longest.is_none_or(|(l, _)| len > l * (1.0 + 1e-9)) {
                longest = Some((len, e / len));
            }
        }
    }
    let Some((_, dir)) = longest else {
        return Ok(Vec::new());
    };
    let o = if area > 0.0 {
        first + acc / area
    } else {
        first
    };
    let perp = dir.perp();
    let local: Vec<[DVec2; 3]> = flat
        .iter()
        .map(|t| {
            t.map(|p| {
                let d = p - o;
                DVec2::new(d.dot(dir), d.dot(perp))
            })
        })
        .collect();
    // The triangles' centroids in input order, which settle a tie between a plan's own
    // symmetries (see `canonical_turn`); a triangle's centroid does not depend on which
    // corner a mirroring node lists first.
    let marks: Vec<DVec2> = local.iter().map(|t| (t[0] + t[1] + t[2]) / 3.0).collect();
    let local = weld(local, 0.5 * eps);
    let mut bounds = (DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY));
    for p in local.iter().flatten() {
        bounds = (bounds.0.min(*p), bounds.1.max(*p));
    }
    let grid = (bounds.1 - bounds.0).length() * PLAN_GRID;
    if !(grid > 0.0 && grid.is_finite()) {
        return Ok(Vec::new());
    }
    let exact = ExactVertices::new(flat.iter().flatten().copied(), grid);
    // Thinner than half the tolerance on average is noise (what the union's own grid dropped
    // when it was the tolerance's).
    let noise = |r: &[DVec2]| ring_mean_width(r) < 0.5 * eps;
    let mut pieces = Vec::new();
    for mut poly in union_triangles(&split_t_junctions(&local, eps.max(grid)), grid) {
        if noise(&poly.outer) {
            continue;
        }
        poly.holes.retain(|h| !noise(h));
        let (turn, canonical) = canonical_turn(&poly, grid, &marks);
        // The union snapped every vertex to the grid: a vertex on a straight edge can come
        // back up to half a step off it along each axis, and so can the two it is judged
        // against (an L turned by (1.47, -0.52, -0.04) rad kept such a vertex on its long
        // edge at exactly eps + 1e-10; an L whose frame follows a tile's diagonal kept its
        // T-junction 1.0 steps off, tests/cells_props.rs). Within the tolerance plus two
        // steps is straight.
        let straight = (eps + 2.0 * grid) / grid;
        let outer = simplify_ring(&canonical.outer, straight);
        if outer.len() < 3 {
            continue;
        }
        let local = Polygon2 {
            outer,
            holes: canonical
                .holes
                .iter()
                .map(|h| simplify_ring(h, straight))
                .collect(),
        };
        let back = |c: DVec2| {
            let c = symmetry_back(c, turn) * grid;
            o + dir * c.x + perp * c.y
        };
        let ps = convex_partition(&local)?;
        let mut keyed: Vec<(Vec<usize>, Vec<DVec2>)> = ps
            .into_iter()
            .map(|p| {
                let mut piece: Vec<DVec2> = p.into_iter().map(back).collect();
                if turn >= 4 {
                    // Mapped back through a reflection: turned the input's way again.
                    piece.reverse();
                }
                let piece = exact.restore(piece);
                let mut key: Vec<usize> = piece
                    .iter()
                    .map(|q| exact.index_of(*q).unwrap_or(usize::MAX))
                    .collect();
                key.sort_unstable();
                (key, piece)
            })
            .collect();
        // Input order, not position, orders the pieces: the same for a moved level.
        keyed.sort_by(|a, b| a.0.cmp(&b.0));
        pieces.extend(keyed.into_iter().map(|(_, p)| p));
    }
    Ok(pieces)
}

/// The plan partition's grid step, relative to the plan's extent: integer coordinates up to
/// 2^20, whose squared distances and cross products stay exact in f64.
const PLAN_GRID: f64 = 1.0 / (1u64 << 20) as f64;

/// Every vertex within `tol` of another (transitively) moved onto the least of them (by x,
/// then y): f32 noise between the corners of neighbouring floor tiles is gone before the
/// union, whose grid is finer than the tolerance (`geom::weld`).
fn weld(tris: Vec<[DVec2; 3]>, tol: f64) -> Vec<[DVec2; 3]> {
    let pts: Vec<DVec3> = tris.iter().flatten().map(|p| p.extend(0.0)).collect();
    let out = crate::geom::weld::weld(&pts, tol);
    out.chunks_exact(3)
        .map(|t| [t[0].truncate(), t[1].truncate(), t[2].truncate()])
        .collect()
}

/// `q` turned `n` quarter turns counter-clockwise about the origin (exact).
fn quarter_turns(q: DVec2, n: usize) -> DVec2 {
    (0..n % 4).fold(q, |q, _| DVec2::new(-q.y, q.x))
}

/// One of the grid's eight symmetries: `n` quarter turns (`n % 4`), after a reflection in
/// the first axis when `n >= 4`. With the reflections, a mirrored room's plan has the same
/// canonical form as the original's, so it is cut into the mirror image of the same pieces.
fn symmetry(q: DVec2, n: usize) -> DVec2 {
    let q = if n >= 4 { DVec2::new(q.x, -q.y) } else { q };
    quarter_turns(q, n)
}

/// The inverse of [`symmetry`].
fn symmetry_back(q: DVec2, n: usize) -> DVec2 {
    let q = quarter_turns(q, 4 - n % 4);
    if n >= 4 {
        DVec2::new(q.x, -q.y)
    } else {
        q
    }
}

/// The symmetry (0 to 7, see [`symmetry`]) of a polygon on the grid whose rings, each read from its least
/// point (by x, then y) and the holes sorted by theirs, come first, and the polygon so turned,
/// in grid steps (integers, exact in f64): the partition then sees the same numbers for a
/// level scaled by any factor, and no tie between float areas can go another way.
///
/// A polygon symmetric in itself comes first under several symmetries, which map its pieces
/// back to different places (a sector's two halves swapped). The tie goes to the symmetry
/// that puts `marks` (points in input order) first, so the choice moves with the level: a
/// mirrored level picks the mirror of the original's symmetry and gets the mirror image of its
/// pieces, not their twin.
fn canonical_turn(p: &Polygon2, grid: f64, marks: &[DVec2]) -> (usize, Polygon2) {
    let steps = |q: &DVec2| ((q.x / grid).round() as i64, (q.y / grid).round() as i64);
    let ring = |r: &[DVec2], n: usize| -> Vec<(i64, i64)> {
        let mut r: Vec<(i64, i64)> = r.iter().map(|q| steps(&symmetry(*q, n))).collect();
        if n >= 4 {
            // A reflection reverses the ring's turn: read it the other way to keep it.
            r.reverse();
        }
        if let Some(at) = (0..r.len()).min_by_key(|&i| r[i]) {
            r.rotate_left(at);
        }
        r
    };
    type Ring = Vec<(i64, i64)>;
    let form = |n: usize| -> (Ring, Vec<Ring>) {
        let mut holes: Vec<Ring> = p.holes.iter().map(|h| ring(h, n)).collect();
        holes.sort();
        (ring(&p.outer, n), holes)
    };
    let forms: Vec<(Ring, Vec<Ring>)> = (0..8).map(form).collect();
    let least = forms.iter().min().cloned().unwrap_or_default();
    let turn = (0..8)
        .filter(|&n| forms[n] == least)
        .min_by_key(|&n| {
            marks
                .iter()
                .map(|m| steps(&symmetry(*m, n)))
                .collect::<Vec<_>>()
        })
        .unwrap_or(0);
    let (outer, holes) = least;
    let back = |r: Ring| -> Vec<DVec2> {
        r.into_iter()
            .map(|(x, y)| DVec2::new(x as f64, y as f64))
            .collect()
    };
    (
        turn,
        Polygon2 {
            outer: back(outer),
            holes: holes.into_iter().map(back).collect(),
        },
    )
}

/// Inserts every vertex that lies on another triangle's edge (a T-junction, as where a floor
/// tile meets the middle of a longer one) into that edge. Without it, rounding a turned
/// level's coordinates can open hairline gaps along such edges and the union falls apart.
fn split_t_junctions(flat: &[[DVec2; 3]], tol: f64) -> Vec<[DVec2; 3]> {
    let mut verts: Vec<DVec2> = flat.iter().flatten().copied().collect();
    verts.sort_by(|a, b| a.x.total_cmp(&b.x).then(a.y.total_cmp(&b.y)));
    verts.dedup_by(|a, b| a.distance_squared(*b) <= tol * tol);
    let mut out = Vec::with_capacity(flat.len());
    for t in flat {
        let mut ring: Vec<DVec2> = Vec::with_capacity(3);
        let mut split = false;
        for k in 0..3 {
            let (p, q) = (t[k], t[(k + 1) % 3]);
            ring.push(p);
            let d = q - p;
            let len2 = d.length_squared();
            if len2 <= tol * tol {
                continue;
            }
            let (lo, hi) = (p.x.min(q.x) - tol, p.x.max(q.x) + tol);
            let first = verts.partition_point(|v| v.x < lo);
            let mut on: Vec<(f64, DVec2)> = verts[first..]
                .iter()
                .take_while(|v| v.x <= hi)
                .filter_map(|v| {
                    let s = (*v - p).dot(d) / len2;
                    let off = (*v - p).perp_dot(d).abs() / len2.sqrt();
                    let inner = s * len2.sqrt() > tol && (1.0 - s) * len2.sqrt() > tol;
                    (inner && off <= tol).then_some((s, *v))
                })
                .collect();
            if !on.is_empty() {
                split = true;
                on.sort_by(|a, b| a.0.total_cmp(&b.0));
                ring.extend(on.into_iter().map(|(_, v)| v));
            }
        }
        if split {
            // A fan from the first corner covers the triangle; triangles that come out flat
            // (points on the corner's own edges) carry no area and are ignored by the union.
            for w in ring[1..].windows(2) {
                out.push([ring[0], w[0], w[1]]);
            }
        } else {
            out.push(*t);
        }
    }
    out
}

/// Drops ring vertices within `eps` of the line through their neighbours (walls that f32
/// noise bent by less than the tolerance are straight).
fn simplify_ring(ring: &[DVec2], eps: f64) -> Vec<DVec2> {
    let mut r = ring.to_vec();
    let mut changed = true;
    while changed && r.len() > 3 {
        changed = false;
        for i in 0..r.len() {
            let (a, p, b) = (r[(i + r.len() - 1) % r.len()], r[i], r[(i + 1) % r.len()]);
            let ab = b - a;
            let l = ab.length();
            let off = if l > 0.0 {
                (p - a).perp_dot(ab).abs() / l
            } else {
                p.distance(a)
            };
            if off <= eps {
                r.remove(i);
                changed = true;
                break;
            }
        }
    }
    r
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Corners within the tolerance of each other (transitively) become the least of them,
    /// in any triangle order; corners further apart stay.
    #[test]
    fn weld_moves_noise_apart_corners_onto_the_least() {
        let a = DVec2::new(1.0, 1.0);
        let b = DVec2::new(1.0 + 4e-7, 1.0 - 3e-7);
        let c = DVec2::new(1.0 + 8e-7, 1.0);
        let far = DVec2::new(3.0, 1.0);
        let tris = vec![[b, far, DVec2::new(2.0, 3.0)], [c, a, DVec2::new(0.0, 3.0)]];
        for order in [tris.clone(), tris.iter().rev().copied().collect()] {
            let out = weld(order, 6e-7);
            let corners: Vec<DVec2> = out.iter().flatten().copied().collect();
            for p in [b, c] {
                assert!(!corners.contains(&p), "{p} welded");
            }
            assert_eq!(corners.iter().filter(|&&p| p == a).count(), 3);
            assert!(corners.contains(&far));
        }
        // A tolerance of zero welds nothing.
        assert_eq!(weld(tris.clone(), 0.0), tris);
    }
}
