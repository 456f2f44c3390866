//! The air of a room built of solid blocks, as convex cells: the room's hull minus the union
//! of its solids, and of that only what is the room's inside.
//!
//! The way qbsp finds a map's inside (brush CSG, a BSP of the brush faces, the outside filled
//! from the void and from leak portals), with the room's convex hull as the world's box:
//!
//! 1. **BSP.** The hull is split by the planes of the solids' faces and of the room's other
//!    surfaces, until no face lies inside a leaf. A region that lies wholly inside one convex
//!    solid is solid at once and split no further (most of a brush map's volume). The splitter
//!    is chosen among the planes nearest the middle of the node's faces by how few faces it
//!    cuts and how evenly it divides them (as qbsp does, without its preference for axial
//!    planes, so a turned level is cut the same way), ties by plane order, which follows the
//!    canonical triangle order. Each node costs a bounded number of passes over its faces.
//! 2. **Air.** A leaf is air when its inside point lies in no solid (by their planes, or by
//!    the winding number of a solid that is not convex) and no surface on its faces turns its
//!    back on it.
//! 3. **Inside.** Air leaves that share a face (area over the tolerance) are one region. A
//!    region *opens* where a leaf face lies on the hull and no surface of the room covers it.
//!    Regions that do not open (sealed by the solids), regions holding a player start, and
//!    regions a surface of the room faces into are inside. When some region is inside, the
//!    others are the void around the level and make no cells (qbsp's outside fill). When none
//!    is (a leaking room, a room open to the sky, with no start), a region is inside when the
//!    solids hold it over more area than it opens: a roofless room's basin is, the wedge of
//!    void outside an L-shaped building's corner is not. Nothing is decided by volume.
//! 4. **Cells.** The inside leaves are merged into maximal convex unions as for any room.
//!
//! **Gates** (a door's brush, an area portal's or visportal's brush) are volumes of air that
//! something can close: their faces split the BSP like any face but bound nothing, and leaves
//! are merged only with leaves inside the same gates, so each gate's air is cells of its own
//! whose portals the gate can close (qbsp keeps doors out of the world BSP; an engine that
//! closes a door must know which openings it fills).
//!
//! A leak then shows as it does for any room: a cell with an exterior opening, found by
//! `check --sealed` with the path from the player start.

use std::collections::HashMap;

use glam::DVec3;

use super::interior::{merge, thickness, unit_normal, PlaneIndex};
use super::solids::Solid;
use crate::disjoint::DisjointSets;
use crate::geom::aabb::Aabb;
use crate::geom::grid::BoxGrid;
use crate::geom::plane::Plane;
use crate::geom::polyhedron::{clip_polygon, polygon_area, ConvexPolyhedron};

/// A piece of one face of a solid or a surface.
#[derive(Debug, Clone)]
struct Frag {
    pts: Vec<DVec3>,
    plane: u32,
    /// Unit normal towards the air: out of a solid, in front of a surface.
    air: DVec3,
    /// Part of a surface (not of a solid): it covers and seeds what it faces.
    surface: bool,
}

/// What the BSP reads: planes, and the solids by box.
struct Space<'a> {
    planes: Vec<Plane>,
    solids: &'a [Solid],
    grid: BoxGrid,
    eps: f64,
}

/// A leaf of the BSP with the surface fragments on its faces.
struct Leaf {
    region: ConvexPolyhedron,
    surfaces: Vec<Frag>,
}

/// The inside of a block room as convex cells (see the module docs). `solids` are the room's
/// structural solids, `surfaces` its other structural triangles, `hull` the hull of both,
/// `gates` the gates' convex volumes, `seeds` the player starts (all recentred); gaps narrower
/// than `min_opening` (the format's own, see `Scene::min_opening`) join nothing. Each cell
/// comes with the indices of the gates it lies in (none for most). Empty when nothing is
/// inside.
pub(crate) fn decompose(
    solids: &[Solid],
    surfaces: &[[DVec3; 3]],
    hull: &ConvexPolyhedron,
    gates: &[ConvexPolyhedron],
    seeds: &[DVec3],
    min_opening: f64,
    eps: f64,
) -> Vec<(ConvexPolyhedron, Vec<usize>)> {
    let mut index = PlaneIndex::default();
    let mut planes: Vec<Plane> = Vec::new();
    let mut active = Vec::new();
    let mut on_hull: Vec<Frag> = Vec::new();
    let all = solids
        .iter()
        .flat_map(|s| s.tris.iter().map(|t| (t, false)))
        .chain(surfaces.iter().map(|t| (t, true)));
    for (t, surface) in all {
        let Some(unit) = unit_normal(t, eps) else {
            continue;
        };
        let hull_face = hull
            .faces
            .iter()
            .any(|f| t.iter().all(|p| f.plane.distance(*p).abs() <= 2.0 * eps));
        if hull_face && !surface {
            continue; // a solid's face on the hull bounds nothing the hull does not
        }
        let id = index.intern(&mut planes, unit, t, eps);
        let frag = Frag {
            pts: t.to_vec(),
            plane: id as u32,
            air: unit,
            surface,
        };
        if hull_face {
            on_hull.push(frag);
        } else {
            active.push(frag);
        }
    }
    // Air joins air through a face wider than a crack, as the portal stage lets sight through
    // (geom/crack.rs): a tenth of the shortest edge of the room's faces, never under ten
    // tolerances. Leaves that meet along an edge, or across a hairline gap between two blocks
    // that were meant to touch, are not one region.
    let crack = shortest_edge(&active, &on_hull, eps) / 10.0;
    let crack = crack.max(min_opening).max(10.0 * eps);
    // The gates' faces cut, inside the hull, and are neither solid nor surface.
    for g in gates {
        for f in &g.faces {
            let mut pts = f.points.clone();
            for h in &hull.faces {
                pts = clip_polygon(&pts, h.plane.normal, h.plane.d);
            }
            if pts.len() < 3 || polygon_area(&pts, f.plane.normal) <= eps * eps {
                continue;
            }
            if hull
                .faces
                .iter()
                .any(|h| pts.iter().all(|p| h.plane.distance(*p).abs() <= 2.0 * eps))
            {
                continue;
            }
            let t = [pts[0], pts[1], pts[2]];
            let id = index.intern(&mut planes, f.plane.normal, &t, eps);
            active.push(Frag {
                pts,
                plane: id as u32,
                air: f.plane.normal,
                surface: false,
            });
        }
    }
    let space = Space {
        planes,
        solids,
        grid: BoxGrid::new(solids.iter().map(|s| s.bounds).collect()),
        eps,
    };
    let leaves = space.leaves(hull.clone(), active, on_hull.clone());
    let air: Vec<Leaf> = leaves.into_iter().filter(|l| space.is_air(l)).collect();
    let keep = inside(&air, hull, &on_hull, seeds, crack, eps);
    // Leaves grouped by the gates they lie in, merged within each group only.
    let mut groups: std::collections::BTreeMap<Vec<usize>, Vec<ConvexPolyhedron>> =
        Default::default();
    for (l, _) in air.into_iter().zip(keep).filter(|(_, k)| *k) {
        let p = l.region.interior_point();
        let inside_gates: Vec<usize> = (0..gates.len())
            .filter(|&g| gates[g].contains(p, eps))
            .collect();
        groups.entry(inside_gates).or_default().push(l.region);
    }
    groups
        .into_iter()
        .flat_map(|(g, cells)| merge(cells, eps).into_iter().map(move |c| (c, g.clone())))
        .collect()
}

impl Space<'_> {
    /// The BSP's leaves that are not wholly inside one convex solid.
    fn leaves(&self, region: ConvexPolyhedron, active: Vec<Frag>, bound: Vec<Frag>) -> Vec<Leaf> {
        let eps = self.eps;
        let mut out = Vec::new();
        let mut stack = vec![(region, active, bound)];
        while let Some((region, mut active, mut bound)) = stack.pop() {
            if self.inside_one_solid(&region) {
                continue;
            }
            let split = loop {
                let Some(id) = self.splitter(&active) else {
                    break None;
                };
                let pl = self.planes[id as usize];
                match (region.clip(&pl, eps), region.clip(&pl.flipped(), eps)) {
                    (Some(b), Some(f)) => break Some((id, b, f)),
                    _ => {
                        // The plane only grazes the region: its faces lie on the boundary.
                        let (on, rest): (Vec<Frag>, Vec<Frag>) =
                            active.into_iter().partition(|f| f.plane == id);
                        active = rest;
                        bound.extend(on.into_iter().filter(|f| f.surface));
                    }
                }
            };
            let Some((id, back, front)) = split else {
                out.push(Leaf {
                    region,
                    surfaces: bound,
                });
                continue;
            };
            let pl = self.planes[id as usize];
            let mut sides: [(Vec<Frag>, Vec<Frag>); 2] = Default::default();
            for (list, is_active) in [(active, true), (bound, false)] {
                for f in list {
                    let mut put = |k: usize, f: Frag| {
                        if is_active {
                            sides[k].0.push(f)
                        } else {
                            sides[k].1.push(f)
                        }
                    };
                    let (lo, hi) = extent(&pl, &f.pts);
                    if lo >= -eps && hi <= eps {
                        if f.surface {
                            sides[0].1.push(f.clone());
                            sides[1].1.push(f);
                        }
                    } else if hi <= eps {
                        put(0, f);
                    } else if lo >= -eps {
                        put(1, f);
                    } else {
                        for (k, (n, d)) in [(pl.normal, pl.d), (-pl.normal, -pl.d)]
                            .into_iter()
                            .enumerate()
                        {
                            let pts = clip_polygon(&f.pts, n, d);
                            if pts.len() >= 3 && polygon_area(&pts, f.air) > eps * eps {
                                put(k, Frag { pts, ..f.clone() });
                            }
                        }
                    }
                }
            }
            let [(ab, bb), (af, bf)] = sides;
            stack.push((front, af, bf));
            stack.push((back, ab, bb));
        }
        out
    }

    /// Whether every corner of `region` lies in one convex solid.
    fn inside_one_solid(&self, region: &ConvexPolyhedron) -> bool {
        let b = region.bounds();
        self.grid.query(&b, self.eps).into_iter().any(|i| {
            let s = &self.solids[i];
            s.convex
                && s.hull.as_ref().is_some_and(|h| {
                    region
                        .faces
                        .iter()
                        .flat_map(|f| f.points.iter())
                        .all(|p| h.contains(*p, self.eps))
                })
        })
    }

    /// The plane to split by: among the (at most 12) planes nearest the middle of the node's
    /// faces, the one cutting fewest faces and dividing them most evenly; ties by plane order.
    fn splitter(&self, active: &[Frag]) -> Option<u32> {
        let mut candidates: Vec<u32> = active.iter().map(|f| f.plane).collect();
        candidates.sort_unstable();
        candidates.dedup();
        if candidates.len() <= 1 {
            return candidates.first().copied();
        }
        let eps = self.eps;
        let centre = active
            .iter()
            .map(|f| f.pts.iter().copied().sum::<DVec3>() / f.pts.len() as f64)
            .sum::<DVec3>()
            / active.len() as f64;
        const NEAREST: usize = 12;
        if candidates.len() > NEAREST {
            let grid = |x: f64| (x / eps).round() as i64;
            candidates.sort_by_key(|&p| (grid(self.planes[p as usize].distance(centre).abs()), p));
            candidates.truncate(NEAREST);
            candidates.sort_unstable();
        }
        candidates.into_iter().min_by_key(|&p| {
            let pl = &self.planes[p as usize];
            let (mut cuts, mut back, mut front) = (0i64, 0i64, 0i64);
            for f in active {
                let (lo, hi) = extent(pl, &f.pts);
                if lo < -eps && hi > eps {
                    cuts += 1;
                } else if hi <= eps && lo < -eps {
                    back += 1;
                } else if lo >= -eps && hi > eps {
                    front += 1;
                }
            }
            (5 * cuts + (back - front).abs(), p)
        })
    }

    /// Whether a leaf is air: in no solid, and no surface on it faces away.
    fn is_air(&self, leaf: &Leaf) -> bool {
        let eps = self.eps;
        if thickness(&leaf.region) <= 2.0 * eps {
            return false;
        }
        let p = leaf.region.interior_point();
        if surface_evidence(leaf, p) < 0.0 {
            return false;
        }
        let b = Aabb { min: p, max: p };
        !self
            .grid
            .query(&b, eps)
            .into_iter()
            .any(|i| self.solids[i].contains(p, eps))
    }
}

/// The least and greatest signed distance of some points from a plane.
fn extent(pl: &Plane, pts: &[DVec3]) -> (f64, f64) {
    pts.iter()
        .map(|p| pl.distance(*p))
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), d| {
            (lo.min(d), hi.max(d))
        })
}

/// Area of the surfaces on a leaf facing into it, less the area facing away.
fn surface_evidence(leaf: &Leaf, inside: DVec3) -> f64 {
    leaf.surfaces
        .iter()
        .map(|f| {
            let c = f.pts.iter().copied().sum::<DVec3>() / f.pts.len() as f64;
            polygon_area(&f.pts, f.air) * f.air.dot(inside - c).signum()
        })
        .sum()
}

/// The shortest edge longer than `eps` of any face (solids' and surfaces').
fn shortest_edge(a: &[Frag], b: &[Frag], eps: f64) -> f64 {
    a.iter()
        .chain(b)
        .flat_map(|f| {
            (0..f.pts.len()).map(move |k| f.pts[k].distance(f.pts[(k + 1) % f.pts.len()]))
        })
        .filter(|&l| l > eps)
        .fold(f64::INFINITY, f64::min)
}

/// Twice the area over the perimeter: how wide a polygon is on average.
fn mean_width(pts: &[DVec3], normal: DVec3) -> f64 {
    let perimeter: f64 = (0..pts.len())
        .map(|k| pts[k].distance(pts[(k + 1) % pts.len()]))
        .sum();
    2.0 * polygon_area(pts, normal) / perimeter.max(f64::MIN_POSITIVE)
}

/// The part of convex polygon `a` inside convex polygon `b` (both on one plane, `b` wound
/// counter-clockwise about `normal`).
fn overlap(a: &[DVec3], b: &[DVec3], normal: DVec3) -> Vec<DVec3> {
    let mut out = a.to_vec();
    for i in 0..b.len() {
        let (p, q) = (b[i], b[(i + 1) % b.len()]);
        // Outward normal of b's edge pq in the plane.
        let Some(m) = (q - p).cross(normal).try_normalize() else {
            continue;
        };
        out = clip_polygon(&out, m, m.dot(p));
        if out.len() < 3 {
            return Vec::new();
        }
    }
    out
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
            let facing = f.plane.normal.dot(g.plane.normal) < -0.999_999
                && (f.plane.d + g.plane.d).abs() <= 2.0 * eps;
            let common = facing.then(|| overlap(&f.points, &g.points, g.plane.normal))?;
            (common.len() >= 3).then_some((common, f.plane.normal))
        })
    })
}

/// Which air leaves are the room's inside (see the module docs, step 3).
fn inside(
    air: &[Leaf],
    hull: &ConvexPolyhedron,
    on_hull: &[Frag],
    seeds: &[DVec3],
    crack: f64,
    eps: f64,
) -> Vec<bool> {
    let n = air.len();
    let mut parts = DisjointSets::new(n);
    let mut shared = vec![0.0f64; n];
    let grid = BoxGrid::new(air.iter().map(|l| l.region.bounds()).collect());
    for (i, j) in grid.pairs(2.0 * eps) {
        let area: f64 = shared_faces(&air[i].region, &air[j].region, eps)
            .filter(|(common, normal)| mean_width(common, *normal) > crack)
            .map(|(common, normal)| polygon_area(&common, normal))
            .sum();
        if area > eps * eps {
            shared[i] += area;
            shared[j] += area;
            parts.union(i, j);
        }
    }
    // Surfaces on the hull, by the hull face they lie on, cover what they face.
    let mut cover: HashMap<usize, Vec<&Frag>> = HashMap::new();
    for f in on_hull.iter().filter(|f| f.surface) {
        if let Some(k) = hull.faces.iter().position(|h| {
            f.pts
                .iter()
                .all(|p| h.plane.distance(*p).abs() <= 2.0 * eps)
        }) {
            if f.air.dot(hull.faces[k].plane.normal) < 0.0 {
                cover.entry(k).or_default().push(f);
            }
        }
    }
    let (mut open, mut total, mut seeded) = (vec![0.0f64; n], vec![0.0f64; n], vec![false; n]);
    for (i, leaf) in air.iter().enumerate() {
        for f in &leaf.region.faces {
            let area = polygon_area(&f.points, f.plane.normal);
            total[i] += area;
            let Some(k) = hull
                .faces
                .iter()
                .position(|h| h.plane.same_as(&f.plane, 2.0 * eps, 1e-6))
            else {
                continue;
            };
            let covered: f64 = cover.get(&k).map_or(0.0, |list| {
                list.iter()
                    .map(|c| {
                        let part = overlap(&c.pts, &f.points, f.plane.normal);
                        if part.len() >= 3 {
                            polygon_area(&part, f.plane.normal)
                        } else {
                            0.0
                        }
                    })
                    .sum()
            });
            open[i] += (area - covered).max(0.0);
        }
        let p = leaf.region.interior_point();
        seeded[i] =
            surface_evidence(leaf, p) > 0.0 || seeds.iter().any(|s| leaf.region.contains(*s, eps));
    }
    // Per region: open area, held area, seeded.
    let mut regions: HashMap<usize, (f64, f64, bool)> = HashMap::new();
    for i in 0..n {
        let r = parts.find(i);
        let e = regions.entry(r).or_insert((0.0, 0.0, false));
        e.0 += open[i];
        e.1 += (total[i] - shared[i] - open[i]).max(0.0);
        e.2 |= seeded[i];
    }
    let sealed_below = (10.0 * eps).powi(2);
    let is_inside = |&(open, _, seeded): &(f64, f64, bool)| seeded || open <= sealed_below;
    let any_inside = regions.values().any(is_inside);
    (0..n)
        .map(|i| {
            let r = &regions[&parts.find(i)];
            if any_inside {
                is_inside(r)
            } else {
                r.1 > r.0
            }
        })
        .collect()
}
