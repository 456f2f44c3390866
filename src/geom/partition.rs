//! 2D footprints and their convex partition.
//!
//! Cells are convex, so a room whose floor plan is an L, a U or a ring around a pillar has to be
//! cut into convex pieces, and every extra piece is an extra cell and extra portals for the
//! visibility stage to pay for. The partition therefore aims at few pieces, not just at *some*
//! convex cover: it keeps every cut on an existing vertex (no Steiner points, so shared edges
//! stay exact), prefers cuts that resolve two reflex corners at once, resolves every other
//! reflex corner with a cut of its own to the nearest vertex it sees (so the pieces follow the
//! plan, not the triangulation's diagonals), and finishes with a local search that replaces
//! three pieces by two where it can.
//!
//! Every convexity and cone decision goes through `robust::orient2d`, so collinear walls and
//! exactly aligned corners (the normal case in authored levels) cannot flip a decision, and the
//! result does not change when the level is moved or scaled by a power of ten.

use std::cmp::Ordering;
use std::collections::{BinaryHeap, HashMap, HashSet, VecDeque};
use std::fmt;
use std::panic::{catch_unwind, AssertUnwindSafe};

use glam::DVec2;
use i_overlay::core::fill_rule::FillRule;
use i_overlay::core::overlay::{Overlay, ShapeType};
use i_overlay::core::overlay_rule::OverlayRule;
use i_overlay::i_float::int::point::IntPoint;
use robust::{orient2d, Coord};
use spade::handles::FixedVertexHandle;
use spade::{
    ConstrainedDelaunayTriangulation, Intersection, LineIntersectionIterator, Point2, Triangulation,
};

/// A polygon with holes: outer ring counter-clockwise, holes clockwise, no repeated closing vertex.
#[derive(Debug, Clone, PartialEq)]
pub struct Polygon2 {
    /// The boundary, counter-clockwise.
    pub outer: Vec<DVec2>,
    /// Holes, each clockwise and inside `outer`.
    pub holes: Vec<Vec<DVec2>>,
}

impl Polygon2 {
    /// Area enclosed by the outer ring minus the holes. Ring windings are not trusted: a hole
    /// written counter-clockwise still removes area, as it would for the partition.
    pub fn area(&self) -> f64 {
        ring_area(&self.outer).abs() - self.holes.iter().map(|h| ring_area(h).abs()).sum::<f64>()
    }

    /// Mean width: twice the area over the perimeter (holes' edges count). Thinner than the
    /// tolerance is float noise along edges that should meet, not a region.
    pub(crate) fn mean_width(&self) -> f64 {
        let total = perimeter(&self.outer) + self.holes.iter().map(|h| perimeter(h)).sum::<f64>();
        if total > 0.0 {
            2.0 * self.area() / total
        } else {
            0.0
        }
    }
}

/// The mean width of one ring (either winding): twice its area over its perimeter.
pub(crate) fn ring_mean_width(r: &[DVec2]) -> f64 {
    let total = perimeter(r);
    if total > 0.0 {
        2.0 * ring_area(r).abs() / total
    } else {
        0.0
    }
}

fn perimeter(r: &[DVec2]) -> f64 {
    (0..r.len())
        .map(|i| r[i].distance(r[(i + 1) % r.len()]))
        .sum()
}

/// Why a polygon could not be partitioned.
#[derive(Debug, Clone, PartialEq)]
pub enum PartitionError {
    /// Non-finite coordinates, fewer than three distinct corners, or no area.
    Degenerate,
    /// More vertices than [`MAX_VERTICES`]; a hostile file must not stall the pipeline.
    TooComplex,
    /// The triangulation library failed on the input (it is contained, never a panic).
    Triangulation(String),
}

impl fmt::Display for PartitionError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            PartitionError::Degenerate => f.write_str("the polygon is degenerate"),
            PartitionError::TooComplex => f.write_str("the polygon has too many vertices"),
            PartitionError::Triangulation(m) => write!(f, "triangulation failed: {m}"),
        }
    }
}

impl std::error::Error for PartitionError {}

/// No floor plan comes near this; the limit only keeps a hostile input from stalling.
pub const MAX_VERTICES: usize = 200_000;

/// Union of 2D triangles (either winding) into polygons with holes, computed by i_overlay on a fixed grid of
/// `grid` units (results repeat exactly for the same input); collinear vertices removed; slivers thinner than grid dropped.
///
/// The grid is anchored at the origin (a vertex snaps to the nearest multiple of `grid`), so two
/// footprints that share an edge in the input share it exactly in the output. A contour whose
/// mean width (twice its area over its perimeter) is under one grid step is dropped whole: such
/// slivers are modelling noise, and a cell built on one would have no room inside. Triangles
/// that are degenerate, non-finite or too far out for the integer engine are skipped; a
/// non-positive or non-finite `grid` gives no polygons.
pub fn union_triangles(tris: &[[DVec2; 3]], grid: f64) -> Vec<Polygon2> {
    if !(grid.is_finite() && grid > 0.0) {
        return Vec::new();
    }
    // Far inside the i64 engine's safe range (2^62), so products in its predicates cannot overflow.
    const LIMIT: f64 = (1u64 << 52) as f64;
    let snap = |p: DVec2| -> Option<IntPoint<i64>> {
        let (x, y) = ((p.x / grid).round(), (p.y / grid).round());
        (x.is_finite() && y.is_finite() && x.abs() < LIMIT && y.abs() < LIMIT)
            .then(|| IntPoint::new(x as i64, y as i64))
    };
    let mut overlay = Overlay::<i64>::new(tris.len() * 3);
    for t in tris {
        let (Some(a), Some(b), Some(c)) = (snap(t[0]), snap(t[1]), snap(t[2])) else {
            continue;
        };
        let cross =
            (b.x - a.x) as i128 * (c.y - a.y) as i128 - (b.y - a.y) as i128 * (c.x - a.x) as i128;
        match cross.cmp(&0) {
            Ordering::Greater => overlay.add_contour(&[a, b, c], ShapeType::Subject),
            Ordering::Less => overlay.add_contour(&[a, c, b], ShapeType::Subject),
            Ordering::Equal => {}
        }
    }
    let shapes = overlay.overlay(OverlayRule::Subject, FillRule::NonZero);
    let mut out = Vec::new();
    for shape in shapes {
        let mut rings = shape.iter().filter(|c| !is_sliver(c)).map(|c| {
            let ring: Vec<DVec2> = c
                .iter()
                .map(|p| DVec2::new(p.x as f64 * grid, p.y as f64 * grid))
                .collect();
            remove_collinear(&ring)
        });
        // The first contour is the outer one; when it is a sliver its holes go with it.
        if shape.first().is_none_or(|c| is_sliver(c)) {
            continue;
        }
        let Some(mut outer) = rings.next() else {
            continue;
        };
        if outer.len() < 3 {
            continue;
        }
        if ring_area(&outer) < 0.0 {
            outer.reverse();
        }
        let holes = rings
            .filter(|h| h.len() >= 3)
            .map(|mut h| {
                if ring_area(&h) > 0.0 {
                    h.reverse();
                }
                h
            })
            .collect();
        out.push(Polygon2 { outer, holes });
    }
    out
}

/// Mean width under one grid step (in grid units: twice the area over the perimeter < 1).
fn is_sliver(c: &[IntPoint<i64>]) -> bool {
    let n = c.len();
    if n < 3 {
        return true;
    }
    let mut twice_area: i128 = 0;
    let mut perimeter = 0.0f64;
    for i in 0..n {
        let (p, q) = (c[i], c[(i + 1) % n]);
        twice_area += p.x as i128 * q.y as i128 - q.x as i128 * p.y as i128;
        perimeter += (((q.x - p.x) as f64).powi(2) + ((q.y - p.y) as f64).powi(2)).sqrt();
    }
    // mean width = 2A/P = twice_area/P; sliver when twice_area < P.
    (twice_area.unsigned_abs() as f64) < perimeter
}

/// Convex partition of one polygon with holes: pieces are convex CCW polygons (no collinear vertices), their areas sum to
/// the polygon's, they do not overlap, and their union is the polygon. Near-minimal count: the optimum on the
/// rectilinear plans rooms are made of (L 2, U 3, square ring 4, T 2, plus 3, a comb of k teeth k + 1).
///
/// For valid input, piece vertices are polygon vertices (no Steiner points), so neighbouring
/// pieces share exact edges and the cells built on them meet without cracks.
///
/// Holes are taken by the even-odd rule, whatever their winding. Rings that cross themselves or
/// each other are first resolved by i_overlay (even-odd, on a power-of-two grid 2^-40 of the
/// polygon's extent, so the snapping is tiny and exact to undo), and the pieces of every
/// resulting polygon are returned together.
pub fn convex_partition(p: &Polygon2) -> Result<Vec<Vec<DVec2>>, PartitionError> {
    let rings = clean_rings(p)?;
    // Most polygons asked about are convex already (a door, a window, a rectangular room's
    // plan): they are their own partition, and need no triangulation.
    if let [ring] = rings.as_slice() {
        let ids: Vec<u32> = (0..ring.len() as u32).collect();
        if is_convex(&ids, ring) {
            return Ok(vec![ring.clone()]);
        }
    }
    let run = |rings: &[Vec<DVec2>]| {
        catch_unwind(AssertUnwindSafe(|| partition_rings(rings))).unwrap_or_else(|payload| {
            let msg = payload
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| payload.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "panic in the triangulation".to_string());
            Err(Attempt::Failed(PartitionError::Triangulation(msg)))
        })
    };
    match run(&rings) {
        Ok(pieces) => Ok(pieces),
        Err(Attempt::Failed(e)) => Err(e),
        Err(Attempt::Crossing) => {
            let mut all = Vec::new();
            for poly in simplify_rings(&rings)? {
                let rings = clean_rings(&poly)?;
                match run(&rings) {
                    Ok(pieces) => all.extend(pieces),
                    Err(Attempt::Failed(e)) => return Err(e),
                    Err(Attempt::Crossing) => return Err(PartitionError::Degenerate),
                }
            }
            if all.is_empty() {
                return Err(PartitionError::Degenerate);
            }
            Ok(all)
        }
    }
}

enum Attempt {
    /// Two ring edges cross: the rings must be resolved into simple polygons first.
    Crossing,
    Failed(PartitionError),
}

fn c(p: DVec2) -> Coord<f64> {
    Coord { x: p.x, y: p.y }
}

fn orient(a: DVec2, b: DVec2, q: DVec2) -> f64 {
    orient2d(c(a), c(b), c(q))
}

fn ring_area(r: &[DVec2]) -> f64 {
    let n = r.len();
    (0..n).map(|i| r[i].perp_dot(r[(i + 1) % n])).sum::<f64>() * 0.5
}

/// Drops repeated points, collinear points and zero-width spikes, all of which leave the
/// enclosed region unchanged but would make a corner look convex or reflex at random.
fn remove_collinear(ring: &[DVec2]) -> Vec<DVec2> {
    let n = ring.len();
    if n < 3 {
        return ring.to_vec();
    }
    let mut next: Vec<usize> = (0..n).map(|i| (i + 1) % n).collect();
    let mut prev: Vec<usize> = (0..n).map(|i| (i + n - 1) % n).collect();
    let mut alive = vec![true; n];
    let mut count = n;
    let mut work: Vec<usize> = (0..n).rev().collect();
    while let Some(i) = work.pop() {
        if !alive[i] || count < 3 {
            continue;
        }
        let (p, q) = (prev[i], next[i]);
        let redundant =
            ring[i] == ring[p] || ring[i] == ring[q] || orient(ring[p], ring[i], ring[q]) == 0.0;
        if redundant {
            alive[i] = false;
            count -= 1;
            next[p] = q;
            prev[q] = p;
            work.push(p);
            work.push(q);
        }
    }
    if count < 3 {
        return Vec::new();
    }
    let start = (0..n).find(|&i| alive[i]).unwrap_or(0);
    let mut out = Vec::with_capacity(count);
    let mut i = start;
    loop {
        out.push(ring[i]);
        i = next[i];
        if i == start || out.len() > count {
            break;
        }
    }
    out
}

/// Validated rings with the interior on the left of every edge: outer first, counter-clockwise;
/// holes clockwise.
fn clean_rings(p: &Polygon2) -> Result<Vec<Vec<DVec2>>, PartitionError> {
    let total = p.outer.len() + p.holes.iter().map(Vec::len).sum::<usize>();
    if total > MAX_VERTICES {
        return Err(PartitionError::TooComplex);
    }
    let all_finite = p
        .outer
        .iter()
        .chain(p.holes.iter().flatten())
        .all(|v| v.is_finite());
    if !all_finite {
        return Err(PartitionError::Degenerate);
    }
    let mut outer = remove_collinear(&p.outer);
    if outer.len() < 3 {
        return Err(PartitionError::Degenerate);
    }
    let a = ring_area(&outer);
    if !a.is_finite() {
        return Err(PartitionError::Degenerate);
    }
    // A ring with no net area is not simple (a symmetric bow tie); the crossing check that
    // follows sends it to simplification.
    if a < 0.0 {
        outer.reverse();
    }
    let mut rings = vec![outer];
    for h in &p.holes {
        let mut h = remove_collinear(h);
        if h.len() < 3 {
            continue;
        }
        if ring_area(&h) > 0.0 {
            h.reverse();
        }
        rings.push(h);
    }
    Ok(rings)
}

/// Resolves crossing rings into simple polygons with holes (even-odd rule).
fn simplify_rings(rings: &[Vec<DVec2>]) -> Result<Vec<Polygon2>, PartitionError> {
    let extent = rings
        .iter()
        .flatten()
        .fold(0.0f64, |m, p| m.max(p.x.abs()).max(p.y.abs()));
    if !(extent > 0.0 && extent.is_finite()) {
        return Err(PartitionError::Degenerate);
    }
    // A power of two, so scaling by it and back is exact for everything that did not snap.
    let grid = 2f64.powi(extent.log2().floor() as i32 - 40);
    let to_int =
        |p: &DVec2| IntPoint::new((p.x / grid).round() as i64, (p.y / grid).round() as i64);
    let mut overlay = Overlay::<i64>::new(rings.iter().map(Vec::len).sum());
    for r in rings {
        let ring: Vec<IntPoint<i64>> = r.iter().map(to_int).collect();
        overlay.add_contour(&ring, ShapeType::Subject);
    }
    let shapes = overlay.overlay(OverlayRule::Subject, FillRule::EvenOdd);
    let back = |c: &Vec<IntPoint<i64>>| -> Vec<DVec2> {
        c.iter()
            .map(|p| DVec2::new(p.x as f64 * grid, p.y as f64 * grid))
            .collect()
    };
    Ok(shapes
        .iter()
        .filter(|s| !s.is_empty())
        .map(|s| Polygon2 {
            outer: back(&s[0]),
            holes: s[1..].iter().map(back).collect(),
        })
        .collect())
}

type Cdt = ConstrainedDelaunayTriangulation<Point2<f64>>;

/// Undirected vertex pair, smaller index first.
fn key(a: u32, b: u32) -> (u32, u32) {
    if a < b {
        (a, b)
    } else {
        (b, a)
    }
}

/// Above this many reflex corners the quadratic search for two-corner cuts is skipped; the
/// merge and local search still give a good partition.
const MAX_REFLEX_PAIRS: usize = 4_000;
/// Nearest partners per reflex corner whose visibility is walked when looking for two-corner cuts.
const MAX_WALKS_PER_CORNER: usize = 8;

fn partition_rings(rings: &[Vec<DVec2>]) -> Result<Vec<Vec<DVec2>>, Attempt> {
    let mut cdt = Cdt::new();
    let mut handles: Vec<Vec<FixedVertexHandle>> = Vec::with_capacity(rings.len());
    for r in rings {
        let mut hs = Vec::with_capacity(r.len());
        for p in r {
            let h = cdt
                .insert(Point2::new(p.x, p.y))
                .map_err(|_| Attempt::Failed(PartitionError::Degenerate))?;
            hs.push(h);
        }
        handles.push(hs);
    }
    let pos: Vec<DVec2> = (0..cdt.num_vertices())
        .map(|i| {
            let p = cdt.vertex(FixedVertexHandle::from_index(i)).position();
            DVec2::new(p.x, p.y)
        })
        .collect();

    // Ring edges, as pairs of vertices: the partition may never remove them, and only they
    // count when deciding what is inside.
    let mut ring_edges: HashSet<(u32, u32)> = HashSet::new();
    for hs in &handles {
        for i in 0..hs.len() {
            let (a, b) = (hs[i], hs[(i + 1) % hs.len()]);
            if a == b {
                continue;
            }
            let added = cdt.try_add_constraint(a, b);
            if added.is_empty() && !cdt.exists_constraint(a, b) {
                return Err(Attempt::Crossing);
            }
            for e in added {
                let [u, v] = cdt
                    .directed_edge(e)
                    .vertices()
                    .map(|v| v.fix().index() as u32);
                ring_edges.insert(key(u, v));
            }
            // An edge that was already a constraint (a ring doubling back) returns no edges.
            if cdt.exists_constraint(a, b) {
                ring_edges.insert(key(a.index() as u32, b.index() as u32));
            }
        }
    }

    let mut forced = add_two_corner_cuts(&mut cdt, rings, &handles, &pos);
    add_one_corner_cuts(&mut cdt, rings, &handles, &pos, &mut forced);

    // Inside faces by crossing parity from the outer face (the triangulation covers the hull).
    let nf = cdt.num_all_faces();
    let mut depth: Vec<Option<u32>> = vec![None; nf];
    let outer = cdt.outer_face().fix().index();
    depth[outer] = Some(0);
    let mut adj: Vec<Vec<(usize, bool)>> = vec![Vec::new(); nf];
    for e in cdt.directed_edges() {
        let [u, v] = e.vertices().map(|v| v.fix().index() as u32);
        adj[e.face().fix().index()].push((
            e.rev().face().fix().index(),
            ring_edges.contains(&key(u, v)),
        ));
    }
    let mut queue = VecDeque::from([outer]);
    while let Some(f) = queue.pop_front() {
        let d = depth[f].unwrap_or(0);
        for &(g, crossing) in &adj[f] {
            if depth[g].is_none() {
                depth[g] = Some(d + crossing as u32);
                queue.push_back(g);
            }
        }
    }
    let mut loops: Vec<Vec<u32>> = Vec::new();
    for f in cdt.inner_faces() {
        if depth[f.fix().index()].is_some_and(|d| d % 2 == 1) {
            loops.push(f.vertices().map(|v| v.fix().index() as u32).to_vec());
        }
    }
    if loops.is_empty() {
        return Err(Attempt::Failed(PartitionError::Degenerate));
    }

    let mut pieces = Pieces::new(loops, &pos, forced);
    pieces.optimise();
    Ok(pieces.output())
}

/// A reflex corner `v` with ring neighbours `p` (before) and `n` (after), interior on the left.
#[derive(Clone, Copy)]
struct Corner {
    v: u32,
    p: u32,
    n: u32,
}

impl Corner {
    /// Whether a cut from this corner to `w` leaves both sides with an angle of at most 180
    /// degrees here: `w` lies in the closed cone between the extensions of the two ring edges.
    fn resolves_towards(&self, w: u32, pos: &[DVec2]) -> bool {
        let (v, p, n, w) = (
            pos[self.v as usize],
            pos[self.p as usize],
            pos[self.n as usize],
            pos[w as usize],
        );
        w != v && orient(v, n, w) >= 0.0 && orient(v, w, p) >= 0.0
    }
}

/// Adds cuts that each resolve two reflex corners at once (the cuts an optimal partition of
/// a rectilinear plan is made of: the base of a comb's tooth, the inner sides of a plus).
/// Shortest first, each corner at most once; a cut must see its end without touching any
/// other vertex or crossing any constraint. Returns the added cuts.
fn add_two_corner_cuts(
    cdt: &mut Cdt,
    rings: &[Vec<DVec2>],
    handles: &[Vec<FixedVertexHandle>],
    pos: &[DVec2],
) -> HashSet<(u32, u32)> {
    let corners = reflex_corners(rings, handles);
    let mut forced = HashSet::new();
    if corners.len() < 2 || corners.len() > MAX_REFLEX_PAIRS {
        return forced;
    }
    // Mutual-cone partners, nearest first; only the nearest few are walked for visibility.
    let nc = corners.len();
    let mut partners: Vec<Vec<(f64, usize)>> = vec![Vec::new(); nc];
    for i in 0..nc {
        for j in i + 1..nc {
            let (a, b) = (corners[i], corners[j]);
            if a.resolves_towards(b.v, pos) && b.resolves_towards(a.v, pos) {
                let d = pos[a.v as usize].distance_squared(pos[b.v as usize]);
                partners[i].push((d, j));
                partners[j].push((d, i));
            }
        }
    }
    let handle = |i: usize| FixedVertexHandle::from_index(corners[i].v as usize);
    let mut graph: Vec<Vec<(f64, usize)>> = vec![Vec::new(); nc];
    for i in 0..nc {
        partners[i].sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
        for &(d, j) in partners[i].iter().take(MAX_WALKS_PER_CORNER) {
            if i < j && sees(cdt, handle(i), handle(j)) {
                graph[i].push((d, j));
                graph[j].push((d, i));
            }
        }
    }
    // Greedy matching, least-connected corner first: optimal on the paths and trees these
    // graphs usually are (a row of aligned reflex corners), where nearest-first is not.
    let mut used = vec![false; nc];
    let degree = |graph: &Vec<Vec<(f64, usize)>>, used: &Vec<bool>, i: usize| {
        graph[i].iter().filter(|&&(_, j)| !used[j]).count()
    };
    loop {
        let pick = (0..nc)
            .filter(|&i| !used[i])
            .map(|i| (degree(&graph, &used, i), i))
            .filter(|&(d, _)| d > 0)
            .min();
        let Some((_, i)) = pick else { break };
        let mut options: Vec<(usize, f64, usize)> = graph[i]
            .iter()
            .filter(|&&(_, j)| !used[j])
            .map(|&(d, j)| (degree(&graph, &used, j), d, j))
            .collect();
        options.sort_by(|x, y| x.0.cmp(&y.0).then(x.1.total_cmp(&y.1)).then(x.2.cmp(&y.2)));
        for (_, _, j) in options {
            // An earlier cut may cross this one; it is a constraint by now, so `sees` says so.
            if !sees(cdt, handle(i), handle(j)) {
                continue;
            }
            if cdt.try_add_constraint(handle(i), handle(j)).is_empty()
                && !cdt.exists_constraint(handle(i), handle(j))
            {
                continue;
            }
            used[j] = true;
            forced.insert(key(corners[i].v, corners[j].v));
            break;
        }
        // Matched or not, this corner is settled.
        used[i] = true;
    }
    forced
}

/// Resolves every reflex corner no two-corner cut took with a cut of its own, to the nearest
/// vertex it sees in its cone (ties by vertex order, corners in vertex order). The pieces are
/// then fixed by the plan alone, before the triangulation is merged: its diagonals follow the
/// Delaunay rule, which near-cocircular corners (a rectangle's, with f32 noise) settle one way
/// or the other as the booleans' grid changes, and the merge kept whichever diagonal at a
/// corner came first, so the same L could be cut along either of its two arms.
fn add_one_corner_cuts(
    cdt: &mut Cdt,
    rings: &[Vec<DVec2>],
    handles: &[Vec<FixedVertexHandle>],
    pos: &[DVec2],
    forced: &mut HashSet<(u32, u32)>,
) {
    let done: HashSet<u32> = forced.iter().flat_map(|&(a, b)| [a, b]).collect();
    let mut corners: Vec<Corner> = reflex_corners(rings, handles)
        .into_iter()
        .filter(|c| !done.contains(&c.v))
        .collect();
    if corners.len() > MAX_REFLEX_PAIRS {
        return;
    }
    corners.sort_by_key(|c| c.v);
    for c in corners {
        let from = pos[c.v as usize];
        let mut options: Vec<(f64, u32)> = (0..pos.len() as u32)
            .filter(|&w| c.resolves_towards(w, pos))
            .map(|w| (from.distance_squared(pos[w as usize]), w))
            .collect();
        options.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
        let u = FixedVertexHandle::from_index(c.v as usize);
        for &(_, w) in options.iter().take(MAX_WALKS_PER_CORNER) {
            let wh = FixedVertexHandle::from_index(w as usize);
            if !sees(cdt, u, wh) {
                continue;
            }
            if cdt.try_add_constraint(u, wh).is_empty() && !cdt.exists_constraint(u, wh) {
                continue;
            }
            forced.insert(key(c.v, w));
            break;
        }
    }
}

/// The reflex corners of the rings, but those where the boundary touches itself (two corners
/// at one vertex, where a cut is ambiguous).
fn reflex_corners(rings: &[Vec<DVec2>], handles: &[Vec<FixedVertexHandle>]) -> Vec<Corner> {
    let mut corners: Vec<Corner> = Vec::new();
    let mut seen: HashSet<u32> = HashSet::new();
    let mut shared: HashSet<u32> = HashSet::new();
    for (r, hs) in rings.iter().zip(handles) {
        let n = r.len();
        for i in 0..n {
            let (ip, inx) = ((i + n - 1) % n, (i + 1) % n);
            if orient(r[ip], r[i], r[inx]) < 0.0 {
                let v = hs[i].index() as u32;
                if !seen.insert(v) {
                    shared.insert(v);
                }
                corners.push(Corner {
                    v,
                    p: hs[ip].index() as u32,
                    n: hs[inx].index() as u32,
                });
            }
        }
    }
    corners.retain(|c| !shared.contains(&c.v));
    corners
}

/// The open segment u-v crosses no constraint and touches no vertex.
fn sees(cdt: &Cdt, u: FixedVertexHandle, v: FixedVertexHandle) -> bool {
    for x in LineIntersectionIterator::new_from_handles(cdt, u, v) {
        match x {
            Intersection::VertexIntersection(w) => {
                if w.fix() != u && w.fix() != v {
                    return false;
                }
            }
            Intersection::EdgeIntersection(e) | Intersection::EdgeOverlap(e) => {
                if e.is_constraint_edge() {
                    return false;
                }
            }
        }
    }
    true
}

/// Convex pieces as vertex loops (counter-clockwise, collinear vertices kept so that shared
/// edges stay literally shared), merged and improved in place.
struct Pieces<'a> {
    loops: Vec<Option<Vec<u32>>>,
    area: Vec<f64>,
    pos: &'a [DVec2],
    /// Two-corner cuts: merged across last, since removing one is almost never right.
    forced: HashSet<(u32, u32)>,
}

/// A heap entry for a merge across the shared edge `a -> b` of piece `p` (with `b -> a` in `q`).
struct Merge {
    rank: u8,
    area: f64,
    p: usize,
    q: usize,
    a: u32,
    b: u32,
}

impl Merge {
    fn order(&self, o: &Self) -> Ordering {
        self.rank
            .cmp(&o.rank)
            .then(self.area.total_cmp(&o.area))
            // Deterministic ties: earlier pieces first.
            .then(o.p.cmp(&self.p))
            .then(o.q.cmp(&self.q))
            .then(o.a.cmp(&self.a))
            .then(o.b.cmp(&self.b))
    }
}
impl PartialEq for Merge {
    fn eq(&self, o: &Self) -> bool {
        self.order(o) == Ordering::Equal
    }
}
impl Eq for Merge {}
impl PartialOrd for Merge {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Merge {
    fn cmp(&self, o: &Self) -> Ordering {
        self.order(o)
    }
}

/// Pieces of at most this many vertices take part in the three-into-two search.
const MAX_LOCAL_VERTICES: usize = 96;
const MAX_ROUNDS: usize = 12;

impl<'a> Pieces<'a> {
    fn new(loops: Vec<Vec<u32>>, pos: &'a [DVec2], forced: HashSet<(u32, u32)>) -> Self {
        let area = loops.iter().map(|l| loop_area(l, pos)).collect();
        Pieces {
            loops: loops.into_iter().map(Some).collect(),
            area,
            pos,
            forced,
        }
    }

    fn optimise(&mut self) {
        self.merge_pairs();
        for _ in 0..MAX_ROUNDS {
            if !self.three_into_two() {
                break;
            }
            self.merge_pairs();
        }
    }

    /// Directed loop edge -> piece.
    fn edge_map(&self) -> HashMap<(u32, u32), usize> {
        let mut m = HashMap::new();
        for (i, l) in self.loops.iter().enumerate() {
            if let Some(l) = l {
                for k in 0..l.len() {
                    m.insert((l[k], l[(k + 1) % l.len()]), i);
                }
            }
        }
        m
    }

    /// Hertel–Mehlhorn: merge neighbours while the union stays convex, the largest union
    /// first (big pieces early leave fewer awkward remnants), two-corner cuts last.
    fn merge_pairs(&mut self) {
        loop {
            let map = self.edge_map();
            let mut heap = BinaryHeap::new();
            for (&(a, b), &p) in &map {
                if a < b {
                    if let Some(&q) = map.get(&(b, a)) {
                        if q != p {
                            heap.push(self.merge_entry(p, q, a, b));
                        }
                    }
                }
            }
            let mut owner: Vec<usize> = (0..self.loops.len()).collect();
            let find = |owner: &mut Vec<usize>, mut x: usize| {
                while owner[x] != x {
                    owner[x] = owner[owner[x]];
                    x = owner[x];
                }
                x
            };
            let mut merged_any = false;
            while let Some(m) = heap.pop() {
                let (p, q) = (find(&mut owner, m.p), find(&mut owner, m.q));
                if p == q {
                    continue;
                }
                if p != m.p || q != m.q || m.area != self.area[p] + self.area[q] {
                    heap.push(self.merge_entry(p, q, m.a, m.b));
                    continue;
                }
                let (Some(lp), Some(lq)) = (&self.loops[p], &self.loops[q]) else {
                    continue;
                };
                let Some(u) = splice(lp, lq, m.a, m.b) else {
                    continue;
                };
                if !is_convex(&u, self.pos) {
                    continue;
                }
                self.loops[p] = Some(u);
                self.loops[q] = None;
                self.area[p] += self.area[q];
                owner[q] = p;
                merged_any = true;
            }
            if !merged_any {
                return;
            }
        }
    }

    fn merge_entry(&self, p: usize, q: usize, a: u32, b: u32) -> Merge {
        let rank = if self.forced.contains(&key(a, b)) {
            0
        } else {
            1
        };
        Merge {
            rank,
            area: self.area[p] + self.area[q],
            p,
            q,
            a,
            b,
        }
    }

    /// Local search: three neighbouring pieces whose union can be cut into two convex pieces
    /// are replaced by those two. This repairs the usual Hertel–Mehlhorn mistake of merging
    /// across a corner too early. Returns whether anything changed.
    fn three_into_two(&mut self) -> bool {
        let map = self.edge_map();
        let mut changed = false;
        let mut consumed = vec![false; self.loops.len()];
        for b in 0..self.loops.len() {
            let Some(lb) = &self.loops[b] else { continue };
            if consumed[b] || lb.len() > MAX_LOCAL_VERTICES {
                continue;
            }
            let mut nbrs: Vec<usize> = Vec::new();
            for k in 0..lb.len() {
                if let Some(&q) = map.get(&(lb[(k + 1) % lb.len()], lb[k])) {
                    if q != b && !nbrs.contains(&q) {
                        nbrs.push(q);
                    }
                }
            }
            'pairs: for i in 0..nbrs.len() {
                for j in i + 1..nbrs.len() {
                    let (a, c) = (nbrs[i], nbrs[j]);
                    if consumed[a] || consumed[c] || consumed[b] {
                        continue;
                    }
                    let group: Vec<&Vec<u32>> = [a, b, c]
                        .iter()
                        .filter_map(|&k| self.loops[k].as_ref())
                        .collect();
                    if group.len() != 3 || group.iter().any(|l| l.len() > MAX_LOCAL_VERTICES) {
                        continue;
                    }
                    let Some(u) = union_loop(&group) else {
                        continue;
                    };
                    let Some((x, y)) = split_in_two(&u, self.pos) else {
                        continue;
                    };
                    let total = self.area[a] + self.area[b] + self.area[c];
                    let ax = loop_area(&x, self.pos);
                    self.loops[a] = Some(x);
                    self.area[a] = ax;
                    self.loops[c] = Some(y);
                    self.area[c] = total - ax;
                    self.loops[b] = None;
                    self.area[b] = 0.0;
                    consumed[a] = true;
                    consumed[b] = true;
                    consumed[c] = true;
                    changed = true;
                    break 'pairs;
                }
            }
        }
        changed
    }

    fn output(&self) -> Vec<Vec<DVec2>> {
        self.loops
            .iter()
            .flatten()
            .map(|l| {
                let pts: Vec<DVec2> = l.iter().map(|&i| self.pos[i as usize]).collect();
                remove_collinear(&pts)
            })
            .filter(|p| p.len() >= 3)
            .collect()
    }
}

fn loop_area(l: &[u32], pos: &[DVec2]) -> f64 {
    let pts: Vec<DVec2> = l.iter().map(|&i| pos[i as usize]).collect();
    ring_area(&pts)
}

/// Joins loop `p` (which has the edge `a -> b` or `b -> a`) with loop `q` (the reverse) along
/// that edge. `None` when the edge is not where it should be.
fn splice(p: &[u32], q: &[u32], a: u32, b: u32) -> Option<Vec<u32>> {
    let find =
        |l: &[u32], x: u32, y: u32| (0..l.len()).find(|&k| l[k] == x && l[(k + 1) % l.len()] == y);
    let (x, y) = if find(p, a, b).is_some() {
        (a, b)
    } else {
        (b, a)
    };
    let i = find(p, x, y)?;
    let j = find(q, y, x)?;
    let (np, nq) = (p.len(), q.len());
    let mut out = Vec::with_capacity(np + nq - 2);
    // p from y round to x, then q strictly between x and y.
    out.extend((1..=np).map(|k| p[(i + k) % np]));
    out.extend((2..nq).map(|k| q[(j + k) % nq]));
    Some(out)
}

/// The boundary of a union of pieces: shared edges cancel, the rest must form one loop.
fn union_loop(group: &[&Vec<u32>]) -> Option<Vec<u32>> {
    let mut edges: HashSet<(u32, u32)> = HashSet::new();
    for l in group {
        for k in 0..l.len() {
            let e = (l[k], l[(k + 1) % l.len()]);
            if !edges.remove(&(e.1, e.0)) {
                edges.insert(e);
            }
        }
    }
    let mut next: HashMap<u32, u32> = HashMap::with_capacity(edges.len());
    for &(a, b) in &edges {
        if next.insert(a, b).is_some() {
            return None;
        }
    }
    let start = *next.keys().min()?;
    let mut out = vec![start];
    let mut cur = next[&start];
    while cur != start {
        if out.len() > edges.len() {
            return None;
        }
        out.push(cur);
        cur = *next.get(&cur)?;
    }
    (out.len() == edges.len()).then_some(out)
}

/// Cuts a loop with at most two reflex corners into two convex loops along one diagonal.
fn split_in_two(u: &[u32], pos: &[DVec2]) -> Option<(Vec<u32>, Vec<u32>)> {
    let m = u.len();
    let at = |k: usize| pos[u[k % m] as usize];
    let reflex: Vec<usize> = (0..m)
        .filter(|&k| orient(at(k + m - 1), at(k), at(k + 1)) < 0.0)
        .collect();
    let tries: Vec<(usize, usize)> = match reflex.as_slice() {
        [r] => (0..m).map(|k| (*r, k)).collect(),
        [r, s] => vec![(*r, *s)],
        _ => return None,
    };
    for (i, j) in tries {
        let (i, j) = (i.min(j), i.max(j));
        if j - i < 2 || (i == 0 && j == m - 1) {
            continue;
        }
        let x: Vec<u32> = u[i..=j].to_vec();
        let y: Vec<u32> = u[j..].iter().chain(&u[..=i]).copied().collect();
        if is_convex(&x, pos) && is_convex(&y, pos) {
            return Some((x, y));
        }
    }
    None
}

/// A simple convex counter-clockwise loop: distinct vertices, no right turn, no doubling back,
/// and the edge directions turn exactly once around (so a star polygon does not pass).
fn is_convex(l: &[u32], pos: &[DVec2]) -> bool {
    let m = l.len();
    if m < 3 {
        return false;
    }
    let mut sorted = l.to_vec();
    sorted.sort_unstable();
    if sorted.windows(2).any(|w| w[0] == w[1]) {
        return false;
    }
    let at = |k: usize| pos[l[k % m] as usize];
    // Direction in the upper half-plane (0) or the lower one (1); exact, from signs only.
    let half = |d: DVec2| {
        if d.y > 0.0 || (d.y == 0.0 && d.x > 0.0) {
            0
        } else {
            1
        }
    };
    let mut wraps = 0;
    for k in 0..m {
        let (a, b, q) = (at(k + m - 1), at(k), at(k + 1));
        let o = orient(a, b, q);
        if o < 0.0 {
            return false;
        }
        let (d0, d1) = (b - a, q - b);
        // Collinear: must go on, not back (the sign of a difference of floats is exact).
        if o == 0.0 && (d0.x * d1.x < 0.0 || d0.y * d1.y < 0.0 || (d0.x == 0.0 && d0.y == 0.0)) {
            return false;
        }
        if half(d0) == 1 && half(d1) == 0 {
            wraps += 1;
        }
    }
    wraps == 1
}

#[cfg(test)]
mod tests {
    use super::*;

    fn poly(outer: &[(f64, f64)], holes: &[&[(f64, f64)]]) -> Polygon2 {
        let v = |r: &[(f64, f64)]| r.iter().map(|&(x, y)| DVec2::new(x, y)).collect::<Vec<_>>();
        Polygon2 {
            outer: v(outer),
            holes: holes.iter().map(|h| v(h)).collect(),
        }
    }

    fn check(p: &Polygon2) -> usize {
        let pieces = convex_partition(p).expect("partition");
        let sum: f64 = pieces.iter().map(|q| ring_area(q)).sum();
        assert!(
            (sum - p.area()).abs() <= 1e-9 * p.area().abs(),
            "area {sum} vs {}",
            p.area()
        );
        for q in &pieces {
            for k in 0..q.len() {
                let o = orient(q[(k + q.len() - 1) % q.len()], q[k], q[(k + 1) % q.len()]);
                assert!(o > 0.0, "piece {q:?} not strictly convex");
            }
        }
        pieces.len()
    }

    #[test]
    fn l_shape_is_two() {
        let p = poly(
            &[(0., 0.), (6., 0.), (6., 3.), (3., 3.), (3., 6.), (0., 6.)],
            &[],
        );
        assert_eq!(check(&p), 2);
    }

    #[test]
    fn u_shape_is_three() {
        let p = poly(
            &[
                (0., 0.),
                (9., 0.),
                (9., 6.),
                (6., 6.),
                (6., 3.),
                (3., 3.),
                (3., 6.),
                (0., 6.),
            ],
            &[],
        );
        assert_eq!(check(&p), 3);
    }

    #[test]
    fn ring_is_four() {
        let p = poly(
            &[(0., 0.), (10., 0.), (10., 10.), (0., 10.)],
            &[&[(4., 4.), (4., 6.), (6., 6.), (6., 4.)]],
        );
        assert_eq!(check(&p), 4);
    }

    #[test]
    fn convex_input_is_one_piece() {
        let p = poly(&[(0., 0.), (2., 0.), (4., 0.), (4., 4.), (0., 4.)], &[]);
        let pieces = convex_partition(&p).unwrap();
        assert_eq!(pieces.len(), 1);
        assert_eq!(pieces[0].len(), 4, "collinear vertex removed");
    }

    /// A convex ring comes back as it is (cleaned, counter-clockwise, same first corner); a
    /// ring that turns left at every corner but winds twice (a pentagram) is no convex piece.
    #[test]
    fn convex_ring_is_its_own_partition_but_a_pentagram_is_not() {
        let p = poly(&[(4., 4.), (0., 4.), (0., 0.), (2., 0.), (4., 0.)], &[]);
        let pieces = convex_partition(&p).unwrap();
        let want: Vec<DVec2> = [(4., 4.), (0., 4.), (0., 0.), (4., 0.)]
            .iter()
            .map(|&(x, y)| DVec2::new(x, y))
            .collect();
        assert_eq!(pieces, vec![want]);
        let star: Vec<(f64, f64)> = (0..5)
            .map(|k| {
                let t = k as f64 * 4.0 * std::f64::consts::PI / 5.0;
                (t.cos(), t.sin())
            })
            .collect();
        let pieces = convex_partition(&poly(&star, &[])).unwrap();
        assert!(pieces.len() >= 5, "the five tips, got {pieces:?}");
    }

    #[test]
    fn clockwise_outer_and_counter_clockwise_hole_are_accepted() {
        let p = poly(
            &[(0., 10.), (10., 10.), (10., 0.), (0., 0.)],
            &[&[(4., 4.), (6., 4.), (6., 6.), (4., 6.)]],
        );
        assert_eq!(check(&p), 4);
    }

    #[test]
    fn bad_input_is_an_error_not_a_panic() {
        let nan = poly(&[(0., 0.), (f64::NAN, 0.), (1., 1.)], &[]);
        assert_eq!(convex_partition(&nan), Err(PartitionError::Degenerate));
        let inf = poly(&[(0., 0.), (f64::INFINITY, 0.), (1., 1.)], &[]);
        assert_eq!(convex_partition(&inf), Err(PartitionError::Degenerate));
        let line = poly(&[(0., 0.), (1., 0.), (2., 0.)], &[]);
        assert_eq!(convex_partition(&line), Err(PartitionError::Degenerate));
        let two = poly(&[(0., 0.), (1., 0.)], &[]);
        assert_eq!(convex_partition(&two), Err(PartitionError::Degenerate));
    }

    #[test]
    fn bow_tie_is_resolved_by_simplification() {
        let p = poly(&[(0., 0.), (2., 2.), (2., 0.), (0., 2.)], &[]);
        let pieces = convex_partition(&p).unwrap();
        let sum: f64 = pieces.iter().map(|q| ring_area(q)).sum();
        assert!(
            (sum - 2.0).abs() < 1e-9,
            "two triangles of area 1, got {sum}"
        );
    }

    #[test]
    fn convexity_test_rejects_star_and_spike() {
        let pos: Vec<DVec2> = (0..5)
            .map(|k| {
                let t = k as f64 * 4.0 * std::f64::consts::PI / 5.0;
                DVec2::new(t.cos(), t.sin())
            })
            .collect();
        assert!(!is_convex(&[0, 1, 2, 3, 4], &pos), "pentagram winds twice");
        let sq = [
            DVec2::ZERO,
            DVec2::X,
            DVec2::ONE,
            DVec2::Y,
            DVec2::new(2.0, 0.0),
        ];
        assert!(is_convex(&[0, 1, 2, 3], &sq));
        assert!(!is_convex(&[0, 1, 4, 1, 2, 3], &sq), "repeated vertex");
    }

    #[test]
    fn union_of_square_pair_is_one_rectangle() {
        let t = |a: (f64, f64), b: (f64, f64), c: (f64, f64)| {
            [
                DVec2::new(a.0, a.1),
                DVec2::new(b.0, b.1),
                DVec2::new(c.0, c.1),
            ]
        };
        let tris = [
            t((0., 0.), (1., 0.), (1., 1.)),
            t((0., 0.), (1., 1.), (0., 1.)),
            t((1., 0.), (1., 1.), (2., 0.)), // clockwise on purpose
            t((2., 0.), (1., 1.), (2., 1.)),
        ];
        let u = union_triangles(&tris, 1e-3);
        assert_eq!(u.len(), 1);
        assert_eq!(u[0].outer.len(), 4);
        assert!(u[0].holes.is_empty());
        assert!((u[0].area() - 2.0).abs() < 1e-9);
        assert!(ring_area(&u[0].outer) > 0.0, "outer is counter-clockwise");
    }

    #[test]
    fn union_drops_slivers() {
        let tris = [[DVec2::ZERO, DVec2::new(10.0, 0.0), DVec2::new(10.0, 1e-4)]];
        assert!(union_triangles(&tris, 1e-3).is_empty());
        assert!(union_triangles(&tris, 0.0).is_empty());
    }
}
