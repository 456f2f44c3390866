//! The interior of a room's surface as convex cells, in 3D and with no up axis.
//!
//! Rooms are not prisms: stairs, platforms, soffits, mezzanines, door reveals and vaults change a
//! room's section with height, and a level may lie in any orientation. So the interior is found
//! the way qbsp and dmap find theirs, from the room's own boundary planes:
//!
//! 1. **Planes.** The room's triangles are grouped by plane (every vertex within the tolerance;
//!    the first triangle in input order gives the plane). Triangles on a face of the room's
//!    convex hull already bound the search space; the others are the *active* fragments.
//!    A room with no active fragment is convex: its hull is its one cell (the fast path).
//! 2. **BSP.** The hull is split recursively by the planes of the active fragments. The
//!    splitter of a node is the plane carrying the most length of *reflex edges* inside it
//!    (where the surface folds away from the air, as at a stair's nosing or an L's inner
//!    corner): cutting there separates convex pieces without cutting through the middle of
//!    one, which is what makes a four-step stair hall four cells and not a stack of slabs.
//!    Ties go to the plane that splits the fewest fragments, then to input order. Fragments on
//!    the splitter become boundary of both children; the others are clipped to their side.
//!    A leaf has no surface inside it, so it is wholly air or wholly solid. A whole level
//!    read at once ([`Scope::Level`]) is cut by its walls first (see [`splitter`]).
//! 3. **Inside or outside.** Surfaces face the air (the rendering convention: a floor faces up,
//!    a wall block faces out of the block). A leaf is air when the surface on its faces, by
//!    area, faces into it. A leaf that no surface touches is judged by the generalized winding
//!    number of the room's triangles (Jacobson, Kavan and Sorkine-Hornung 2013), which stays
//!    meaningful where the surface has holes. A room modelled as a solid (its surface facing
//!    out and enclosing more than half of its hull, by the divergence theorem about the hull's
//!    centre) is read the other way round. Rooms of closed solid blocks are read by
//!    `super::blocks` first.
//! 4. **Merge.** Air leaves are merged greedily into maximal convex unions: the pair whose
//!    union is convex (the planes of both that hold every vertex of both enclose no more than
//!    their two volumes) and largest goes first, ties by leaf order.
//!
//! Invariants: every cell is convex, lies inside the room's hull, and is bounded by planes of
//! the room's triangles or of its hull; cells do not overlap; their union is the air of the
//! hull within the tolerance. Limits: a surface that is neither closed nor consistently
//! oriented is read by area-weighted majority, so a few flipped triangles do no harm but a mesh
//! with half its faces flipped is read as a mesh would be rendered, wrongly; leaves thinner than
//! twice the tolerance are dropped as slivers; nothing cuts along the rim of a hole that has no
//! wall, so a room whose floor and ceiling are both open over a neighbour (a walkway around a
//! pit) keeps the space over that neighbour in a cell, unless it is a prism and its plan cuts
//! there ([`super::prism`], tried first).

use std::cmp::Reverse;
use std::collections::BinaryHeap;

use glam::DVec3;
use rayon::prelude::*;

use crate::geom::aabb::Aabb;
use crate::geom::grid::BoxGrid;
use crate::geom::plane::Plane;
use crate::geom::polyhedron::{clip_polygon, overlap, polygon_area, ConvexPolyhedron};
use crate::geom::tolerance::Tolerance;

/// A piece of one room triangle.
#[derive(Debug, Clone)]
struct Frag {
    pts: Vec<DVec3>,
    /// Index into the room's planes.
    plane: u32,
    /// Unit normal towards the air.
    air: DVec3,
}

/// A piece of a reflex edge, on the two planes that meet there.
#[derive(Debug, Clone, Copy)]
struct Seg {
    a: DVec3,
    b: DVec3,
    planes: [u32; 2],
}

/// The room's surface: its planes and its triangles as fragments.
struct Surface {
    planes: Vec<Plane>,
    /// Fragments on a face of the hull (boundary from the start).
    hull_frags: Vec<Frag>,
    /// The other fragments (they split the hull).
    active: Vec<Frag>,
    /// +1 when the triangles face the air, -1 for a room modelled as a solid.
    sense: f64,
    /// Triangles on planes too small to cut by ([`Scope::Level`]'s detail), and a grid
    /// over their boxes.
    detail: Vec<[DVec3; 3]>,
    detail_index: Option<BoxGrid>,
    /// For [`Scope::Level`]: the level's triangles to cast rays at, and its own axes.
    rays: Option<(parry3d_f64::shape::TriMesh, [DVec3; 3])>,
    /// For [`Scope::Level`]: which planes are walls (square to the level's first axis),
    /// by plane index; empty for a tagged room.
    walls: Vec<bool>,
}

/// What the surface read belongs to, one tagged room or a whole level nobody tagged: it decides
/// which side of the surface is air and which planes cut.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Scope {
    /// A tagged room: as rendered, or as a solid when its surface encloses most of its hull.
    Room,
    /// A whole level nobody tagged (`--tags auto`): only as rendered, facing the air, the
    /// convention its voxel air is found by (a closet of six slabs encloses more than half its
    /// hull, which would otherwise read the slabs as the air). Planes whose triangles add up
    /// to less than `detail_area` do not cut, as qbsp's detail brushes do not: a level of
    /// trims, pipes and curved patches would otherwise be cut at every facet. A leaf holding
    /// such detail is air (a surface is drawn there, so a camera sees into it): the cells
    /// grow over the detail, never lose air to it. Its planes square to `axes[0]` (the
    /// direction most of its surface faces along: floors and ceilings) are its walls, and cut
    /// first ([`splitter`]).
    Level { detail_area: f64, axes: [DVec3; 3] },
}

impl Surface {
    /// The BSP's air leaves.
    fn air_leaves(
        &self,
        tris: &[[DVec3; 3]],
        hull: &ConvexPolyhedron,
        eps: f64,
    ) -> Vec<ConvexPolyhedron> {
        let segs = reflex_segments(self, eps);
        let mut leaves: Vec<(ConvexPolyhedron, Vec<Frag>)> = Vec::new();
        split(
            self,
            hull.clone(),
            self.active.clone(),
            self.hull_frags.clone(),
            segs,
            eps,
            &mut leaves,
        );
        // Leaves are judged on their own, in parallel (the order kept): the winding number,
        // a pass over every triangle, is most of a large level's reading (tens of thousands
        // of leaves), and is found once a leaf.
        leaves
            .into_par_iter()
            .filter(|(leaf, boundary)| {
                if thickness(leaf) <= Tolerance::touching(eps) {
                    return false;
                }
                let at = leaf.interior_point();
                let wn = std::cell::OnceCell::new();
                let winding = || *wn.get_or_init(|| winding_number(tris, at));
                ((is_air(leaf, boundary, tris, self.sense) || self.holds_detail(leaf, eps))
                    && (enclosed(leaf, boundary, hull, eps) || -self.sense * winding() > 0.5))
                    || (self.rays_see_air(at, eps) && winding() < 0.5)
            })
            .map(|(leaf, _)| leaf)
            .collect()
    }
}

/// Whether the room's surface holds a leaf more than the leaf opens out of the room: the area
/// of the room's triangles on the leaf's faces against the area of its faces on the room's
/// hull that no triangle covers (faces the BSP cut inside the hull count for neither). A leaf
/// more open than held is the room's only if the room's surface still winds around it (the
/// generalized winding number, as for a leaf no surface touches): a piece of a room beside a
/// wide window is, while a slot between two of the room's open wall meshes that opens onto
/// the next room and the sky (LPortal's BoxRooms door gaps) is not: the portal stage bridges
/// the wall there, as for any wall. (Closed wall blocks are read by `blocks`, where the gap is
/// the room's door reveal.) A closed room has no open face, so this never removes its air.
fn enclosed(leaf: &ConvexPolyhedron, boundary: &[Frag], hull: &ConvexPolyhedron, eps: f64) -> bool {
    let mut covered_on = vec![0.0f64; leaf.faces.len()];
    let mut covered = 0.0;
    for f in boundary {
        let area = polygon_area(&f.pts, f.air);
        covered += area;
        if let Some(k) = leaf
            .faces
            .iter()
            .position(|face| f.pts.iter().all(|p| face.plane.distance(*p).abs() <= eps))
        {
            covered_on[k] += area;
        }
    }
    let open: f64 = leaf
        .faces
        .iter()
        .zip(&covered_on)
        .filter(|(face, _)| {
            hull.faces
                .iter()
                .any(|h| Tolerance::coplanar(&face.plane, &h.plane, Tolerance::touching(eps)))
        })
        .map(|(face, c)| (polygon_area(&face.points, face.plane.normal) - c).max(0.0))
        .sum();
    covered >= open
}

/// The convex cells of the air inside a room's surface. `hull` is the convex hull of `tris`.
/// Returns the hull alone when no triangle lies inside it (a convex room).
///
pub(crate) fn decompose(
    tris: &[[DVec3; 3]],
    hull: &ConvexPolyhedron,
    eps: f64,
    scope: Scope,
) -> Vec<ConvexPolyhedron> {
    let (as_rendered, detail_area) = match scope {
        Scope::Room => (false, 0.0),
        Scope::Level { detail_area, .. } => (true, detail_area),
    };
    // Which way the air lies (see the module docs): a room modelled as a solid encloses most
    // of its hull with its surface facing out; anything else is read as rendered, the air in
    // front of its surfaces (including rooms built of solid wall blocks, which enclose little).
    let centre = hull.interior_point();
    let enclosed: f64 = tris
        .iter()
        .map(|t| (t[0] - centre).dot((t[1] - centre).cross(t[2] - centre)) / 6.0)
        .sum();
    let sense = if enclosed > 0.5 * hull.volume() && !as_rendered {
        -1.0
    } else {
        1.0
    };
    let mut air = Vec::new();
    let senses = if as_rendered {
        &[sense][..]
    } else {
        &[sense, -sense][..]
    };
    for &sense in senses {
        let Some(mut surface) = Surface::new(tris, hull, eps, sense, detail_area) else {
            return vec![hull.clone()];
        };
        if let Scope::Level { axes, .. } = scope {
            surface.rays = crate::geom::ray_mesh::ray_mesh(tris).map(|m| (m, axes));
            surface.walls = (surface.planes.iter())
                .map(|p| p.normal.dot(axes[0]).abs() <= WALL)
                .collect();
        }
        air = surface.air_leaves(tris, hull, eps);
        if !air.is_empty() {
            break;
        }
    }
    if air.is_empty() {
        // Nothing reads as air either way (an unoriented mesh): the hull, as before there was
        // a 3D split, rather than no room at all.
        return vec![hull.clone()];
    }
    merge(air, eps)
}

impl Surface {
    /// `None` when every triangle lies on the hull (the room is convex), or every one inside
    /// it is detail (on a plane of less than `detail_area`).
    fn new(
        tris: &[[DVec3; 3]],
        hull: &ConvexPolyhedron,
        eps: f64,
        sense: f64,
        detail_area: f64,
    ) -> Option<Surface> {
        let on_hull = |t: &[DVec3; 3]| {
            hull.faces.iter().any(|f| {
                t.iter()
                    .all(|p| f.plane.distance(*p).abs() <= Tolerance::touching(eps))
            })
        };
        if tris.iter().all(on_hull) {
            return None;
        }
        let mut planes: Vec<Plane> = Vec::new();
        let mut area: Vec<f64> = Vec::new();
        let mut index = PlaneIndex::default();
        let mut frags: Vec<(Frag, bool)> = Vec::new();
        for t in tris {
            let Some(unit) = unit_normal(t, eps) else {
                continue;
            };
            let id = index.intern(&mut planes, unit, t, eps);
            area.resize(planes.len(), 0.0);
            area[id] += 0.5 * (t[1] - t[0]).cross(t[2] - t[0]).length();
            let frag = Frag {
                pts: t.to_vec(),
                plane: id as u32,
                air: unit * sense,
            };
            frags.push((frag, on_hull(t)));
        }
        let (mut hull_frags, mut active, mut detail) = (Vec::new(), Vec::new(), Vec::new());
        for (frag, on) in frags {
            if on {
                hull_frags.push(frag);
            } else if area[frag.plane as usize] < detail_area {
                detail.push([frag.pts[0], frag.pts[1], frag.pts[2]]);
            } else {
                active.push(frag);
            }
        }
        let detail_index = (!detail.is_empty())
            .then(|| BoxGrid::new(detail.iter().map(Aabb::from_points).collect()));
        (!active.is_empty()).then_some(Surface {
            planes,
            hull_frags,
            active,
            sense,
            detail,
            detail_index,
            rays: None,
            walls: Vec::new(),
        })
    }

    /// The voxel air's rule at a leaf's interior point: of the first surfaces met along the
    /// level's six axis directions, more are fronts than backs, and at least two. The space
    /// over a roof whose walls were left out above it (Doom's sky hack) is air by it, as a
    /// ray from a ledge down past the roof's edge crosses it; open sky over the ground alone
    /// is not. Nor is the inside of a closed solid (winding number +1), where the rays may
    /// meet the fronts of other solids overlapping it (the six slabs of a closet): the caller
    /// asks that of the winding number at `at`, a leaf's interior point.
    fn rays_see_air(&self, at: DVec3, eps: f64) -> bool {
        let Some((mesh, axes)) = &self.rays else {
            return false;
        };
        let (mut front, mut back) = (0, 0);
        for dir in axes.iter().flat_map(|a| [*a, -*a]) {
            match first_met(mesh, at, dir, eps) {
                Some(true) => front += 1,
                Some(false) => back += 1,
                None => {}
            }
        }
        crate::auto::air::by_first_hits(front, back)
    }

    /// Whether some detail triangle reaches more than the tolerance into `leaf`.
    fn holds_detail(&self, leaf: &ConvexPolyhedron, eps: f64) -> bool {
        let Some(index) = &self.detail_index else {
            return false;
        };
        index.query(&leaf.bounds(), 0.0).into_iter().any(|i| {
            let t = &self.detail[i];
            let normal = (t[1] - t[0]).cross(t[2] - t[0]).normalize_or_zero();
            let mut pts = t.to_vec();
            for f in &leaf.faces {
                pts = clip_polygon(&pts, f.plane.normal, f.plane.d - eps);
                if pts.len() < 3 {
                    return false;
                }
            }
            polygon_area(&pts, normal) > eps * eps
        })
    }
}

/// Whether the first surface a ray from `at` along `dir` meets faces it (`Some(true)`), turns
/// its back (`Some(false)`), or nothing is met. Surfaces within two tolerances of the first
/// hit are one place, as a two-sided wall's two faces are, and the ray meets the face turned
/// towards it, as the voxel air's lines do (`auto::air`): otherwise the rounding of a turned
/// level picks either face (a turned level read a large leaf as air and a small one not, the
/// other way round from as it is).
fn first_met(mesh: &parry3d_f64::shape::TriMesh, at: DVec3, dir: DVec3, eps: f64) -> Option<bool> {
    use parry3d_f64::bounding_volume::Aabb as ParryAabb;
    use parry3d_f64::query::{Ray, RayCast};
    use parry3d_f64::shape::CompositeShapeRef;
    let ray = Ray::new(at, dir);
    let (i, hit) = CompositeShapeRef(mesh).cast_local_ray_and_get_normal(&ray, f64::MAX, false)?;
    // parry turns the hit's normal towards the ray; the triangle's own says the side.
    let faces = |k: u32| {
        let t = mesh.triangle(k);
        (t.b - t.a).cross(t.c - t.a).dot(dir) < 0.0
    };
    if faces(i) {
        return Some(true);
    }
    let place = Tolerance::touching(eps);
    let p = at + dir * hit.time_of_impact;
    let near = ParryAabb::new(p - DVec3::splat(place), p + DVec3::splat(place));
    let front_there = mesh.bvh().intersect_aabb(&near).any(|k| {
        faces(k)
            && (mesh.triangle(k))
                .cast_local_ray(&ray, hit.time_of_impact + place, false)
                .is_some_and(|t| t >= hit.time_of_impact - place)
    });
    Some(front_there)
}

/// The room's planes by direction: a triangle is looked for among the planes whose normal
/// lies in the same or a neighbouring bin of about a degree (either way round), not among all
/// of them (a big room has thousands of planes).
#[derive(Default)]
pub(super) struct PlaneIndex {
    bins: std::collections::HashMap<[i32; 3], Vec<usize>>,
}

/// A triangle's unit normal, `None` when it has no area to speak of (its mean width under the
/// tolerance): no surface.
pub(super) fn unit_normal(t: &[DVec3; 3], eps: f64) -> Option<DVec3> {
    let n = (t[1] - t[0]).cross(t[2] - t[0]);
    let len = n.length();
    let perimeter = t[0].distance(t[1]) + t[1].distance(t[2]) + t[2].distance(t[0]);
    (len > eps * perimeter).then(|| n / len)
}

impl PlaneIndex {
    const BINS: f64 = 64.0;

    /// The plane of triangle `t` (unit normal `n`): the earliest that holds it, else a new one
    /// through its centroid.
    pub(super) fn intern(
        &mut self,
        planes: &mut Vec<Plane>,
        n: DVec3,
        t: &[DVec3; 3],
        eps: f64,
    ) -> usize {
        if let Some(i) = self.find(planes, n, t, eps) {
            return i;
        }
        let c = (t[0] + t[1] + t[2]) / 3.0;
        planes.push(Plane {
            normal: n,
            d: n.dot(c),
        });
        self.add(n, planes.len() - 1);
        planes.len() - 1
    }

    /// The normal's bin (a plane is filed under its first triangle's normal, and looked for
    /// under both `n` and `-n`).
    fn key(n: DVec3) -> [i32; 3] {
        let q = (n * Self::BINS).floor();
        [q.x as i32, q.y as i32, q.z as i32]
    }

    fn add(&mut self, n: DVec3, id: usize) {
        self.bins.entry(Self::key(n)).or_default().push(id);
    }

    /// The earliest plane holding every corner of `t` within `eps`.
    fn find(&self, planes: &[Plane], n: DVec3, t: &[DVec3; 3], eps: f64) -> Option<usize> {
        let mut best: Option<usize> = None;
        for m in [n, -n] {
            let k = Self::key(m);
            for dx in -1..=1 {
                for dy in -1..=1 {
                    for dz in -1..=1 {
                        let Some(ids) = self.bins.get(&[k[0] + dx, k[1] + dy, k[2] + dz]) else {
                            continue;
                        };
                        for &i in ids {
                            let p = &planes[i];
                            if best.is_none_or(|b| i < b)
                                && p.normal.dot(n).abs() > 0.5
                                && t.iter().all(|q| p.distance(*q).abs() <= eps)
                            {
                                best = Some(i);
                            }
                        }
                    }
                }
            }
        }
        best
    }
}

/// The reflex edges of the surface: where a triangle `g` meets the plane of a triangle `f`
/// along an edge that `f` holds, with `g` behind `f` (on its solid side). Only triangles that
/// share a corner with `g`'s edge are asked: a reflex edge that meets another triangle only
/// along the middle of its side (a T-junction) is not credited, which changes which cut comes
/// first, never whether the cells are right.
fn reflex_segments(s: &Surface, eps: f64) -> Vec<Seg> {
    let frags: Vec<&Frag> = s.active.iter().chain(s.hull_frags.iter()).collect();
    // Triangles meet at shared corners: each corner's neighbours are found through a grid of
    // cells a few tolerances wide (a corner and its copy in the next triangle may differ by
    // the tolerance and straddle a cell boundary, so the 27 cells around are asked).
    let cell = CORNER_CELL * eps;
    let key = |p: DVec3| {
        let q = (p / cell).floor();
        [q.x as i64, q.y as i64, q.z as i64]
    };
    let mut at: std::collections::HashMap<[i64; 3], Vec<u32>> = std::collections::HashMap::new();
    for (i, f) in frags.iter().enumerate() {
        for p in &f.pts {
            at.entry(key(*p)).or_default().push(i as u32);
        }
    }
    let near = |p: DVec3, out: &mut Vec<u32>| {
        let k = key(p);
        for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    if let Some(ids) = at.get(&[k[0] + dx, k[1] + dy, k[2] + dz]) {
                        out.extend_from_slice(ids);
                    }
                }
            }
        }
    };
    let mut out = Vec::new();
    let mut candidates: Vec<u32> = Vec::new();
    for g in &frags {
        for k in 0..3 {
            let (a, b, c) = (g.pts[k], g.pts[(k + 1) % 3], g.pts[(k + 2) % 3]);
            if a.distance(b) <= eps {
                continue;
            }
            candidates.clear();
            near(a, &mut candidates);
            near(b, &mut candidates);
            candidates.sort_unstable();
            candidates.dedup();
            for &fi in &candidates {
                let f = frags[fi as usize];
                let p = &s.planes[f.plane as usize];
                if f.plane == g.plane || p.distance(a).abs() > eps || p.distance(b).abs() > eps {
                    continue;
                }
                if f.air.dot(c - a) >= -eps {
                    continue;
                }
                if let Some((x, y)) = clip_segment_to_triangle(a, b, &f.pts, eps) {
                    out.push(Seg {
                        a: x,
                        b: y,
                        planes: [f.plane, g.plane],
                    });
                }
            }
        }
    }
    out
}

/// The part of segment `ab` (on the triangle's plane) within `eps` of the triangle.
fn clip_segment_to_triangle(a: DVec3, b: DVec3, t: &[DVec3], eps: f64) -> Option<(DVec3, DVec3)> {
    let n = (t[1] - t[0]).cross(t[2] - t[0]);
    let (mut lo, mut hi) = (0.0f64, 1.0f64);
    for k in 0..3 {
        let (p, q) = (t[k], t[(k + 1) % 3]);
        let m = n.cross(q - p).try_normalize()?; // points into the triangle
        let (da, db) = (m.dot(a - p) + eps, m.dot(b - p) + eps);
        if da < 0.0 && db < 0.0 {
            return None;
        }
        if da < 0.0 {
            lo = lo.max(da / (da - db));
        } else if db < 0.0 {
            hi = hi.min(da / (da - db));
        }
    }
    let (x, y) = (a + (b - a) * lo, a + (b - a) * hi);
    (hi > lo && x.distance(y) > eps).then_some((x, y))
}

/// Which side of a plane some points lie on.
#[derive(PartialEq)]
enum Side {
    On,
    Back,
    Front,
    Both,
}

fn side(pl: &Plane, pts: &[DVec3], eps: f64) -> Side {
    let (mut back, mut front) = (false, false);
    for p in pts {
        let d = pl.distance(*p);
        back |= d < -eps;
        front |= d > eps;
    }
    match (back, front) {
        (false, false) => Side::On,
        (true, false) => Side::Back,
        (false, true) => Side::Front,
        (true, true) => Side::Both,
    }
}

/// A fragment's parts behind and in front of a plane (pieces without area are dropped).
fn cut(f: &Frag, pl: &Plane, eps: f64) -> (Option<Frag>, Option<Frag>) {
    let piece = |pts: Vec<DVec3>| {
        let keep = pts.len() >= 3 && polygon_area(&pts, f.air) > eps * eps;
        keep.then_some(Frag {
            pts,
            plane: f.plane,
            air: f.air,
        })
    };
    (
        piece(clip_polygon(&f.pts, pl.normal, pl.d)),
        piece(clip_polygon(&f.pts, -pl.normal, -pl.d)),
    )
}

/// A BSP node still to split: its region and the fragments and reflex edges in it.
struct Node {
    region: ConvexPolyhedron,
    active: Vec<Frag>,
    boundary: Vec<Frag>,
    segs: Vec<Seg>,
}

/// The BSP (see the module docs); leaves are pushed back child first. Nodes wait on a stack of
/// their own, not the thread's: a room of thousands of planes can be thousands of cuts deep.
fn split(
    s: &Surface,
    region: ConvexPolyhedron,
    active: Vec<Frag>,
    boundary: Vec<Frag>,
    segs: Vec<Seg>,
    eps: f64,
    leaves: &mut Vec<(ConvexPolyhedron, Vec<Frag>)>,
) {
    let mut stack = vec![Node {
        region,
        active,
        boundary,
        segs,
    }];
    while let Some(node) = stack.pop() {
        match split_node(s, node, eps) {
            Ok([back, front]) => {
                // Front first onto the stack, so the back child comes off first.
                stack.push(front);
                stack.push(back);
            }
            Err(leaf) => leaves.push(leaf),
        }
    }
}

/// One node: its two children, or the leaf it is (its region and boundary fragments).
fn split_node(
    s: &Surface,
    node: Node,
    eps: f64,
) -> Result<[Node; 2], (ConvexPolyhedron, Vec<Frag>)> {
    let Node {
        region,
        mut active,
        mut boundary,
        mut segs,
    } = node;
    // A plane that only grazes the region puts its fragments on the region's boundary; the
    // next plane is then tried.
    let (id, back, front) = loop {
        let Some(id) = splitter(s, &active, &segs, eps) else {
            return Err((region, boundary));
        };
        let pl = s.planes[id as usize];
        match (region.clip(&pl, eps), region.clip(&pl.flipped(), eps)) {
            (Some(back), Some(front)) => break (id, back, front),
            _ => {
                let (on, rest): (Vec<Frag>, Vec<Frag>) =
                    active.into_iter().partition(|f| f.plane == id);
                active = rest;
                boundary.extend(on);
                segs.retain(|g| !g.planes.contains(&id));
            }
        }
    };
    let pl = s.planes[id as usize];
    let mut sides: [(Vec<Frag>, Vec<Frag>, Vec<Seg>); 2] = Default::default();
    for (list, is_active) in [(active, true), (boundary, false)] {
        for f in list {
            // Where a piece goes on its side: an active fragment stays active, a boundary one
            // stays boundary; one on the cut is boundary of both children.
            let keep = |side: &mut (Vec<Frag>, Vec<Frag>, Vec<Seg>), f: Frag| {
                if is_active {
                    side.0.push(f)
                } else {
                    side.1.push(f)
                }
            };
            match side(&pl, &f.pts, eps) {
                Side::On => {
                    sides[0].1.push(f.clone());
                    sides[1].1.push(f);
                }
                Side::Back => keep(&mut sides[0], f),
                Side::Front => keep(&mut sides[1], f),
                Side::Both => {
                    let (b, fr) = cut(&f, &pl, eps);
                    b.into_iter().for_each(|b| keep(&mut sides[0], b));
                    fr.into_iter().for_each(|fr| keep(&mut sides[1], fr));
                }
            }
        }
    }
    for g in segs {
        let (da, db) = (pl.distance(g.a), pl.distance(g.b));
        if da.abs() <= eps && db.abs() <= eps {
            continue; // on the cut: resolved
        }
        if da <= eps && db <= eps {
            sides[0].2.push(g);
        } else if da >= -eps && db >= -eps {
            sides[1].2.push(g);
        } else {
            let x = g.a + (g.b - g.a) * (da / (da - db));
            let (back_end, front_end) = if da < 0.0 { (g.a, g.b) } else { (g.b, g.a) };
            for (k, end) in [(0, back_end), (1, front_end)] {
                if end.distance(x) > eps {
                    sides[k].2.push(Seg { a: end, b: x, ..g });
                }
            }
        }
    }
    let [(ab, bb, sb), (af, bf, sf)] = sides;
    Ok([
        Node {
            region: back,
            active: ab,
            boundary: bb,
            segs: sb,
        },
        Node {
            region: front,
            active: af,
            boundary: bf,
            segs: sf,
        },
    ])
}

/// The width, in tolerances, of the grid cells the surface's corners are found in: a few
/// tolerances, so a corner and its copy in the next triangle (up to a touching distance
/// apart) lie in one cell or in neighbours.
const CORNER_CELL: f64 = 4.0;

/// Reflex lengths within this many tolerances of the best tie: a length is a sum of segments
/// whose ends are each good to the tolerance, so a turned level's copy of the best length
/// comes out a few tolerances off it, and must choose alike.
const TIED_REFLEX: f64 = 4.0;

/// Reflex segments no longer than this many tolerances do not score a plane.
const SHORT_REFLEX: f64 = 64.0;

/// A plane of a level read whole is a wall when its normal is within 3° of square to the
/// level's first axis (sin 3°; the level's frame counts normals within 3° of an axis for it).
const WALL: f64 = 0.052_335_956_242_943_83;

/// The plane to split a node by: the most reflex-edge length, then the fewest fragments cut,
/// then the earliest plane. `None` when no active fragment is left (a leaf).
///
/// A whole level read at once ([`Scope::Level`]) is cut by its walls first: while a wall
/// (a plane square to the level's first axis, the direction its floors and ceilings face
/// along) has a fragment in the node, only walls are candidates. A level's rooms stand on
/// floors and end at walls, and its floors and ceilings lie at a few heights that many rooms
/// share: one such plane gathers the reflex edges (stair nosings, soffits) of every room at
/// its height, so by length alone it came first, and its cut sliced the whole node into a
/// slab at that height, through rooms far from any of its own triangles; the merge then
/// joined slab pieces across doorways into cells of several rooms, each drawn whenever any
/// of it is seen (a merged Doom map drew about a third more than its designer's sectors).
/// Cut by the walls first, a node falls into columns over the level's plan, as the designer's
/// sectors do, and each column is then cut at its own floors and ceilings only (nearly the
/// designer's share, in about half the cells). Walls are found from the level's own frame, so
/// a level turned or moved is cut alike; a tagged room keeps the length rule alone.
fn splitter(s: &Surface, active: &[Frag], segs: &[Seg], eps: f64) -> Option<u32> {
    let mut candidates: Vec<u32> = active.iter().map(|f| f.plane).collect();
    candidates.sort_unstable();
    candidates.dedup();
    if candidates.is_empty() {
        return None;
    }
    if !s.walls.is_empty() && candidates.iter().any(|&p| s.walls[p as usize]) {
        candidates.retain(|&p| s.walls[p as usize]);
    }
    let mut reflex = vec![0.0f64; candidates.len()];
    for g in segs {
        let len = g.a.distance(g.b);
        // A remnant a few tolerances long is rounding, not an edge: scored, it chose the
        // plane by noise (a turned level was split by another plane for a reflex length of a
        // micrometre, and its PVS changed).
        if len <= SHORT_REFLEX * eps {
            continue;
        }
        for p in g.planes {
            if let Ok(k) = candidates.binary_search(&p) {
                reflex[k] += len;
            }
        }
    }
    // Lengths within `TIED_REFLEX` tolerances of the best are equal (a turned level must choose
    // alike).
    let best = reflex.iter().copied().fold(0.0, f64::max);
    let tied: Vec<u32> = candidates
        .iter()
        .zip(&reflex)
        .filter(|(_, r)| **r >= best - TIED_REFLEX * eps)
        .map(|(p, _)| *p)
        .collect();
    if tied.len() == 1 {
        return Some(tied[0]);
    }
    tied.into_iter().min_by_key(|&p| {
        let pl = &s.planes[p as usize];
        let cuts = active
            .iter()
            .filter(|f| side(pl, &f.pts, eps) == Side::Both)
            .count();
        (cuts, p)
    })
}

/// The width of a convex polyhedron across its thinnest face direction.
pub(super) fn thickness(p: &ConvexPolyhedron) -> f64 {
    p.faces
        .iter()
        .map(|f| {
            p.faces
                .iter()
                .flat_map(|g| g.points.iter())
                .map(|q| -f.plane.distance(*q))
                .fold(0.0, f64::max)
        })
        .fold(f64::INFINITY, f64::min)
}

/// Whether a leaf is air: by the surface on its faces, else by the winding number.
fn is_air(leaf: &ConvexPolyhedron, boundary: &[Frag], tris: &[[DVec3; 3]], sense: f64) -> bool {
    let inside = leaf.interior_point();
    let evidence: f64 = boundary
        .iter()
        .map(|f| {
            let c = f.pts.iter().copied().sum::<DVec3>() / f.pts.len() as f64;
            polygon_area(&f.pts, f.air) * f.air.dot(inside - c).signum()
        })
        .sum();
    if evidence != 0.0 {
        return evidence > 0.0;
    }
    // No surface touches the leaf. The winding number is +1 inside a surface facing out, so
    // the air of a surface facing in (sense +1) is where it is -1.
    -sense * winding_number(tris, inside) > 0.5
}

/// The generalized winding number of a triangle soup at `p` (+1 inside a closed surface whose
/// triangles are counter-clockwise seen from outside).
pub(crate) fn winding_number(tris: &[[DVec3; 3]], p: DVec3) -> f64 {
    let mut total = 0.0;
    for t in tris {
        let (a, b, c) = (t[0] - p, t[1] - p, t[2] - p);
        let (la, lb, lc) = (a.length(), b.length(), c.length());
        let num = a.dot(b.cross(c));
        let den = la * lb * lc + a.dot(b) * lc + b.dot(c) * la + c.dot(a) * lb;
        total += 2.0 * num.atan2(den);
    }
    total / (4.0 * std::f64::consts::PI)
}

/// Air leaves merged greedily into maximal convex unions (see the module docs). Candidates
/// come from a grid over the leaves' boxes: a merged cell asks for the leaves its box meets and
/// tries the cells they now belong to.
pub(super) fn merge(mut cells: Vec<ConvexPolyhedron>, eps: f64) -> Vec<ConvexPolyhedron> {
    if cells.len() < 2 {
        return cells;
    }
    let total: f64 = cells.iter().map(|c| c.volume()).sum();
    // Volumes compared on a grid of a millionth of the room's: near-equal volumes are ties.
    let key = |v: f64| (v / total * 1e6).round() as i64;
    let n = cells.len();
    let grid = BoxGrid::new(cells.iter().map(|c| c.bounds()).collect());
    let mut bounds: Vec<Aabb> = cells.iter().map(|c| c.bounds()).collect();
    // The cell each leaf now belongs to, and each cell's leaves.
    let mut owner: Vec<usize> = (0..n).collect();
    let mut members: Vec<Vec<usize>> = (0..n).map(|i| vec![i]).collect();
    let mut version = vec![0u32; n];
    // (volume key, first cell, second cell, their versions when the union was found).
    type Candidate = (i64, Reverse<usize>, Reverse<usize>, u32, u32);
    let mut heap: BinaryHeap<Candidate> = BinaryHeap::new();
    let mut unions: std::collections::HashMap<(usize, usize), ConvexPolyhedron> =
        std::collections::HashMap::new();
    // Pushes every convex union of cell `i` with a cell its box meets.
    let consider =
        |i: usize,
         cells: &[ConvexPolyhedron],
         bounds: &[Aabb],
         owner: &[usize],
         version: &[u32],
         only_later: bool,
         heap: &mut BinaryHeap<Candidate>,
         unions: &mut std::collections::HashMap<(usize, usize), ConvexPolyhedron>| {
            let mut others: Vec<usize> = grid
                .query(&bounds[i], eps)
                .into_iter()
                .map(|leaf| owner[leaf])
                .filter(|&k| k != i && (!only_later || k > i))
                .collect();
            others.sort_unstable();
            others.dedup();
            for k in others {
                if !bounds[i].grown(eps).meets(&bounds[k]) {
                    continue;
                }
                if let Some(u) = convex_union(&cells[i], &cells[k], eps) {
                    let (a, b) = (i.min(k), i.max(k));
                    heap.push((
                        key(u.volume()),
                        Reverse(a),
                        Reverse(b),
                        version[a],
                        version[b],
                    ));
                    unions.insert((a, b), u);
                }
            }
        };
    for i in 0..n {
        consider(
            i,
            &cells,
            &bounds,
            &owner,
            &version,
            true,
            &mut heap,
            &mut unions,
        );
    }
    while let Some((_, Reverse(i), Reverse(j), vi, vj)) = heap.pop() {
        if owner[i] != i || owner[j] != j || version[i] != vi || version[j] != vj {
            continue;
        }
        let Some(u) = unions.remove(&(i, j)) else {
            continue;
        };
        bounds[i] = u.bounds();
        cells[i] = u;
        for leaf in std::mem::take(&mut members[j]) {
            owner[leaf] = i;
            members[i].push(leaf);
        }
        version[i] += 1;
        version[j] += 1;
        consider(
            i,
            &cells,
            &bounds,
            &owner,
            &version,
            false,
            &mut heap,
            &mut unions,
        );
    }
    cells
        .into_iter()
        .enumerate()
        .filter_map(|(i, c)| (owner[i] == i).then_some(c))
        .collect()
}

/// The union of two convex polyhedra when it is convex: the planes of either that hold every
/// vertex of both, if they enclose no more than the two volumes (within the tolerance over
/// the union's surface).
fn convex_union(a: &ConvexPolyhedron, b: &ConvexPolyhedron, eps: f64) -> Option<ConvexPolyhedron> {
    let verts: Vec<DVec3> = a
        .faces
        .iter()
        .chain(b.faces.iter())
        .flat_map(|f| f.points.iter().copied())
        .collect();
    let mut planes: Vec<Plane> = Vec::new();
    for f in a.faces.iter().chain(b.faces.iter()) {
        if verts.iter().all(|v| f.plane.distance(*v) <= eps)
            && !planes.iter().any(|p| Tolerance::coplanar(p, &f.plane, eps))
        {
            planes.push(f.plane);
        }
    }
    let bounds = a.bounds().union(&b.bounds());
    let u = ConvexPolyhedron::from_planes(&planes, &bounds, eps)?;
    let area: f64 = u
        .faces
        .iter()
        .map(|f| polygon_area(&f.points, f.plane.normal))
        .sum();
    if u.volume() > a.volume() + b.volume() + Tolerance::touching(eps) * area {
        return None;
    }
    // Every face of the union lies on faces of the two: a wedge missing between them (a
    // sliver of a solid the union would swallow) leaves part of the union's boundary bare,
    // however little volume it has.
    let bare = u.faces.iter().any(|f| {
        let covered: f64 = a
            .faces
            .iter()
            .chain(b.faces.iter())
            .filter(|g| Tolerance::coplanar(&g.plane, &f.plane, eps))
            .map(|g| {
                let part = overlap(&g.points, &f.points, f.plane.normal);
                if part.len() >= 3 {
                    polygon_area(&part, f.plane.normal)
                } else {
                    0.0
                }
            })
            .sum();
        let perimeter: f64 = (0..f.points.len())
            .map(|k| f.points[k].distance(f.points[(k + 1) % f.points.len()]))
            .sum();
        polygon_area(&f.points, f.plane.normal) - covered > Tolerance::touching(eps) * perimeter
    });
    (!bare).then_some(u)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The inward-facing triangles of an axis-aligned box.
    fn box_tris(lo: DVec3, hi: DVec3) -> Vec<[DVec3; 3]> {
        let c = |x: bool, y: bool, z: bool| {
            DVec3::new(
                if x { hi.x } else { lo.x },
                if y { hi.y } else { lo.y },
                if z { hi.z } else { lo.z },
            )
        };
        let quads = [
            [
                c(false, false, false),
                c(false, true, false),
                c(false, true, true),
                c(false, false, true),
            ],
            [
                c(true, false, false),
                c(true, false, true),
                c(true, true, true),
                c(true, true, false),
            ],
            [
                c(false, false, false),
                c(false, false, true),
                c(true, false, true),
                c(true, false, false),
            ],
            [
                c(false, true, false),
                c(true, true, false),
                c(true, true, true),
                c(false, true, true),
            ],
            [
                c(false, false, false),
                c(true, false, false),
                c(true, true, false),
                c(false, true, false),
            ],
            [
                c(false, false, true),
                c(false, true, true),
                c(true, true, true),
                c(true, false, true),
            ],
        ];
        let mut out = Vec::new();
        for q in quads {
            // Each quad is listed counter-clockwise seen from inside the box.
            out.push([q[0], q[1], q[2]]);
            out.push([q[0], q[2], q[3]]);
        }
        out
    }

    #[test]
    fn winding_number_of_a_closed_box() {
        let t = box_tris(DVec3::ZERO, DVec3::ONE);
        // Inward-facing: -1 inside, 0 outside.
        assert!((winding_number(&t, DVec3::splat(0.5)) + 1.0).abs() < 1e-9);
        assert!(winding_number(&t, DVec3::splat(2.0)).abs() < 1e-9);
    }

    #[test]
    fn a_box_room_is_its_hull() {
        let t = box_tris(DVec3::ZERO, DVec3::new(4.0, 3.0, 4.0));
        let pts: Vec<DVec3> = t.iter().flatten().copied().collect();
        let h = crate::geom::hull::hull(&pts, 1e-9).unwrap();
        let cells = decompose(&t, &h, 1e-9, Scope::Room);
        assert_eq!(cells.len(), 1);
        assert!((cells[0].volume() - 48.0).abs() < 1e-9);
    }

    #[test]
    fn segment_clipping_keeps_the_shared_part() {
        let t = [
            DVec3::ZERO,
            DVec3::new(2.0, 0.0, 0.0),
            DVec3::new(0.0, 2.0, 0.0),
        ];
        let (a, b) = clip_segment_to_triangle(
            DVec3::new(-1.0, 0.0, 0.0),
            DVec3::new(1.0, 0.0, 0.0),
            &t,
            1e-9,
        )
        .unwrap();
        assert!(a.distance(DVec3::ZERO) < 1e-6 && b.distance(DVec3::X) < 1e-9);
        assert!(clip_segment_to_triangle(
            DVec3::new(3.0, 0.0, 0.0),
            DVec3::new(4.0, 0.0, 0.0),
            &t,
            1e-9
        )
        .is_none());
    }
}
