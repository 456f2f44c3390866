//! The engine side: a converted level's cells and portals, loaded from the
//! `PORTCULLIS_portals` extension alone, and the frame-time queries an engine runs on them:
//! [`Level::locate`] finds the camera's cell, [`Level::trace`] walks the portals it can see
//! (the traversal of Godot 3's portal tracer and id Tech 4's `FloodViewThroughArea`), and
//! [`Level::cells_touching`] and [`Trace::box_visible`] place and cull moving objects.
//!
//! Numbers are `f64` throughout: the extension stores `f64`, levels far from the origin
//! (2^20 m) keep sub-millimetre planes, and a trace's cost is its branching, not its
//! arithmetic. An engine with `f32` cameras converts at the call.
//!
//! Nothing here depends on the import or build stages; it reads what `convert` wrote.
//!
//! ```no_run
//! use portcullis_runtime::runtime::{Doors, Level, TraceOptions, Trace, View};
//! // written by `portcullis convert samples/two_rooms.gltf -o two_rooms.glb`; the guide's engine
//! // example runs this against a converted file
//! let level = Level::load("two_rooms.glb".as_ref())?;
//! let doors = Doors::new(&level);
//! let mut trace = Trace::default();
//! let view = View::new([1.0, 1.5, 2.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], 70.0, 16.0 / 9.0, 0.05)?;
//! level.trace(&view, &doors, &TraceOptions::default(), &mut trace);
//! for seen in trace.visible() {
//!     // draw seen.cell's nodes, scissored to seen.rect
//!     assert!(seen.rect[0] <= seen.rect[2]);
//! }
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! The files: `load.rs` reads the .glb JSON chunk or .gltf text and the one buffer view of the PVS,
//! never the meshes, into a [`Level`] (cells' planes, faces and bounds, portals with their plane
//! facing by the winding, links per region with the outside as the region after the cells,
//! [`Doors`]). `locate.rs`: a uniform grid over the cells' bounds, the point's cell (hint first,
//! nested rooms to the highest stored priority then the smallest cell, ties on a boundary to the
//! hint then the lowest index, never to a distance within the tolerance), the nearest cell by exact
//! distance to its faces, the cells a box touches. `trace.rs`: the portal walk (a portal clipped to
//! the near plane and the planes of the transformed portals on its path, projected, and cut to the
//! parent's convex screen polygon, which is the view; its bounds are the rectangle; mirrors and
//! teleporters in camera space by a draw transform; doors, one-way, the PVS row of the camera's
//! cell as prefilter, the portal and cell guards of a path, depth limits). `clip.rs`: half-spaces,
//! 3D and screen polygon clipping that keeps what lies within a hair of the inside (culling errs
//! towards drawing), distances. `error.rs`: [`LoadError`] (the file, the hint) around a
//! [`LevelError`] (what is wrong with the file or with one of its records).
//!
//! Invariants: a trace allocates nothing once its [`Trace`] has grown; every result is a superset
//! of what rays through the level's triangles reach (tests/runtime.rs); the same answer for the
//! level moved with the camera.

pub mod answer;
mod clip;
mod cost;
mod draw;
mod error;
mod load;
mod locate;
mod trace;

use std::ops::Range;
use std::path::Path;

use glam::{DMat4, DVec3};

pub use cost::{Meshes, Submitted, ViewCost};
pub use draw::{DrawList, DrawRange};
pub use error::{LevelError, LoadError};
pub use locate::Location;
pub use trace::{Stats, Trace, TraceOptions, View, ViewError, Visible};

use crate::format::Annotated;
use crate::format::Pvs;
use clip::Half;

/// A portal's transform whose determinant is smaller than this (in magnitude) squashes space
/// flat, or nearly: its inverse, which places what is seen through it, is not to be trusted.
/// (A level's transforms are rigid or mirror motions, of determinant ±1, or scale by a factor
/// in the tens at most.)
const SINGULAR: f64 = 1e-12;

/// What kind of opening a portal is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// An opening: the view passes straight through.
    Plain,
    /// Reflects the view back into its own cell.
    Mirror,
    /// The view continues from the exit portal's side, transformed.
    Teleporter,
}

/// A level's culling data, read from its extension.
pub struct Level {
    tolerance: f64,
    cells: Vec<Cell>,
    /// Every cell's planes, each cell a range.
    planes: Vec<Half>,
    /// Every cell's faces (for the nearest cell of a point outside).
    faces: Vec<Face>,
    points: Vec<DVec3>,
    portals: Vec<Portal>,
    /// Portal polygons, each portal a range.
    corners: Vec<DVec3>,
    transforms: Vec<(DMat4, DMat4)>,
    /// Links out of each region (cells, then the outside), in portal order.
    links: Vec<Link>,
    link_start: Vec<u32>,
    pvs: Option<Pvs>,
    grid: locate::Grid,
    /// What each cell draws (`cells[].nodes`, `cells[].draws`, `split`).
    draw: draw::Draws,
    /// Per cell, whether it may see the outside (`visibility.outside`; all, when the file
    /// stores no PVS).
    outside: Vec<bool>,
}

struct Cell {
    room: String,
    planes: Range<u32>,
    faces: Range<u32>,
    min: DVec3,
    max: DVec3,
    /// Cells with overlapping bounds (nested rooms) are not accepted from a hint alone.
    overlapped: bool,
    volume: f64,
    /// The room's priority: where cells overlap, the highest holds the point.
    priority: i64,
}

struct Face {
    points: Range<u32>,
    plane: Half,
}

struct Portal {
    from: u32,
    to: Option<u32>,
    corners: Range<u32>,
    /// The portal's plane, `n` pointing from the source cell into the target.
    plane: Half,
    kind: Kind,
    one_way: bool,
    closed: bool,
    /// Index into `Level::transforms`: source side to target side, and back (kept apart so
    /// the portals the walk reads stay small).
    transform: Option<u32>,
    partner: Option<u32>,
}

/// A way out of a region: a portal crossed forwards, or an exterior opening crossed from the
/// outside into its cell (`reversed`).
#[derive(Clone, Copy)]
struct Link {
    portal: u32,
    to: u32,
    reversed: bool,
}

impl Level {
    /// Loads the extension of a converted .glb or .gltf (the meshes are not read).
    pub fn load(path: &Path) -> Result<Level, LoadError> {
        let (annotated, pvs) = load::read(path)?;
        Level::from_annotation(&annotated, pvs).map_err(|kind| LoadError {
            path: path.to_path_buf(),
            kind,
            hint: load::CONVERT_HINT,
            unreadable: false,
        })
    }

    /// Reads a converted level from its bytes (a .glb, or a .gltf whose buffers are embedded
    /// or, with `dir`, files in that folder): what an engine's asset loader calls.
    pub fn from_bytes(bytes: &[u8], dir: Option<&Path>) -> Result<Level, LevelError> {
        let (annotated, pvs) = load::parse(bytes, dir)?;
        Level::from_annotation(&annotated, pvs)
    }

    /// Builds the runtime data of an annotation already read. `Err` names the first record
    /// that cannot be used.
    pub fn from_annotation(a: &Annotated, pvs: Option<Pvs>) -> Result<Level, LevelError> {
        if let Some(problem) = crate::format::read::consistency(a, usize::MAX)
            .into_iter()
            .next()
        {
            return Err(LevelError::Inconsistent(problem));
        }
        let tolerance = if a.tolerance.is_finite() && a.tolerance > 0.0 {
            a.tolerance
        } else {
            return Err(LevelError::Tolerance(a.tolerance));
        };
        let mut level = Level {
            tolerance,
            cells: Vec::with_capacity(a.cells.len()),
            planes: Vec::new(),
            faces: Vec::new(),
            points: Vec::new(),
            portals: Vec::with_capacity(a.portals.len()),
            corners: Vec::new(),
            transforms: Vec::new(),
            links: Vec::new(),
            link_start: Vec::new(),
            pvs,
            grid: locate::Grid::default(),
            draw: draw::Draws::read(a)?,
            outside: Vec::new(),
        };
        let (mut a_buf, mut b_buf) = (Vec::new(), Vec::new());
        for (i, c) in a.cells.iter().enumerate() {
            level.add_cell(i, c, &mut a_buf, &mut b_buf)?;
        }
        for (i, p) in a.portals.iter().enumerate() {
            level.add_portal(i, p)?;
        }
        let cells = level.cells.len();
        level.outside = match a.visibility.as_ref().map(|v| v.get("outside")) {
            // No PVS stored: nothing is known.
            None => vec![true; cells],
            Some(None) => vec![false; cells],
            Some(Some(list)) => {
                let mut out = vec![false; cells];
                for c in list.as_array().into_iter().flatten() {
                    match c.as_u64().map(|c| c as usize).filter(|&c| c < cells) {
                        Some(c) => out[c] = true,
                        None => return Err(LevelError::OutsideCell(c.to_string())),
                    }
                }
                out
            }
        };
        level.link_regions();
        if level.pvs.as_ref().is_some_and(|p| p.cells() != cells) {
            return Err(LevelError::PvsRows);
        }
        level.grid = locate::Grid::build(&level);
        locate::mark_overlaps(&mut level);
        Ok(level)
    }

    /// Cell `i` of the annotation: its planes made unit, its faces (a square on each plane
    /// cut by the others; their corners give a point inside and the distance from outside)
    /// and its volume.
    fn add_cell(
        &mut self,
        i: usize,
        c: &crate::format::CellRecord,
        a_buf: &mut Vec<DVec3>,
        b_buf: &mut Vec<DVec3>,
    ) -> Result<(), LevelError> {
        let tolerance = self.tolerance;
        let start = self.planes.len() as u32;
        for p in &c.planes {
            let n = DVec3::new(p[0], p[1], p[2]);
            let len = n.length();
            if !(len.is_finite() && len > 0.5 && p[3].is_finite()) {
                return Err(LevelError::PlaneNotUnit { cell: i, plane: *p });
            }
            self.planes.push(Half {
                n: n / len,
                d: p[3] / len,
            });
        }
        let planes = start..self.planes.len() as u32;
        let (min, max) = (DVec3::from(c.bounds.min), DVec3::from(c.bounds.max));
        if !(min.is_finite() && max.is_finite() && min.cmple(max).all()) {
            return Err(LevelError::BoundsNotBox(i));
        }
        // Faces: a square on each plane cut by the others; their corners give a point
        // inside and the distance from outside.
        let size = (max - min).length().max(self.tolerance) * 2.0;
        let centre = (min + max) / 2.0;
        let face_start = self.faces.len() as u32;
        let cell_planes = &self.planes[planes.start as usize..planes.end as usize];
        let mut sum = DVec3::ZERO;
        let mut count = 0.0;
        let mut volume = 0.0;
        for (k, h) in cell_planes.iter().enumerate() {
            a_buf.clear();
            a_buf.extend(clip::plane_square(*h, centre, size));
            for (j, other) in cell_planes.iter().enumerate() {
                if j != k {
                    clip::clip(a_buf, *other, tolerance, b_buf);
                    std::mem::swap(a_buf, b_buf);
                }
            }
            if a_buf.len() >= 3 {
                let from = self.points.len() as u32;
                self.points.extend_from_slice(a_buf);
                self.faces.push(Face {
                    points: from..self.points.len() as u32,
                    plane: *h,
                });
                sum += a_buf.iter().copied().sum::<DVec3>();
                count += a_buf.len() as f64;
            }
        }
        if count == 0.0 {
            return Err(LevelError::EnclosesNothing(i));
        }
        let inner = sum / count;
        // Divergence theorem about the inner point (so a level far from the origin keeps
        // its digits): each face adds its area times its plane's distance, over three.
        for f in &self.faces[face_start as usize..] {
            let pts = &self.points[f.points.start as usize..f.points.end as usize];
            volume += clip::newell(pts).dot(f.plane.n).abs() / 2.0 * -f.plane.dist(inner) / 3.0;
        }
        self.cells.push(Cell {
            room: c.room.clone(),
            planes,
            faces: face_start..self.faces.len() as u32,
            min,
            max,
            overlapped: false,
            volume: volume.abs(),
            priority: c.priority,
        });
        Ok(())
    }

    /// Portal `i` of the annotation, its plane and transform checked.
    fn add_portal(&mut self, i: usize, p: &crate::format::PortalRecord) -> Result<(), LevelError> {
        let start = self.corners.len() as u32;
        self.corners
            .extend(p.polygon.iter().map(|v| DVec3::from(*v)));
        let poly = &self.corners[start as usize..];
        if poly.len() < 3 || !poly.iter().all(|v| v.is_finite()) {
            return Err(LevelError::NotPolygon(i));
        }
        let from = p.from();
        let centre = poly.iter().copied().sum::<DVec3>() / poly.len() as f64;
        // Counter-clockwise seen from the source: the Newell normal points back into the
        // source, so sight travels against it. A mirror standing free in its room faces
        // away from the room's middle, so the winding, not the cell, says which way.
        let plane = Half::through(centre, -clip::newell(poly)).ok_or(LevelError::NoArea(i))?;
        let transform = match p.transform {
            None => None,
            Some(m) => {
                let m = DMat4::from_cols_array(&m);
                let det = m.determinant();
                if !(det.is_finite() && det.abs() > SINGULAR) {
                    return Err(LevelError::Singular(i));
                }
                self.transforms.push((m, m.inverse()));
                Some(self.transforms.len() as u32 - 1)
            }
        };
        self.portals.push(Portal {
            from: from as u32,
            to: p.to().map(|t| t as u32),
            corners: start..self.corners.len() as u32,
            plane,
            kind: match p.kind.as_deref() {
                Some("mirror") => Kind::Mirror,
                Some("teleporter") => Kind::Teleporter,
                _ => Kind::Plain,
            },
            one_way: p.one_way,
            closed: p.closed,
            transform,
            partner: p.partner.map(|q| q as u32),
        });
        Ok(())
    }

    /// Links per region, in portal order: forward for every portal, and from the outside
    /// back through each exterior opening that sight may cross both ways.
    fn link_regions(&mut self) {
        let cells = self.cells.len();
        let outside = cells as u32;
        let mut by_region: Vec<Vec<Link>> = vec![Vec::new(); cells + 1];
        for (i, p) in self.portals.iter().enumerate() {
            by_region[p.from as usize].push(Link {
                portal: i as u32,
                to: p.to.unwrap_or(outside),
                reversed: false,
            });
            if p.to.is_none() && !p.one_way {
                by_region[cells].push(Link {
                    portal: i as u32,
                    to: p.from,
                    reversed: true,
                });
            }
        }
        for region in by_region {
            self.link_start.push(self.links.len() as u32);
            self.links.extend(region);
        }
        self.link_start.push(self.links.len() as u32);
    }

    /// Number of cells (the extension's `cells`).
    pub fn cells(&self) -> usize {
        self.cells.len()
    }

    /// Number of portals (the extension's `portals`).
    pub fn portals(&self) -> usize {
        self.portals.len()
    }

    /// The portal of the same opening seen from the other side, if any.
    pub fn partner(&self, p: usize) -> Option<usize> {
        self.portals.get(p)?.partner.map(|q| q as usize)
    }

    /// The name of the room cell `c` belongs to.
    pub fn room(&self, c: usize) -> &str {
        &self.cells[c].room
    }

    /// The distance tolerance the level was built with (m): what "on a boundary" means.
    pub fn tolerance(&self) -> f64 {
        self.tolerance
    }

    /// The bounds of cell `c` as `(min, max)`.
    pub fn bounds(&self, c: usize) -> ([f64; 3], [f64; 3]) {
        (self.cells[c].min.to_array(), self.cells[c].max.to_array())
    }

    /// Portal `p`'s `[source, target]` cells (`None`: the outside), kind and flags.
    pub fn portal_cells(&self, p: usize) -> (usize, Option<usize>) {
        let q = &self.portals[p];
        (q.from as usize, q.to.map(|t| t as usize))
    }

    /// The kind of portal `p`.
    pub fn portal_kind(&self, p: usize) -> Kind {
        self.portals[p].kind
    }

    /// Whether cell `c` may see the outside (the sky, the void past an opening to the
    /// exterior): the PVS row's `outside` flag, true when the file stores no PVS. An engine
    /// skips its sky pass when no visible cell may see the outside.
    pub fn sees_outside(&self, c: usize) -> bool {
        self.outside.get(c).copied().unwrap_or(true)
    }

    /// Whether the stored PVS lets cell `from` see cell `to` (true when none is stored).
    pub fn pvs_sees(&self, from: usize, to: usize) -> bool {
        self.pvs.as_ref().is_none_or(|p| p.sees(from, to))
    }

    fn cell_planes(&self, c: usize) -> &[Half] {
        let r = &self.cells[c].planes;
        &self.planes[r.start as usize..r.end as usize]
    }

    fn polygon(&self, p: usize) -> &[DVec3] {
        let r = &self.portals[p].corners;
        &self.corners[r.start as usize..r.end as usize]
    }

    fn outside(&self) -> usize {
        self.cells.len()
    }
}

/// Which portals are closed: the extension's initially-closed doors, changed at run time. A
/// door is one opening, so closing a portal closes its partner too.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Doors {
    closed: Vec<bool>,
}

impl Doors {
    /// The doors as the level starts: the portals flagged `closed`.
    pub fn new(level: &Level) -> Doors {
        Doors {
            closed: level.portals.iter().map(|p| p.closed).collect(),
        }
    }

    /// Opens or closes portal `p` and its partner. Out-of-range indices are ignored.
    pub fn set(&mut self, level: &Level, p: usize, closed: bool) {
        let Some(portal) = level.portals.get(p) else {
            return;
        };
        self.closed[p] = closed;
        if let Some(q) = portal.partner {
            self.closed[q as usize] = closed;
        }
    }

    /// Whether portal `p` is closed now (out-of-range `p`: false).
    pub fn is_closed(&self, p: usize) -> bool {
        self.closed.get(p).copied().unwrap_or(false)
    }
}
