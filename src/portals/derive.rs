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
//! portal). Cracks narrower than the crack width (`[cells] crack_width`, the cell stage's, one
//! absolute width) are cut from what is left (`geom/crack.rs`: a stair a hair short of a
//! jamb), and openings thinner on average than that or ten tolerances are dropped; each
//! opening is partitioned into convex pieces (or hulled), and the pieces (and the claims) get the
//! exact input coordinates back, a corner where two input edges cross on their crossing
//! (`geom/exact.rs`). The part of a face that no other cell claims and no triangle covers is an
//! exterior opening.
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
use crate::geom::crack::{holds_disc, without_cracks, ClosedGaps};
use crate::geom::exact::ExactVertices;
use crate::geom::grid::BoxGrid;
use crate::geom::partition::{convex_partition, Polygon2};
use crate::geom::plane::Plane;
use crate::geom::polyhedron::{convex_ring_on_plane, polygon_area, usable_polygon};
use crate::geom::tolerance::Tolerance;
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
/// jamb a fraction of a tolerance off plumb was cut at its top corner or at its bottom one as
/// the tolerance went). Finer than f32 coordinates on the face; i_overlay's i32 engine holds it.
fn face_grid(ring: &[DVec2]) -> f64 {
    (diagonal(ring_bounds(ring.iter())) * FACE_GRID).max(f64::MIN_POSITIVE)
}

const FACE_GRID: f64 = 1.0 / (1u64 << 24) as f64;

/// An opening (or a face region nothing blocks) narrower on average than this many
/// tolerances is float noise, not a way through: what snapping and the grown covers can leave
/// of a closed wall is a few tolerances wide (see [`Limits::closed`]).
pub(crate) const NOISE_WIDTH: f64 = 10.0;

/// Pieces smaller than this share of a tolerance squared are dropped as a region is cut:
/// leftovers of cutting along edges that meet within a tolerance.
const SLIVER_SHARE: f64 = 1.0 / 64.0;

/// The thickest slab the blockers are asked about, beyond the wall reach, in tolerances: a
/// slab spans the gap (at most the reach) and a tolerance either side, and one more allows
/// for the rounding of the gap.
const SLAB_MARGIN: f64 = 3.0;

/// The tilt (radians: metres per metre of the two cells' size) the face pairs' prefilter
/// allows for: a face whose plane is further from the other cell's box than the reach, plus
/// this times both cells' size, faces nothing of it. A hundred times [`ANGLE`], so a face
/// tilted within the angle tolerance is never filtered out, whatever the lever.
///
/// [`ANGLE`]: crate::geom::tolerance::ANGLE
const TILT_PAD: f64 = 1e-3;

/// The cells in the gap between two faces are looked for only in a gap wider than this many
/// tolerances: a cell must reach into it by more than a tolerance past each face's own
/// tolerance to stand between them.
const ROOM_BETWEEN: f64 = 4.0;

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

/// What is an opening of a region left open: the region without its vertices within the
/// tolerance of a straight edge ([`drop_near_collinear`]) and without its cracks
/// (`geom/crack.rs`), if that is at least `min_width` wide on average, or, with `disc` (between
/// generated cells), holds a disc as wide as a crack somewhere: what a ray as thick as a crack
/// passes. Tagged levels keep the average alone, so their verdicts stay what they were (a
/// wedge beside a stair, a little wider than a crack at its widest, stays a crack there). A
/// region nothing blocks (`clear`: a face two cells of the same air share, on one plane) is
/// no gap between blockers: it is kept whole however narrow (a sliver cell's face), unless it
/// is float noise (under ten tolerances wide on average).
fn opening(o: &Polygon2, k: &Limits, clear: bool, disc: bool) -> Option<Polygon2> {
    let straight = Polygon2 {
        outer: drop_near_collinear(&o.outer, k.eps),
        holes: o
            .holes
            .iter()
            .map(|h| drop_near_collinear(h, k.eps))
            .collect(),
    };
    if clear {
        return Some(straight).filter(|o| o.mean_width() >= NOISE_WIDTH * k.eps);
    }
    // Wide enough on average, or wide enough somewhere: a wedge a crack-thick ray passes
    // (wider than a crack across, half that on average) is an opening.
    without_cracks(&straight, k.crack).filter(|o| {
        o.mean_width() >= k.min_width || (disc && k.crack > 0.0 && holds_disc(o, 0.98 * k.crack))
    })
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
    let mut k = Limits::new(cells.tolerance.distance, cfg);
    let reach = k.reach;
    // The blockers' index and the cell pairs are built side by side (each is one pass).
    let (opaque, (near_cells, pairs)) = rayon::join(
        || Opaque::new(scene, tagging, cells, reach + SLAB_MARGIN * k.eps),
        || cells.pairs_in_order(reach),
    );
    k.crack = cells.crack;
    k.min_width = k.min_width.max(k.crack);
    // Each pair's openings are computed in parallel; they are applied in pair order, so the
    // portals are numbered the same whatever the thread count. Pairs differ a lot in cost
    // (most share nothing): in jobs of at most `JOB` pairs no thread is left waiting long
    // for another's last job.
    //
    // A pair's openings are found in the frame of the first cell's faces and carried over to
    // the second's, so which cell goes first is taken from an order of the cells that does
    // not depend on the order the rooms are listed in (their names); numbers follow the
    // cells' (the lower first).
    let order = PairOrder {
        rank: &set.cell_rank,
    };
    // Generated cells tile the air the reading found: what lies between two of them is a
    // solid's inside or air it left out, never a wall to bridge. Bridging it (sight only
    // straight through, along the normal) lost the rays that cross such a gap slantwise and
    // leave it sideways (a gap between slabs of air of a generated reading).
    let generated = |c: usize| {
        (tagging.generated.as_deref()).is_some_and(|g| g.boxes_of(cells.cells[c].room).is_some())
    };
    let generated: Vec<bool> = (0..cells.cells.len()).map(generated).collect();
    let cx = PairContext {
        cells,
        opaque: &opaque,
        near_cells: &near_cells,
        cfg,
        k: &k,
        generated: &generated,
    };
    let mut found: Vec<PairOpenings> = pairs
        .par_iter()
        .with_max_len(JOB)
        .map(|&pair| {
            let (x, y) = order.first(pair);
            Shadows::with(|shadows| pair_openings(x, y, &cx, shadows))
        })
        .collect();
    add_pair_portals(&mut set.portals, cells, &pairs, &mut found, &order);
    set.closed = found
        .iter()
        .fold(ClosedGaps::default(), |t, f| t.merged(&f.closed));
    if !cfg.exterior {
        return;
    }
    let claims = sorted_claims(&found, &pairs, &order);
    let claimed = ClaimIndex {
        sorted: &claims,
        found: &found,
    };
    let exterior = exterior_openings(cells, &opaque, cfg, &k, &claimed, &generated);
    crate::free::drop_elsewhere((found, claims, opaque));
    for (c, (list, closed)) in exterior.into_iter().enumerate() {
        set.closed = set.closed.merged(&closed);
        for (polygon, normal, area) in list {
            set.portals
                .push(Portal::plain(c, None, polygon, normal, area, false, None));
        }
    }
}

/// Which cell of a pair goes first: the one earlier in the cells' name order.
struct PairOrder<'a> {
    rank: &'a [u32],
}

impl PairOrder<'_> {
    /// Without a rank (a set not made by `portals::build`), the cells' numbers.
    fn rank_of(&self, c: usize) -> u64 {
        self.rank.get(c).map_or(c as u64, |&r| u64::from(r))
    }

    fn first(&self, (a, b): (usize, usize)) -> (usize, usize) {
        if self.rank_of(a) <= self.rank_of(b) {
            (a, b)
        } else {
            (b, a)
        }
    }
}

/// Turns each pair's openings into two portals, one each way, numbered in pair order (the
/// lower cell of the pair first) whichever cell the openings were found from.
fn add_pair_portals(
    portals: &mut Vec<Portal>,
    cells: &CellSet,
    pairs: &[(usize, usize)],
    found: &mut [PairOpenings],
    order: &PairOrder,
) {
    for (&(a, b), found) in pairs.iter().zip(found.iter_mut()) {
        let internal = cells.cells[a].room == cells.cells[b].room;
        let swapped = order.first((a, b)).0 != a;
        for (on_x, on_y, nx, area) in std::mem::take(&mut found.portals) {
            // As seen from `a`: its side of the opening and the normal from it to `b`.
            let (on_a, on_b, na) = if swapped {
                (reversed(&on_y), reversed(&on_x), -nx)
            } else {
                (on_x, on_y, nx)
            };
            let i = portals.len();
            let back = Portal::plain(b, Some(a), on_b, -na, area, internal, Some(i));
            let polygon = reversed(&on_a);
            portals.push(Portal::plain(
                a,
                Some(b),
                polygon,
                na,
                area,
                internal,
                Some(i + 1),
            ));
            portals.push(back);
        }
    }
}

/// For each cell face, the regions other cells claim (in that face's frame). The claims
/// stay where the pairs put them and are found through a list sorted by cell and face,
/// and within a face by the claiming cell's room name, then its place in its room: the
/// order the claims are cut and unioned in (and their vertices put back) is then the same
/// when the rooms are listed in another order (cell numbers follow the room order).
fn sorted_claims(
    found: &[PairOpenings],
    pairs: &[(usize, usize)],
    order: &PairOrder,
) -> Vec<(u32, u32, u64, u32, u32)> {
    let mut claims: Vec<(u32, u32, u64, u32, u32)> = found
        .iter()
        .enumerate()
        .flat_map(|(p, f)| {
            let (a, b) = order.first(pairs[p]);
            f.claims
                .iter()
                .enumerate()
                .map(move |(k, &(cell, face, _))| {
                    let other = if cell == a { b } else { a };
                    (
                        cell as u32,
                        face as u32,
                        order.rank_of(other),
                        p as u32,
                        k as u32,
                    )
                })
        })
        .collect();
    claims.par_sort_unstable();
    claims
}

/// The claims on each cell face, through the sorted list of [`sorted_claims`].
struct ClaimIndex<'a> {
    sorted: &'a [(u32, u32, u64, u32, u32)],
    found: &'a [PairOpenings],
}

impl<'a> ClaimIndex<'a> {
    /// The rings other cells claim of face `i` of cell `c`, in their sorted order.
    fn on(&self, c: usize, i: usize) -> impl Iterator<Item = &'a [DVec2]> + 'a {
        let (sorted, found) = (self.sorted, self.found);
        let key = (c as u32, i as u32);
        let from = sorted.partition_point(|&(cell, face, ..)| (cell, face) < key);
        sorted[from..]
            .iter()
            .take_while(move |&&(cell, face, ..)| (cell, face) == key)
            .map(move |&(_, _, _, p, k)| found[p as usize].claims[k as usize].2.as_slice())
    }
}

/// What the openings of cell faces to the exterior read, shared by every cell in parallel.
struct ExteriorContext<'a> {
    opaque: &'a Opaque,
    cfg: &'a PortalsConfig,
    k: &'a Limits,
    claimed: &'a ClaimIndex<'a>,
    generated: &'a [bool],
}

/// An opening of a cell to the exterior: its polygon, normal and area.
type ExteriorOpening = (Vec<DVec3>, DVec3, f64);

/// Every cell's openings to the exterior and the gaps to it closed as cracks, by cell.
fn exterior_openings(
    cells: &CellSet,
    opaque: &Opaque,
    cfg: &PortalsConfig,
    k: &Limits,
    claimed: &ClaimIndex,
    generated: &[bool],
) -> Vec<(Vec<ExteriorOpening>, ClosedGaps)> {
    let cx = ExteriorContext {
        opaque,
        cfg,
        k,
        claimed,
        generated,
    };
    cells
        .cells
        .par_iter()
        .enumerate()
        .with_max_len(JOB)
        .map(|(c, cell)| {
            Shadows::with(|shadows| {
                let (mut out, mut closed) = (Vec::new(), ClosedGaps::default());
                for (i, face) in cell.poly.faces.iter().enumerate() {
                    face_exterior(&cx, c, i, face, shadows, (&mut out, &mut closed));
                }
                (out, closed)
            })
        })
        .collect()
}

/// The openings to the exterior of face `i` of cell `c`: what neither another cell claims
/// nor anything opaque covers, added to `out`.
fn face_exterior(
    cx: &ExteriorContext,
    c: usize,
    i: usize,
    face: &crate::geom::polyhedron::Face,
    shadows: &mut Shadows,
    (out, closed): (&mut Vec<ExteriorOpening>, &mut ClosedGaps),
) {
    let (k, eps) = (cx.k, cx.k.eps);
    let f = Frame2::of_face(face);
    let ring: Vec<DVec2> = face.points.iter().map(|p| f.to2(*p)).collect();
    let grid = face_grid(&ring);
    // Claims first: a face between two rooms is claimed whole by its neighbour,
    // and then no shadow is needed to know it has no opening to the exterior.
    let mut left = Remainder::new(&ring, k.grow, k.sliver);
    for claim in cx.claimed.on(c, i) {
        left.cut(claim);
    }
    if left.at_most(k.closed) {
        return;
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
        beyond: &[],
    };
    cx.opaque.shadows(&bb, &slab, shadows);
    let mut covered: Vec<&[DVec2]> = cx.claimed.on(c, i).collect();
    let claimed_len = covered.len();
    covered.extend(shadows.rings());
    for shadow in &covered[claimed_len..] {
        left.cut(shadow);
    }
    if left.at_most(k.closed) {
        return;
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
    for region in &difference(&whole, &covered, grid) {
        let kept = opening(region, k, false, cx.generated[c]);
        if let Some(w) = closed_crack(region, kept.is_some(), false, k) {
            closed.add(w, region_point(region, &f));
        }
        let Some(o) = kept else { continue };
        for piece in pieces(&o, cx.cfg.conservative, eps) {
            let piece = exact.restore(piece);
            let pts: Vec<DVec3> = piece.iter().map(|q| f.to3(*q, DVec3::ZERO)).collect();
            let Some(pts) = usable_polygon(&pts, face.plane.normal, eps) else {
                continue;
            };
            let area = polygon_area(&pts, face.plane.normal);
            out.push((reversed(&pts), face.plane.normal, area));
        }
    }
}

/// The most cell pairs (or cells) one job of a parallel loop takes.
const JOB: usize = 64;

/// The distances derivation works with: all from the one tolerance but the crack width, an
/// absolute length (the cell stage's) so that it does not move with the tolerance.
struct Limits {
    eps: f64,
    /// Openings thinner than this on average are float noise (ten tolerances) or cracks,
    /// whichever is wider.
    min_width: f64,
    /// Parts of an opening narrower than this are cracks (`geom/crack.rs`): the cell stage's
    /// crack width, so a gap the solid-block reading closed is no portal either.
    crack: f64,
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
            min_width: NOISE_WIDTH * eps,
            crack: 0.0,
            reach: cfg.max_wall_thickness + eps,
            closed: eps * eps,
            grow: eps,
            sliver: SLIVER_SHARE * eps * eps,
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
    /// The regions left open that were closed as cracks.
    closed: ClosedGaps,
}

/// The width of a region left open that [`opening`] closed as a crack (its mean width), or
/// `None` when it was kept, is a clear face's float noise, or is a hair between blockers
/// meant to meet (`geom::crack::counts_as_gap`).
fn closed_crack(o: &Polygon2, kept: bool, clear: bool, k: &Limits) -> Option<f64> {
    let w = o.mean_width();
    (!kept && !clear && crate::geom::crack::counts_as_gap(w, k.crack, k.eps)).then_some(w)
}

/// A point of a region in its face's frame (the mean of its outline), for where a gap is.
fn region_point(o: &Polygon2, f: &Frame2) -> DVec3 {
    let n = o.outer.len().max(1) as f64;
    f.to3(o.outer.iter().copied().sum::<DVec2>() / n, DVec3::ZERO)
}

/// Whether some point of box `b` is within `pad` of `plane`.
fn plane_meets_box(plane: &Plane, b: &Aabb, pad: f64) -> bool {
    let c = (b.min + b.max) * 0.5;
    let r = ((b.max - b.min) * 0.5).dot(plane.normal.abs());
    let d = plane.distance(c);
    d - r <= pad && d + r >= -pad
}

/// What finding the openings between cells reads, shared by every pair looked at in parallel.
struct PairContext<'a> {
    cells: &'a CellSet,
    opaque: &'a Opaque,
    near_cells: &'a BoxGrid,
    cfg: &'a PortalsConfig,
    k: &'a Limits,
    /// Per cell, whether `--tags auto` generated it: no wall is bridged to it, and its
    /// openings are kept where a crack-wide disc fits ([`opening`]).
    generated: &'a [bool],
}

fn pair_openings(a: usize, b: usize, cx: &PairContext, shadows: &mut Shadows) -> PairOpenings {
    let (eps, reach) = (cx.k.eps, cx.k.reach);
    let mut out = PairOpenings::default();
    let ca = &cx.cells.cells[a];
    let cb = &cx.cells.cells[b];
    // Two faces that share a region are nearer each other than the wall reach, plus what a
    // tilt within the angle tolerance can add across either cell, plus snapping;
    // a face whose plane is further than that from the other cell's box is not looked at (a
    // cell pair meets along one or two faces of each, out of six or more).
    let pad = reach
        + Tolerance::touching(eps)
        + TILT_PAD * (ca.bounds.size().length() + cb.bounds.size().length());
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
            // Faces within the angle tolerance of opposite face each other.
            if !Tolerance::facing(na, fb.plane.normal) || !box_a.meets(box_b) {
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
            // Two generated cells are never bridged (see `derive`); a tagged cell facing a
            // generated one is, across the tagged room's wall, as between tagged rooms.
            if gap < -eps || gap > reach || (gap > eps && cx.generated[a] && cx.generated[b]) {
                continue;
            }
            let gap = gap.max(0.0);
            if let Some(fp) = FacePair::new(cx, (a, ia, fa), (b, ib, fb), gap) {
                fp.open(cx, shadows, &mut out);
            }
        }
    }

    out
}

/// Two faces of a pair of cells that face each other, on one plane or across a wall `gap`
/// thick, and the region they share (in A's face frame): what their openings and claims are
/// cut from.
struct FacePair<'f> {
    a: usize,
    b: usize,
    ia: usize,
    ib: usize,
    fa: &'f crate::geom::polyhedron::Face,
    fb: &'f crate::geom::polyhedron::Face,
    na: DVec3,
    gap: f64,
    f: Frame2,
    fb2: Frame2,
    ra: Vec<DVec2>,
    rb: Vec<DVec2>,
    grid: f64,
    shared: Vec<Polygon2>,
    exact_shared: ExactVertices,
}

impl<'f> FacePair<'f> {
    /// The two faces and what they share, or `None` when they share nothing with area or
    /// another cell fills the gap between them.
    fn new(
        cx: &PairContext,
        (a, ia, fa): (usize, usize, &'f crate::geom::polyhedron::Face),
        (b, ib, fb): (usize, usize, &'f crate::geom::polyhedron::Face),
        gap: f64,
    ) -> Option<Self> {
        let eps = cx.k.eps;
        let na = fa.plane.normal;
        let f = Frame2::of_face(fa);
        let ra: Vec<DVec2> = fa.points.iter().map(|p| f.to2(*p)).collect();
        let rb: Vec<DVec2> = fb.points.iter().map(|p| f.to2(*p)).collect();
        let grid = face_grid(&ra);
        // Rings whose boxes, snapped to the boolean's grid, do not overlap with some area
        // have an intersection without area, which the boolean drops: most face pairs of
        // neighbouring cells (a diagonal neighbour's wall is in the same plane, further
        // along it, touching at most along an edge).
        if !snapped_boxes_overlap(&ra, &rb, grid) {
            return None;
        }
        let shared = intersection(std::slice::from_ref(&ra), std::slice::from_ref(&rb), grid);
        if shared.is_empty() {
            return None;
        }
        // A wall is bridged only if no other cell fills the gap (then the faces do
        // not face each other across a wall, but across that cell).
        if gap > eps {
            let big = shared.iter().max_by(|x, y| x.area().total_cmp(&y.area()));
            if let Some(big) = big {
                let c2 = big.outer.iter().copied().sum::<DVec2>() / big.outer.len() as f64;
                let mid = f.to3(c2, na * (gap * 0.5));
                let probe = Aabb { min: mid, max: mid };
                let filled = cx.near_cells.query(&probe, 0.0).into_iter().any(|k| {
                    k != a && k != b && cx.cells.cells[k].poly.contains_strictly(mid, eps)
                });
                if filled {
                    return None;
                }
            }
        }
        let fb2 = Frame2::of_face(fb);
        // Claims are cut from the faces' other openings and the exterior: with their
        // corners left on the grid, those openings' corners moved with it.
        let exact_shared = ExactVertices::new(ra.iter().chain(rb.iter()).copied(), grid)
            .with_rings([ra.as_slice(), rb.as_slice()]);
        Some(FacePair {
            a,
            b,
            ia,
            ib,
            fa,
            fb,
            na,
            gap,
            f,
            fb2,
            ra,
            rb,
            grid,
            shared,
            exact_shared,
        })
    }

    /// Records that `cell` claims `piece` (in A's face frame) of its face, moved onto B's
    /// face and frame when the cell is B.
    fn claim(&self, out: &mut PairOpenings, cell: usize, piece: Vec<DVec2>) {
        if cell == self.a {
            out.claims.push((self.a, self.ia, piece));
        } else {
            let back = piece
                .iter()
                .map(|q| self.fb2.to2(self.f.to3(*q, self.na * self.gap)))
                .collect();
            out.claims.push((self.b, self.ib, back));
        }
    }

    /// The openings through the shared region and the claims on the two faces.
    fn open(&self, cx: &PairContext, shadows: &mut Shadows, out: &mut PairOpenings) {
        let eps = cx.k.eps;
        let gap = self.gap;
        // Faces on one plane claim all they share: whatever is open there opens onto the
        // other cell. Faces across a wall, below, each what is not a hole into the wall.
        let bridged = gap > eps;
        if !bridged {
            for s in &self.shared {
                let piece = self.exact_shared.restore(s.outer.clone());
                self.claim(out, self.a, piece.clone());
                self.claim(out, self.b, piece);
            }
        }
        let (lo, hi) = (self.fa.plane.d - eps, self.fa.plane.d + gap + eps);
        let (slo, shi, bb, beside) = self.cast_shadows(cx, lo, hi, shadows);
        let between = if gap > ROOM_BETWEEN * eps {
            cells_between(
                self.a,
                self.b,
                cx.cells,
                cx.near_cells,
                &self.fa.plane,
                &self.f,
                gap,
                &bb,
                eps,
            )
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
        let k = cx.k;
        let closed = self.shared.iter().all(|s| {
            s.holes.is_empty() && is_covered(&s.outer, &blockers, k.grow, k.sliver, k.closed)
        });
        let mut through: Vec<Vec<DVec2>> = Vec::new();
        if !closed {
            through = self.openings(cx, &blockers, out);
        }
        if bridged {
            self.claim_wall_sides(cx, shadows, &blockers, &through, (lo, hi, beside), out);
        }
    }

    /// What blocks: everything on the plane, or inside the wall slab (from `lo` to `hi` along
    /// A's normal), within 2·eps of the shared region, cast into `shadows`. Returns the
    /// bounds of that region, grown by 2·eps, the box asked for, and how far off a thin slab
    /// a blocker may lie.
    fn cast_shadows(
        &self,
        cx: &PairContext,
        lo: f64,
        hi: f64,
        shadows: &mut Shadows,
    ) -> (DVec2, DVec2, Aabb, f64) {
        let (eps, gap, f, na) = (cx.k.eps, self.gap, &self.f, self.na);
        // The others (the next room's wall, in the same plane past the
        // corner) leave the same region open, and none of their points is near enough to
        // be put back as an exact vertex. The grid is asked for the box around that part
        // of the slab, which holds every triangle whose shadow can be kept (a long wall
        // shared with a short room's asks for the short room's part only).
        let (slo, shi) = ring_bounds(self.shared.iter().flat_map(|s| s.outer.iter()));
        let thin = gap <= eps;
        let beside = NEAR * diagonal((slo, shi));
        let reach = Tolerance::touching(eps);
        let (slo, shi) = (slo - DVec2::splat(reach), shi + DVec2::splat(reach));
        let mut near = Aabb::EMPTY;
        for t in [-eps - beside, gap + eps + beside] {
            for c in [slo, DVec2::new(shi.x, slo.y), shi, DVec2::new(slo.x, shi.y)] {
                near.add(f.to3(c, na * t));
            }
        }
        // Never more than the faces' own box, as ever (the 2·eps reach can pass it).
        let bb = Aabb::from_points(self.fa.points.iter().chain(self.fb.points.iter()))
            .grown(eps + beside)
            .intersection(&near);
        // On one plane, what lies outside either cell (on or past another of its faces)
        // cannot stand between them.
        let beyond: Vec<Plane> = if thin {
            let (pa, pb) = (&cx.cells.cells[self.a].poly, &cx.cells.cells[self.b].poly);
            let others = pa.faces.iter().enumerate().filter(|(i, _)| *i != self.ia);
            others
                .chain(pb.faces.iter().enumerate().filter(|(i, _)| *i != self.ib))
                .map(|(_, face)| Plane {
                    normal: face.plane.normal,
                    d: face.plane.d - eps,
                })
                .collect()
        } else {
            Vec::new()
        };
        let slab = Slab {
            n: na,
            lo,
            hi,
            frame: f,
            thin,
            near: beside,
            beyond: &beyond,
        };
        cx.opaque.shadows(&bb, &slab, shadows);
        (slo, shi, bb, beside)
    }

    /// Exact vertices of the two faces and the blockers, to put the corners of what is cut
    /// from the shared region back where they were before snapping.
    fn exact(&self, blockers: &[&[DVec2]]) -> ExactVertices {
        ExactVertices::new(
            self.ra
                .iter()
                .chain(self.rb.iter())
                .chain(blockers.iter().flat_map(|r| r.iter()))
                .copied(),
            self.grid,
        )
        .with_rings(
            [self.ra.as_slice(), self.rb.as_slice()]
                .into_iter()
                .chain(blockers.iter().copied()),
        )
    }

    /// The portals through what the blockers leave open of the shared region, added to `out`;
    /// returns their pieces (in A's face frame), which the wall's faces count as covered.
    fn openings(
        &self,
        cx: &PairContext,
        blockers: &[&[DVec2]],
        out: &mut PairOpenings,
    ) -> Vec<Vec<DVec2>> {
        let (eps, na, gap) = (cx.k.eps, self.na, self.gap);
        let mut through: Vec<Vec<DVec2>> = Vec::new();
        let open = difference(&self.shared, blockers, self.grid);
        let exact = self.exact(blockers);
        let clear = self.gap <= eps && blockers.is_empty();
        let disc = cx.generated[self.a] && cx.generated[self.b];
        for region in &open {
            let kept = opening(region, cx.k, clear, disc);
            if let Some(w) = closed_crack(region, kept.is_some(), clear, cx.k) {
                out.closed.add(w, region_point(region, &self.f));
            }
            let Some(o) = kept else { continue };
            for piece in pieces(&o, cx.cfg.conservative, eps) {
                let piece = exact.restore(piece);
                // CCW about na in 2D: seen from A (behind the plane) it turns the
                // other way, so A's polygon is the reversed ring.
                let on_a: Vec<DVec3> = piece.iter().map(|q| self.f.to3(*q, DVec3::ZERO)).collect();
                let Some(on_a) = usable_polygon(&on_a, na, eps) else {
                    continue;
                };
                let on_b: Vec<DVec3> = on_a.iter().map(|p| *p + na * gap).collect();
                let area = polygon_area(&on_a, na);
                out.portals.push((on_a, on_b, na, area));
                through.push(piece);
            }
        }
        through
    }

    /// Each face of the wall on its own: what lies on it and what was bridged
    /// through; what is left is a hole into the wall that does not go through it
    /// (the doors of two rooms' walls, offset along the hollow between them). The
    /// face claims the rest, and the exterior stage finds the hole open unless
    /// another cell's claim covers it.
    fn claim_wall_sides(
        &self,
        cx: &PairContext,
        shadows: &Shadows,
        blockers: &[&[DVec2]],
        through: &[Vec<DVec2>],
        (lo, hi, beside): (f64, f64, f64),
        out: &mut PairOpenings,
    ) {
        let (eps, k, gap, grid) = (cx.k.eps, cx.k, self.gap, self.grid);
        let sides = [
            (self.a, lo - beside, lo + Tolerance::touching(eps) + beside),
            (self.b, hi - Tolerance::touching(eps) - beside, hi + beside),
        ];
        for (cell, from, to) in sides {
            let mut cover: Vec<&[DVec2]> = shadows
                .rings_with_spans()
                .filter(|(_, (x, y))| *x >= from && *y <= to)
                .map(|(r, _)| r)
                .collect();
            cover.extend(through.iter().map(Vec::as_slice));
            let whole = !cx.cfg.exterior
                || self.shared.iter().all(|s| {
                    s.holes.is_empty() && is_covered(&s.outer, &cover, k.grow, k.sliver, k.closed)
                });
            // Holes narrower than the wall is thick are where two doors' jambs miss
            // each other by a modelling error, not a way into the wall.
            let holes: Vec<Vec<DVec2>> = if whole {
                Vec::new()
            } else {
                difference(&self.shared, &cover, grid)
                    .into_iter()
                    .filter(|o| o.mean_width() >= gap.max(k.min_width))
                    .map(|o| o.outer)
                    .collect()
            };
            if holes.is_empty() {
                for s in &self.shared {
                    self.claim(out, cell, self.exact_shared.restore(s.outer.clone()));
                }
                continue;
            }
            let exact = self.exact(blockers);
            for o in difference(&self.shared, &holes, grid) {
                for piece in pieces(&o, false, eps) {
                    self.claim(out, cell, exact.restore(piece));
                }
            }
        }
    }
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
        bb.min + DVec3::splat(Tolerance::touching(eps)),
        bb.max - DVec3::splat(Tolerance::touching(eps)),
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

#[cfg(test)]
mod tests {
    use super::*;

    /// A 5 cm x 3 m region where the crack width is 0.3 m (set coarse for the
    /// test): between blockers it is a crack and goes; as a face two cells of the same air
    /// share with nothing on it, it is kept whole.
    #[test]
    fn a_narrow_region_is_a_crack_only_between_blockers() {
        let mut k = Limits::new(1e-5, &PortalsConfig::default());
        k.crack = 0.3;
        k.min_width = k.min_width.max(k.crack);
        let slot = Polygon2 {
            outer: vec![
                DVec2::new(0.0, 0.0),
                DVec2::new(0.05, 0.0),
                DVec2::new(0.05, 3.0),
                DVec2::new(0.0, 3.0),
            ],
            holes: vec![],
        };
        assert!(opening(&slot, &k, false, false).is_none());
        let kept = opening(&slot, &k, true, false).unwrap();
        assert!((kept.area() - 0.15).abs() < 1e-12);
        // Float noise stays noise: under ten tolerances wide.
        let hair = Polygon2 {
            outer: slot
                .outer
                .iter()
                .map(|p| DVec2::new(p.x * 1e-3, p.y))
                .collect(),
            holes: vec![],
        };
        assert!(opening(&hair, &k, true, false).is_none());
    }
}
