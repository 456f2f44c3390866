//! The space among solid blocks cut into convex leaves, the way qbsp builds its tree: a BSP of
//! the world region over the planes of the solids' faces, of the rooms' surfaces and of cuts
//! (room hulls, gates) that bound nothing but must not straddle a leaf.
//!
//! A region that lies wholly inside one convex solid is solid at once and split no further
//! (most of a brush map's volume). The splitter is chosen among the planes nearest the middle
//! of the node's faces by how few faces it cuts and how evenly it divides them (as qbsp does,
//! without its preference for axial planes, so a turned level is cut the same way), ties by
//! plane order, which follows the canonical order of the faces. Each node costs a bounded
//! number of passes over its faces; big nodes are split on two threads, their leaves joined in
//! the order a single thread makes them.
//!
//! A leaf keeps the surface fragments lying on its faces (a one-sided wall, a floor quad),
//! with the room they belong to: whether a surface faces into a leaf or away is the room's
//! own evidence of where its air is.

use glam::DVec3;

use super::interior::PlaneIndex;
use super::solids::Solid;
use crate::geom::aabb::Aabb;
use crate::geom::grid::BoxGrid;
use crate::geom::plane::Plane;
use crate::geom::polyhedron::{clip_polygon, polygon_area, ConvexPolyhedron};
use crate::geom::tolerance::Tolerance;

/// What a fragment is a piece of.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Owner {
    /// A face of solid `.0`: it bounds air on its front.
    Solid(u32),
    /// A surface of room `.0` (an index into the reading's rooms): air in front of it.
    Surface(u32),
    /// A plane that must cut (a room's hull, a gate) but bounds nothing.
    Cut,
}

/// A piece of one face.
#[derive(Debug, Clone)]
pub(super) struct Frag {
    pub pts: Vec<DVec3>,
    pub plane: u32,
    /// Unit normal towards the air: out of a solid, in front of a surface.
    pub air: DVec3,
    pub owner: Owner,
    /// Its area.
    pub area: f64,
}

/// A leaf of the BSP, with the surface fragments on its faces.
pub(super) struct Leaf {
    pub region: ConvexPolyhedron,
    pub surfaces: Vec<Frag>,
}

/// The faces the BSP splits by, gathered before it runs: their planes (one per plane of the
/// faces, the first face in canonical order giving it) and the fragments.
pub(super) struct Faces<'w> {
    world: &'w ConvexPolyhedron,
    index: PlaneIndex,
    pub planes: Vec<Plane>,
    pub frags: Vec<Frag>,
    eps: f64,
}

impl<'w> Faces<'w> {
    pub fn new(world: &'w ConvexPolyhedron, eps: f64) -> Self {
        Faces {
            world,
            index: PlaneIndex::default(),
            planes: Vec::new(),
            frags: Vec::new(),
            eps,
        }
    }

    /// Whether a polygon lies on a face of the world (it bounds nothing the world does not).
    fn on_world(&self, pts: &[DVec3]) -> bool {
        self.world.faces.iter().any(|f| {
            pts.iter()
                .all(|p| f.plane.distance(*p).abs() <= Tolerance::touching(self.eps))
        })
    }

    /// A face of a solid or a surface (a convex polygon), facing the air with its front. A
    /// face on the world's boundary bounds nothing the world does not: it is returned, not
    /// added (a surface there still covers what it lies on).
    pub fn face(&mut self, pts: &[DVec3], owner: Owner) -> Option<Frag> {
        if pts.len() < 3 {
            return None;
        }
        let t = [pts[0], pts[1], pts[2]];
        let unit = newell(pts).try_normalize()?;
        let perimeter: f64 = (0..pts.len())
            .map(|k| pts[k].distance(pts[(k + 1) % pts.len()]))
            .sum();
        if polygon_area(pts, unit) * 2.0 <= self.eps * perimeter {
            return None;
        }
        let on_world = self.on_world(pts);
        let plane = if on_world {
            0
        } else {
            self.index.intern(&mut self.planes, unit, &t, self.eps) as u32
        };
        let frag = Frag {
            pts: pts.to_vec(),
            plane,
            air: unit,
            owner,
            area: polygon_area(pts, unit),
        };
        if on_world {
            return Some(frag);
        }
        self.frags.push(frag);
        None
    }

    /// A face of a convex volume that only cuts (a room's hull, a gate), clipped to the world.
    pub fn cut(&mut self, pts: &[DVec3], normal: DVec3) {
        let mut pts = pts.to_vec();
        for h in &self.world.faces {
            pts = clip_polygon(&pts, h.plane.normal, h.plane.d);
        }
        if pts.len() < 3 || polygon_area(&pts, normal) <= self.eps * self.eps {
            return;
        }
        if self.on_world(&pts) {
            return;
        }
        let t = [pts[0], pts[1], pts[2]];
        let id = self.index.intern(&mut self.planes, normal, &t, self.eps);
        self.frags.push(Frag {
            area: polygon_area(&pts, normal),
            pts,
            plane: id as u32,
            air: normal,
            owner: Owner::Cut,
        });
    }
}

/// What the BSP reads: the planes, and the solids by box.
pub(super) struct Space<'a> {
    planes: Vec<Plane>,
    solids: &'a [Solid],
    grid: BoxGrid,
    eps: f64,
}

/// Nodes with more fragments than this are split on two threads.
const PARALLEL: usize = 4096;

impl<'a> Space<'a> {
    pub fn new(planes: Vec<Plane>, solids: &'a [Solid], eps: f64) -> Self {
        Space {
            planes,
            solids,
            grid: BoxGrid::new(solids.iter().map(|s| s.bounds).collect()),
            eps,
        }
    }

    /// The leaves of the BSP of `region` that are not wholly inside one convex solid, back
    /// child first.
    pub fn leaves(&self, region: ConvexPolyhedron, active: Vec<Frag>) -> Vec<Leaf> {
        let mut out = Vec::new();
        self.split(region, active, Vec::new(), &mut out);
        out
    }

    fn split(
        &self,
        region: ConvexPolyhedron,
        active: Vec<Frag>,
        bound: Vec<Frag>,
        out: &mut Vec<Leaf>,
    ) {
        let mut stack = vec![(region, active, bound)];
        while let Some((region, active, bound)) = stack.pop() {
            match self.node(region, active, bound) {
                Split::Leaf(leaf) => out.extend(leaf),
                Split::Children([back, front]) if back.1.len() + front.1.len() > PARALLEL => {
                    let (mut b, f) = rayon::join(
                        || {
                            let mut o = Vec::new();
                            self.split(back.0, back.1, back.2, &mut o);
                            o
                        },
                        || {
                            let mut o = Vec::new();
                            self.split(front.0, front.1, front.2, &mut o);
                            o
                        },
                    );
                    b.extend(f);
                    // Leaves already out come before these, those still on the stack after.
                    out.extend(b);
                }
                Split::Children([back, front]) => {
                    stack.push(front);
                    stack.push(back);
                }
            }
        }
    }

    /// One node: its two children, or the leaf it is (none when it lies in one solid).
    fn node(&self, region: ConvexPolyhedron, mut active: Vec<Frag>, mut bound: Vec<Frag>) -> Split {
        let eps = self.eps;
        if self.inside_one_solid(&region) {
            return Split::Leaf(None);
        }
        let (id, back, front) = loop {
            let Some(id) = self.splitter(&region, &active) else {
                return Split::Leaf(Some(Leaf {
                    region,
                    surfaces: bound,
                }));
            };
            let pl = self.planes[id as usize];
            match (region.clip(&pl, eps), region.clip(&pl.flipped(), eps)) {
                (Some(b), Some(f)) => break (id, b, f),
                _ => {
                    // The plane only grazes the region: its faces lie on the boundary.
                    let (on, rest): (Vec<Frag>, Vec<Frag>) =
                        active.into_iter().partition(|f| f.plane == id);
                    active = rest;
                    bound.extend(on.into_iter().filter(is_surface));
                }
            }
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
                    if is_surface(&f) {
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
                        let area = if pts.len() >= 3 {
                            polygon_area(&pts, f.air)
                        } else {
                            0.0
                        };
                        if area > eps * eps {
                            put(
                                k,
                                Frag {
                                    pts,
                                    area,
                                    ..f.clone()
                                },
                            );
                        }
                    }
                }
            }
        }
        let [(ab, bb), (af, bf)] = sides;
        Split::Children([(back, ab, bb), (front, af, bf)])
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

    /// Whether a point lies inside a solid or on one's boundary (within the tolerance).
    pub fn held(&self, p: DVec3) -> bool {
        let b = Aabb { min: p, max: p };
        self.grid
            .query(&b, self.eps)
            .into_iter()
            .any(|i| self.solids[i].holds(p, self.eps))
    }

    /// Whether a point lies inside a solid by more than the tolerance.
    pub fn in_solid(&self, p: DVec3) -> Option<usize> {
        let b = Aabb { min: p, max: p };
        self.grid
            .query(&b, self.eps)
            .into_iter()
            .find(|&i| self.solids[i].contains(p, self.eps))
    }

    /// The plane to split by, among the planes nearest the middle of the node's faces and
    /// the planes carrying the most face area: one whose faces cover at least half of its
    /// section through the node first (a wall, not the side of a door jamb carried across
    /// the room), then, as qbsp scores its planes, the one that cuts the fewest faces for the
    /// most it carries (pieces of faces, as triangles) and divides the rest most evenly; ties
    /// by plane order. (Preferring the most covered plane outright cut brush maps into cells
    /// whose PVS was looser; a wall with a doorway covers less than nine tenths of its section,
    /// and passing it over ran strips through a grid's rooms; scoring the faces carried as
    /// qbsp does, 5 a face against 5 a cut, cut fewer cell pairs but left the PVS looser than
    /// vis's, and 3 a face keeps it tighter.)
    fn splitter(&self, region: &ConvexPolyhedron, active: &[Frag]) -> Option<u32> {
        let mut area: Vec<(u32, f64)> = active.iter().map(|f| (f.plane, f.area)).collect();
        area.sort_unstable_by_key(|(p, _)| *p);
        let mut by_plane: Vec<(u32, f64)> = Vec::new();
        for (p, a) in area {
            match by_plane.last_mut() {
                Some((q, sum)) if *q == p => *sum += a,
                _ => by_plane.push((p, a)),
            }
        }
        if by_plane.len() <= 1 {
            return by_plane.first().map(|(p, _)| *p);
        }
        let eps = self.eps;
        let centre = active
            .iter()
            .map(|f| f.pts.iter().copied().sum::<DVec3>() / f.pts.len() as f64)
            .sum::<DVec3>()
            / active.len() as f64;
        const NEAREST: usize = 12;
        const WIDEST: usize = 12;
        let mut candidates: Vec<u32> = Vec::new();
        if by_plane.len() > NEAREST + WIDEST {
            let grid = |x: f64| (x / eps).round() as i64;
            let mut near: Vec<u32> = by_plane.iter().map(|(p, _)| *p).collect();
            near.sort_by_key(|&p| (grid(self.planes[p as usize].distance(centre).abs()), p));
            candidates.extend(near.into_iter().take(NEAREST));
            let mut wide = by_plane.clone();
            wide.sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(&b.0)));
            candidates.extend(wide.into_iter().take(WIDEST).map(|(p, _)| p));
            candidates.sort_unstable();
            candidates.dedup();
        } else {
            candidates = by_plane.iter().map(|(p, _)| *p).collect();
        }
        let total: f64 = by_plane
            .iter()
            .map(|(_, a)| a)
            .sum::<f64>()
            .max(f64::MIN_POSITIVE);
        let face_area = |p: u32| {
            by_plane
                .binary_search_by_key(&p, |(q, _)| *q)
                .map_or(0.0, |k| by_plane[k].1)
        };
        candidates.into_iter().min_by_key(|&p| {
            let pl = &self.planes[p as usize];
            let section = section_area(region, pl, eps);
            let cover = if section > 0.0 {
                (face_area(p) / section).min(1.0)
            } else {
                0.0
            };
            let (mut cuts, mut back, mut front, mut facing) = (0i64, 0i64, 0i64, 0i64);
            for f in active {
                if f.plane == p {
                    facing += 1;
                    continue;
                }
                let (lo, hi) = extent(pl, &f.pts);
                if lo < -eps && hi > eps {
                    cuts += 1;
                } else if hi <= eps && lo < -eps {
                    back += 1;
                } else if lo >= -eps && hi > eps {
                    front += 1;
                }
            }
            // Ties go to the plane carrying more face area (steps of a millionth of the
            // node's), which the input's order does not change, then to plane order.
            let area = (face_area(p) / total * 1e6).round() as i64;
            (
                cover < 0.5,
                5 * cuts - 3 * facing + (back - front).abs(),
                -area,
                p,
            )
        })
    }
}

/// The area of a convex region's section by a plane (0 when the plane misses it).
fn section_area(region: &ConvexPolyhedron, pl: &Plane, eps: f64) -> f64 {
    let mut pts: Vec<DVec3> = Vec::new();
    for f in &region.faces {
        let n = f.points.len();
        for k in 0..n {
            let (a, b) = (f.points[k], f.points[(k + 1) % n]);
            let (da, db) = (pl.distance(a), pl.distance(b));
            if da.abs() <= eps {
                pts.push(a);
            } else if (da < 0.0) != (db < 0.0) && db.abs() > eps {
                pts.push(a + (b - a) * (da / (da - db)));
            }
        }
    }
    let ring = crate::geom::polyhedron::convex_ring_on_plane(&pts, pl, eps);
    if ring.len() < 3 {
        0.0
    } else {
        polygon_area(&ring, pl.normal)
    }
}

/// A node's outcome.
enum Split {
    Leaf(Option<Leaf>),
    Children([(ConvexPolyhedron, Vec<Frag>, Vec<Frag>); 2]),
}

fn is_surface(f: &Frag) -> bool {
    matches!(f.owner, Owner::Surface(_))
}

/// The least and greatest signed distance of some points from a plane.
pub(super) fn extent(pl: &Plane, pts: &[DVec3]) -> (f64, f64) {
    pts.iter()
        .map(|p| pl.distance(*p))
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), d| {
            (lo.min(d), hi.max(d))
        })
}

/// The normal of a polygon by Newell's method (its length twice the area).
fn newell(pts: &[DVec3]) -> DVec3 {
    let o = pts[0];
    let mut n = DVec3::ZERO;
    for w in pts[1..].windows(2) {
        n += (w[0] - o).cross(w[1] - o);
    }
    n
}
