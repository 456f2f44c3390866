//! Which of the air among solid blocks is whose: regions, occupants and the rules that decide
//! a room's air, each from what lies around the region in question (docs/guide.md, "Rooms
//! built of solid blocks").
//!
//! 1. **Regions.** Air leaves (in no solid) that share a face are joined when the face is wider
//!    than the crack width (its least width across, as qbsp drops a portal with fewer than
//!    three edges longer than its 0.2 units) and no surface lies on it. A region none of whose
//!    leaves is thicker than the crack width is a crack: solid.
//! 2. **Rooms.** A leaf is a room's when it lies in the room's hull (the hull of its solids)
//!    and none of the room's surfaces on its faces turns its back on it. A leaf in several
//!    rooms' hulls (a door reveal whose wall only one room lists) goes to the room whose own
//!    blocks frame the leaves of its kind there over the most area, then to the room of the
//!    smaller hull, then to the room first by name.
//! 3. **Occupants**, as qbsp's outside fill: the regions an occupant (a player start, a brush
//!    map's point entity, a node tagged `occupant`) stands in are reached. A room that owns a
//!    reached leaf is occupied; its air is the reached leaves it owns, and what no occupant
//!    reaches is filled: sealed pockets (reported with their volume) and the void.
//! 4. **Rooms no occupant reaches** are read region by region, each by itself: a region
//!    sealed by the blocks (no opening wider than a crack) is air; a region that opens is air
//!    when the blocks and the room's surfaces hold it over more area than it opens (a roofless
//!    yard's basin is, the void outside an L-shaped building's corner is not). Nothing is
//!    decided by volume, and no block away from a region changes its verdict.
//!
//! A leak is then what it is for any room: a kept leaf with a face to the outside, which the
//! portal stage finds as an exterior opening and `check --sealed` traces from its occupant.

use glam::DVec3;

use super::bsp::{Frag, Leaf, Owner};
use super::interior::thickness;
use super::solids::Solid;
use crate::disjoint::DisjointSets;
use crate::geom::aabb::Aabb;
use crate::geom::crack::ClosedGaps;
use crate::geom::grid::BoxGrid;
use crate::geom::polyhedron::{overlap, polygon_area, ConvexPolyhedron};
use crate::geom::tolerance::Tolerance;

/// Two air leaves sharing a face.
struct Link {
    a: u32,
    b: u32,
    area: f64,
    /// Wider than a crack and not covered by a surface: air flows through.
    joined: bool,
}

/// A face two air leaves share, as [`Air::new`] finds it, before it becomes a [`Link`].
struct SharedFace {
    /// The two leaves.
    a: usize,
    b: usize,
    area: f64,
    /// Wider than a crack and not covered by a surface: air flows through.
    joined: bool,
    /// The face of `a`, and of `b`, it lies on.
    face_a: usize,
    face_b: usize,
    /// Open but narrower than a crack: the shared polygon and its normal, which may be a
    /// sliver of a wide opening the BSP cut up.
    narrow: Option<(Vec<DVec3>, DVec3)>,
}

impl SharedFace {
    /// Every face two of `leaves` (`grid` over their boxes) share, pair by pair in the
    /// grid's order.
    fn find(leaves: &[Leaf], grid: &BoxGrid, crack: f64, eps: f64) -> Vec<SharedFace> {
        use rayon::prelude::*;
        let pairs = grid.pairs(Tolerance::touching(eps));
        let found: Vec<Vec<SharedFace>> =
            pairs
                .par_iter()
                .map(|&(i, j)| {
                    let (a, b) = (&leaves[i], &leaves[j]);
                    let mut out = Vec::new();
                    for (common, normal) in shared_faces(&a.region, &b.region, eps) {
                        let area = polygon_area(&common, normal);
                        if area <= eps * eps {
                            continue;
                        }
                        let covered = covered_by(&a.surfaces, &common, normal, eps)
                            .max(covered_by(&b.surfaces, &common, -normal, eps));
                        let open = covered < 0.5 * area
                            && deeper_than(&a.region, &common, -normal, Tolerance::touching(eps))
                            && deeper_than(&b.region, &common, normal, Tolerance::touching(eps));
                        let joined = open && least_width(&common, normal) > crack;
                        // A narrow face may be a sliver of a wide opening the BSP cut up.
                        let narrow = (open && !joined).then(|| (common.clone(), normal));
                        out.push(SharedFace {
                            a: i,
                            b: j,
                            area,
                            joined,
                            face_a: face_of(&a.region, normal),
                            face_b: face_of(&b.region, -normal),
                            narrow,
                        });
                    }
                    out
                })
                .collect();
        found.into_iter().flatten().collect()
    }
}

/// The air leaves and how they connect.
pub(super) struct Air<'a> {
    pub leaves: Vec<Leaf>,
    links: Vec<Link>,
    /// Links of each leaf (indices into `links`).
    by_leaf: Vec<Vec<u32>>,
    /// Per leaf, per face: the area no other air leaf shares.
    rest: Vec<Vec<f64>>,
    /// Per leaf, per face: whether it lies on the world's boundary, and how much of it the
    /// surfaces lying there cover.
    world: Vec<Vec<Option<f64>>>,
    /// The level-wide region (joined component) of each leaf, and whether it is a crack.
    pub region: Vec<usize>,
    pub thin: Vec<bool>,
    /// The gaps the crack width closed: regions of air thinner than a crack (between blocks),
    /// and pairs of regions that meet only through faces narrower than a crack.
    pub closed: ClosedGaps,
    grid: BoxGrid,
    eps: f64,
    _life: std::marker::PhantomData<&'a ()>,
}

impl<'a> Air<'a> {
    /// Links the air leaves (see step 1 of the module docs). `world_surfaces` are the
    /// surfaces lying on the world's boundary.
    pub fn new(
        leaves: Vec<Leaf>,
        world: &ConvexPolyhedron,
        world_surfaces: &[Frag],
        crack: f64,
        eps: f64,
    ) -> Air<'a> {
        let n = leaves.len();
        let grid = BoxGrid::new(leaves.iter().map(|l| l.region.bounds()).collect());
        let found = SharedFace::find(&leaves, &grid, crack, eps);
        use rayon::prelude::*;
        let mut rest: Vec<Vec<f64>> = leaves
            .iter()
            .map(|l| {
                l.region
                    .faces
                    .iter()
                    .map(|f| polygon_area(&f.points, f.plane.normal))
                    .collect()
            })
            .collect();
        let mut links = Vec::new();
        let mut by_leaf = vec![Vec::new(); n];
        let mut narrow: Vec<(usize, Vec<DVec3>, DVec3)> = Vec::new();
        for shared in found {
            let SharedFace {
                a: i,
                b: j,
                area,
                joined,
                face_a: fa,
                face_b: fb,
                narrow: thin,
            } = shared;
            if let Some((poly, normal)) = thin {
                narrow.push((links.len(), poly, normal));
            }
            rest[i][fa] -= area;
            rest[j][fb] -= area;
            by_leaf[i].push(links.len() as u32);
            by_leaf[j].push(links.len() as u32);
            links.push(Link {
                a: i as u32,
                b: j as u32,
                area,
                joined,
            });
        }
        let on_world: Vec<Vec<Option<f64>>> = leaves
            .par_iter()
            .map(|l| {
                l.region
                    .faces
                    .iter()
                    .map(|f| {
                        world
                            .faces
                            .iter()
                            .any(|w| {
                                Tolerance::coplanar(&w.plane, &f.plane, Tolerance::touching(eps))
                            })
                            .then(|| covered_by(world_surfaces, &f.points, f.plane.normal, eps))
                    })
                    .collect()
            })
            .collect();
        let mut parts = DisjointSets::new(n);
        for l in links.iter().filter(|l| l.joined) {
            parts.union(l.a as usize, l.b as usize);
        }
        join_fragments(&mut links, &narrow, &mut parts, crack, eps);
        let region: Vec<usize> = (0..n).map(|i| parts.find(i)).collect();
        let mut thick = vec![false; n];
        for (i, l) in leaves.iter().enumerate() {
            if thickness(&l.region) > crack {
                thick[region[i]] = true;
            }
        }
        let thin: Vec<bool> = (0..n).map(|i| !thick[region[i]]).collect();
        let closed = closed_gaps(&leaves, &links, &narrow, (&region, &thin), crack, eps);
        Air {
            leaves,
            links,
            by_leaf,
            rest,
            world: on_world,
            region,
            thin,
            closed,
            grid,
            eps,
            _life: std::marker::PhantomData,
        }
    }

    /// The air leaf holding a point, if any (the first by leaf order).
    pub fn leaf_at(&self, p: DVec3) -> Option<usize> {
        let b = Aabb { min: p, max: p };
        self.grid
            .query(&b, self.eps)
            .into_iter()
            .find(|&i| self.leaves[i].region.contains(p, self.eps))
    }

    /// The rooms that may own each leaf (the leaf lies in the room's hull, and none of the
    /// room's surfaces on it turns its back on it), by index into `hulls`.
    pub fn candidates(&self, hulls: &[Option<&ConvexPolyhedron>]) -> Vec<Vec<u32>> {
        use rayon::prelude::*;
        let ids: Vec<u32> = (0..hulls.len() as u32)
            .filter(|&r| hulls[r as usize].is_some())
            .collect();
        let grid = BoxGrid::index_ids(ids.iter().copied(), |r| {
            hulls[r as usize].map_or(Aabb::EMPTY, |h| h.bounds())
        });
        self.leaves
            .par_iter()
            .enumerate()
            .map(|(i, l)| {
                if self.thin[i] {
                    return Vec::new();
                }
                let p = l.region.interior_point();
                grid.query_by(&l.region.bounds(), self.eps, |r| {
                    hulls[r].map_or(Aabb::EMPTY, |h| h.bounds())
                })
                .into_iter()
                .filter(|&r| hulls[r].is_some_and(|h| h.contains(p, self.eps)))
                .filter(|&r| evidence(l, r as u32, p) >= 0.0)
                .map(|r| r as u32)
                .collect()
            })
            .collect()
    }

    /// One owner per leaf (see step 2 of the module docs): `frame(leaf, room)` is the area of
    /// the leaf's faces on the room's own blocks and surfaces; `size` and `rank` break ties
    /// (the room of the smaller hull, then the lower rank).
    pub fn owners(
        &self,
        candidates: &[Vec<u32>],
        size: &[f64],
        rank: &[usize],
        frame: &dyn Fn(usize, u32) -> f64,
    ) -> Vec<Option<u32>> {
        let n = self.leaves.len();
        let mut owner: Vec<Option<u32>> = candidates
            .iter()
            .map(|c| (c.len() == 1).then(|| c[0]))
            .collect();
        // Zones: joined leaves with the same two or more candidates.
        let mut zones = DisjointSets::new(n);
        for l in self.links.iter().filter(|l| l.joined) {
            let (a, b) = (l.a as usize, l.b as usize);
            if candidates[a].len() >= 2 && candidates[a] == candidates[b] {
                zones.union(a, b);
            }
        }
        let mut score: std::collections::BTreeMap<usize, Vec<f64>> = Default::default();
        for i in (0..n).filter(|&i| candidates[i].len() >= 2) {
            let s = score
                .entry(zones.find(i))
                .or_insert_with(|| vec![0.0; candidates[i].len()]);
            for (k, &r) in candidates[i].iter().enumerate() {
                s[k] += frame(i, r);
            }
        }
        let area_key = |a: f64| (a / (self.eps * self.eps).max(f64::MIN_POSITIVE)).round() as i64;
        for i in (0..n).filter(|&i| candidates[i].len() >= 2) {
            let s = &score[&zones.find(i)];
            let best = (0..candidates[i].len()).max_by(|&x, &y| {
                let (rx, ry) = (candidates[i][x] as usize, candidates[i][y] as usize);
                area_key(s[x])
                    .cmp(&area_key(s[y]))
                    .then(size[ry].total_cmp(&size[rx]))
                    .then(rank[ry].cmp(&rank[rx]))
            });
            owner[i] = best.map(|k| candidates[i][k]);
        }
        owner
    }

    /// The leaves reached from some seed leaves through joined faces.
    pub fn flood(&self, seeds: &[usize]) -> Vec<bool> {
        let mut reached = vec![false; self.leaves.len()];
        let mut stack: Vec<usize> = Vec::new();
        for &s in seeds {
            if !self.thin[s] && !reached[s] {
                reached[s] = true;
                stack.push(s);
            }
        }
        while let Some(i) = stack.pop() {
            for &k in &self.by_leaf[i] {
                let l = &self.links[k as usize];
                if !l.joined {
                    continue;
                }
                let j = if l.a as usize == i { l.b } else { l.a } as usize;
                if !reached[j] {
                    reached[j] = true;
                    stack.push(j);
                }
            }
        }
        reached
    }

    /// Whether a level-wide region touches the world's boundary (reaches the void).
    pub fn open_regions(&self) -> Vec<bool> {
        let mut open = vec![false; self.leaves.len()];
        for i in 0..self.leaves.len() {
            if self.world[i]
                .iter()
                .zip(&self.rest[i])
                .any(|(w, r)| w.is_some_and(|cover| *r - cover > self.eps * self.eps))
            {
                open[self.region[i]] = true;
            }
        }
        (0..self.leaves.len())
            .map(|i| open[self.region[i]])
            .collect()
    }

    /// The components of a set of leaves joined among themselves.
    pub fn components(&self, members: &[usize]) -> Vec<Vec<usize>> {
        let mut slot = std::collections::HashMap::new();
        for (k, &i) in members.iter().enumerate() {
            slot.insert(i, k);
        }
        let mut parts = DisjointSets::new(members.len());
        for (k, &i) in members.iter().enumerate() {
            for &li in &self.by_leaf[i] {
                let l = &self.links[li as usize];
                let j = if l.a as usize == i { l.b } else { l.a } as usize;
                if let (true, Some(&kj)) = (l.joined, slot.get(&j)) {
                    parts.union(k, kj);
                }
            }
        }
        let mut groups: std::collections::BTreeMap<usize, Vec<usize>> = Default::default();
        for (k, &i) in members.iter().enumerate() {
            groups.entry(parts.find(k)).or_default().push(i);
        }
        groups.into_values().collect()
    }

    /// How much a set of leaves is held (faces on blocks, surfaces, cracks) and how much it
    /// opens (faces through which air flows out of it, or onto the world's boundary).
    pub fn held_and_open(&self, part: &[usize]) -> (f64, f64) {
        let inside: std::collections::HashSet<usize> = part.iter().copied().collect();
        let (mut held, mut open) = (0.0, 0.0);
        for &i in part {
            for &li in &self.by_leaf[i] {
                let l = &self.links[li as usize];
                let j = if l.a as usize == i { l.b } else { l.a } as usize;
                if inside.contains(&j) {
                    continue;
                }
                if l.joined && !self.thin[j] {
                    open += l.area;
                } else {
                    held += l.area;
                }
            }
            for (w, r) in self.world[i].iter().zip(&self.rest[i]) {
                let r = r.max(0.0);
                match w {
                    Some(cover) => {
                        held += cover.min(r);
                        open += (r - cover).max(0.0);
                    }
                    None => held += r,
                }
            }
        }
        (held, open)
    }

    /// The volume of some leaves.
    pub fn volume(&self, part: &[usize]) -> f64 {
        part.iter().map(|&i| self.leaves[i].region.volume()).sum()
    }

    /// A point inside the largest of some leaves (for reports).
    pub fn point(&self, part: &[usize]) -> DVec3 {
        part.iter()
            .map(|&i| &self.leaves[i].region)
            .max_by(|a, b| a.volume().total_cmp(&b.volume()))
            .map_or(DVec3::ZERO, |r| r.interior_point())
    }
}

/// What the crack width closed among the air (see [`Air::closed`]), in leaf and link order;
/// hairs between blocks meant to touch are not counted (`geom::crack::counts_as_gap`).
fn closed_gaps(
    leaves: &[Leaf],
    links: &[Link],
    narrow: &[(usize, Vec<DVec3>, DVec3)],
    (region, thin): (&[usize], &[bool]),
    crack: f64,
    eps: f64,
) -> ClosedGaps {
    let mut out = ClosedGaps::default();
    // A crack between blocks: its thickest leaf.
    let mut cracks: std::collections::BTreeMap<usize, (f64, DVec3)> = Default::default();
    for (i, l) in leaves.iter().enumerate().filter(|&(i, _)| thin[i]) {
        let t = thickness(&l.region);
        let e = cracks
            .entry(region[i])
            .or_insert((t, l.region.interior_point()));
        if t > e.0 {
            *e = (t, l.region.interior_point());
        }
    }
    // Two regions meeting only through narrow faces: the widest face between them.
    let mut pairs: std::collections::BTreeMap<(usize, usize), (f64, DVec3)> = Default::default();
    for (k, poly, normal) in narrow {
        let l = &links[*k];
        let (ra, rb) = (region[l.a as usize], region[l.b as usize]);
        if l.joined || ra == rb || thin[l.a as usize] || thin[l.b as usize] {
            continue;
        }
        let w = least_width(poly, *normal);
        let at = poly.iter().copied().sum::<DVec3>() / poly.len().max(1) as f64;
        let e = pairs.entry((ra.min(rb), ra.max(rb))).or_insert((w, at));
        if w > e.0 {
            *e = (w, at);
        }
    }
    for (w, at) in cracks.into_values().chain(pairs.into_values()) {
        if crate::geom::crack::counts_as_gap(w, crack, eps) {
            out.add(w, at);
        }
    }
    out
}

/// Joins regions that meet through narrow faces which together make an opening wider than a
/// crack: the BSP may cut one 6 cm hole into slivers between different leaves. The faces
/// between two regions on one plane are united, cracks taken off as the portal stage takes
/// them (`geom/crack.rs`); what is left at least the crack width wide on average joins them.
fn join_fragments(
    links: &mut [Link],
    narrow: &[(usize, Vec<DVec3>, DVec3)],
    parts: &mut DisjointSets,
    crack: f64,
    eps: f64,
) {
    use crate::geom::boolean2::union;
    use crate::geom::crack::without_cracks;
    use crate::geom::plane::Plane;
    loop {
        // Narrow faces by the pair of regions they lie between, then by plane.
        let mut groups: std::collections::BTreeMap<(usize, usize), Vec<usize>> = Default::default();
        for (k, (li, _, _)) in narrow.iter().enumerate() {
            let l = &links[*li];
            let (ra, rb) = (parts.find(l.a as usize), parts.find(l.b as usize));
            if ra != rb {
                groups.entry((ra.min(rb), ra.max(rb))).or_default().push(k);
            }
        }
        let mut changed = false;
        for ((ra, rb), list) in groups {
            if parts.find(ra) == parts.find(rb) || list.len() < 2 {
                continue;
            }
            let mut planes: Vec<(Plane, Vec<usize>)> = Vec::new();
            for k in list {
                let (_, poly, n) = &narrow[k];
                let pl = Plane {
                    normal: *n,
                    d: n.dot(poly[0]),
                };
                match planes.iter_mut().find(|(q, _)| {
                    Tolerance::aligned(q.normal, pl.normal)
                        && poly
                            .iter()
                            .all(|p| q.distance(*p).abs() <= Tolerance::touching(eps))
                }) {
                    Some((_, v)) => v.push(k),
                    None => planes.push((pl, vec![k])),
                }
            }
            for (pl, ks) in planes.iter().filter(|(_, ks)| ks.len() >= 2) {
                let (u, v) = pl.basis();
                let o = narrow[ks[0]].1[0];
                let rings: Vec<Vec<glam::DVec2>> = ks
                    .iter()
                    .map(|&k| {
                        narrow[k]
                            .1
                            .iter()
                            .map(|p| glam::DVec2::new((*p - o).dot(u), (*p - o).dot(v)))
                            .collect()
                    })
                    .collect();
                let wide = union(&rings, eps)
                    .iter()
                    .any(|p| without_cracks(p, crack).is_some_and(|q| q.mean_width() >= crack));
                if wide {
                    for &k in ks {
                        links[narrow[k].0].joined = true;
                    }
                    parts.union(ra, rb);
                    changed = true;
                    break;
                }
            }
        }
        if !changed {
            return;
        }
    }
}

/// Whether the region behind a face polygon, along `into`, is deeper than `depth` somewhere
/// over it. Where two solids' faces meet at a shallow angle their planes lie within the
/// tolerance of each other over a strip (an f32 brush map's faces 0.8 degrees apart, over
/// 14 mm): the BSP cannot part them there, so a leaf on one side touches a wedge of the gap
/// beyond over the strip, where the wedge is thinner than the tolerance. Air does not pass
/// through what is no thicker than the tolerance: in exact arithmetic the two only meet at
/// the wedge's edge. Sampled at the polygon's corners, edge midpoints and centroid.
fn deeper_than(region: &ConvexPolyhedron, poly: &[DVec3], into: DVec3, depth: f64) -> bool {
    let n = poly.len();
    let centroid = poly.iter().copied().sum::<DVec3>() / n.max(1) as f64;
    let samples = poly
        .iter()
        .copied()
        .chain((0..n).map(|i| 0.5 * (poly[i] + poly[(i + 1) % n])))
        .chain(std::iter::once(centroid));
    samples.into_iter().any(|v| {
        let exit = region
            .faces
            .iter()
            .filter(|f| f.plane.normal.dot(into) > 0.0 && !Tolerance::square(f.plane.normal, into))
            .map(|f| -f.plane.distance(v) / f.plane.normal.dot(into))
            .fold(f64::INFINITY, f64::min);
        exit > depth
    })
}

/// Area of a room's surfaces on a leaf facing into it, less the area facing away.
fn evidence(leaf: &Leaf, room: u32, inside: DVec3) -> f64 {
    leaf.surfaces
        .iter()
        .filter(|f| f.owner == Owner::Surface(room))
        .map(|f| {
            let c = f.pts.iter().copied().sum::<DVec3>() / f.pts.len() as f64;
            polygon_area(&f.pts, f.air) * f.air.dot(inside - c).signum()
        })
        .sum()
}

/// The index of the face of `p` whose outward normal is `normal` (the nearest).
fn face_of(p: &ConvexPolyhedron, normal: DVec3) -> usize {
    (0..p.faces.len())
        .max_by(|&a, &b| {
            p.faces[a]
                .plane
                .normal
                .dot(normal)
                .total_cmp(&p.faces[b].plane.normal.dot(normal))
        })
        .unwrap_or(0)
}

/// The area of a convex polygon (`normal` its side) that surface fragments lying on its plane
/// cover, either way round.
fn covered_by(surfaces: &[Frag], poly: &[DVec3], normal: DVec3, eps: f64) -> f64 {
    let Some(&o) = poly.first() else { return 0.0 };
    surfaces
        .iter()
        .filter(|f| {
            Tolerance::aligned(f.air, normal)
                && f.pts
                    .iter()
                    .all(|p| (*p - o).dot(normal).abs() <= Tolerance::touching(eps))
        })
        .map(|f| {
            let part = overlap(&f.pts, poly, normal);
            if part.len() >= 3 {
                polygon_area(&part, normal)
            } else {
                0.0
            }
        })
        .sum()
}

/// Where two convex regions touch face to face: each common polygon (opposite coplanar faces'
/// overlap) with the first region's outward normal.
pub(super) fn shared_faces<'a>(
    a: &'a ConvexPolyhedron,
    b: &'a ConvexPolyhedron,
    eps: f64,
) -> impl Iterator<Item = (Vec<DVec3>, DVec3)> + 'a {
    a.faces.iter().flat_map(move |f| {
        b.faces.iter().filter_map(move |g| {
            let facing = Tolerance::parallel(f.plane.normal, -g.plane.normal)
                && (f.plane.d + g.plane.d).abs() <= Tolerance::touching(eps);
            let common = facing.then(|| overlap(&f.points, &g.points, g.plane.normal))?;
            (common.len() >= 3).then_some((common, f.plane.normal))
        })
    })
}

/// The least width of a convex polygon across (the least, over its edges, of the farthest
/// vertex from the edge's line): a slit 1 mm wide and 3 m long is 1 mm wide, as qbsp's tiny
/// portal test (fewer than three edges longer than its epsilon) sees it.
pub(super) fn least_width(pts: &[DVec3], normal: DVec3) -> f64 {
    let n = pts.len();
    let mut best = f64::INFINITY;
    for i in 0..n {
        let (p, q) = (pts[i], pts[(i + 1) % n]);
        let Some(m) = (q - p).cross(normal).try_normalize() else {
            continue;
        };
        let far = pts
            .iter()
            .map(|v| (*v - p).dot(m).abs())
            .fold(0.0, f64::max);
        best = best.min(far);
    }
    if best.is_finite() {
        best
    } else {
        0.0
    }
}

/// The area of each air leaf's faces lying on a solid's faces, per solid touched: which blocks
/// bound which leaves (ownership, props).
pub(super) fn touching(
    leaf: &Leaf,
    solids: &[Solid],
    near: impl Iterator<Item = usize>,
    eps: f64,
) -> Vec<(usize, f64)> {
    let mut out: Vec<(usize, f64)> = Vec::new();
    let b = leaf.region.bounds();
    for s in near {
        let solid = &solids[s];
        if !solid.bounds.grown(Tolerance::touching(eps)).meets(&b) {
            continue;
        }
        let mut area = 0.0;
        for f in &leaf.region.faces {
            for t in &solid.tris {
                let tn = (t[1] - t[0]).cross(t[2] - t[0]);
                let Some(tn) = tn.try_normalize() else {
                    continue;
                };
                if !Tolerance::parallel(tn, -f.plane.normal)
                    || t.iter()
                        .any(|p| f.plane.distance(*p).abs() > Tolerance::touching(eps))
                {
                    continue;
                }
                let part = overlap(t, &f.points, f.plane.normal);
                if part.len() >= 3 {
                    area += polygon_area(&part, f.plane.normal);
                }
            }
        }
        if area > eps * eps {
            out.push((s, area));
        }
    }
    out
}
