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
//! The work is bounded by a budget of portal tests (see [`portal_vis`]): a source cut short
//! takes what its frame might still see as seen, which keeps every row conservative.
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
    /// Portals one source may test before the rest of its might-see is taken as seen.
    budget: u64,
    /// Per cell with more leaving portals than a bit row has words (the outside), its
    /// leaving portals as a bit row: walked word by word against the frame's might-see.
    wide: &'a [Option<Vec<u64>>],
}

/// The portals leaving a cell, in ascending order, that a frame's might-see still holds.
enum Walk<'a> {
    List(std::slice::Iter<'a, usize>),
    Mask {
        mask: &'a [u64],
        at: usize,
        word: u64,
        base: usize,
    },
}

impl Walk<'_> {
    fn next(&mut self, might: &[u64]) -> Option<usize> {
        match self {
            Walk::List(it) => it.next().copied(),
            Walk::Mask {
                mask,
                at,
                word,
                base,
            } => loop {
                if *word != 0 {
                    let q = *base + word.trailing_zeros() as usize;
                    *word &= *word - 1;
                    return Some(q);
                }
                if *at >= mask.len() {
                    return None;
                }
                *word = mask[*at] & might[*at];
                *base = *at * 64;
                *at += 1;
            },
        }
    }
}

struct State {
    frames: Vec<Frame>,
    vis: Vec<u64>,
    tmp: Vec<DVec3>,
    planes: Vec<Plane>,
    /// Portals tested from the current source.
    steps: u64,
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

/// The first per-source bound once the flow has spent half its budget: small, so every
/// portal gets a tightened row before any gets a long search.
const FIRST_PASS: u64 = 1024;

/// The cell PVS, and how many sources the flow cut short. `might`: the `fast` might-see
/// sets, the filter of the flow; `budget`: the portal tests the flow may make in all.
pub fn pvs(g: &VisGraph, might: Vec<Vec<u64>>, depth: usize, budget: u64) -> (Pvs, usize) {
    let (rows, cut) = portal_vis(g, might, depth, budget);
    (super::fast::cell_pvs(g, &rows, depth), cut)
}

/// Where the flow stands: the per-portal rows and what is known of each.
struct Progress {
    /// Per portal, its flow result once `finished`, else its might-see set (or the
    /// conservative row of a flow cut short).
    rows: Vec<Vec<u64>>,
    finished: Vec<bool>,
    /// The largest per-source bound each portal was run with (0: not yet run).
    tried: Vec<u64>,
    sym: Option<Symmetry>,
    /// Portal tests made so far.
    spent: u64,
}

/// Per directed portal, the portals it sees, and how many sources were cut short. `rows`
/// starts as the might-see sets; each is replaced by the flow's result when its wave is
/// over, so one matrix serves as the filter, the finished results and the output.
///
/// The work is bounded by `budget` portal tests, deterministically. The flow runs as
/// always while it has spent less than half: each source may then use half the budget
/// shared over its wave, which ordinary levels never reach. Past half, the remaining
/// sources are run in passes with a per-source bound that starts at [`FIRST_PASS`] and
/// grows fourfold while the budget allows it for all that are still cut short. A source cut
/// short takes the rest of its might-see as seen (see `give_up`), so its row, and the PVS,
/// stay conservative. The bounds depend only on work counted at wave ends, never on time
/// or threads.
pub(crate) fn portal_vis(
    g: &VisGraph,
    rows: Vec<Vec<u64>>,
    depth: usize,
    budget: u64,
) -> (Vec<Vec<u64>>, usize) {
    let n = g.portals.len();
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by_key(|&p| (bits::count(&rows[p]), g.order[p], p));
    let wave = n.div_ceil(WAVES).max(1);
    let mut entering = vec![Vec::new(); g.cells];
    for (i, p) in g.portals.iter().enumerate() {
        entering[p.to].push(i);
    }
    let spheres: Vec<(DVec3, f64)> = g.portals.iter().map(|p| sphere(&p.winding)).collect();
    let all = bits::all(n);
    let wide = wide_cells(g);
    // Every sightline can be walked back only when every portal has its reverse.
    let symmetric = !g.has_transforms() && g.reverse.iter().all(Option::is_some);
    let mut at = Progress {
        rows,
        finished: vec![false; n],
        tried: vec![0; n],
        sym: symmetric.then(|| Symmetry {
            finished: vec![0; bits::words(n)],
            seen: vec![vec![0; bits::words(n)]; g.cells],
        }),
        spent: 0,
    };
    let half = budget / 2;
    let mut cap = (half / wave as u64).max(1);
    let mut exact = true;
    let mut pending = order;
    loop {
        for (i, chunk) in pending.chunks(wave).enumerate() {
            let run = Run {
                g,
                rows: &at.rows,
                finished: &at.finished,
                sym: at.sym.as_ref(),
                entering: &entering,
                spheres: &spheres,
                depth,
                all: &all,
                wide: &wide,
                budget: cap,
            };
            let results = run.wave(chunk, &at.tried);
            at.record(g, &entering, chunk, results, cap);
            if exact && at.spent >= half {
                // What is left of the budget, shared over the sources not yet run.
                exact = false;
                let left = pending.len().saturating_sub((i + 1) * wave) as u64;
                cap = (budget.saturating_sub(at.spent) / left.max(1)).clamp(1, FIRST_PASS);
            }
        }
        // The next pass: the sources still cut short, at a bound none of them has had yet,
        // while the budget covers it for all of them.
        pending.retain(|&p| !at.finished[p]);
        // Saturating: a budget near u64::MAX (`--flow-budget` takes any) must not wrap.
        let mut next = cap.saturating_mul(4);
        while pending.iter().all(|&p| at.tried[p] >= next) && !pending.is_empty() {
            if next == u64::MAX {
                break;
            }
            next = next.saturating_mul(4);
        }
        let runs = pending.iter().filter(|&&p| at.tried[p] < next).count() as u64;
        if runs == 0 || at.spent.saturating_add(next.saturating_mul(runs)) > budget {
            break;
        }
        cap = next;
        exact = false;
    }
    (at.rows, pending.len())
}

/// Per cell with more leaving portals than a bit row has words (the outside), its leaving
/// portals as a bit row.
fn wide_cells(g: &VisGraph) -> Vec<Option<Vec<u64>>> {
    let words = bits::words(g.portals.len());
    (g.leaving.iter())
        .map(|l| {
            (l.len() > words).then(|| {
                let mut m = vec![0; words];
                l.iter().for_each(|&q| bits::set(&mut m, q));
                m
            })
        })
        .collect()
}

impl Progress {
    /// Takes a wave's results: every row is replaced (a row cut short is still
    /// conservative), and the sources that ran within `cap` are finished.
    fn record(
        &mut self,
        g: &VisGraph,
        entering: &[Vec<usize>],
        chunk: &[usize],
        results: Vec<Option<(Vec<u64>, u64)>>,
        cap: u64,
    ) {
        for (&p, run) in chunk.iter().rev().zip(results) {
            let Some((r, steps)) = run else {
                continue;
            };
            self.spent = self.spent.saturating_add(steps);
            if steps < cap {
                if let (Some(sym), Some(rp)) = (&mut self.sym, g.reverse[p]) {
                    // Rows hold every portal into a seen cell; the first marks the cell.
                    bits::set(&mut sym.finished, rp);
                    for q in bits::ones(&r) {
                        let to = g.portals[q].to;
                        if entering[to].first() == Some(&q) {
                            bits::set(&mut sym.seen[to], rp);
                        }
                    }
                }
                self.finished[p] = true;
            }
            self.tried[p] = self.tried[p].max(cap);
            self.rows[p] = r;
        }
    }
}

impl Run<'_> {
    /// Runs a wave's sources (each with its row and the tests it made), largest first (the
    /// order is ascending), in small pieces, so the threads finish the wave together. The
    /// wave's members, and so the result, are fixed. A source already run with at least
    /// this bound keeps its row.
    fn wave(&self, chunk: &[usize], tried: &[u64]) -> Vec<Option<(Vec<u64>, u64)>> {
        chunk
            .par_iter()
            .rev()
            .with_max_len(4)
            .map_init(
                || State {
                    frames: Vec::new(),
                    vis: Vec::new(),
                    tmp: Vec::new(),
                    planes: Vec::new(),
                    steps: 0,
                },
                |st, &p| {
                    if tried[p] >= self.budget {
                        return None;
                    }
                    let r = self.source(st, p);
                    Some((r, st.steps))
                },
            )
            .collect()
    }

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
        st.steps = 0;
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
        let mut walk = match &self.wide[cell] {
            Some(mask) => Walk::Mask {
                mask,
                at: 0,
                word: 0,
                base: 0,
            },
            None => Walk::List(g.leaving[cell].iter()),
        };
        while let Some(q) = walk.next(&st.frames[d].might) {
            if st.steps >= self.budget {
                self.give_up(st, d);
                return;
            }
            let (lo, hi) = st.frames.split_at_mut(d + 1);
            let cur = &mut lo[d];
            let next = &mut hi[0];
            if !bits::get(&cur.might, q) {
                continue;
            }
            st.steps += 1;
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

    /// Takes every portal frame `d` might still see as seen, with the cells it leads into:
    /// what any longer chain could find is among them, so the row stays conservative.
    fn give_up(&self, st: &mut State, d: usize) {
        let f = &st.frames[d];
        for w in 0..f.might.len() {
            let mut new = f.might[w] & !st.vis[w];
            while new != 0 {
                let q = w * 64 + new.trailing_zeros() as usize;
                new &= new - 1;
                bits::set(&mut st.vis, q);
                for &r in &self.entering[self.g.portals[q].to] {
                    bits::set(&mut st.vis, r);
                }
            }
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
