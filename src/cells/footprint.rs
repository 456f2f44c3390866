//! Footprints: floor polygons (flat or sloped, Panda3D style) extruded upward into cells.
//!
//! Each planar part of a footprint is partitioned into convex pieces; every piece vertex rises
//! to the geometry above it (a ray cast against the level, footprints and portals excluded),
//! so a ground-floor cell ends under the next storey's floor and an outdoor cell rises to the
//! top of the level. The cell is the hull of the piece and its raised copy: its bottom is
//! exactly the footprint piece, which is what "cells cover the footprint" means.

use std::collections::HashSet;

use glam::{DVec2, DVec3};
use parry3d_f64::query::{Ray, RayCast};
use parry3d_f64::shape::TriMesh;

use super::gather::{canonical_triangles, node_triangles};
use super::plan::{plan_pieces, Frame};
use crate::config::CellsConfig;
use crate::geom::hull::{hull, HullError};
use crate::geom::partition::PartitionError;
use crate::geom::plane::Plane;
use crate::geom::polyhedron::ConvexPolyhedron;
use crate::geom::tolerance::Tolerance;
use crate::scene::{NodeId, Scene};

/// Why a footprint node gives no cells; the text follows the node's and room's names.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub(crate) enum FootprintError {
    /// Every triangle is vertical (or has no area).
    #[error("it has no non-vertical triangles")]
    NoFloor,
    /// A planar part's outline cannot be cut into convex pieces.
    #[error("cannot partition it: {0}")]
    Partition(PartitionError),
    /// A piece and its raised copy have no hull.
    #[error("{0}")]
    Hull(HullError),
}

/// The ray that finds a footprint's ceiling starts this fraction of the height to the level's
/// top above the footprint, so the footprint's own floor is not hit: a length of the level, so
/// a level modelled in millimetres lifts as far, relatively, as one in metres.
const RAY_LIFT: f64 = 1e-3;

/// The ray also starts at least this many tolerances above the footprint, clear of the floor's
/// own noise: its triangles, each good to the tolerance, meet within a touching distance, and
/// twice that is clear of them.
const LIFT_NOISE: f64 = 4.0;

/// A level whose top is fewer than this many tolerances above its lowest footprint has no
/// storey height of its own (it is flat to within its noise): its size stands for one.
const LEAST_STOREY: f64 = 1e3;

/// Footprint triangles on planes this many tolerances apart or less are one planar part: a
/// floor of f32 tiles bends by a few tolerances across a room.
const PLANE_SLACK: f64 = 10.0;

/// The f64 rounding of a coordinate relative to the piece's size: the raised pieces' hull
/// merges only what rounding split.
const F64_ROUNDING: f64 = 1e-9;

pub(crate) struct Context<'a> {
    scene: &'a Scene,
    origin: DVec3,
    cfg: &'a CellsConfig,
    eps: f64,
    /// The level's top, recentred.
    top: f64,
    frame: Frame,
    obstacles: Option<TriMesh>,
    /// How high a footprint rises where nothing is above it and the level's top is too close,
    /// and ten times the least clearance taken for a ceiling (nearer geometry is a rug, a
    /// decal or a copy of the floor): `[cells] default_height`, else the level's own storey
    /// height (see [`storey_height`]), so a level modelled in millimetres rises as far,
    /// relatively, as one in metres.
    storey: f64,
}

impl<'a> Context<'a> {
    /// `skip`: nodes that are not obstacles (footprints themselves, portals, bounds, ignored).
    /// `footprints`: the nodes that will be extruded (none: no ray mesh is built).
    pub fn new(
        scene: &'a Scene,
        skip: &HashSet<NodeId>,
        footprints: &[NodeId],
        origin: DVec3,
        cfg: &'a CellsConfig,
        eps: f64,
        frame_top: (Frame, f64),
    ) -> Self {
        let (frame, top) = frame_top;
        let needed = !footprints.is_empty();
        let obstacles = if needed && cfg.footprint_height.is_none() {
            let nodes: Vec<NodeId> = scene
                .walk()
                .into_iter()
                .filter(|n| !skip.contains(n))
                .collect();
            crate::geom::ray_mesh::ray_mesh(&node_triangles(scene, &nodes, origin))
        } else {
            None
        };
        let mut ctx = Context {
            scene,
            origin,
            cfg,
            eps,
            top,
            frame,
            obstacles,
            storey: cfg.default_height.unwrap_or(0.0),
        };
        if cfg.default_height.is_none() && cfg.footprint_height.is_none() && needed {
            ctx.storey = ctx.storey_height(footprints);
        }
        ctx
    }

    /// The level's storey height: the median clearance above the centres of its footprints'
    /// triangles (the ceilings most of the floor area has above it, whatever the level's
    /// unit). With nothing above any footprint, the height from the lowest footprint to the
    /// level's top, and on a level that is only flat footprints, their extent across.
    fn storey_height(&self, footprints: &[NodeId]) -> f64 {
        let up = self.frame.up;
        let tris = node_triangles(self.scene, footprints, self.origin);
        let mut found: Vec<f64> = Vec::new();
        let mut bounds = crate::geom::aabb::Aabb::EMPTY;
        let mut lowest = f64::INFINITY;
        for t in &tris {
            t.iter().for_each(|p| bounds.add(*p));
            lowest = t.iter().map(|p| p.dot(up)).fold(lowest, f64::min);
            let n = (t[1] - t[0]).cross(t[2] - t[0]);
            let len = n.length();
            if len <= 0.0 || (n.dot(up) / len).abs() < 0.05 {
                continue;
            }
            let c = (t[0] + t[1] + t[2]) / 3.0;
            let lift = (RAY_LIFT * (self.top - c.dot(up))).max(LIFT_NOISE * self.eps);
            if let Some(h) = self.clearance(c + up * lift) {
                found.push(h + lift);
            }
        }
        if !found.is_empty() {
            found.sort_by(f64::total_cmp);
            return found[(found.len() - 1) / 2];
        }
        let above = self.top - lowest;
        if above > LEAST_STOREY * self.eps {
            above
        } else {
            bounds.size().length().max(LEAST_STOREY * self.eps)
        }
    }

    /// Clearance above `p` (recentred), if anything is above it.
    fn clearance(&self, p: DVec3) -> Option<f64> {
        let mesh = self.obstacles.as_ref()?;
        let ray = Ray::new(p, self.frame.up);
        mesh.cast_local_ray(&ray, f64::MAX, false)
    }

    fn height_at(&self, p: DVec3, fixed: Option<f64>) -> Option<f64> {
        if let Some(h) = fixed.or(self.cfg.footprint_height) {
            return Some(h);
        }
        // The ray starts a little above the footprint, so the footprint's own floor is not
        // hit (`RAY_LIFT`, `LIFT_NOISE`).
        let up = self.frame.up;
        let lift = (RAY_LIFT * (self.top - p.dot(up))).max(LIFT_NOISE * self.eps);
        match self.clearance(p + up * lift) {
            Some(t) if t + lift > 0.1 * self.storey => Some(t + lift),
            Some(_) => None,
            None if self.top - p.dot(up) > 0.1 * self.storey => Some(self.top - p.dot(up)),
            None => Some(self.storey),
        }
    }

    /// The cells of one footprint node; `fixed` is its height from extras
    /// (`footprint_height`), before the configuration's and the geometry above.
    pub(crate) fn extrude(
        &self,
        node: NodeId,
        fixed: Option<f64>,
    ) -> Result<Vec<ConvexPolyhedron>, FootprintError> {
        let tris = canonical_triangles(self.scene, &[node], self.origin);
        // Group the triangles by plane (normals made to face up).
        let mut groups: Vec<(Plane, Vec<[DVec2; 3]>)> = Vec::new();
        for t in &tris {
            let n = (t[1] - t[0]).cross(t[2] - t[0]);
            let len = n.length();
            let up = self.frame.up;
            if len <= 0.0 || (n.dot(up) / len).abs() < 0.05 {
                continue;
            }
            let n = if n.dot(up) < 0.0 { -n } else { n };
            let Some(pl) = Plane::from_point_normal(t[0], n) else {
                continue;
            };
            let flat = t.map(|p| self.frame.plan(p));
            match groups
                .iter_mut()
                .find(|(g, _)| Tolerance::coplanar(g, &pl, PLANE_SLACK * self.eps))
            {
                Some((_, v)) => v.push(flat),
                None => groups.push((pl, vec![flat])),
            }
        }
        if groups.is_empty() {
            return Err(FootprintError::NoFloor);
        }
        let mut out = Vec::new();
        for (pl, flat) in &groups {
            // The point of the footprint plane above ground-plane point q.
            let f = self.frame;
            let lift = |q: DVec2| {
                let g = f.lift(q);
                let h = (pl.d - pl.normal.dot(g)) / pl.normal.dot(f.up);
                g + f.up * h
            };
            for piece in plan_pieces(flat, self.eps).map_err(FootprintError::Partition)? {
                let centre = piece.iter().copied().sum::<DVec2>() / piece.len() as f64;
                let centre_h = self.height_at(lift(centre), fixed).unwrap_or(self.storey);
                let mut pts = Vec::with_capacity(piece.len() * 2);
                for q in &piece {
                    let bottom = lift(*q);
                    let probe = lift(*q + (centre - *q) * 0.02);
                    let h = self.height_at(probe, fixed).unwrap_or(centre_h);
                    pts.push(bottom);
                    pts.push(bottom + self.frame.up * h);
                }
                // The raised corners are computed, not read: a top that the geometry above
                // bends by about the tolerance (a stair's underside) kept one facet or two as
                // rounding went, and which one. Only f64 rounding is flat here.
                let size = crate::geom::aabb::Aabb::from_points(pts.iter())
                    .size()
                    .length();
                let flat = (F64_ROUNDING * size).min(self.eps);
                out.push(hull(&pts, flat).map_err(FootprintError::Hull)?);
            }
        }
        Ok(out)
    }
}

/// The extrusion height designers set in extras (`footprint_height`), on the footprint itself
/// or else on its room's node; only a positive number counts (the tags stage reports others).
pub(crate) fn extras_height(scene: &Scene, nodes: &[NodeId]) -> Option<f64> {
    nodes.iter().find_map(|&n| {
        crate::tags::extras::read_number(scene.nodes[n].extras.as_ref(), "footprint_height")
            .filter(|h| *h > 0.0)
    })
}
