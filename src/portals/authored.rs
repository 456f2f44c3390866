//! Authored portals: linked to the derived portal they cover (which takes their name, kind and
//! flags), or, for mirrors and teleporters, made into transformed portals of their own.
//!
//! Each authored quad (Newell normal from its winding, convex outline) is matched to derived
//! portals that are parallel within 3°, within the wall thickness and overlap it, in the direction
//! its names give; it lends its node and flags; one-way claims drop unclaimed partners; mirrors and
//! teleporters become transformed portals of their own (a mirror, and a teleporter whose exit is
//! itself, is its own partner). Each quad's outline and the derived portals it overlaps are found
//! for all quads in parallel first; the linking loop that flags portals runs in quad order.

use rayon::prelude::*;

use glam::{DMat4, DVec3};

use super::{Portal, PortalSet};
use crate::cells::CellSet;
use crate::config::PortalsConfig;
use crate::diag::{Code, Diagnostic, Location};
use crate::geom::aabb::Aabb;
use crate::geom::grid::BoxGrid;
use crate::geom::plane::Plane;
use crate::geom::polyhedron::{convex_ring_on_plane, polygon_area, usable_polygon};
use crate::scene::{NodeId, Scene};
use crate::tags::rules::{Facing, PortalKind};
use crate::tags::{AuthoredPortal, Tagging};

/// How far (radians) an authored portal may be turned off the derived portals it stands for:
/// not the angle tolerance, as a portal is drawn by hand, and a few degrees off the wall still
/// means that wall (which derived portals it covers is settled by distance and overlap).
pub(crate) const HAND_DRAWN: f64 = 0.05;

/// How many tolerances a derived portal may lie off an authored quad's plane beyond the wall
/// thickness and still be the one it covers: the derived portal is on a cell's face, within
/// a tolerance of the wall's side, and the quad's centre is measured from its own points.
const QUAD_REACH: f64 = 10.0;

/// How many tolerances off its own plane a vertex of an authored portal may lie before the
/// flattening is reported, with [`FLAT_ENOUGH`] as the floor: exporters write a quad to a
/// few digits, and one off by less was drawn flat.
const OFF_PLANE: f64 = 10.0;

/// The floor (m) of the tolerance that report scales: a drawn quad less than a millimetre
/// ([`OFF_PLANE`] of these) off its plane is flat, however fine the level's tolerance.
const FLAT_ENOUGH: f64 = 1e-4;

/// How many tolerances (at least) in front of and behind an unmatched quad are probed for
/// the cells it lies between, when half the wall thickness is less: far enough off the
/// quad's plane that the probe falls in the cell, not on its face.
const PROBE: f64 = 100.0;

/// An authored portal's geometry: centroid, unit normal (from its winding), convex outline.
struct Quad {
    centre: DVec3,
    normal: DVec3,
    ring: Vec<DVec3>,
    max_off_plane: f64,
    /// Area of the mesh's triangles: less than the ring's when the outline is not convex.
    mesh_area: f64,
}

fn quad(scene: &Scene, node: NodeId, eps: f64) -> Option<Quad> {
    let n = &scene.nodes[node];
    let mesh = &scene.meshes[n.mesh?];
    let w: Vec<DVec3> = mesh
        .positions
        .iter()
        .map(|p| n.world.transform_point3(*p))
        .collect();
    let mut normal = DVec3::ZERO;
    let mut centre = DVec3::ZERO;
    let mut area = 0.0;
    let winding = scene.winding(node);
    for &t in &mesh.triangles {
        let [a, b, c] = winding.order(t).map(|i| w[i as usize]);
        let cr = (b - a).cross(c - a);
        normal += cr;
        let ar = 0.5 * cr.length();
        centre += (a + b + c) / 3.0 * ar;
        area += ar;
    }
    let normal = normal.try_normalize()?;
    if area <= 0.0 {
        return None;
    }
    let centre = centre / area;
    let plane = Plane::from_point_normal(centre, normal)?;
    let used: Vec<DVec3> = mesh
        .triangles
        .iter()
        .flatten()
        .map(|&i| w[i as usize])
        .collect();
    let max_off_plane = used
        .iter()
        .map(|p| plane.distance(*p).abs())
        .fold(0.0, f64::max);
    let flat: Vec<DVec3> = used
        .iter()
        .map(|p| *p - normal * plane.distance(*p))
        .collect();
    let ring = convex_ring_on_plane(&flat, &plane, eps);
    let ring = usable_polygon(&ring, normal, eps)?;
    Some(Quad {
        centre,
        normal,
        ring,
        max_off_plane,
        mesh_area: area,
    })
}

/// Overlap area of an authored quad and a portal (both convex, near one plane), measured on
/// `plane`: each projected onto it first, so a quad a hair off the portal's plane still meets it.
fn overlap(a: &[DVec3], b: &[DVec3], plane: &Plane) -> f64 {
    let onto = |p: &DVec3| *p - plane.normal * plane.distance(*p);
    let (a, b): (Vec<DVec3>, Vec<DVec3>) =
        (a.iter().map(onto).collect(), b.iter().map(onto).collect());
    let part = crate::geom::polyhedron::overlap(&a, &b, plane.normal);
    polygon_area(&part, plane.normal)
}

/// The derived two-way portals an authored quad lies on: parallel within `cos_tol`, within
/// `reach` of its plane, and overlapping it by more than 1% of the smaller of the two.
fn overlapping(q: &Quad, set: &PortalSet, near: &BoxGrid, reach: f64, cos_tol: f64) -> Vec<usize> {
    let plane = Plane::from_point_normal(q.centre, q.normal).unwrap_or(Plane {
        normal: q.normal,
        d: 0.0,
    });
    let mut candidates: Vec<usize> = Vec::new();
    let around = Aabb::from_points(q.ring.iter());
    for i in near.query(&around, reach) {
        let p = &set.portals[i];
        if p.to.is_none() || p.transform.is_some() || p.normal.dot(q.normal).abs() < cos_tol {
            continue;
        }
        let dist = (p.normal.dot(p.polygon[0]) - p.normal.dot(q.centre)).abs();
        if dist > reach {
            continue;
        }
        let a = overlap(&q.ring, &p.polygon, &plane);
        if a > 0.01 * p.area.min(polygon_area(&q.ring, q.normal)) {
            candidates.push(i);
        }
    }
    candidates
}

fn cell_at(cells: &CellSet, p: DVec3, eps: f64) -> Option<usize> {
    (0..cells.cells.len()).find(|&c| cells.cells[c].poly.contains(p, eps))
}

/// A frame at a portal: x along its normal, y up (as close as the plane allows), origin at
/// its centre.
fn frame(q: &Quad) -> DMat4 {
    let x = q.normal;
    let up = if x.y.abs() < 0.9 { DVec3::Y } else { DVec3::Z };
    let y = (up - x * up.dot(x)).normalize();
    let z = x.cross(y);
    DMat4::from_cols(
        x.extend(0.0),
        y.extend(0.0),
        z.extend(0.0),
        q.centre.extend(1.0),
    )
}

/// What every step of linking the authored portals reads: the level, its tags and cells, and
/// the tolerances, so each step takes the one context instead of a long list of arguments.
struct Linking<'a> {
    scene: &'a Scene,
    tagging: &'a Tagging,
    cells: &'a CellSet,
    eps: f64,
    /// How far in front of and behind a quad its cells are looked for.
    probe: f64,
}

/// Which derived portals the authored ones claimed so far: the one-way flag each claimed with
/// (which decides, once all are linked, which partners go) and the node that claimed it (to
/// spot two quads in one opening).
struct Claims {
    one_way: Vec<Option<bool>>,
    by: Vec<Option<NodeId>>,
}

impl Linking<'_> {
    fn loc(&self, n: NodeId) -> Location {
        Location::file(&self.scene.path)
            .with_source(self.scene.nodes[n].source.clone())
            .with_node(self.scene.node_path(n))
    }

    fn room_of(&self, c: usize) -> usize {
        self.cells.cells[c].room
    }
}

pub(crate) fn link(
    scene: &Scene,
    tagging: &Tagging,
    cells: &CellSet,
    cfg: &PortalsConfig,
    set: &mut PortalSet,
) {
    let eps = cells.tolerance.distance;
    let probe = (cfg.max_wall_thickness * 0.5).max(PROBE * eps);
    let l = Linking {
        scene,
        tagging,
        cells,
        eps,
        probe,
    };
    let mut claims = Claims {
        one_way: vec![None; set.portals.len()],
        by: vec![None; set.portals.len()],
    };
    let mut transformed_done: Vec<NodeId> = Vec::new();
    let prepared = prepare_quads(scene, tagging, cfg, set, eps);
    for (ap, (q, candidates)) in tagging.portals.iter().zip(prepared) {
        let Some(q) = q else {
            l.report_no_area(ap, set);
            continue;
        };
        l.report_outline(ap, &q, set);
        if ap.kind != PortalKind::Plain {
            if !transformed_done.contains(&ap.node) {
                l.transformed(ap, &q, set, &mut transformed_done);
            }
            continue;
        }
        l.link_plain(ap, &q, &candidates, &mut claims, set);
    }
    drop_unclaimed_partners(set, &claims.one_way);
}

/// Each quad's outline and the derived portals it overlaps depend on nothing the linking
/// changes (it flags derived portals and appends transformed ones the grid never holds), so
/// they are found first, on every thread.
fn prepare_quads(
    scene: &Scene,
    tagging: &Tagging,
    cfg: &PortalsConfig,
    set: &PortalSet,
    eps: f64,
) -> Vec<(Option<Quad>, Vec<usize>)> {
    // Authored portals are drawn by hand: a few degrees off the wall still means that wall.
    let cos_tol = HAND_DRAWN.cos();
    // The derived portals, by their bounds: an authored quad is compared with those near it.
    let near = BoxGrid::new(
        set.portals
            .iter()
            .map(|p| Aabb::from_points(p.polygon.iter()))
            .collect(),
    );
    tagging
        .portals
        .par_iter()
        .map(|ap| {
            let q = quad(scene, ap.node, eps);
            let candidates = match &q {
                Some(q) if ap.kind == PortalKind::Plain => overlapping(
                    q,
                    set,
                    &near,
                    cfg.max_wall_thickness + QUAD_REACH * eps,
                    cos_tol,
                ),
                _ => Vec::new(),
            };
            (q, candidates)
        })
        .collect()
}

impl Linking<'_> {
    /// No mesh is a tag problem, reported there; a mesh without area is reported here.
    fn report_no_area(&self, ap: &AuthoredPortal, set: &mut PortalSet) {
        let scene = self.scene;
        let node = &scene.nodes[ap.node];
        if let Some(m) = node.mesh {
            let pts = &scene.meshes[m].positions;
            let centre = pts.iter().copied().sum::<DVec3>() / pts.len().max(1) as f64;
            set.diagnostics.push(
                Diagnostic::new(
                    Code::PORTAL_TOO_FEW_POINTS,
                    format!(
                        "portal `{}` has no area: its mesh has fewer than 3 distinct points off one line",
                        scene.node_label(ap.node)
                    ),
                    self.loc(ap.node).with_position(node.world.transform_point3(centre).to_array()),
                )
                .hint("give the portal a quad (or polygon) covering the opening"),
            );
        }
    }

    /// Warns where the quad used differs from the mesh drawn: a convex hull stands in for a
    /// concave outline, and off-plane vertices were flattened.
    fn report_outline(&self, ap: &AuthoredPortal, q: &Quad, set: &mut PortalSet) {
        let (scene, eps) = (self.scene, self.eps);
        let ring_area = polygon_area(&q.ring, q.normal);
        if ring_area > q.mesh_area * 1.001 + eps * eps {
            set.diagnostics.push(
                Diagnostic::new(
                    Code::PORTAL_NOT_CONVEX,
                    format!(
                        "portal `{}` is not convex (or has holes): its outline covers {:.4} m² but its mesh only {:.4} m²; its convex hull was used",
                        scene.node_label(ap.node),
                        ring_area,
                        q.mesh_area
                    ),
                    self.loc(ap.node).with_position(q.centre.to_array()),
                )
                .hint("split it into convex portals, one per opening, or make it convex"),
            );
        }
        if q.max_off_plane > OFF_PLANE * eps.max(FLAT_ENOUGH) {
            set.diagnostics.push(
                Diagnostic::new(
                    Code::PORTAL_NOT_PLANAR,
                    format!(
                        "portal `{}` is not planar: a vertex is {:.4} m off its plane",
                        scene.node_label(ap.node),
                        q.max_off_plane
                    ),
                    self.loc(ap.node).with_position(q.centre.to_array()),
                )
                .hint(
                    "flatten the portal mesh; its vertices were projected onto the average plane",
                ),
            );
        }
    }

    /// Links a plain authored portal to the derived portals it covers that lead the way its
    /// tags (or its facing) say, or reports why it covers none.
    fn link_plain(
        &self,
        ap: &AuthoredPortal,
        q: &Quad,
        candidates: &[usize],
        claims: &mut Claims,
        set: &mut PortalSet,
    ) {
        // Direction: the named source room, else the named target, else the way it faces
        // (Godot's convention: a portal faces out of the room it belongs to).
        let dir_ok = |i: usize| -> bool {
            let p = &set.portals[i];
            let to = p.to.unwrap_or(p.from);
            let source_ok = ap.source_room.is_none_or(|s| self.room_of(p.from) == s);
            let target_ok = ap.target_room.is_none_or(|t| self.room_of(to) == t);
            let named = ap.source_room.is_some() || ap.target_room.is_some();
            source_ok && target_ok && (named || p.normal.dot(q.normal) > 0.0)
        };
        let chosen: Vec<usize> = candidates.iter().copied().filter(|&i| dir_ok(i)).collect();
        if chosen.is_empty() {
            self.report_unmatched(ap, q, candidates.is_empty(), set);
            return;
        }
        self.report_ambiguous(ap, q, &chosen, set);
        self.claim(ap, q, &chosen, claims, set);
        for &i in &chosen {
            if let Some(j) = set.portals[i].partner {
                if ap.closed {
                    set.portals[j].closed = true;
                }
                if set.portals[j].authored.is_none() && !ap.one_way {
                    set.portals[j].authored = Some(ap.node);
                }
            }
        }
    }

    /// Says what lies on either side of a quad that covers no opening it may lead through,
    /// which tells a quad in a solid wall from one floating inside a room.
    fn report_unmatched(
        &self,
        ap: &AuthoredPortal,
        q: &Quad,
        no_candidates: bool,
        set: &mut PortalSet,
    ) {
        let (scene, cells, eps, probe) = (self.scene, self.cells, self.eps, self.probe);
        let front = cell_at(cells, q.centre + q.normal * probe, eps);
        let back = cell_at(cells, q.centre - q.normal * probe, eps);
        let side = |c: Option<usize>| match c {
            Some(c) => format!(
                "cell {c} (room `{}`)",
                self.tagging.rooms[self.room_of(c)].name
            ),
            None => "no cell".to_string(),
        };
        if front.is_some() && front == back {
            set.diagnostics.push(
                Diagnostic::new(
                    Code::PORTAL_SEPARATES_NOTHING,
                    format!(
                        "portal `{}` has {} on both sides ({probe:.3} m in front and behind): it separates nothing",
                        scene.node_label(ap.node),
                        side(front)
                    ),
                    self.loc(ap.node).with_position(q.centre.to_array()),
                )
                .hint("move the portal into the opening between two rooms, or remove it"),
            );
            return;
        }
        let n = q.normal;
        set.diagnostics.push(
            Diagnostic::new(
                Code::PORTAL_AUTHORED_UNMATCHED,
                format!(
                    "portal `{}` covers no opening between cells{}: it faces ({:.3}, {:.3}, {:.3}); probed {:.3} m in front: {}, behind: {}",
                    scene.node_label(ap.node),
                    if no_candidates { "" } else { " leading where its tags say" },
                    n.x, n.y, n.z, probe, side(front), side(back)
                ),
                self.loc(ap.node).with_position(q.centre.to_array()),
            )
            .hint("move the portal into the wall opening between its two rooms (or open the wall behind it), and check its source and target names"),
        );
    }

    /// One authored quad should open one way between two rooms; more means the link is a
    /// guess.
    fn report_ambiguous(
        &self,
        ap: &AuthoredPortal,
        q: &Quad,
        chosen: &[usize],
        set: &mut PortalSet,
    ) {
        let tagging = self.tagging;
        let mut links: Vec<(usize, usize)> = chosen
            .iter()
            .map(|&i| {
                let p = &set.portals[i];
                (self.room_of(p.from), self.room_of(p.to.unwrap_or(p.from)))
            })
            .filter(|(a, b)| a != b)
            .collect();
        links.sort_unstable();
        links.dedup();
        if links.len() > 1 {
            let names: Vec<String> = links
                .iter()
                .map(|(a, b)| {
                    format!(
                        "`{}` -> `{}`",
                        tagging.rooms[*a].name, tagging.rooms[*b].name
                    )
                })
                .collect();
            set.diagnostics.push(
                Diagnostic::new(
                    Code::PORTAL_AUTHORED_AMBIGUOUS,
                    format!(
                        "portal `{}` covers openings between several pairs of rooms ({}); it was linked to all of them",
                        self.scene.node_label(ap.node),
                        names.join(", ")
                    ),
                    self.loc(ap.node).with_position(q.centre.to_array()),
                )
                .hint("name its source and target rooms (e.g. `portal_TARGET` inside the source room), or split it into one quad per opening"),
            );
        }
    }

    /// Gives each chosen derived portal the authored node, its closed and one-way flags, and
    /// reports an opening claimed twice or a quad facing against its convention.
    fn claim(
        &self,
        ap: &AuthoredPortal,
        q: &Quad,
        chosen: &[usize],
        claims: &mut Claims,
        set: &mut PortalSet,
    ) {
        let (scene, tagging) = (self.scene, self.tagging);
        for &i in chosen {
            if let Some(other) = claims.by[i].filter(|&o| o != ap.node) {
                let p = &set.portals[i];
                set.diagnostics.push(
                    Diagnostic::new(
                        Code::PORTAL_DUPLICATE,
                        format!(
                            "portals `{}` and `{}` both cover the opening from `{}` to `{}`",
                            scene.node_label(other),
                            scene.node_label(ap.node),
                            tagging.rooms[self.room_of(p.from)].name,
                            tagging.rooms[self.room_of(p.to.unwrap_or(p.from))].name
                        ),
                        self.loc(ap.node).with_position(q.centre.to_array()),
                    )
                    .hint("remove one of them; one portal per opening is enough"),
                );
            }
            claims.by[i] = Some(ap.node);
            let p = &mut set.portals[i];
            p.authored = Some(ap.node);
            p.closed |= ap.closed;
            claims.one_way[i] = Some(ap.one_way);
            let facing = p.normal.dot(q.normal);
            let wrong = match ap.faces {
                Facing::Out => facing < 0.0,
                Facing::In => facing > 0.0,
            };
            if wrong && ap.source_room.is_some() {
                set.diagnostics.push(
                    Diagnostic::new(
                        Code::PORTAL_AUTHORED_WRONG_WAY,
                        format!(
                            "portal `{}` faces the wrong way for its convention ({}): {} its source room `{}`",
                            scene.node_label(ap.node),
                            if ap.faces == Facing::Out { "front out of the source room" } else { "front into the source room" },
                            if ap.faces == Facing::Out { "back into" } else { "out of" },
                            tagging.rooms[self.room_of(set.portals[i].from)].name
                        ),
                        self.loc(ap.node).with_position(q.centre.to_array()),
                    )
                    .hint("flip the portal's faces (reverse its winding)"),
                );
            }
        }
    }
}

/// One-way: a claimed direction whose partner no authored portal claimed loses the partner;
/// two one-way quads covering both directions (Panda3D) make one two-way pair.
fn drop_unclaimed_partners(set: &mut PortalSet, one_way_claim: &[Option<bool>]) {
    let mut remove = vec![false; set.portals.len()];
    for i in 0..one_way_claim.len() {
        if one_way_claim[i] == Some(true) {
            if let Some(j) = set.portals[i].partner {
                if one_way_claim.get(j).copied().flatten().is_none() {
                    remove[j] = true;
                    set.portals[i].one_way = true;
                    set.portals[i].partner = None;
                }
            }
        }
    }
    compact(set, &remove);
}

/// Drops removed portals and renumbers partners.
fn compact(set: &mut PortalSet, remove: &[bool]) {
    let mut new_index = vec![None; set.portals.len()];
    let mut k = 0;
    for (i, r) in remove.iter().enumerate() {
        if !r {
            new_index[i] = Some(k);
            k += 1;
        }
    }
    let old = std::mem::take(&mut set.portals);
    for (i, mut p) in old.into_iter().enumerate() {
        if remove.get(i).copied().unwrap_or(false) {
            continue;
        }
        p.partner = p.partner.and_then(|j| new_index.get(j).copied().flatten());
        set.portals.push(p);
    }
}

impl Linking<'_> {
    /// Makes a mirror or teleporter into a transformed portal of its own, out of the cell its
    /// front faces; `done` keeps the nodes used, so a teleporter's exit is not made again.
    fn transformed(
        &self,
        ap: &AuthoredPortal,
        q: &Quad,
        set: &mut PortalSet,
        done: &mut Vec<NodeId>,
    ) {
        let (scene, probe) = (self.scene, self.probe);
        let Some(from) = cell_at(self.cells, q.centre + q.normal * probe, self.eps) else {
            set.diagnostics.push(
                Diagnostic::new(
                    Code::PORTAL_AUTHORED_UNMATCHED,
                    format!(
                        "{} `{}` faces no cell: probed {:.3} m in front of it",
                        if ap.kind == PortalKind::Mirror {
                            "mirror"
                        } else {
                            "teleporter"
                        },
                        scene.node_label(ap.node),
                        probe
                    ),
                    self.loc(ap.node).with_position(q.centre.to_array()),
                )
                .hint(
                    "the front of a mirror or teleporter (its winding's normal) must face into a cell",
                ),
            );
            return;
        };
        done.push(ap.node);
        match ap.kind {
            PortalKind::Mirror => mirror(ap, q, from, set),
            PortalKind::Teleporter => self.teleporter(ap, q, from, set, done),
            PortalKind::Plain => {}
        }
    }

    /// A teleporter from cell `from` to the cell its exit faces: two portals, one each way,
    /// unless it is one-way or exits at itself.
    fn teleporter(
        &self,
        ap: &AuthoredPortal,
        q: &Quad,
        from: usize,
        set: &mut PortalSet,
        done: &mut Vec<NodeId>,
    ) {
        let (scene, eps, probe) = (self.scene, self.eps, self.probe);
        // Seen from the source cell, which lies in front of it.
        let polygon = q.ring.clone();
        let area = polygon_area(&q.ring, q.normal);
        let Some(exit) = ap.teleport_exit else {
            return;
        };
        let Some(xq) = quad(scene, exit, eps) else {
            set.diagnostics.push(
                Diagnostic::new(
                    Code::PORTAL_AUTHORED_UNMATCHED,
                    format!(
                        "teleporter `{}` exits at `{}`, which has no mesh",
                        scene.node_label(ap.node),
                        scene.node_label(exit)
                    ),
                    self.loc(ap.node),
                )
                .hint(
                    "the exit of a teleporter must be a portal mesh (a quad) facing into its cell",
                ),
            );
            return;
        };
        let Some(to) = cell_at(self.cells, xq.centre + xq.normal * probe, eps) else {
            set.diagnostics.push(
                Diagnostic::new(
                    Code::PORTAL_AUTHORED_UNMATCHED,
                    format!(
                        "the exit `{}` of teleporter `{}` faces no cell",
                        scene.node_label(exit),
                        scene.node_label(ap.node)
                    ),
                    self.loc(exit),
                )
                .hint("turn the exit so its front faces into a cell"),
            );
            return;
        };
        done.push(exit);
        // Walking into the entry (against its normal) comes out of the exit along its
        // normal: entry frame, half a turn about up, exit frame.
        let half_turn = DMat4::from_rotation_y(std::f64::consts::PI);
        let t = frame(&xq) * half_turn * frame(q).inverse();
        // A teleporter whose exit is itself: the transform is a half turn about the
        // portal's own axis, its own inverse, so the portal is its own partner (as a mirror
        // is) rather than a second copy of itself, which was reported as PORTAL_DUPLICATE
        // (tests/stiff.rs, teleporter_into_itself).
        let into_itself = exit == ap.node;
        let i = set.portals.len();
        set.portals.push(Portal {
            from,
            to: Some(to),
            polygon,
            normal: -q.normal,
            area,
            kind: PortalKind::Teleporter,
            one_way: ap.one_way,
            closed: ap.closed,
            door: false,
            internal: false,
            transform: Some(t),
            authored: Some(ap.node),
            partner: if into_itself {
                Some(i)
            } else {
                (!ap.one_way).then_some(i + 1)
            },
        });
        if !ap.one_way && !into_itself {
            set.portals.push(Portal {
                from: to,
                to: Some(from),
                polygon: xq.ring.clone(),
                normal: -xq.normal,
                area: polygon_area(&xq.ring, xq.normal),
                kind: PortalKind::Teleporter,
                one_way: false,
                closed: ap.closed,
                door: false,
                internal: false,
                transform: Some(t.inverse()),
                authored: Some(exit),
                partner: Some(i),
            });
        }
    }
}

/// A mirror in cell `from`: a portal back into the same cell through the mirror's reflection.
fn mirror(ap: &AuthoredPortal, q: &Quad, from: usize, set: &mut PortalSet) {
    // Seen from the source cell, which lies in front of it.
    let polygon = q.ring.clone();
    let area = polygon_area(&q.ring, q.normal);
    let plane = Plane::from_point_normal(q.centre, q.normal).unwrap_or(Plane {
        normal: q.normal,
        d: 0.0,
    });
    let i = set.portals.len();
    set.portals.push(Portal {
        from,
        to: Some(from),
        polygon,
        normal: -q.normal,
        area,
        kind: PortalKind::Mirror,
        one_way: false,
        closed: ap.closed,
        door: false,
        internal: false,
        transform: Some(plane.reflection()),
        authored: Some(ap.node),
        // A reflection is its own inverse: the mirror is its own partner.
        partner: Some(i),
    });
}
