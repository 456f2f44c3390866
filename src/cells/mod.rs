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
//! are taken in an order fixed by node path and vertex indices (`gather.rs`), so shuffling nodes or
//! triangles breaks no tie differently. Rooms are built in parallel (`rooms.rs`, the room builder)
//! and their cells numbered in room order afterwards, so the result does not depend on the thread
//! count. What the readings of a floor plan share (the ground frame, the plan's convex pieces) is
//! `plan.rs`; the level-wide readings the builder is handed are `block_rooms.rs` (solid blocks)
//! and `generated.rs` (`--tags auto`). This file holds the stage's types and its driver.
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

use glam::DVec3;
use rayon::prelude::*;
use serde::Serialize;

use crate::config::CellsConfig;
use crate::diag::{Code, Diagnostic, Diagnostics, Location};
use crate::geom::aabb::Aabb;
use crate::geom::grid::BoxGrid;
use crate::geom::polyhedron::ConvexPolyhedron;
use crate::geom::tolerance::Tolerance;
use crate::scene::{NodeId, Scene};
use crate::tags::{RoomId, Tagging};

mod air;
mod assign;
pub use assign::drop_far_structure;
mod areas;
pub use areas::split as split_areas;
mod block_rooms;
mod blocks;
mod bsp;
pub mod draws;
mod footprint;
mod gather;
mod generated;
mod interior;
mod overlap;
pub use overlap::Overlap;
mod plan;
use plan::Frame;
mod prism;
mod props;
mod rooms;
use rooms::{RoomBuilder, RoomCells};
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

/// A room mesh taken for a prop, and why: what `inspect` shows the designer, who can override
/// it with a tag.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct Prop {
    /// The prop's node.
    pub node: NodeId,
    /// Why it is one.
    pub reason: PropReason,
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
    /// Room meshes recognised as props (they do not shape cells), each with why.
    pub props: Vec<Prop>,
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
    /// The props' nodes, in the order of [`CellSet::props`].
    pub fn prop_nodes(&self) -> Vec<NodeId> {
        self.props.iter().map(|p| p.node).collect()
    }

    /// Whether node `n` was taken for a prop.
    pub fn is_prop(&self, n: NodeId) -> bool {
        self.props.iter().any(|p| p.node == n)
    }

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
    let frame = Frame::new(cfg.up);
    let top = rooms::level_top(scene, origin, &frame);
    let (skip, extruded) = rooms::footprint_nodes(scene, tagging, origin, &frame);
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
        scope: match tagging.generated.as_deref() {
            Some(g) => interior::Scope::Level {
                detail_area: g.detail_area,
                axes: g.axes.map(DVec3::from_array),
            },
            None => interior::Scope::Room,
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
        props.extend(room.props);
    }
    let mut set = CellSet {
        cells,
        room_cells,
        tolerance: tol,
        props,
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
