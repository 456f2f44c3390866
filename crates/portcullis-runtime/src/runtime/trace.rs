//! Portal traversal from a camera, as id Tech 4's `FloodViewThroughArea_r` and Godot 3's
//! `PortalTracer::trace_recursive` do it: each portal facing the eye is clipped to the near
//! plane (so nothing behind the camera is ever projected) and to the planes of the mirrors
//! and teleporters on its path, projected, and clipped to the view that reached its cell; what
//! is left bounds the view into the next cell, and its bounds are the cell's screen rectangle.
//! A view is kept as its convex polygon on the screen: the planes through the eye and its
//! edges are the 3D view, but clipping in 2D against the polygon costs half as much as
//! building and clipping against those planes, and is the same cut.
//!
//! Mirrors and teleporters are followed in camera space: a cell seen through them is placed by
//! its draw transform (the inverse of the crossed portals' transforms), so every plane and
//! rectangle stays in the camera's frame. Everything a trace needs lives in [`Trace`], reused
//! from frame to frame: once its buffers have grown, a trace allocates nothing.

use std::ops::Range;

use glam::{DMat4, DVec3};

use super::clip::{self, Half};
use super::{Doors, Level, Location};

/// A perspective camera. NDC: x right, y up, both -1..1.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct View {
    eye: DVec3,
    forward: DVec3,
    right: DVec3,
    up: DVec3,
    tan_x: f64,
    tan_y: f64,
    near: f64,
}

/// Why a camera cannot be used: which of [`View::new`]'s arguments is unusable. The messages
/// are the JavaScript port's (`ViewError` in js/portcullis-three/runtime.js), word for word.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ViewError {
    /// The eye has a coordinate that is infinite or not a number.
    EyeNotFinite,
    /// The look direction is zero (or not finite).
    NoLook,
    /// The up direction is zero, along the look direction, or not finite.
    UpAlongLook,
    /// The vertical field of view is not strictly between 0 and 180 degrees.
    FovOutOfRange,
    /// The aspect ratio is not a positive finite width / height.
    AspectNotPositive,
    /// The near plane's distance is not a positive finite distance.
    NearNotPositive,
}

impl std::fmt::Display for ViewError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            ViewError::EyeNotFinite => "eye is not a finite point",
            ViewError::NoLook => "look has no direction",
            ViewError::UpAlongLook => "up has no direction across look (parallel or zero)",
            ViewError::FovOutOfRange => "fov_y must lie strictly between 0 and 180 degrees",
            ViewError::AspectNotPositive => "aspect must be a positive width / height",
            ViewError::NearNotPositive => "near must be a positive distance",
        })
    }
}

impl std::error::Error for ViewError {}

impl View {
    /// `look`: the direction of view; `up`: any direction not along it; `fov_y_degrees`: the
    /// vertical field of view; `aspect`: width / height; `near`: the near plane's distance.
    pub fn new(
        eye: [f64; 3],
        look: [f64; 3],
        up: [f64; 3],
        fov_y_degrees: f64,
        aspect: f64,
        near: f64,
    ) -> Result<View, ViewError> {
        let eye = DVec3::from(eye);
        if !eye.is_finite() {
            return Err(ViewError::EyeNotFinite);
        }
        let Some(forward) = DVec3::from(look).try_normalize() else {
            return Err(ViewError::NoLook);
        };
        let Some(right) = forward.cross(DVec3::from(up)).try_normalize() else {
            return Err(ViewError::UpAlongLook);
        };
        if !(fov_y_degrees > 0.0 && fov_y_degrees < 180.0) {
            return Err(ViewError::FovOutOfRange);
        }
        if !(aspect.is_finite() && aspect > 0.0) {
            return Err(ViewError::AspectNotPositive);
        }
        if !(near.is_finite() && near > 0.0) {
            return Err(ViewError::NearNotPositive);
        }
        let tan_y = (fov_y_degrees.to_radians() / 2.0).tan();
        Ok(View {
            eye,
            forward,
            right,
            up: right.cross(forward),
            tan_x: tan_y * aspect,
            tan_y,
            near,
        })
    }

    /// The eye's world position (m).
    pub fn eye(&self) -> DVec3 {
        self.eye
    }

    /// The NDC of `p`, or `None` when it lies behind the near plane.
    pub fn ndc(&self, p: DVec3) -> Option<[f64; 2]> {
        let v = p - self.eye;
        let z = v.dot(self.forward);
        (z >= self.near).then(|| self.ndc_at(v, z))
    }

    fn ndc_at(&self, v: DVec3, z: f64) -> [f64; 2] {
        [
            v.dot(self.right) / (z * self.tan_x),
            v.dot(self.up) / (z * self.tan_y),
        ]
    }

    /// The distance from the eye to the near plane's corners: a portal closer than this may
    /// cut the near plane, so the camera counts as standing in it.
    pub fn near_radius(&self) -> f64 {
        self.near * (1.0 + self.tan_x * self.tan_x + self.tan_y * self.tan_y).sqrt()
    }

    /// Whether any of the box `min..max` may lie in the view's frustum (beyond the near
    /// plane, within the four sides): false only when one plane has all eight corners
    /// outside. An unbounded box is always seen.
    pub fn sees_box(&self, min: DVec3, max: DVec3) -> bool {
        if !(min.is_finite() && max.is_finite()) {
            return true;
        }
        // Outward normals through the eye of the four sides, and the near plane's.
        let sides = [
            self.right - self.forward * self.tan_x,
            -self.right - self.forward * self.tan_x,
            self.up - self.forward * self.tan_y,
            -self.up - self.forward * self.tan_y,
        ];
        let nearest = |n: DVec3| {
            // The corner furthest inside (least along n).
            DVec3::new(
                if n.x > 0.0 { min.x } else { max.x },
                if n.y > 0.0 { min.y } else { max.y },
                if n.z > 0.0 { min.z } else { max.z },
            )
        };
        if sides.iter().any(|&n| n.dot(nearest(n) - self.eye) > 0.0) {
            return false;
        }
        let n = -self.forward;
        n.dot(nearest(n) - self.eye) <= -self.near
    }

    /// The near plane, inside beyond it.
    fn near_plane(&self) -> Half {
        Half {
            n: -self.forward,
            d: -self.forward.dot(self.eye) - self.near,
        }
    }
}

/// Limits of a trace.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TraceOptions {
    /// Portals crossed on one path at most.
    pub max_depth: usize,
    /// Mirrors and teleporters crossed on one path at most.
    pub max_transform_depth: usize,
    /// Skip cells the stored PVS says the camera's cell cannot see (untransformed paths only).
    pub use_pvs: bool,
}

impl Default for TraceOptions {
    fn default() -> TraceOptions {
        TraceOptions {
            max_depth: 32,
            max_transform_depth: crate::format::DEFAULT_TRANSFORM_DEPTH,
            use_pvs: true,
        }
    }
}

/// What one trace did.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize)]
pub struct Stats {
    /// Cells (and the outside) entered, counting each path.
    pub entered: u32,
    /// Portals looked at.
    pub portals_tested: u32,
    /// Portals facing away, edge-on, or clipped away by the view.
    pub portals_culled: u32,
    /// Portals into cells the stored PVS rules out.
    pub pvs_skipped: u32,
    /// Closed doors.
    pub closed_skipped: u32,
    /// Portals already on the path.
    pub on_path_skipped: u32,
    /// Portals the camera stands in (passed through without narrowing).
    pub passed_through: u32,
    /// Portals not crossed because the path was `max_depth` deep.
    pub depth_limit_hits: u32,
    /// Mirrors and teleporters not crossed because the path had crossed
    /// `max_transform_depth` of them.
    pub transform_limit_hits: u32,
    /// The deepest path, in portals.
    pub deepest: u32,
}

/// One cell (or the outside) as the camera sees it, through one chain of transforms.
#[derive(Debug, Clone, PartialEq)]
pub struct Visible {
    /// The cell; `None` for the outside.
    pub cell: Option<usize>,
    /// NDC bounds `[xmin, ymin, xmax, ymax]` of every path into it: a scissor rectangle.
    pub rect: [f64; 4],
    /// Portals crossed on the shallowest path.
    pub depth: usize,
    /// Where the camera sees the cell: the matrix to draw its geometry with (through mirrors
    /// and teleporters); `None` for the identity.
    pub transform: Option<DMat4>,
    /// Seen through an odd number of mirrors: draw with the winding flipped.
    pub mirrored: bool,
    via: Range<u32>,
    first_view: u32,
}

const NONE: u32 = u32::MAX;

/// Two draw transforms are one when every entry agrees within this share of their size (one
/// plus the largest translation): the same path of portals composed in another order differs
/// by a few ulps, about 1e-16 of it, and two different placements by far more.
const SAME_TRANSFORM: f64 = 1e-9;

/// The view of one path into a visible cell (its screen polygon and 3D clip planes),
/// chained per cell.
#[derive(Debug, Clone)]
struct ViewRec {
    view: Range<u32>,
    clips: Range<u32>,
    next: u32,
}

#[derive(Debug, Clone, Copy)]
struct Step {
    portal: u32,
    transformed: bool,
}

/// The result of [`Level::trace`], and the buffers it reuses: keep one per camera.
#[derive(Debug, Clone, Default)]
pub struct Trace {
    /// Where the eye was found.
    pub location: Location,
    /// What the trace cost: cells entered, portals tested and why portals were skipped.
    pub stats: Stats,
    visible: Vec<Visible>,
    via: Vec<u32>,
    views: Vec<ViewRec>,
    /// Clip planes: the near plane first, then those of transformed portals.
    planes: Vec<Half>,
    /// Screen polygons of the views, counter-clockwise.
    screen: Vec<[f64; 2]>,
    camera: Option<View>,
    path: Vec<Step>,
    /// Per region: the generation that last visited it untransformed, and its entry.
    stamp: Vec<u32>,
    entry: Vec<u32>,
    generation: u32,
    poly_a: Vec<DVec3>,
    poly_b: Vec<DVec3>,
    flat_a: Vec<[f64; 2]>,
    flat_b: Vec<[f64; 2]>,
    /// The outside's links whose openings face the eye (indices into the level's links).
    outside_links: Vec<u32>,
    /// Per region: how often it is on the current untransformed path.
    on_path_cells: Vec<u16>,
    /// The cells an eye in no cell walked with the whole view (see `walk_from_nearby_cells`).
    roots: Vec<u32>,
    /// Per region: the generation, view and depth of its last untransformed walk entered by
    /// passing through a portal the eye stands in (see `Level::cross`).
    passed: Vec<(u32, u32, u32)>,
}

impl Trace {
    /// The cells seen, in the order first reached (depth first, portals in index order).
    pub fn visible(&self) -> &[Visible] {
        &self.visible
    }

    /// The portals crossed, in order, on the shallowest path to `v`.
    pub fn via(&self, v: &Visible) -> &[u32] {
        &self.via[v.via.start as usize..v.via.end as usize]
    }

    /// Whether a moving object with world bounds `min`..`max`, drawn with visible entry
    /// `entry`, can be seen: its box against the view of each path into that cell (the clip
    /// planes, then its corners on the screen against the view's polygon). Conservative: a
    /// box reaching behind the near plane counts as seen.
    pub fn box_visible(&self, entry: usize, min: DVec3, max: DVec3) -> bool {
        let (Some(v), Some(camera)) = (self.visible.get(entry), self.camera.as_ref()) else {
            return false;
        };
        let corners: [DVec3; 8] = std::array::from_fn(|i| {
            let c = DVec3::select(
                glam::BVec3::new(i & 1 != 0, i & 2 != 0, i & 4 != 0),
                max,
                min,
            );
            v.transform.map_or(c, |m| m.transform_point3(c))
        });
        let mut at = v.first_view;
        while at != NONE {
            let view = &self.views[at as usize];
            at = view.next;
            let clips = &self.planes[view.clips.start as usize..view.clips.end as usize];
            if clips
                .iter()
                .any(|h| corners.iter().all(|&c| h.dist(c) > 0.0))
            {
                continue;
            }
            let mut flat = [[0.0; 2]; 8];
            for (k, &c) in corners.iter().enumerate() {
                match camera.ndc(c) {
                    Some(q) => flat[k] = q,
                    None => return true,
                }
            }
            let poly = &self.screen[view.view.start as usize..view.view.end as usize];
            let apart = (0..poly.len()).any(|k| {
                let (a, b) = (poly[k], poly[(k + 1) % poly.len()]);
                flat.iter().all(|&q| clip::cross2(a, b, q) < 0.0)
            });
            if !apart {
                return true;
            }
        }
        false
    }

    fn reset(&mut self, regions: usize) {
        self.stats = Stats::default();
        self.visible.clear();
        self.via.clear();
        self.views.clear();
        self.planes.clear();
        self.screen.clear();
        self.path.clear();
        // Every walk undoes its own counts, so they are all zero again between traces.
        if self.on_path_cells.len() != regions {
            self.on_path_cells.clear();
            self.on_path_cells.resize(regions, 0);
        }
        if self.stamp.len() != regions {
            self.stamp.clear();
            self.stamp.resize(regions, 0);
            self.entry.resize(regions, 0);
            self.passed.clear();
            self.passed.resize(regions, (0, 0, 0));
            self.generation = 0;
        }
        self.generation = self.generation.wrapping_add(1);
        if self.generation == 0 {
            self.stamp.fill(0);
            self.passed.fill((0, 0, 0));
            self.generation = 1;
        }
    }

    /// Records a visit: its entry (new, or the one for the same region and transform) takes
    /// the union of the rectangles and the shallowest path, and the visit's planes.
    fn visit(&mut self, f: &Frame) {
        let region = f.region as usize;
        let found = match &f.draw {
            None => (self.stamp[region] == self.generation).then(|| self.entry[region] as usize),
            Some((d, _)) => self.visible.iter().position(|v| {
                v.cell == f.cell
                    && v.transform.is_some_and(|t| {
                        t.abs_diff_eq(*d, SAME_TRANSFORM * (1.0 + d.w_axis.abs().max_element()))
                    })
            }),
        };
        let view = self.views.len() as u32;
        let depth = f.depth as usize;
        let i = match found {
            Some(i) => {
                let v = &mut self.visible[i];
                v.rect = [
                    v.rect[0].min(f.rect[0]),
                    v.rect[1].min(f.rect[1]),
                    v.rect[2].max(f.rect[2]),
                    v.rect[3].max(f.rect[3]),
                ];
                if depth < v.depth {
                    v.depth = depth;
                    let start = self.via.len() as u32;
                    self.via.extend(self.path.iter().map(|s| s.portal));
                    self.visible[i].via = start..self.via.len() as u32;
                }
                i
            }
            None => {
                let start = self.via.len() as u32;
                self.via.extend(self.path.iter().map(|s| s.portal));
                self.visible.push(Visible {
                    cell: f.cell,
                    rect: f.rect,
                    depth,
                    transform: f.draw.map(|(d, _)| d),
                    mirrored: f.mirrored,
                    via: start..self.via.len() as u32,
                    first_view: NONE,
                });
                let i = self.visible.len() - 1;
                if f.draw.is_none() {
                    self.stamp[region] = self.generation;
                    self.entry[region] = i as u32;
                }
                i
            }
        };
        self.views.push(ViewRec {
            view: f.view.clone(),
            clips: f.clips.clone(),
            next: self.visible[i].first_view,
        });
        self.visible[i].first_view = view;
        self.stats.entered += 1;
        self.stats.deepest = self.stats.deepest.max(f.depth);
    }

    fn on_path(&self, portal: u32) -> bool {
        for s in self.path.iter().rev() {
            if s.portal == portal {
                return true;
            }
            if s.transformed {
                return false;
            }
        }
        false
    }
}

/// What a portal leaves of a view.
enum Narrowed {
    /// The view into the next region (screen polygon, clip planes) and its rectangle.
    Seen(Range<u32>, Range<u32>, [f64; 4]),
    /// Nothing of the portal is in view.
    Culled,
}

/// One step of the walk: a region reached through a view.
struct Frame {
    region: u32,
    cell: Option<usize>,
    /// The view's screen polygon (in `Trace::screen`) and 3D clip planes (`Trace::planes`).
    view: Range<u32>,
    clips: Range<u32>,
    rect: [f64; 4],
    depth: u32,
    transforms: u32,
    /// Cell space to camera space, and back.
    draw: Option<(DMat4, DMat4)>,
    mirrored: bool,
}

impl Frame {
    /// Where a walk starts: the whole screen (`Trace::screen` 0..4) and the near plane
    /// (`Trace::planes` 0).
    fn root(region: usize, cell: Option<usize>) -> Frame {
        Frame {
            region: region as u32,
            cell,
            view: 0..4,
            clips: 0..1,
            rect: [-1.0, -1.0, 1.0, 1.0],
            depth: 0,
            transforms: 0,
            draw: None,
            mirrored: false,
        }
    }
}

struct Ctx<'a> {
    view: &'a View,
    doors: &'a Doors,
    opts: &'a TraceOptions,
    /// The camera's cell, when its PVS row may prefilter.
    pvs_row: Option<usize>,
    near_radius: f64,
    tol: f64,
}

impl Level {
    /// Walks the portals from the camera's cell, into `out` (whose last location is the
    /// hint for this one). Doors closed in `doors` stop the walk.
    pub fn trace(&self, view: &View, doors: &Doors, opts: &TraceOptions, out: &mut Trace) {
        let hint = out.location.cell();
        out.reset(self.cells.len() + 1);
        out.location = self.locate(view.eye, hint);
        let (region, cell) = match out.location {
            Location::Inside(c) | Location::Boundary(c) => (c, Some(c)),
            Location::Outside { .. } => (self.outside(), None),
        };
        let pvs_row = match out.location {
            Location::Inside(c) if opts.use_pvs && self.pvs.is_some() => Some(c),
            _ => None,
        };
        out.camera = Some(*view);
        out.planes.push(view.near_plane());
        out.screen
            .extend([[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]]);
        let reach = view.near_radius() + self.tolerance;
        out.outside_links.clear();
        let (from, to) = (
            self.link_start[self.outside()] as usize,
            self.link_start[self.outside() + 1] as usize,
        );
        for (i, link) in self.links[from..to].iter().enumerate() {
            let p = &self.portals[link.portal as usize];
            let plane = if link.reversed {
                p.plane.flipped()
            } else {
                p.plane
            };
            if -plane.dist(view.eye) >= -reach {
                out.outside_links.push((from + i) as u32);
            }
        }
        let ctx = Ctx {
            view,
            doors,
            opts,
            pvs_row,
            near_radius: view.near_radius(),
            tol: self.tolerance,
        };
        self.walk(&ctx, Frame::root(region, cell), out);
        match out.location {
            Location::Outside { nearest } => self.walk_from_nearby_cells(&ctx, nearest, out),
            Location::Boundary(c) => self.walk_from_other_sides(&ctx, c, out),
            Location::Inside(_) => {}
        }
    }

    /// An eye on its cell's boundary (within the tolerance of a face) stands on every cell
    /// whose boundary holds it: across a wall of no thickness, away from any portal, its near
    /// plane lies in the room it looks into, which no portal leads to. Each such cell is walked
    /// too, with the whole view, in index order.
    fn walk_from_other_sides(&self, ctx: &Ctx, c: usize, out: &mut Trace) {
        let eye = ctx.view.eye;
        let tol = self.tolerance;
        out.roots.clear();
        out.roots.push(c as u32);
        for &k in self.grid.items(self.grid.bucket(eye)) {
            let k = k as usize;
            if out.roots.contains(&(k as u32)) || self.margin(k, eye) < -tol {
                continue;
            }
            out.roots.push(k as u32);
            self.walk(ctx, Frame::root(k, Some(k)), out);
        }
    }

    /// An eye in no cell may still see into cells without crossing their portals: standing in
    /// a thick wall's doorway (between a bridged pair of portals), or closer to a cell than the
    /// near plane's corners (clipping into a wall). Those cells are walked too, each with the
    /// whole view, as id Tech 4 draws everything from solid. Rare, so a scan of the portals.
    fn walk_from_nearby_cells(&self, ctx: &Ctx, nearest: Option<usize>, out: &mut Trace) {
        let eye = ctx.view.eye;
        let reach = ctx.near_radius + ctx.tol;
        let root = |c: usize| Frame::root(c, Some(c));
        out.roots.clear();
        if let Some((c, d)) = nearest.and_then(|_| self.nearest(eye)) {
            if d <= reach {
                out.roots.push(c as u32);
                self.walk(ctx, root(c), out);
            }
        }
        for (i, p) in self.portals.iter().enumerate() {
            let Some(to) = p.to else { continue };
            if p.transform.is_some() || ctx.doors.is_closed(i) {
                continue;
            }
            let back = p.partner.map_or(p, |q| &self.portals[q as usize]);
            // Beyond both faces of the pair (they face each other across the doorway), and no
            // deeper than the doorway is.
            let depth = back.plane.dist(eye);
            let here = p.plane.dist(eye);
            let doorway = if p.partner.is_some() {
                (p.plane.d + back.plane.d).abs()
            } else {
                0.0
            };
            let across = here >= -reach && depth >= -reach && here.max(depth) <= doorway + reach;
            if across
                && clip::distance_to_polygon(eye - p.plane.n * here, self.polygon(i), p.plane.n)
                    <= reach
            {
                // Each with the whole view once, though it may have been reached already
                // through a narrower opening (a window in the same wall, seen from outside).
                for c in [p.from, to] {
                    if !out.roots.contains(&c) {
                        out.roots.push(c);
                        self.walk(ctx, root(c as usize), out);
                    }
                }
            }
        }
    }

    fn walk(&self, ctx: &Ctx, frame: Frame, out: &mut Trace) {
        out.visit(&frame);
        // A straight sightline meets a convex cell in one segment: along one untransformed
        // path no cell comes twice (the outside is not convex, and may).
        let convex = frame.draw.is_none() && frame.cell.is_some();
        if convex {
            out.on_path_cells[frame.region as usize] += 1;
        }
        let eye = ctx.view.eye;
        let eye_here = frame.draw.map_or(eye, |(_, inv)| inv.transform_point3(eye));
        // The outside holds every exterior opening of the level, and most face away from the
        // eye: untransformed, it walks the list `trace` kept of those facing it.
        let region = frame.region as usize;
        let kept = frame.draw.is_none() && region == self.outside();
        let (first, count) = match kept {
            true => (0, out.outside_links.len()),
            false => {
                let r = self.link_start[region] as usize;
                (r, self.link_start[region + 1] as usize - r)
            }
        };
        for k in 0..count {
            let link = &self.links[if kept {
                out.outside_links[k] as usize
            } else {
                first + k
            }];
            self.cross(ctx, &frame, link, eye_here, out);
        }
        if convex {
            out.on_path_cells[frame.region as usize] -= 1;
        }
    }

    /// Tests one link out of `frame`'s region and, where sight passes it, walks on beyond it
    /// with the view narrowed to the portal (`eye_here`: the eye in the frame's cell space).
    /// Every way a link is passed over is counted in the stats.
    fn cross(
        &self,
        ctx: &Ctx,
        frame: &Frame,
        link: &super::Link,
        eye_here: DVec3,
        out: &mut Trace,
    ) {
        out.stats.portals_tested += 1;
        let p = &self.portals[link.portal as usize];
        if ctx.doors.is_closed(link.portal as usize) {
            out.stats.closed_skipped += 1;
            return;
        }
        let plane = if link.reversed {
            p.plane.flipped()
        } else {
            p.plane
        };
        // Positive on the side sight enters from.
        let dist = -plane.dist(eye_here);
        let reach = ctx.near_radius + ctx.tol;
        if dist < -reach {
            out.stats.portals_culled += 1;
            return;
        }
        let poly = self.polygon(link.portal as usize);
        // A camera in the doorway (or between a portal a hair off its wall and the wall)
        // sees through it whichever side of its plane the eye is on.
        let standing_in =
            dist <= reach && clip::distance_to_polygon(eye_here, poly, plane.n) <= reach;
        if dist < -ctx.tol && !standing_in {
            out.stats.portals_culled += 1;
            return;
        }
        let transform = match p.transform {
            Some(t) if !link.reversed => Some(&self.transforms[t as usize]),
            _ => None,
        };
        if self.passed_over(ctx, frame, link, transform.is_some(), out) {
            return;
        }
        let (view, clips, rect) = if standing_in {
            out.stats.passed_through += 1;
            // Passing through keeps the view, so a region already walked with this very view,
            // untransformed and no deeper, would be walked again to no end: every simple path
            // among the portals within the near plane's reach (a 1 m near plane among a brush
            // map's small cells) is a walk. A straight sightline in that view meets each cell
            // once, and the first walk followed it wherever this one could.
            if frame.draw.is_none() && transform.is_none() {
                let at = &mut out.passed[link.to as usize];
                let (generation, view, depth) = *at;
                if generation == out.generation && view == frame.view.start && depth <= frame.depth
                {
                    return;
                }
                *at = (out.generation, frame.view.start, frame.depth);
            }
            (frame.view.clone(), frame.clips.clone(), frame.rect)
        } else if dist <= ctx.tol {
            out.stats.portals_culled += 1;
            return;
        } else {
            match self.narrow(ctx, frame, poly, transform.is_some(), out) {
                Narrowed::Seen(view, clips, rect) => (view, clips, rect),
                Narrowed::Culled => {
                    out.stats.portals_culled += 1;
                    return;
                }
            }
        };
        self.descend(ctx, frame, link, transform, (view, clips, rect), out);
    }

    /// Whether the walk must not go through `link` whatever is seen through it: it would come
    /// back along its own path, the PVS says the cell beyond is hidden, or a depth limit is
    /// reached. Counted in the stats.
    fn passed_over(
        &self,
        ctx: &Ctx,
        frame: &Frame,
        link: &super::Link,
        transformed: bool,
        out: &mut Trace,
    ) -> bool {
        let again = frame.draw.is_none()
            && !transformed
            && out
                .on_path_cells
                .get(link.to as usize)
                .is_some_and(|&n| n > 0);
        if !transformed && (again || out.on_path(link.portal)) {
            out.stats.on_path_skipped += 1;
            return true;
        }
        let target = link.to as usize;
        if let Some(row) = ctx.pvs_row {
            let untransformed = frame.draw.is_none() && !transformed;
            if untransformed && target < self.cells.len() && !self.pvs_sees(row, target) {
                out.stats.pvs_skipped += 1;
                return true;
            }
        }
        if frame.depth as usize >= ctx.opts.max_depth {
            out.stats.depth_limit_hits += 1;
            return true;
        }
        if transformed && frame.transforms as usize >= ctx.opts.max_transform_depth {
            out.stats.transform_limit_hits += 1;
            return true;
        }
        false
    }

    /// Walks the region beyond `link` with the view seen through it, the portal on the
    /// path meanwhile; a mirror or teleporter's `transform` carries the draw transform on.
    fn descend(
        &self,
        ctx: &Ctx,
        frame: &Frame,
        link: &super::Link,
        transform: Option<&(DMat4, DMat4)>,
        (view, clips, rect): (Range<u32>, Range<u32>, [f64; 4]),
        out: &mut Trace,
    ) {
        let target = link.to as usize;
        let (draw, mirrored, transforms) = match transform {
            None => (frame.draw, frame.mirrored, frame.transforms),
            Some(&(m, inv)) => {
                let (d, d_inv) = frame.draw.unwrap_or((DMat4::IDENTITY, DMat4::IDENTITY));
                (
                    Some((d * inv, m * d_inv)),
                    frame.mirrored ^ (m.determinant() < 0.0),
                    frame.transforms + 1,
                )
            }
        };
        out.path.push(Step {
            portal: link.portal,
            transformed: transform.is_some(),
        });
        let child = Frame {
            region: link.to,
            cell: (target < self.cells.len()).then_some(target),
            view,
            clips,
            rect,
            depth: frame.depth + 1,
            transforms,
            draw,
            mirrored,
        };
        self.walk(ctx, child, out);
        out.path.pop();
    }

    /// The view through portal polygon `poly` (in the frame's cell space): clipped to the
    /// frame's clip planes, projected, and clipped to the frame's screen polygon; for a mirror
    /// or teleporter, its own plane joins the clip planes (what it shows starts at its
    /// surface). `Culled` when nothing of it is seen.
    fn narrow(
        &self,
        ctx: &Ctx,
        frame: &Frame,
        poly: &[DVec3],
        transformed: bool,
        out: &mut Trace,
    ) -> Narrowed {
        let view = ctx.view;
        let eye = view.eye;
        let mut a = std::mem::take(&mut out.poly_a);
        let mut b = std::mem::take(&mut out.poly_b);
        a.clear();
        match &frame.draw {
            None => a.extend_from_slice(poly),
            Some((d, _)) => a.extend(poly.iter().map(|v| d.transform_point3(*v))),
        }
        let surface = match transformed {
            false => None,
            true => {
                let centre = a.iter().copied().sum::<DVec3>() / a.len() as f64;
                Half::through(centre, clip::newell(&a)).map(|h| {
                    if h.dist(eye) < 0.0 {
                        h.flipped()
                    } else {
                        h
                    }
                })
            }
        };
        for i in frame.clips.clone() {
            let h = out.planes[i as usize];
            // Most planes cut nothing: only a plane with a corner beyond it copies.
            if a.iter().all(|&v| h.dist(v) <= ctx.tol) {
                continue;
            }
            clip::clip(&a, h, ctx.tol, &mut b);
            std::mem::swap(&mut a, &mut b);
            if a.len() < 3 {
                break;
            }
        }
        let mut result = Narrowed::Culled;
        if a.len() >= 3 {
            let mut f = std::mem::take(&mut out.flat_a);
            let mut g = std::mem::take(&mut out.flat_b);
            f.clear();
            f.extend(a.iter().map(|&v| {
                let rel = v - eye;
                view.ndc_at(rel, rel.dot(view.forward).max(view.near * 0.5))
            }));
            if let Some((view_poly, rect)) = self.clip_screen(frame, &mut f, &mut g, out) {
                let start = out.screen.len() as u32;
                out.screen.extend_from_slice(view_poly);
                let view_range = start..out.screen.len() as u32;
                let clips = match surface {
                    None => frame.clips.clone(),
                    Some(h) => {
                        let from = out.planes.len() as u32;
                        out.planes.extend_from_within(
                            frame.clips.start as usize..frame.clips.end as usize,
                        );
                        out.planes.push(h);
                        from..out.planes.len() as u32
                    }
                };
                result = Narrowed::Seen(view_range, clips, rect);
            }
            out.flat_a = f;
            out.flat_b = g;
        }
        out.poly_a = a;
        out.poly_b = b;
        result
    }

    /// The projected portal `f` (scratch `g`) cut to the frame's screen polygon,
    /// counter-clockwise, with its rectangle; `None` when nothing is left. Points within a
    /// hair (1e-9 of the screen) of the view count as in it.
    fn clip_screen<'s>(
        &self,
        frame: &Frame,
        f: &'s mut Vec<[f64; 2]>,
        g: &'s mut Vec<[f64; 2]>,
        out: &Trace,
    ) -> Option<(&'s [[f64; 2]], [f64; 4])> {
        /// The slack (NDC units) of the rectangle tests and clips: a hair, for the rounding of
        /// a projection, a millionth of a pixel on any screen.
        const EPS: f64 = 1e-9;
        let p = frame.rect;
        let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        for q in f.iter() {
            lo = [lo[0].min(q[0]), lo[1].min(q[1])];
            hi = [hi[0].max(q[0]), hi[1].max(q[1])];
        }
        if lo[0] > p[2] + EPS || hi[0] < p[0] - EPS || lo[1] > p[3] + EPS || hi[1] < p[1] - EPS {
            return None;
        }
        if clip::area2(f) < 0.0 {
            f.reverse();
        }
        let parent = &out.screen[frame.view.start as usize..frame.view.end as usize];
        for k in 0..parent.len() {
            let (a, b) = (parent[k], parent[(k + 1) % parent.len()]);
            if f.iter().all(|&q| clip::cross2(a, b, q) >= -EPS) {
                continue;
            }
            clip::clip2(f, a, b, EPS, g);
            std::mem::swap(f, g);
            if f.len() < 3 {
                return None;
            }
        }
        // A view pinched to a line or a point sees nothing. Each clip keeps a hair (EPS) of
        // slack, so a pinched view is a sliver some hairs wide, not an empty one: an eye on
        // the plane through aligned portal edges saw through a chain of portals along it
        // (into cells the stored PVS rightly leaves out). The threshold sits far above what
        // the slack can add up to (a hair per clip) and far below a pixel (10^6 hairs), so
        // rounding never decides it: at four hairs, turning the level and the camera together
        // showed or hid such slivers.
        const PINCH: f64 = 1e-6;
        if clip::area2(f) <= PINCH * clip::perimeter2(f) {
            return None;
        }
        let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        for q in f.iter() {
            lo = [lo[0].min(q[0]), lo[1].min(q[1])];
            hi = [hi[0].max(q[0]), hi[1].max(q[1])];
        }
        let rect = [
            lo[0].max(p[0]),
            lo[1].max(p[1]),
            hi[0].min(p[2]),
            hi[1].min(p[3]),
        ];
        (rect[0] <= rect[2] && rect[1] <= rect[3]).then_some((&f[..], rect))
    }
}
