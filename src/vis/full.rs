//! `full`: Quake's portal flow. From each directed portal (the source) the flow walks into the
//! cells beyond, and for each further portal keeps only the part that can be seen from the
//! source through every portal passed so far: the pass portal is clipped by the source's plane,
//! the source by the pass portal's back, and both by the separating planes between them (an
//! edge of one and a vertex of the other, with the two on opposite sides), all four ways as in
//! ericw-tools' `testlevel 4`. A portal with anything left is visible; the flow recurses
//! through it with what is left. Every sightline through the chain passes through what is
//! left, so the result is conservative.
//!
//! Speed comes from never looking at what cannot matter: the stack carries the "might see"
//! bits of every portal passed (ANDed), a portal whose might-see adds nothing new to what the
//! source already sees and that is itself already seen is skipped, portals wholly behind a
//! separating plane are dropped from the stack's bits, and the polygons live in per-depth
//! buffers reused for the whole run. Portals are processed in waves ordered by their
//! might-see count; a wave uses the finished results of earlier waves as its (tighter)
//! might-see, and starts each source from what the finished portals out of the same cell
//! already see (the cell's PVS is their union, so only what is new to the cell is looked
//! for). Where every portal has its reverse and none is transformed, visibility is symmetric:
//! `p` can see `q` only if `q`'s reverse sees `p`'s reverse, so a finished reverse that never
//! reached `p`'s cell rules `q` out of `p`'s might-see. The result depends only on the wave
//! split, never on the thread count; the split breaks ties by the graph's `order` (the cells'
//! rank by room name where the level gives it), not by the portals' numbers, so the same
//! level with its rooms listed in another order gets the same PVS.
//!
//! A transformed portal moves the whole stack (source, pass, planes) into the target side's
//! space, and the might-see of the world no longer applies, so it is reset to every portal;
//! `depth` bounds how many transformed portals one chain may pass.

use glam::DVec3;
use rayon::prelude::*;

use super::bits;
use super::graph::{transform_plane, VisGraph};
use super::winding::{chop, chop_in_sphere, clip_by, separators, sphere, Chop};
use super::Pvs;
use crate::geom::plane::Plane;

/// ericw-tools' tests 2 and 3: also narrow the source by the separators of the target.
const NARROW_SOURCE: bool = true;

#[derive(Default)]
struct Frame {
    source: Vec<DVec3>,
    pass: Vec<DVec3>,
    has_pass: bool,
    /// The plane of the portal this frame went through (facing onwards).
    pass_plane: Option<Plane>,
    /// The source portal's plane, in this frame's space.
    source_plane: Option<Plane>,
    might: Vec<u64>,
    transforms: usize,
    /// A sphere around `source`, computed on first use.
    source_sphere: Option<(DVec3, f64)>,
    /// The separating planes between this frame's source and pass, computed on first use.
    seps: Vec<Plane>,
    seps_ready: bool,
}

struct Run<'a> {
    g: &'a VisGraph,
    /// Per portal, its flow result once `finished`, else its might-see set.
    rows: &'a [Vec<u64>],
    finished: &'a [bool],
    /// The symmetry filter, where every portal has a reverse and none is transformed.
    sym: Option<&'a Symmetry>,
    entering: &'a [Vec<usize>],
    /// Per portal, a bounding sphere (centre, radius).
    spheres: &'a [(DVec3, f64)],
    depth: usize,
    all: &'a [u64],
}

struct State {
    frames: Vec<Frame>,
    vis: Vec<u64>,
    tmp: Vec<DVec3>,
    planes: Vec<Plane>,
}

/// Symmetry on graphs where every portal has its reverse and none is transformed: `p` can
/// see `r` only if `r`'s reverse sees `p`'s reverse, which enters `p`'s cell. Both rows are
/// indexed by `r` (the reverse of the finished portal), so the filter is a word-wide mask.
struct Symmetry {
    /// Bit `r`: `r`'s reverse is finished.
    finished: Vec<u64>,
    /// Per cell, bit `r`: `r`'s reverse is finished and saw the cell.
    seen: Vec<Vec<u64>>,
}

impl Symmetry {
    /// Drops from `row` (what a portal out of `cell` might see) every portal whose finished
    /// reverse never saw `cell`.
    fn filter(&self, row: &mut [u64], cell: usize) {
        for ((m, f), s) in row.iter_mut().zip(&self.finished).zip(&self.seen[cell]) {
            *m &= !f | s;
        }
    }
}

/// How many waves the sorted portals are split into.
const WAVES: usize = 64;

/// The cell PVS. `might`: the `fast` might-see sets, the filter of the flow.
pub fn pvs(g: &VisGraph, might: Vec<Vec<u64>>, depth: usize) -> Pvs {
    super::fast::cell_pvs(g, &portal_vis(g, might, depth), depth)
}

/// Per directed portal, the portals it sees. `rows` starts as the might-see sets; each is
/// replaced by the flow's result when its wave is over, so one matrix serves as the filter,
/// the finished results and the output.
pub(crate) fn portal_vis(g: &VisGraph, mut rows: Vec<Vec<u64>>, depth: usize) -> Vec<Vec<u64>> {
    let n = g.portals.len();
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by_key(|&p| (bits::count(&rows[p]), g.order[p], p));
    let mut finished = vec![false; n];
    let wave = n.div_ceil(WAVES).max(1);
    let mut entering = vec![Vec::new(); g.cells];
    for (i, p) in g.portals.iter().enumerate() {
        entering[p.to].push(i);
    }
    let spheres: Vec<(DVec3, f64)> = g.portals.iter().map(|p| sphere(&p.winding)).collect();
    let all = bits::all(n);
    // Every sightline can be walked back only when every portal has its reverse.
    let symmetric = !g.has_transforms() && g.reverse.iter().all(Option::is_some);
    let mut sym = Symmetry {
        finished: vec![0; bits::words(n)],
        seen: vec![vec![0; bits::words(n)]; if symmetric { g.cells } else { 0 }],
    };
    for chunk in order.chunks(wave) {
        let run = Run {
            g,
            rows: &rows,
            finished: &finished,
            sym: symmetric.then_some(&sym),
            entering: &entering,
            spheres: &spheres,
            depth,
            all: &all,
        };
        // Largest first within the wave (the order is ascending), in small pieces, so the
        // threads finish the wave together. The wave's members, and so the result, are fixed.
        let results: Vec<Vec<u64>> = chunk
            .par_iter()
            .rev()
            .with_max_len(4)
            .map_init(
                || State {
                    frames: Vec::new(),
                    vis: Vec::new(),
                    tmp: Vec::new(),
                    planes: Vec::new(),
                },
                |st, &p| run.source(st, p),
            )
            .collect();
        for (&p, r) in chunk.iter().rev().zip(results) {
            if let (true, Some(rp)) = (symmetric, g.reverse[p]) {
                // Rows hold every portal into a seen cell; the first marks the cell.
                bits::set(&mut sym.finished, rp);
                for q in bits::ones(&r) {
                    let to = g.portals[q].to;
                    if entering[to].first() == Some(&q) {
                        bits::set(&mut sym.seen[to], rp);
                    }
                }
            }
            rows[p] = r;
            finished[p] = true;
        }
    }
    rows
}

impl Run<'_> {
    fn frame(st: &mut State, d: usize, words: usize) {
        while st.frames.len() <= d {
            st.frames.push(Frame {
                might: vec![0; words],
                ..Default::default()
            });
        }
    }

    /// Marks a cell seen by marking every portal into it: the flow's "anything new?" test then
    /// skips chains that could only find cells already seen, and the row stays a valid
    /// might-see filter for later waves (it holds every portal the source can see).
    fn see(&self, st: &mut State, cell: usize) {
        for &r in &self.entering[cell] {
            bits::set(&mut st.vis, r);
        }
    }

    fn source(&self, st: &mut State, p: usize) -> Vec<u64> {
        let g = self.g;
        let words = bits::words(g.portals.len());
        st.vis.clear();
        st.vis.resize(words, 0);
        let src = &g.portals[p];
        // What the finished portals out of the same cell see is already in the cell's PVS:
        // starting from it, the flow looks only for what is new to the cell. The row stays a
        // superset of what `p` sees, so it is still a valid filter.
        for &o in &g.leaving[src.from] {
            if self.finished[o] {
                for (v, x) in st.vis.iter_mut().zip(&self.rows[o]) {
                    *v |= x;
                }
            }
        }
        Self::frame(st, 0, words);
        let f = &mut st.frames[0];
        f.source.clear();
        f.source.extend_from_slice(&src.winding);
        f.has_pass = false;
        f.pass_plane = Some(src.plane);
        f.source_plane = Some(src.plane);
        f.might.copy_from_slice(&self.rows[p]);
        if let Some(sym) = self.sym {
            sym.filter(&mut f.might, src.from);
        }
        f.transforms = 0;
        f.seps_ready = false;
        f.source_sphere = None;
        if let Some(m) = src.transform {
            if self.depth == 0 {
                return st.vis.clone();
            }
            for v in f.source.iter_mut() {
                *v = m.transform_point3(*v);
            }
            let pl = transform_plane(&m, &src.plane);
            f.pass_plane = Some(pl);
            f.source_plane = Some(pl);
            f.might.copy_from_slice(self.all);
            f.transforms = 1;
        }
        self.see(st, src.to);
        self.flow(st, 0, src.to);
        st.vis.clone()
    }

    fn flow(&self, st: &mut State, d: usize, cell: usize) {
        let g = self.g;
        let eps = g.epsilon;
        let words = st.vis.len();
        Self::frame(st, d + 1, words);
        for &q in &g.leaving[cell] {
            let (lo, hi) = st.frames.split_at_mut(d + 1);
            let cur = &mut lo[d];
            let next = &mut hi[0];
            if !bits::get(&cur.might, q) {
                continue;
            }
            let portal = &g.portals[q];
            if portal.transform.is_some() && cur.transforms >= self.depth {
                continue;
            }
            let test = &self.rows[q];
            let more = bits::and_into(&mut next.might, &cur.might, test, &st.vis);
            if !more && bits::get(&st.vis, q) {
                continue;
            }
            let source_plane = cur.source_plane.expect("set on every frame");
            let pass_plane = portal.plane;
            // What of the portal is in front of the source.
            let sph = self.spheres[q];
            if chop_in_sphere(&portal.winding, sph, &source_plane, eps, &mut next.pass)
                == Chop::Gone
            {
                continue;
            }
            // What of the source is behind the portal.
            let src_sph = *cur.source_sphere.get_or_insert_with(|| sphere(&cur.source));
            let flipped = pass_plane.flipped();
            let source_cut =
                match chop_in_sphere(&cur.source, src_sph, &flipped, eps, &mut next.source) {
                    Chop::Gone => continue,
                    Chop::Whole => false,
                    Chop::Cut => true,
                };
            if cur.has_pass {
                let prev_plane = cur.pass_plane.expect("set on every frame");
                if !chop(&next.pass, &prev_plane, eps, &mut st.tmp) {
                    continue;
                }
                std::mem::swap(&mut next.pass, &mut st.tmp);
                let t = &mut st.tmp;
                // Separators between the source and the previous pass: the frame's own set
                // while the source is uncut, which is nearly always.
                let planes = if source_cut {
                    st.planes.clear();
                    separators(&next.source, &cur.pass, false, eps, &mut st.planes);
                    separators(&cur.pass, &next.source, true, eps, &mut st.planes);
                    &st.planes
                } else {
                    if !cur.seps_ready {
                        cur.seps.clear();
                        separators(&cur.source, &cur.pass, false, eps, &mut cur.seps);
                        separators(&cur.pass, &cur.source, true, eps, &mut cur.seps);
                        cur.seps_ready = true;
                    }
                    &cur.seps
                };
                if !clip_by(planes, &mut next.pass, t, eps) {
                    continue;
                }
                if NARROW_SOURCE {
                    // Narrow the source by the planes through the target's edges that have
                    // the previous pass in front (ericw-tools' test 3); this keeps the
                    // separators of deeper frames tight.
                    st.planes.clear();
                    separators(&next.pass, &cur.pass, false, eps, &mut st.planes);
                    if !clip_by(&st.planes, &mut next.source, t, eps) {
                        continue;
                    }
                }
            }
            next.seps_ready = false;
            next.source_sphere = None;
            next.has_pass = true;
            next.pass_plane = Some(pass_plane);
            next.source_plane = Some(source_plane);
            next.transforms = cur.transforms;
            if let Some(m) = portal.transform {
                for v in next.source.iter_mut().chain(next.pass.iter_mut()) {
                    *v = m.transform_point3(*v);
                }
                next.pass_plane = Some(transform_plane(&m, &pass_plane));
                next.source_plane = Some(transform_plane(&m, &source_plane));
                next.might.copy_from_slice(self.all);
                next.transforms += 1;
            }
            self.see(st, portal.to);
            if !self.prune(st, d + 1) {
                continue;
            }
            self.flow(st, d + 1, portal.to);
        }
    }

    /// Before recursing into frame `d`: drops from its might-see every portal not yet covered
    /// whose bounding sphere lies wholly behind the source plane, the pass plane or a
    /// separating plane of the frame (nothing of it can be seen through this chain). False
    /// when nothing new is left to find, so the recursion is skipped.
    fn prune(&self, st: &mut State, d: usize) -> bool {
        let eps = self.g.epsilon;
        let f = &mut st.frames[d];
        if f.might.iter().zip(&st.vis).all(|(m, v)| m & !v == 0) {
            return false;
        }
        if !f.seps_ready {
            f.seps.clear();
            separators(&f.source, &f.pass, false, eps, &mut f.seps);
            separators(&f.pass, &f.source, true, eps, &mut f.seps);
            f.seps_ready = true;
        }
        // In the world's space the rows start from `fast` rows (portals partly in front of the
        // source), and the separators reject nearly all the pass plane would; behind a
        // transform the rows hold everything, so both planes are tested there. Dropping a
        // test only weakens the pruning, never the result.
        let planes = if f.transforms > 0 {
            [f.source_plane, f.pass_plane]
        } else {
            [None, None]
        };
        let seps = &f.seps;
        // Whether a portal is wholly behind a plane: the sphere first, the polygon's corners
        // when the sphere straddles.
        let behind = |pl: &Plane, (c, r): (DVec3, f64), wind: &[DVec3]| {
            let dc = pl.distance(c);
            dc < -r - eps || (dc < r && wind.iter().all(|v| pl.distance(*v) < -eps))
        };
        // The plane that rejected last is tried first: neighbouring portals tend to fall
        // behind the same one. The order changes only the speed, never which bits go.
        let mut last = 0;
        let mut any = false;
        for (w, (m, v)) in f.might.iter_mut().zip(&st.vis).enumerate() {
            let mut cand = *m & !v;
            while cand != 0 {
                let b = cand.trailing_zeros();
                cand &= cand - 1;
                let idx = w * 64 + b as usize;
                let sph = self.spheres[idx];
                let wind = &self.g.portals[idx].winding[..];
                let mut gone = planes.iter().flatten().any(|pl| behind(pl, sph, wind));
                if !gone && !seps.is_empty() {
                    if behind(&seps[last], sph, wind) {
                        gone = true;
                    } else if let Some(i) =
                        (0..seps.len()).find(|&i| i != last && behind(&seps[i], sph, wind))
                    {
                        last = i;
                        gone = true;
                    }
                }
                if gone {
                    *m &= !(1u64 << b);
                } else {
                    any = true;
                }
            }
        }
        any
    }
}
