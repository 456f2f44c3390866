//! The level's opaque triangles, and their shadows on a cell face: what blocks sight through
//! the region two faces share.
//!
//! On a big level this is the portals stage's inner loop (every face pair two cells share asks
//! for the triangles near it, a hundred and more on a floor), so nothing here allocates per
//! triangle: candidates and shadows go into buffers the caller keeps between face pairs.
//!
//! The blocking triangles are kept as indexed world vertices in eight `geom/grid.rs` grids, built
//! beside the cell pairs. A triangle goes in the grid of the axes whose slabs it cannot shadow (its
//! normal at exactly a right angle to the axis and wider along it than any slab), and a slab across
//! an axis skips those grids; a test holds the shadows to a plain pass over every triangle. For a
//! face pair the grids are asked for the box around the slab over the shared region, each triangle
//! offered is boxed and clipped in one pass, and only the shadows kept are sorted back into scene
//! order (the order the booleans and exact vertices depend on). A triangle crossing a face's
//! tolerance slab at more than a degree casts no shadow (its part inside is a strip as wide as the
//! tolerance makes it); one lying within a degree of the slab's planes, across them or beside them
//! within a thousandth of the face's size (`NEAR`), casts all of itself (its part inside would be a
//! strip as wide as its distance over the angle's sine).

use std::collections::HashSet;

use glam::{DVec2, DVec3};
use rayon::prelude::*;

use crate::cells::CellSet;
use crate::geom::aabb::Aabb;
use crate::geom::boolean2::signed_area;
use crate::geom::grid::{BoxGrid, Marks};
use crate::scene::{NodeId, Scene};
use crate::tags::Tagging;

/// Triangles that block sight, indexed by their bounds. Vertices are stored once in world
/// space and triangles as indices, and the bounds are recomputed when asked: on a big level
/// this is the portals stage's largest allocation (a third of it as [DVec3; 3] and boxes).
///
/// The triangles are indexed in eight grids, by the axes whose slabs can skip them: a
/// triangle whose normal is at exactly a right angle to an axis, and which is wider along
/// that axis than any slab, is never wholly inside a slab across the axis, and if it crosses
/// one it stands at exactly a right angle to it and casts no shadow. A slab across an axis
/// skips the four grids of triangles that it can skip. Two thirds of the triangles near a
/// face pair of an axis-aligned level are of this kind (the floor under a wall, the walls
/// meeting it, the jambs of a door in it).
pub(crate) struct Opaque {
    verts: Vec<DVec3>,
    tris: Vec<[u32; 3]>,
    /// Grid `g` holds the triangles skippable by slabs across the axes whose bits `g` has.
    grids: Vec<BoxGrid>,
    /// The thickest slab triangles may be skipped for.
    thick: f64,
}

/// A face's plane frame: 2D coordinates on the plane, CCW about the normal.
#[derive(Clone, Copy)]
pub(crate) struct Frame2 {
    origin: DVec3,
    u: DVec3,
    v: DVec3,
}

impl Frame2 {
    /// A frame of the plane alone: origin at the foot of the world origin, axes from a world
    /// helper axis. For tests; the pipeline frames faces with [`Frame2::of_face`].
    #[cfg(test)]
    pub fn new(p: &crate::geom::plane::Plane) -> Frame2 {
        let (u, v) = p.basis();
        Frame2 {
            origin: p.normal * p.d,
            u,
            v,
        }
    }

    /// The frame of a face, made from the face alone, so that moving or turning the level
    /// moves it along and the 2D coordinates (and the booleans' grid) stay where they were on
    /// the face: origin at the face's area centroid, `u` along its longest edge (the first
    /// of equally long ones in ring order), `v` completing a frame CCW about the normal. An
    /// axis-aligned room turned off the axes keeps its walls on the grid's axes.
    pub(crate) fn of_face(face: &crate::geom::polyhedron::Face) -> Frame2 {
        let n = face.plane.normal;
        let pts = &face.points;
        let Some(&o) = pts.first() else {
            let (u, v) = face.plane.basis();
            return Frame2 {
                origin: n * face.plane.d,
                u,
                v,
            };
        };
        let (mut area, mut acc) = (0.0, DVec3::ZERO);
        for w in pts[1..].windows(2) {
            let a = (w[0] - o).cross(w[1] - o).dot(n);
            area += a;
            acc += a * (w[0] + w[1] - 2.0 * o) / 3.0;
        }
        let centre = if area.abs() > 0.0 {
            o + acc / area
        } else {
            pts.iter().map(|p| *p - o).sum::<DVec3>() / pts.len() as f64 + o
        };
        // On the plane exactly: the face's points are within the tolerance of it.
        let origin = centre - n * face.plane.distance(centre);
        let mut best: Option<(f64, DVec3)> = None;
        for i in 0..pts.len() {
            let e = pts[(i + 1) % pts.len()] - pts[i];
            let e = e - n * e.dot(n);
            let len = e.length();
            if len > 0.0 && best.is_none_or(|(l, _)| len > l * (1.0 + LONGER)) {
                best = Some((len, e / len));
            }
        }
        let Some((_, u)) = best else {
            let (u, v) = face.plane.basis();
            return Frame2 { origin, u, v };
        };
        Frame2 {
            origin,
            u,
            v: n.cross(u),
        }
    }
    pub(crate) fn to2(&self, p: DVec3) -> DVec2 {
        let d = p - self.origin;
        DVec2::new(d.dot(self.u), d.dot(self.v))
    }
    pub(crate) fn to3(&self, q: DVec2, offset: DVec3) -> DVec3 {
        self.origin + offset + self.u * q.x + self.v * q.y
    }
}

/// The slab a face pair looks through: points with `lo <= n·p <= hi`, projected by `frame`.
pub(crate) struct Slab<'a> {
    pub n: DVec3,
    pub lo: f64,
    pub hi: f64,
    pub frame: &'a Frame2,
    /// Only the tolerance around one plane (a face, or two coplanar faces), not a wall's
    /// thickness: a triangle crossing it steeply touches the plane along a line.
    pub thin: bool,
    /// How far off a thin slab a triangle within a degree of its plane may lie and still lie
    /// on the face (see [`NEAR`]); 0 for thick slabs.
    pub near: f64,
    /// The planes of the other faces of the two cells sharing a thin slab's face, moved out by
    /// the tolerance. A triangle wholly on or in front of one lies outside that cell, and the
    /// face, a part of the cell's boundary, meets it along a line at most: it casts no shadow.
    /// A sliver cell's own side walls lie within a degree of the face it shares with its
    /// neighbour and touch it at the tip; cast whole, they covered most of the face (a Doom
    /// sector's thin wedge).
    pub beyond: &'a [crate::geom::plane::Plane],
}

/// Shadows of the triangles in a slab, as rings in one flat buffer (in triangle order), plus the
/// buffers of the grid query; kept by the caller between face pairs.
#[derive(Default)]
pub(crate) struct Shadows {
    marks: Marks,
    /// Shadows in the order the grid offered their triangles, and (triangle, start, end) of
    /// each in `scratch`.
    scratch: Vec<DVec2>,
    kept: Vec<(u32, usize, usize)>,
    pts: Vec<DVec2>,
    ends: Vec<usize>,
    /// Per ring, the least and greatest height of its triangle along the slab's normal.
    spans: Vec<(f64, f64)>,
}

impl Shadows {
    /// Runs `f` with this thread's buffers, kept from one face pair to the next: a parallel
    /// loop over face pairs is cut into many small jobs (so no thread waits long for the
    /// last), and buffers made per job would be zeroed as often (the marks alone are a bit
    /// per triangle of the level). A call made while the thread's buffers are in use (a job
    /// stolen inside another) gets buffers of its own.
    pub fn with<R>(f: impl FnOnce(&mut Shadows) -> R) -> R {
        thread_local! {
            static MINE: std::cell::RefCell<Shadows> = std::cell::RefCell::new(Shadows::default());
        }
        MINE.with(|mine| match mine.try_borrow_mut() {
            Ok(mut s) => f(&mut s),
            Err(_) => f(&mut Shadows::default()),
        })
    }

    /// Every ring (duplicates kept) with the span of its triangle along the slab's normal:
    /// which of a wall's two faces a shadow lies on.
    pub(crate) fn rings_with_spans(&self) -> impl Iterator<Item = (&[DVec2], (f64, f64))> {
        let starts = std::iter::once(0).chain(self.ends.iter().copied());
        starts
            .zip(self.ends.iter().copied())
            .zip(self.spans.iter().copied())
            .map(|((a, b), span)| (&self.pts[a..b], span))
    }

    /// The rings, in the order of the triangles that cast them, each once: a ring with the
    /// same corners as an earlier one (to the bit, in any order) is left out. A wall between
    /// two rooms is usually modelled from both sides, the same triangles twice; a boolean or a
    /// cover test gives the same answer for one copy as for two, at half the cost.
    pub(crate) fn rings(&self) -> Vec<&[DVec2]> {
        let mut seen: HashSet<[(u64, u64); 5], foldhash::fast::FixedState> =
            HashSet::with_capacity_and_hasher(self.ends.len(), Default::default());
        let mut start = 0;
        let mut out = Vec::with_capacity(self.ends.len());
        for &end in &self.ends {
            let r = &self.pts[start..end];
            start = end;
            // Shadows are convex with at most five corners: their corner set is the ring.
            let mut key = [(u64::MAX, u64::MAX); 5];
            for (k, q) in key.iter_mut().zip(r) {
                *k = (q.x.to_bits(), q.y.to_bits());
            }
            key.sort_unstable();
            if r.len() > 5 || seen.insert(key) {
                out.push(r);
            }
        }
        out
    }
}

/// The nodes whose meshes block sight, with their mesh: every mesh node but portals, ignored,
/// detail, bound and footprint nodes, rooms' detail and `props`.
pub(crate) fn blocking_nodes(
    scene: &Scene,
    tagging: &Tagging,
    props: &[NodeId],
) -> Vec<(NodeId, usize)> {
    let mut skip: HashSet<NodeId> = HashSet::new();
    skip.extend(tagging.portals.iter().map(|p| p.node));
    skip.extend(tagging.ignored.iter().map(|n| n.node));
    skip.extend(tagging.detail.iter().map(|n| n.node));
    skip.extend(tagging.bounds.iter().map(|n| n.node));
    skip.extend(tagging.footprints.iter().map(|n| n.node));
    skip.extend(tagging.rooms.iter().flat_map(|r| r.detail.iter().copied()));
    skip.extend(props.iter().copied());
    scene
        .walk()
        .into_iter()
        .filter(|n| !skip.contains(n))
        .filter_map(|n| Some((n, scene.nodes[n].mesh?)))
        .collect()
}

/// The triangles that block sight, in world space (see `blocking_nodes`).
pub fn blocking_triangles(scene: &Scene, tagging: &Tagging, props: &[NodeId]) -> Vec<[DVec3; 3]> {
    let mut out = Vec::new();
    for (n, m) in blocking_nodes(scene, tagging, props) {
        let world = scene.nodes[n].world;
        let mesh = &scene.meshes[m];
        let winding = scene.winding(n);
        let sky = tagging.sky_triangles(mesh);
        let open = |i: usize| sky.as_ref().is_some_and(|s| s[i]);
        out.extend(mesh.triangles.iter().enumerate().filter_map(|(i, &t)| {
            if open(i) {
                return None;
            }
            let p = winding.order(t).map(|i| {
                mesh.positions
                    .get(i as usize)
                    .map(|p| world.transform_point3(*p))
            });
            Some([p[0]?, p[1]?, p[2]?])
        }));
    }
    out
}

impl Opaque {
    /// `thick`: the thickest slab [`Opaque::shadows`] will be asked about (thicker ones are
    /// answered too, from every grid).
    pub fn new(scene: &Scene, tagging: &Tagging, cells: &CellSet, thick: f64) -> Opaque {
        let blocking = blocking_nodes(scene, tagging, &cells.prop_nodes());
        let meshes = || blocking.iter().map(|&(_, m)| &scene.meshes[m]);
        let mut verts = Vec::with_capacity(meshes().map(|m| m.positions.len()).sum());
        let mut tris = Vec::with_capacity(meshes().map(|m| m.triangles.len()).sum());
        for &(n, m) in &blocking {
            let world = scene.nodes[n].world;
            let mesh = &scene.meshes[m];
            // More than 2^32 vertices cannot come from a glTF (indices are u32) and would not
            // fit in memory as f64 anyway; stop rather than wrap.
            let Ok(base) = u32::try_from(verts.len()) else {
                break;
            };
            verts.extend(mesh.positions.iter().map(|p| world.transform_point3(*p)));
            // In a canonical order: each triangle from its least vertex (winding kept), the
            // mesh's triangles sorted. The shadows come out in this order, and the booleans
            // and the exact vertices put back depend on it (an f32 level's near-duplicate
            // corners), so the same mesh written in another triangle order gives the same
            // openings.
            let start = tris.len();
            // The sky blocks no sight (`Tagging::sky`).
            let sky = tagging.sky_triangles(mesh);
            let open = |i: usize| sky.as_ref().is_some_and(|s| s[i]);
            tris.extend(
                mesh.triangles
                    .iter()
                    .enumerate()
                    .filter(|&(i, _)| !open(i))
                    .map(|(_, t)| {
                        let k = (0..3).min_by_key(|&k| t[k]).unwrap_or(0);
                        [t[k], t[(k + 1) % 3], t[(k + 2) % 3]].map(|i| base + i)
                    }),
            );
            let mine = &mut tris[start..];
            if !mine.is_sorted() {
                mine.sort_unstable();
            }
            // Turned after sorting, so a mirrored instance keeps the original's order.
            let winding = scene.winding(n);
            if winding.mirrored {
                for t in mine.iter_mut() {
                    *t = winding.order(*t);
                }
            }
        }
        Opaque::from_triangles(verts, tris, thick)
    }

    /// Indexes triangles (indices into `verts`, world space).
    fn from_triangles(verts: Vec<DVec3>, tris: Vec<[u32; 3]>, thick: f64) -> Opaque {
        // Margin over the rounding of a slab's thickness and of a triangle's extent.
        let wide = thick * (1.0 + ROUNDING);
        let group: Vec<u8> = tris
            .par_iter()
            .map(|t| skippable_by(&t.map(|v| verts[v as usize]), wide))
            .collect();
        let box_of = |i: u32| tri_box(&verts, &tris[i as usize]);
        let grids: Vec<BoxGrid> = (0..8u8)
            .into_par_iter()
            .map(|g| {
                let group = &group;
                let ids = (0..group.len() as u32).filter(move |&i| group[i as usize] == g);
                BoxGrid::index_ids(ids, box_of)
            })
            .collect();
        Opaque {
            verts,
            tris,
            grids,
            thick,
        }
    }

    fn triangle(&self, i: u32) -> [DVec3; 3] {
        self.tris[i as usize].map(|v| self.verts[v as usize])
    }

    /// Fills `out` with the shadows in `slab` of the triangles whose bounds meet `b`, in scene
    /// order (the order the booleans and exact vertices depend on). Each triangle near `b` is
    /// boxed and clipped in one pass, and only the shadows kept are sorted: most candidates
    /// stand across the slab and cast none.
    pub(crate) fn shadows(&self, b: &Aabb, slab: &Slab, out: &mut Shadows) {
        out.pts.clear();
        out.ends.clear();
        out.spans.clear();
        out.kept.clear();
        out.scratch.clear();
        let Shadows {
            marks,
            kept,
            scratch,
            ..
        } = out;
        let mut each = |i| {
            let t = self.triangle(i);
            if !Aabb::from_points(&t).meets(b) {
                return;
            }
            let start = scratch.len();
            if slab_shadow(&t, slab, scratch) {
                if outside_either(&t, slab.beyond) {
                    scratch.truncate(start);
                } else {
                    kept.push((i, start, scratch.len()));
                }
            }
        };
        let skip = match exact_axis(slab.n) {
            Some(a) if slab.hi - slab.lo <= self.thick => 1 << a,
            _ => 0,
        };
        for (g, grid) in self.grids.iter().enumerate() {
            if g & skip == 0 {
                grid.visit(b, 0.0, marks, &mut each);
            }
        }
        kept.sort_unstable_by_key(|k| k.0);
        for &(i, start, end) in kept.iter() {
            out.pts.extend_from_slice(&out.scratch[start..end]);
            out.ends.push(out.pts.len());
            let d = self.triangle(i).map(|p| slab.n.dot(p));
            out.spans
                .push((d[0].min(d[1]).min(d[2]), d[0].max(d[1]).max(d[2])));
        }
    }
}

/// Whether all of a triangle is on or in front of one of `planes` (see [`Slab::beyond`]).
fn outside_either(t: &[DVec3; 3], planes: &[crate::geom::plane::Plane]) -> bool {
    planes
        .iter()
        .any(|p| t.iter().all(|&v| p.distance(v) >= 0.0))
}

/// The cosine below which a triangle crossing a slab counts as standing at a right angle to
/// it: its shadow is then at most 1e-12 of the slab's thickness wide, so it blocks nothing.
const STANDING: f64 = 1e-12;

/// An edge is longer than another (to pick a face's frame) only by more than this share:
/// edges of one length to rounding keep the first, so the frame does not hang on the last
/// bits of a turned level.
const LONGER: f64 = 1e-9;

/// The margin, as a share, over the rounding of a slab's thickness and of a triangle's
/// extent: an f64 sum loses about 1e-16 of it, far under this and far over nothing.
const ROUNDING: f64 = 1e-9;

/// A triangle tilted further than this (its normal's cosine to the slab's) from a slab's
/// planes stands across it; within it, the triangle lies on them. Standing across a thin
/// slab, its part inside (a strip along the line where it meets the plane, the slab's
/// thickness over tan θ wide: 115 half thicknesses at 1°) is a tolerance's artefact, as wide
/// as the tolerance makes it. Lying, all of it covers (see [`slab_shadow`]). cos 1°: an
/// angle whose tangent is no ratio of small integers, so no slope of a level on an integer
/// grid (a Doom map's 1 in 5) sits on the threshold, to be settled by rounding.
const TILTED: f64 = 0.999_847_695_156_391_2;

/// How far a triangle within a degree of a thin slab's plane may lie beside the slab and still
/// lie on the face, as a share of the face's size: a sightline through the gap between them
/// is within a twentieth of a degree of grazing the face. Modelled levels are that far off
/// their own footprints (walls a few tolerances off a cell's side, a fraction of a millimetre
/// under a stair), further than their coordinates' precision, so no tolerance from the
/// precision closes the gap at every factor, and whether it was closed moved with the
/// tolerance.
pub(crate) const NEAR: f64 = 1e-3;

/// The axis `n` lies on exactly (its other two components zero), if any: then `n·p` is
/// `±p[axis]` to the bit.
fn exact_axis(n: DVec3) -> Option<usize> {
    let zero = n.to_array().map(|c| c == 0.0);
    match zero {
        [false, true, true] => Some(0),
        [true, false, true] => Some(1),
        [true, true, false] => Some(2),
        _ => None,
    }
}

/// The axes whose slabs (at most `wide` thick, their normals exactly on the axis) a triangle
/// casts no shadow on, as bits: those its normal, computed as [`slab_shadow`] computes it,
/// is at exactly a right angle to, and along which it is wider than `wide`. Along such an
/// axis `n·p` is `±p[axis]` exactly, so the triangle is never wholly in the slab, and when it
/// crosses it, it stands.
fn skippable_by(t: &[DVec3; 3], wide: f64) -> u8 {
    let normal = (t[1] - t[0]).cross(t[2] - t[0]);
    if !normal.is_finite() || normal == DVec3::ZERO {
        return 0;
    }
    let b = Aabb::from_points(t);
    let size = b.max - b.min;
    (0..3)
        .filter(|&a| normal[a] == 0.0 && size[a] > wide)
        .fold(0, |m, a| m | 1 << a)
}

fn tri_box(verts: &[DVec3], t: &[u32; 3]) -> Aabb {
    Aabb::from_points(t.iter().map(|&v| &verts[v as usize]))
}

/// Appends to `out` the part of a triangle inside the slab, projected, and says whether it did
/// (a part without area is not appended).
fn slab_shadow(t: &[DVec3; 3], slab: &Slab, out: &mut Vec<DVec2>) -> bool {
    let (n, lo, hi) = (slab.n, slab.lo, slab.hi);
    // Most triangles near a face are wholly on one side of the slab, or wholly in it (then
    // clipping would return them as they are): decided here without clipping.
    let d = t.map(|p| n.dot(p));
    let beside = d.iter().all(|&x| x > hi) || d.iter().all(|&x| -x > -lo);
    if beside && !(d.iter().any(|&x| x <= hi + slab.near) && d.iter().any(|&x| x >= lo - slab.near))
    {
        return false;
    }
    let start = out.len();
    if !beside && d.iter().all(|&x| x <= hi && -x <= -lo) {
        out.extend(t.iter().map(|p| slab.frame.to2(*p)));
    } else {
        // A triangle standing across the slab (a wall on the floor a face pair looks through,
        // the most common candidate by far) casts a shadow as wide as the slab times the cosine
        // of its angle to the slab: nothing, at a right angle to well within f64 rounding.
        let normal = (t[1] - t[0]).cross(t[2] - t[0]);
        let cos = normal.dot(n).abs();
        if cos <= STANDING * normal.length() {
            return false;
        }
        if cos > TILTED * normal.length() {
            // Lying within a degree of the slab's planes, across one of them or beside it
            // within `near`: a wall or floor on the face, modelled a little off it or bent,
            // and all of it covers. Its part within the slab would be a strip as wide as the
            // distance to the plane over the sine of the angle, so it moved with both: a floor
            // rising a few millimetres over half a metre left the rest of a cell's bottom open
            // to the exterior at one tolerance and closed at another.
            out.extend(t.iter().map(|p| slab.frame.to2(*p)));
        } else if beside || slab.thin {
            // Beside the slab, a tilted triangle is not on the face. Through a thin slab
            // (a wall meeting the face at an angle) its part inside is a strip along the line
            // where it meets the plane: an edge, not a cover. Kept, it ate a strip of a few
            // tolerances off the side of an L room's diagonal portal and of Doom sectors'
            // slanted portals, and so the portal's area moved with the tolerance.
            return false;
        } else {
            // A triangle clipped by two planes has at most five corners.
            let mut a = [DVec3::ZERO; 8];
            let mut b = [DVec3::ZERO; 8];
            a[..3].copy_from_slice(t);
            let k = clip_into(&a[..3], n, hi, &mut b);
            if k < 3 {
                return false;
            }
            let k = clip_into(&b[..k], -n, -lo, &mut a);
            if k < 3 {
                return false;
            }
            out.extend(a[..k].iter().map(|p| slab.frame.to2(*p)));
        }
    }
    if signed_area(&out[start..]).abs() > 0.0 {
        true
    } else {
        out.truncate(start);
        false
    }
}

/// [`crate::geom::polyhedron::clip_polygon`] into a fixed buffer (the same arithmetic, so the
/// same points): the part of `poly` with `normal·p <= d`; returns the number of points.
fn clip_into(poly: &[DVec3], normal: DVec3, d: f64, out: &mut [DVec3; 8]) -> usize {
    let mut k = 0;
    for i in 0..poly.len() {
        let a = poly[i];
        let b = poly[(i + 1) % poly.len()];
        let (da, db) = (normal.dot(a) - d, normal.dot(b) - d);
        if da <= 0.0 {
            out[k] = a;
            k += 1;
        }
        if (da < 0.0 && db > 0.0) || (da > 0.0 && db < 0.0) {
            out[k] = a + (b - a) * (da / (da - db));
            k += 1;
        }
    }
    k
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::plane::Plane;
    use crate::geom::polyhedron::clip_polygon;

    /// Deterministic numbers in [0, 1) from `seed`.
    fn numbers(seed: u64) -> impl FnMut() -> f64 {
        let mut rng = crate::rng::SplitMix64::new(seed);
        move || rng.unit()
    }

    /// The fixed-buffer clip gives the points the allocating one gives, for triangles in, across
    /// and touching a slab.
    #[test]
    fn clip_into_matches_clip_polygon() {
        let mut unit = numbers(11);
        let mut r = || unit() * 4.0 - 2.0;
        let n = DVec3::new(0.3, 0.9, -0.1).normalize();
        for _ in 0..2000 {
            let t = [0, 1, 2].map(|_| DVec3::new(r(), r(), r()));
            let (lo, hi) = (-0.25, 0.5);
            let mut want = clip_polygon(&t, n, hi);
            if want.len() >= 3 {
                want = clip_polygon(&want, -n, -lo);
            }
            let mut a = [DVec3::ZERO; 8];
            let mut b = [DVec3::ZERO; 8];
            a[..3].copy_from_slice(&t);
            let k = clip_into(&a[..3], n, hi, &mut b);
            let got: Vec<DVec3> = if k < 3 {
                b[..k].to_vec()
            } else {
                let k2 = clip_into(&b[..k], -n, -lo, &mut a);
                a[..k2].to_vec()
            };
            if want.len() >= 3 && got.len() >= 3 {
                assert_eq!(got, want);
            } else {
                assert!(want.len() < 3 && got.len() < 3);
            }
        }
    }

    /// Skipping the grids a slab cannot be shadowed from changes nothing: every slab's shadows
    /// are those of a plain pass over all the triangles, on a level of walls, floors, thin
    /// jambs and sills and tilted triangles, for slabs along the axes as thick as allowed and
    /// thicker, and off the axes.
    #[test]
    fn skipped_grids_hold_no_shadow() {
        let mut r = numbers(5);
        let mut verts = Vec::new();
        let mut tris = Vec::new();
        let snap = |x: f64| (x * 8.0).round() / 8.0;
        for _ in 0..600 {
            let lo = DVec3::new(snap(r() * 10.0), snap(r() * 6.0), snap(r() * 10.0));
            let axis = (r() * 3.0) as usize % 3;
            // Boxes as thin as a jamb or as wide as a floor, along each axis.
            let mut size = DVec3::new(snap(r() * 3.0), snap(r() * 3.0), snap(r() * 3.0));
            size[axis] = [0.0, 0.125, 0.25, 0.5][(r() * 4.0) as usize % 4];
            let corner = |k: usize| {
                lo + size * DVec3::new((k & 1) as f64, ((k >> 1) & 1) as f64, (k >> 2) as f64)
            };
            let base = verts.len() as u32;
            verts.extend((0..8).map(corner));
            for f in [
                [0, 1, 3, 2],
                [4, 6, 7, 5],
                [0, 4, 5, 1],
                [2, 3, 7, 6],
                [0, 2, 6, 4],
                [1, 5, 7, 3],
            ] {
                tris.push([f[0], f[1], f[2]].map(|k| base + k));
                tris.push([f[0], f[2], f[3]].map(|k| base + k));
            }
            if r() < 0.2 {
                let b = verts.len() as u32;
                verts.extend((0..3).map(|_| lo + DVec3::new(r(), r(), r()) * 2.0));
                tris.push([b, b + 1, b + 2]);
            }
        }
        let thick = 0.5;
        let opaque = Opaque::from_triangles(verts, tris, thick);
        let mut got = Shadows::default();
        let mut checked = 0;
        for q in 0..3000 {
            let n = match q % 7 {
                0 => DVec3::new(1.0, 0.002, -0.001).normalize(),
                k => [DVec3::X, DVec3::Y, DVec3::Z][k % 3] * if k > 3 { -1.0 } else { 1.0 },
            };
            let plane = crate::geom::plane::Plane {
                normal: n,
                d: n.dot(DVec3::new(
                    snap(r() * 10.0),
                    snap(r() * 6.0),
                    snap(r() * 10.0),
                )),
            };
            let frame = Frame2::new(&plane);
            let t = [0.0, 0.125, 0.25, 0.5, 0.75][q % 5];
            let slab = Slab {
                n,
                lo: plane.d - 1e-6,
                hi: plane.d + t + 1e-6,
                frame: &frame,
                thin: t == 0.0,
                near: [0.0, 0.05][q % 2],
                beyond: &[],
            };
            let c = DVec3::new(r() * 10.0, r() * 6.0, r() * 10.0);
            let b = Aabb {
                min: c,
                max: c + DVec3::new(r(), r(), r()) * 4.0,
            };
            opaque.shadows(&b, &slab, &mut got);
            let mut want = Vec::new();
            let mut ends = Vec::new();
            for i in 0..opaque.tris.len() as u32 {
                let t = opaque.triangle(i);
                if Aabb::from_points(&t).meets(&b) && slab_shadow(&t, &slab, &mut want) {
                    ends.push(want.len());
                }
            }
            assert_eq!((&got.pts, &got.ends), (&want, &ends), "query {q}");
            checked += ends.len();
        }
        assert!(checked > 3000, "the queries found shadows: {checked}");
    }

    /// Shadows of a wall's triangles on its own plane are the triangles; a triangle standing
    /// on the plane casts none; one beyond the slab casts none.
    #[test]
    fn shadows_in_a_slab() {
        let plane = Plane {
            normal: DVec3::Z,
            d: 0.0,
        };
        let frame = Frame2::new(&plane);
        let slab = Slab {
            n: DVec3::Z,
            lo: -1e-6,
            hi: 1e-6,
            frame: &frame,
            thin: false,
            near: 0.0,
            beyond: &[],
        };
        let mut out = Vec::new();
        let flat = [DVec3::ZERO, DVec3::X, DVec3::Y];
        assert!(slab_shadow(&flat, &slab, &mut out));
        assert_eq!(out.len(), 3);
        let standing = [DVec3::ZERO, DVec3::X, DVec3::new(0.0, 0.0, 1.0)];
        assert!(!slab_shadow(&standing, &slab, &mut out));
        assert_eq!(out.len(), 3, "a rejected shadow leaves nothing behind");
        let beyond = flat.map(|p| p + DVec3::Z);
        assert!(!slab_shadow(&beyond, &slab, &mut out));
        let crossing = [
            DVec3::new(0.0, 0.0, -1.0),
            DVec3::new(1.0, 0.0, 1.0),
            DVec3::new(0.0, 1.0, 1.0),
        ];
        assert!(slab_shadow(&crossing, &slab, &mut out));
        assert!(out.len() > 3);
    }

    /// A wall crossing a face's thin slab at more than a degree casts nothing; one lying
    /// within a degree of it casts all of itself, across the slab or beside it within `near`,
    /// on a thin slab or a thick one; beside it further off, or tilted, nothing.
    #[test]
    fn walls_lying_on_a_face_cover_it_whole() {
        let plane = Plane {
            normal: DVec3::Z,
            d: 0.0,
        };
        let frame = Frame2::new(&plane);
        let eps = 1e-4;
        let slab = |hi: f64, near: f64| Slab {
            n: DVec3::Z,
            lo: -eps,
            hi: hi + eps,
            frame: &frame,
            thin: hi == 0.0,
            near,
            beyond: &[],
        };
        // A wall through the line x = 4, leaning back over the face at `deg` degrees from its
        // plane and `lift` above it, split along its diagonal as exporters do.
        let wall = |deg: f64, lift: f64| {
            let (s, c) = deg.to_radians().sin_cos();
            let z = DVec3::Z * lift;
            let far = DVec3::new(4.0 - 2.0 * c, 0.0, 2.0 * s) + z;
            let far_top = far + DVec3::Y * 3.0;
            let (a, b) = (DVec3::new(4.0, 0.0, 0.0) + z, DVec3::new(4.0, 3.0, 0.0) + z);
            [[a, b, far_top], [a, far_top, far]]
        };
        let area = |ts: [[DVec3; 3]; 2], slab: &Slab| {
            let mut out = Vec::new();
            let mut total = 0.0;
            for t in ts {
                let start = out.len();
                if slab_shadow(&t, slab, &mut out) {
                    total += signed_area(&out[start..]).abs();
                }
            }
            total
        };
        let (thin, thick) = (slab(0.0, 3e-3), slab(0.25, 3e-3));
        assert_eq!(area(wall(20.0, 0.0), &thin), 0.0, "steep: an edge");
        let whole = 2.0 * 3.0 * 0.5f64.to_radians().cos();
        for (what, lift) in [("across", 0.0), ("beside", 2e-3), ("below", -2e-3)] {
            let got = area(wall(0.5, lift), &thin);
            assert!((got - whole).abs() < 1e-9, "{what}: {got} of {whole}");
        }
        assert_eq!(area(wall(0.5, 4e-3), &thin), 0.0, "beyond `near`");
        assert_eq!(area(wall(0.5, 4e-3), &slab(0.0, 0.0)), 0.0, "no `near`");
        // On a wall's far face, across the slab's far plane, on a thick slab.
        let far = area(wall(0.5, 0.25 - 1e-3), &thick);
        assert!((far - whole).abs() < 1e-9, "{far} of {whole}");
        // Tilted across a thick slab, the part inside.
        let part = area(wall(20.0, 0.0), &thick);
        assert!(part > 0.0 && part < whole, "{part}");
    }
}
