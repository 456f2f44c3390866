//! Openings between cells (and to the exterior), from the cells' faces and the level's opaque
//! triangles.
//!
//! Cell pairs are found through a grid over their boxes (never all pairs) and visited in the order
//! of the cells' numbers; a pair's faces that are coplanar with opposite normals, or parallel,
//! facing and at most `max_wall_thickness` apart with no third cell in the gap, share the 2D
//! intersection of their polygons. The opaque triangles on the plane (or clipped to the wall slab
//! and projected) are merged and subtracted (`geom/boolean2.rs`, on the face's own grid, 2^-24 of
//! its size) unless `geom/cover.rs` shows them covered (most shared walls, floors and ceilings; an
//! opening the boolean would keep leaves at least 28·eps² uncovered, so skipping changes no
//! portal). Openings thinner than ten tolerances are float noise and dropped; each opening is
//! partitioned into convex pieces (or hulled), and the pieces (and the claims) get the exact input
//! coordinates back, a corner where two input edges cross on their crossing (`geom/exact.rs`). The
//! part of a face that no other cell claims and no triangle covers is an exterior opening.
//!
//! A bridged pair's face claims the shared region minus its holes into the wall (not covered by
//! what lies on that face nor bridged, at least as wide on average as the wall is thick; each
//! shadow carries its triangle's span along the normal, `Shadows::rings_with_spans`, to tell the
//! wall's two faces apart). A cell pair looks only at the faces whose planes come near the other
//! cell's box, and a face pair whose face boxes are further apart than that reach is passed over
//! before projecting. Cell pairs (and cells, for the exterior) go out in jobs of at most 64 with
//! per-thread shadow buffers (`Shadows::with`), so no thread waits long on another's last job; the
//! regions pairs claim on a face are found through an index sorted by cell and face, not pushed one
//! by one.

use rayon::prelude::*;

use glam::{DVec2, DVec3};

use super::opaque::{Frame2, Opaque, Shadows, Slab, NEAR};
use super::{reversed, Portal, PortalSet};
use crate::cells::CellSet;
use crate::config::PortalsConfig;
use crate::geom::aabb::Aabb;
use crate::geom::boolean2::{difference, intersection};
use crate::geom::cover::{is_covered, Remainder};
use crate::geom::exact::ExactVertices;
use crate::geom::grid::BoxGrid;
use crate::geom::partition::{convex_partition, Polygon2};
use crate::geom::plane::Plane;
use crate::geom::polyhedron::{convex_ring_on_plane, polygon_area, usable_polygon};
use crate::scene::Scene;
use crate::tags::Tagging;

/// Whether the boxes of two rings, their points snapped to `grid` as the booleans snap them,
/// overlap with some area. If not, so does not the intersection of the snapped rings.
fn snapped_boxes_overlap(a: &[DVec2], b: &[DVec2], grid: f64) -> bool {
    let bounds = |r: &[DVec2]| {
        r.iter().fold(
            (DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY)),
            |(lo, hi), q| {
                let s = (*q / grid).round();
                (lo.min(s), hi.max(s))
            },
        )
    };
    let ((alo, ahi), (blo, bhi)) = (bounds(a), bounds(b));
    // Not `<=`: a shared edge is no overlap. NaN compares false and keeps the pair.
    !(ahi.x <= blo.x || bhi.x <= alo.x || ahi.y <= blo.y || bhi.y <= alo.y)
}

/// The bounds of some 2D points.
fn ring_bounds<'a>(pts: impl Iterator<Item = &'a DVec2>) -> (DVec2, DVec2) {
    pts.fold(
        (DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY)),
        |(lo, hi), q| (lo.min(*q), hi.max(*q)),
    )
}

/// The length of a box's diagonal in a face's own frame: the face's size, the same wherever the
/// level is moved or turned.
fn diagonal((lo, hi): (DVec2, DVec2)) -> f64 {
    if lo.x <= hi.x && lo.y <= hi.y {
        (hi - lo).length()
    } else {
        0.0
    }
}

/// The booleans' grid on a face: 2^-24 of its size, so that where a face's openings are cut
/// depends on the face alone, not on the tolerance (on a grid of half the tolerance, a door
/// jamb 5e-6 m off plumb was cut at its top corner or at its bottom one as the tolerance
/// went; panda3d). Finer than f32 coordinates on the face; i_overlay's i32 engine holds it.
fn face_grid(ring: &[DVec2]) -> f64 {
    (diagonal(ring_bounds(ring.iter())) * FACE_GRID).max(f64::MIN_POSITIVE)
}

const FACE_GRID: f64 = 1.0 / (1u64 << 24) as f64;

/// A ring without the vertices that lie within `tol` of the chord between their neighbours
/// (and between them along it). The booleans snap to a grid: on a level turned off its axes, a
/// T-junction on a door's edge (a wall tile's corner) comes back a fraction of the grid off the
/// edge, and exact convexity tests then cut a rectangular door in two. Such a vertex moves the
/// outline by less than the tolerance, so it is dropped (tests/metamorphic.rs, random rotation
/// of door_window and arch).
fn drop_near_collinear(ring: &[DVec2], tol: f64) -> Vec<DVec2> {
    let mut r = ring.to_vec();
    let mut i = 0;
    while r.len() > 3 && i < r.len() {
        let n = r.len();
        let (a, b, c) = (r[(i + n - 1) % n], r[i], r[(i + 1) % n]);
        let ac = c - a;
        let len = ac.length();
        let between = (b - a).dot(ac) > 0.0 && (c - b).dot(ac) > 0.0;
        if len > 0.0 && between && (b - a).perp_dot(ac).abs() / len <= tol {
            r.remove(i);
            i = i.saturating_sub(1);
        } else {
            i += 1;
        }
    }
    r
}

/// Each cell's place in an order that does not depend on the order the rooms are listed in:
/// by its room's name, then the room's input order (rooms of one name), then its place among
/// its room's cells (which the cell stage numbers from the room's own geometry).
pub(crate) fn name_rank(cells: &CellSet, tagging: &Tagging) -> Vec<u32> {
    let mut order: Vec<usize> = (0..cells.cells.len()).collect();
    order.sort_by_key(|&c| {
        let r = cells.cells[c].room;
        (tagging.rooms[r].name.as_str(), r, c)
    });
    let mut rank = vec![0u32; order.len()];
    for (k, &c) in order.iter().enumerate() {
        rank[c] = k as u32;
    }
    rank
}

/// Convex pieces of an opening (or its convex hull when the conservative shape is asked for).
/// Vertices within `tol` of a straight edge are dropped first (see [`drop_near_collinear`]).
fn pieces(p: &Polygon2, conservative: bool, tol: f64) -> Vec<Vec<DVec2>> {
    let p = &Polygon2 {
        outer: drop_near_collinear(&p.outer, tol),
        holes: p
            .holes
            .iter()
            .map(|h| drop_near_collinear(h, tol))
            .collect(),
    };
    if conservative {
        let pts: Vec<DVec3> = p.outer.iter().map(|q| DVec3::new(q.x, q.y, 0.0)).collect();
        let ring = convex_ring_on_plane(
            &pts,
            &Plane {
                normal: DVec3::Z,
                d: 0.0,
            },
            0.0,
        );
        return vec![ring.iter().map(|q| DVec2::new(q.x, q.y)).collect()];
    }
    convex_partition(p).unwrap_or_else(|_| vec![p.outer.clone()])
}

pub(crate) fn derive(
    scene: &Scene,
    tagging: &Tagging,
    cells: &CellSet,
    cfg: &PortalsConfig,
    set: &mut PortalSet,
) {
    let k = Limits::new(cells.tolerance.distance, cfg);
    let (eps, min_width, reach) = (k.eps, k.min_width, k.reach);
    // The blockers' index and the cell pairs are built side by side (each is one pass).
    let (opaque, (near_cells, pairs)) = rayon::join(
        || Opaque::new(scene, tagging, cells, reach + 3.0 * eps),
        || cells.pairs_in_order(reach),
    );
    // Each pair's openings are computed in parallel; they are applied in pair order, so the
    // portals are numbered the same whatever the thread count. Pairs differ a lot in cost
    // (most share nothing): in jobs of at most `JOB` pairs no thread is left waiting long
    // for another's last job.
    //
    // A pair's openings are found in the frame of the first cell's faces and carried over to
    // the second's, so which cell goes first is taken from an order of the cells that does
    // not depend on the order the rooms are listed in (their names); numbers follow the
    // cells' (the lower first).
    let rank = &set.cell_rank;
    // Without a rank (a set not made by `portals::build`), the cells' numbers.
    let rank_of = |c: usize| rank.get(c).map_or(c as u64, |&r| u64::from(r));
    let first = |(a, b): (usize, usize)| {
        if rank_of(a) <= rank_of(b) {
            (a, b)
        } else {
            (b, a)
        }
    };
    let mut found: Vec<PairOpenings> = pairs
        .par_iter()
        .with_max_len(JOB)
        .map(|&pair| {
            let (x, y) = first(pair);
            Shadows::with(|shadows| {
                pair_openings(x, y, cells, &opaque, &near_cells, cfg, &k, shadows)
            })
        })
        .collect();
    for (&(a, b), found) in pairs.iter().zip(found.iter_mut()) {
        let internal = cells.cells[a].room == cells.cells[b].room;
        let swapped = first((a, b)).0 != a;
        for (on_x, on_y, nx, area) in std::mem::take(&mut found.portals) {
            // As seen from `a`: its side of the opening and the normal from it to `b`.
            let (on_a, on_b, na) = if swapped {
                (reversed(&on_y), reversed(&on_x), -nx)
            } else {
                (on_x, on_y, nx)
            };
            let i = set.portals.len();
            let back = Portal::plain(b, Some(a), on_b, -na, area, internal, Some(i));
            let polygon = reversed(&on_a);
            set.portals.push(Portal::plain(
                a,
                Some(b),
                polygon,
                na,
                area,
                internal,
                Some(i + 1),
            ));
            set.portals.push(back);
        }
    }
    if !cfg.exterior {
        return;
    }
    // For each cell face, the regions other cells claim (in that face's frame). The claims
    // stay where the pairs put them and are found through a list sorted by cell and face,
    // and within a face by the claiming cell's room name, then its place in its room: the
    // order the claims are cut and unioned in (and their vertices put back) is then the same
    // when the rooms are listed in another order (cell numbers follow the room order).
    let mut claims: Vec<(u32, u32, u64, u32, u32)> = found
        .iter()
        .enumerate()
        .flat_map(|(p, f)| {
            let (a, b) = first(pairs[p]);
            let rank_of = &rank_of;
            f.claims
                .iter()
                .enumerate()
                .map(move |(k, &(cell, face, _))| {
                    let other = if cell == a { b } else { a };
                    (cell as u32, face as u32, rank_of(other), p as u32, k as u32)
                })
        })
        .collect();
    claims.par_sort_unstable();
    let claimed = |c: usize, i: usize| {
        let key = (c as u32, i as u32);
        let from = claims.partition_point(|&(cell, face, ..)| (cell, face) < key);
        claims[from..]
            .iter()
            .take_while(move |&&(cell, face, ..)| (cell, face) == key)
            .map(|&(_, _, _, p, k)| found[p as usize].claims[k as usize].2.as_slice())
    };

    let exterior: Vec<Vec<(Vec<DVec3>, DVec3, f64)>> = cells
        .cells
        .par_iter()
        .enumerate()
        .with_max_len(JOB)
        .map(|(c, cell)| {
            Shadows::with(|shadows| {
                let mut out = Vec::new();
                for (i, face) in cell.poly.faces.iter().enumerate() {
                    let f = Frame2::of_face(face);
                    let ring: Vec<DVec2> = face.points.iter().map(|p| f.to2(*p)).collect();
                    let grid = face_grid(&ring);
                    // Claims first: a face between two rooms is claimed whole by its neighbour,
                    // and then no shadow is needed to know it has no opening to the exterior.
                    let mut left = Remainder::new(&ring, k.grow, k.sliver);
                    for claim in claimed(c, i) {
                        left.cut(claim);
                    }
                    if left.at_most(k.closed) {
                        continue;
                    }
                    let near = NEAR * diagonal(ring_bounds(ring.iter()));
                    let bb = Aabb::from_points(face.points.iter()).grown(eps + near);
                    let d = face.plane.d;
                    let slab = Slab {
                        n: face.plane.normal,
                        lo: d - eps,
                        hi: d + eps,
                        frame: &f,
                        thin: true,
                        near,
                    };
                    opaque.shadows(&bb, &slab, shadows);
                    let mut covered: Vec<&[DVec2]> = claimed(c, i).collect();
                    let claimed_len = covered.len();
                    covered.extend(shadows.rings());
                    for shadow in &covered[claimed_len..] {
                        left.cut(shadow);
                    }
                    if left.at_most(k.closed) {
                        continue;
                    }
                    let whole = intersection(
                        std::slice::from_ref(&ring),
                        std::slice::from_ref(&ring),
                        grid,
                    );
                    let exact = ExactVertices::new(
                        ring.iter()
                            .copied()
                            .chain(covered.iter().flat_map(|r| r.iter()).copied()),
                        grid,
                    )
                    .with_rings(std::iter::once(ring.as_slice()).chain(covered.iter().copied()));
                    for o in difference(&whole, &covered, grid)
                        .iter()
                        .filter(|o| o.mean_width() >= min_width)
                    {
                        for piece in pieces(o, cfg.conservative, eps) {
                            let piece = exact.restore(piece);
                            let pts: Vec<DVec3> =
                                piece.iter().map(|q| f.to3(*q, DVec3::ZERO)).collect();
                            let Some(pts) = usable_polygon(&pts, face.plane.normal, eps) else {
                                continue;
                            };
                            let area = polygon_area(&pts, face.plane.normal);
                            out.push((reversed(&pts), face.plane.normal, area));
                        }
                    }
                }
                out
            })
        })
        .collect();
    crate::free::drop_elsewhere((found, claims, opaque));
    for (c, list) in exterior.into_iter().enumerate() {
        for (polygon, normal, area) in list {
            set.portals
                .push(Portal::plain(c, None, polygon, normal, area, false, None));
        }
    }
}

/// The most cell pairs (or cells) one job of a parallel loop takes.
const JOB: usize = 64;

/// The distances derivation works with, all from the one tolerance.
struct Limits {
    eps: f64,
    /// Openings thinner than this on average are float noise.
    min_width: f64,
    /// Faces this far apart face each other across a wall.
    reach: f64,
    /// A face region with less than this area left once its covers (grown by `grow`) are cut
    /// from it has no opening, and the exact boolean is skipped. An opening `min_width` wide
    /// on average holds a disc of radius min_width / 2 (its area is at most its perimeter
    /// times its inradius), 5·eps; snapping moves it by under eps / 2 and the grown covers
    /// (within grow·√2 of the real ones) eat under 1.5·eps of it, so at least a disc of
    /// radius 3·eps, 28·eps², is left of any opening the boolean would keep.
    closed: f64,
    /// Covers are grown by this much, so an f32 crack between two blockers is not left over.
    grow: f64,
    /// Pieces this small are dropped (and counted) as a region is cut.
    sliver: f64,
}

impl Limits {
    fn new(eps: f64, cfg: &PortalsConfig) -> Limits {
        Limits {
            eps,
            min_width: 10.0 * eps,
            reach: cfg.max_wall_thickness + eps,
            closed: eps * eps,
            grow: eps,
            sliver: eps * eps / 64.0,
        }
    }
}

/// What one pair of cells contributes: the regions of their faces they claim from each other
/// (cell, face, ring in that face's frame), and the openings between them (A's polygon on
/// A's face, B's on B's, A's normal, the area).
#[derive(Default)]
struct PairOpenings {
    claims: Vec<(usize, usize, Vec<DVec2>)>,
    portals: Vec<(Vec<DVec3>, Vec<DVec3>, DVec3, f64)>,
}

/// Whether some point of box `b` is within `pad` of `plane`.
fn plane_meets_box(plane: &Plane, b: &Aabb, pad: f64) -> bool {
    let c = (b.min + b.max) * 0.5;
    let r = ((b.max - b.min) * 0.5).dot(plane.normal.abs());
    let d = plane.distance(c);
    d - r <= pad && d + r >= -pad
}

#[allow(clippy::too_many_arguments)]
fn pair_openings(
    a: usize,
    b: usize,
    cells: &CellSet,
    opaque: &Opaque,
    near_cells: &BoxGrid,
    cfg: &PortalsConfig,
    k: &Limits,
    shadows: &mut Shadows,
) -> PairOpenings {
    let (eps, min_width, reach) = (k.eps, k.min_width, k.reach);
    // Faces this close to opposite are treated as facing each other.
    let cos_tol = (1e-4f64).cos();
    let mut out = PairOpenings::default();
    let ca = &cells.cells[a];
    let cb = &cells.cells[b];
    // Two faces that share a region are nearer each other than the wall reach, plus what a
    // tilt within the angle tolerance (1e-4 rad) can add across either cell, plus snapping;
    // a face whose plane is further than that from the other cell's box is not looked at (a
    // cell pair meets along one or two faces of each, out of six or more).
    let pad = reach + 2.0 * eps + 1e-3 * (ca.bounds.size().length() + cb.bounds.size().length());
    let near = |faces: &[crate::geom::polyhedron::Face], other: &Aabb| -> Vec<usize> {
        (0..faces.len())
            .filter(|&i| plane_meets_box(&faces[i].plane, other, pad))
            .collect()
    };
    let near_b: Vec<(usize, Aabb)> = near(&cb.poly.faces, &ca.bounds)
        .into_iter()
        .map(|i| (i, Aabb::from_points(&cb.poly.faces[i].points)))
        .collect();
    for ia in near(&ca.poly.faces, &cb.bounds) {
        let fa = &ca.poly.faces[ia];
        // Faces whose boxes are more than `pad` apart share nothing: their points are
        // further apart than that, and at most `reach` plus the tilt of it along A's normal,
        // so their shadows on A's plane stay more than 2·eps (four snapping cells) apart and
        // the snapped intersection is empty. Most face pairs of neighbouring cells that face
        // each other are a wall further along the same plane (a diagonal neighbour's).
        let box_a = Aabb::from_points(&fa.points).grown(pad);
        for (ib, box_b) in &near_b {
            let (ib, fb) = (*ib, &cb.poly.faces[*ib]);
            let na = fa.plane.normal;
            if na.dot(fb.plane.normal) > -cos_tol || !box_a.meets(box_b) {
                continue;
            }
            // How far fb is in front of fa, measured at the two faces themselves (each face's
            // centre against the other's plane). `-fb.d - fa.d` measured it at the foot of the
            // world origin: for faces within the angle tolerance of parallel but not exactly,
            // the lever arm from the origin made a door between walls 1e-7 rad apart look like
            // an overlap of -2e-7 m and vanish (tests/stiff.rs, walls_1e7_rad_from_coplanar).
            let centre = |pts: &[DVec3]| pts.iter().copied().sum::<DVec3>() / pts.len() as f64;
            let gap = 0.5
                * (fb.plane.distance(centre(&fa.points)) + fa.plane.distance(centre(&fb.points)));
            if gap < -eps || gap > reach {
                continue;
            }
            let gap = gap.max(0.0);
            let f = Frame2::of_face(fa);
            let ra: Vec<DVec2> = fa.points.iter().map(|p| f.to2(*p)).collect();
            let rb: Vec<DVec2> = fb.points.iter().map(|p| f.to2(*p)).collect();
            let grid = face_grid(&ra);
            // Rings whose boxes, snapped to the boolean's grid, do not overlap with some area
            // have an intersection without area, which the boolean drops: most face pairs of
            // neighbouring cells (a diagonal neighbour's wall is in the same plane, further
            // along it, touching at most along an edge).
            if !snapped_boxes_overlap(&ra, &rb, grid) {
                continue;
            }
            let shared = intersection(std::slice::from_ref(&ra), std::slice::from_ref(&rb), grid);
            if shared.is_empty() {
                continue;
            }
            // A wall is bridged only if no other cell fills the gap (then the faces do
            // not face each other across a wall, but across that cell).
            if gap > eps {
                let big = shared.iter().max_by(|x, y| x.area().total_cmp(&y.area()));
                if let Some(big) = big {
                    let c2 = big.outer.iter().copied().sum::<DVec2>() / big.outer.len() as f64;
                    let mid = f.to3(c2, na * (gap * 0.5));
                    let probe = Aabb { min: mid, max: mid };
                    let filled = near_cells.query(&probe, 0.0).into_iter().any(|k| {
                        k != a && k != b && cells.cells[k].poly.contains_strictly(mid, eps)
                    });
                    if filled {
                        continue;
                    }
                }
            }
            let fb2 = Frame2::of_face(fb);
            // Claims are cut from the faces' other openings and the exterior: with their
            // corners left on the grid, those openings' corners moved with it.
            let exact_shared = ExactVertices::new(ra.iter().chain(rb.iter()).copied(), grid)
                .with_rings([ra.as_slice(), rb.as_slice()]);
            let mut claim = |cell: usize, piece: Vec<DVec2>| {
                if cell == a {
                    out.claims.push((a, ia, piece));
                } else {
                    let back = piece.iter().map(|q| fb2.to2(f.to3(*q, na * gap))).collect();
                    out.claims.push((b, ib, back));
                }
            };
            // Faces on one plane claim all they share: whatever is open there opens onto the
            // other cell. Faces across a wall, below, each what is not a hole into the wall.
            let bridged = gap > eps;
            if !bridged {
                for s in &shared {
                    let piece = exact_shared.restore(s.outer.clone());
                    claim(a, piece.clone());
                    claim(b, piece);
                }
            }
            // What blocks: everything on the plane, or inside the wall slab, within 2·eps of
            // the shared region: the others (the next room's wall, in the same plane past the
            // corner) leave the same region open, and none of their points is near enough to
            // be put back as an exact vertex. The grid is asked for the box around that part
            // of the slab, which holds every triangle whose shadow can be kept (a long wall
            // shared with a short room's asks for the short room's part only).
            let (lo, hi) = (fa.plane.d - eps, fa.plane.d + gap + eps);
            let (slo, shi) = ring_bounds(shared.iter().flat_map(|s| s.outer.iter()));
            let thin = gap <= eps;
            let beside = NEAR * diagonal((slo, shi));
            let reach = 2.0 * eps;
            let (slo, shi) = (slo - DVec2::splat(reach), shi + DVec2::splat(reach));
            let mut near = Aabb::EMPTY;
            for t in [-eps - beside, gap + eps + beside] {
                for c in [slo, DVec2::new(shi.x, slo.y), shi, DVec2::new(slo.x, shi.y)] {
                    near.add(f.to3(c, na * t));
                }
            }
            // Never more than the faces' own box, as ever (the 2·eps reach can pass it).
            let bb = Aabb::from_points(fa.points.iter().chain(fb.points.iter()))
                .grown(eps + beside)
                .intersection(&near);
            let slab = Slab {
                n: na,
                lo,
                hi,
                frame: &f,
                thin,
                near: beside,
            };
            opaque.shadows(&bb, &slab, shadows);
            let between = if gap > 4.0 * eps {
                cells_between(a, b, cells, near_cells, &fa.plane, &f, gap, &bb, eps)
            } else {
                Vec::new()
            };
            let blockers: Vec<&[DVec2]> = shadows
                .rings()
                .into_iter()
                .chain(between.iter().map(|r| r.as_slice()))
                .filter(|r| {
                    let (lo, hi) = ring_bounds(r.iter());
                    lo.x <= shi.x && lo.y <= shi.y && hi.x >= slo.x && hi.y >= slo.y
                })
                .collect();
            let closed = shared.iter().all(|s| {
                s.holes.is_empty() && is_covered(&s.outer, &blockers, k.grow, k.sliver, k.closed)
            });
            let exact = || {
                ExactVertices::new(
                    ra.iter()
                        .chain(rb.iter())
                        .chain(blockers.iter().flat_map(|r| r.iter()))
                        .copied(),
                    grid,
                )
                .with_rings(
                    [ra.as_slice(), rb.as_slice()]
                        .into_iter()
                        .chain(blockers.iter().copied()),
                )
            };
            let mut through: Vec<Vec<DVec2>> = Vec::new();
            if !closed {
                let open = difference(&shared, &blockers, grid);
                let exact = exact();
                for o in open.iter().filter(|o| o.mean_width() >= min_width) {
                    for piece in pieces(o, cfg.conservative, eps) {
                        let piece = exact.restore(piece);
                        // CCW about na in 2D: seen from A (behind the plane) it turns the
                        // other way, so A's polygon is the reversed ring.
                        let on_a: Vec<DVec3> =
                            piece.iter().map(|q| f.to3(*q, DVec3::ZERO)).collect();
                        let Some(on_a) = usable_polygon(&on_a, na, eps) else {
                            continue;
                        };
                        let on_b: Vec<DVec3> = on_a.iter().map(|p| *p + na * gap).collect();
                        let area = polygon_area(&on_a, na);
                        out.portals.push((on_a, on_b, na, area));
                        through.push(piece);
                    }
                }
            }
            if bridged {
                // Each face of the wall on its own: what lies on it and what was bridged
                // through; what is left is a hole into the wall that does not go through it
                // (the doors of two rooms' walls, offset along the hollow between them). The
                // face claims the rest, and the exterior stage finds the hole open unless
                // another cell's claim covers it.
                let sides = [
                    (a, lo - beside, lo + 2.0 * eps + beside),
                    (b, hi - 2.0 * eps - beside, hi + beside),
                ];
                for (cell, from, to) in sides {
                    let mut cover: Vec<&[DVec2]> = shadows
                        .rings_with_spans()
                        .filter(|(_, (x, y))| *x >= from && *y <= to)
                        .map(|(r, _)| r)
                        .collect();
                    cover.extend(through.iter().map(Vec::as_slice));
                    let whole = !cfg.exterior
                        || shared.iter().all(|s| {
                            s.holes.is_empty()
                                && is_covered(&s.outer, &cover, k.grow, k.sliver, k.closed)
                        });
                    // Holes narrower than the wall is thick are where two doors' jambs miss
                    // each other by a modelling error, not a way into the wall.
                    let holes: Vec<Vec<DVec2>> = if whole {
                        Vec::new()
                    } else {
                        difference(&shared, &cover, grid)
                            .into_iter()
                            .filter(|o| o.mean_width() >= gap.max(min_width))
                            .map(|o| o.outer)
                            .collect()
                    };
                    if holes.is_empty() {
                        for s in &shared {
                            claim(cell, exact_shared.restore(s.outer.clone()));
                        }
                        continue;
                    }
                    let exact = exact();
                    for o in difference(&shared, &holes, grid) {
                        for piece in pieces(&o, false, eps) {
                            claim(cell, exact.restore(piece));
                        }
                    }
                }
            }
        }
    }

    out
}

/// The cross-sections, on `plane`'s frame, of the cells other than `a` and `b` that lie in the
/// gap between a face and the face it bridges to. A wall is bridged only where it is wall: a
/// door reveal that is a cell of its own (a room owning the tunnel through its wall) already
/// joins the two, and a bridge across it would be a second, shorter path through the same
/// opening.
#[allow(clippy::too_many_arguments)]
fn cells_between(
    a: usize,
    b: usize,
    cells: &CellSet,
    near_cells: &BoxGrid,
    plane: &Plane,
    f: &Frame2,
    gap: f64,
    bb: &Aabb,
    eps: f64,
) -> Vec<Vec<DVec2>> {
    let n = plane.normal;
    let low = Plane {
        normal: -n,
        d: -(plane.d + eps),
    };
    let high = Plane {
        normal: n,
        d: plane.d + gap - eps,
    };
    let mut out = Vec::new();
    // Only a cell whose box reaches into the gap by more than the tolerance can lie in it; the
    // cells beside the two (the rooms along the same wall) only touch its edges.
    let (lo, hi) = (
        bb.min + DVec3::splat(2.0 * eps),
        bb.max - DVec3::splat(2.0 * eps),
    );
    for k in near_cells.query(bb, 0.0) {
        let kb = &cells.cells[k].bounds;
        if k == a || k == b || kb.min.cmpge(hi).any() || kb.max.cmple(lo).any() {
            continue;
        }
        let Some(inside) = cells.cells[k]
            .poly
            .clip(&low, eps)
            .and_then(|p| p.clip(&high, eps))
        else {
            continue;
        };
        let flat: Vec<DVec3> = inside
            .faces
            .iter()
            .flat_map(|face| face.points.iter())
            .map(|p| *p - n * plane.distance(*p))
            .collect();
        let ring = convex_ring_on_plane(&flat, plane, eps);
        if ring.len() >= 3 {
            out.push(ring.iter().map(|p| f.to2(*p)).collect());
        }
    }
    out
}
