//! Our PVS against ericw-tools' qbsp + vis on the same brush map, measured so that neither
//! tool's way of cutting space matters: cells and leafs differ in number and shape, so their
//! pair counts do not compare, but points do. Random points in the air of both tools are paired;
//! for each pair, the map's own brushes say whether there is a line of sight, and each tool's PVS
//! says whether the cell (leaf) of one point may see the other's. Uniform points weigh every
//! region by its volume, so "ours / LOS" and "vis / LOS" are the volume-weighted looseness of
//! each PVS (1.0 would be exact from-point visibility; a PVS is from-region, so it is above).
//!
//! `QBSP=<qbsp> VIS=<vis> cargo bench --bench pvs_vs_vis -- E1M1-edited-ents.map [MAP.map ...]`
//! (E1M1-edited-ents.map and qbspfeatures.map by default). `ERICW_TESTMAPS` is the maps' folder
//! (`../shared/levels/ericw-tools/testmaps` beside the project when unset); `PVS_SAMPLES` (4000) and
//! `PVS_SEED` (1) set the points; `QBSP_ARGS` adds qbsp options (`-filltype outside`). The maps
//! must be sealed: vis needs the portal file qbsp writes only then.
//!
//! The brushes are the library's own reading of the map (`portcullis::import`, src/import/map):
//! each brush one closed convex mesh in metres (glTF's Y up), its role in its node's extras.
//! Geometry is in metres throughout; sample points are drawn and printed in map units (qbsp's
//! coordinates, to find them in the editor) and mapped to metres by the importer's own axes.
//!
//! Choices: a point is air when it is in one of our cells, in a qbsp leaf that is not solid
//! (leaf 0, `CONTENTS_SOLID`, `CONTENTS_SKY`), and inside no brush that blocks sight or is
//! `func_detail*` (qbsp makes detail solid leafs, we put it in cells; either way not a point to
//! see from). Sight is blocked by what qbsp seals with, the brushes the importer marks `solid`:
//! worldspawn and `func_group` brushes that are not liquids (`*`, which vis sees through by
//! default: `-transwater`), tool brushes (all faces clip, hint, hintskip, origin) or in a
//! `trigger_*`; sky and skip block. `func_detail` (extras `classname` `func_detail*`, tools
//! among them aside) and other brush entities (doors, walls: their own models to qbsp, detail
//! to us) block nothing, as neither PVS is meant to be blocked by them; but vis is, where
//! detail fills a whole structural leaf (qbsp writes no portal into a cluster whose contents
//! are all solid), so the pairs whose sightline also misses every `func_detail` brush are
//! counted apart. A pair is visible to a tool when either point's cell (leaf) lists the other's
//! (the OR: a line of sight runs both ways); pairs listed one way only are counted apart. Two
//! points in one leaf (convex air) always see each other, and two in one of our cells unless a
//! prop (a loose brush, inside the cell) stands between them, which checks the sight test.

use std::path::Path;
use std::process::Command;
use std::time::Instant;

use glam::DVec3;
use rayon::prelude::*;

/// The testmaps folder and the maps named on the command line.
#[allow(dead_code)]
#[path = "../tests/common/testmaps.rs"]
mod testmaps;

/// The crate's own generator, so a seed gives the same points everywhere.
#[allow(dead_code, unused_imports)]
#[path = "../src/rng.rs"]
mod rng;

use portcullis::import::{import_bytes, ImportOptions};
use portcullis::pipeline::{load, pvs, LoadOptions};
use portcullis::scene::{Format, Scene};
use portcullis::vis::Method;

/// Brushes shrink by this much (metres: a hundredth of a map unit, Quake's inch) for sight, so
/// a segment that only grazes a face or runs along a seam between two brushes is not blocked
/// (touching is not blocking).
const GRAZE: f64 = 0.01 * 0.0254;
/// A triangle's plane bounds its brush when no corner of the brush is in front of it by more
/// than this (metres: the importer welds corners within 1e-5 map units, 2.5e-7 m).
const FACE_EPS: f64 = 1e-6;
/// Two triangles' planes are one when their normals and distances (metres) agree this closely.
const SAME_EPS: f64 = 1e-9;
/// Our cells contain a point within this distance (metres) of their planes.
const CELL_EPS: f64 = 1e-7;
/// How many example pairs or points to print per kind.
const EXAMPLES: usize = 4;

/// A brush as half-spaces `n · p <= d` (metres, Y up), with its box for a quick reject.
struct Solid {
    planes: Vec<(DVec3, f64)>,
    lo: DVec3,
    hi: DVec3,
}

impl Solid {
    /// The brush of scene node `node`: the importer's closed convex mesh, each triangle's plane
    /// with its outward normal (counter-clockwise seen from outside), equal planes once. A
    /// sliver triangle's plane that some corner is in front of bounds nothing and is left out.
    /// `None` for a node without a mesh (a point entity, a room) or without four planes.
    fn new(scene: &Scene, node: usize) -> Option<Solid> {
        let m = &scene.meshes[scene.nodes[node].mesh?];
        let pts = scene.world_positions(node);
        let lo = pts.iter().fold(DVec3::INFINITY, |a, p| a.min(*p));
        let hi = pts.iter().fold(DVec3::NEG_INFINITY, |a, p| a.max(*p));
        let mut planes: Vec<(DVec3, f64)> = Vec::new();
        for t in &m.triangles {
            let [a, b, c] = t.map(|i| pts[i as usize]);
            let Some(n) = (b - a).cross(c - a).try_normalize() else {
                continue;
            };
            let d = n.dot(a).max(n.dot(b)).max(n.dot(c));
            let face = pts.iter().all(|p| n.dot(*p) <= d + FACE_EPS);
            let seen = (planes.iter())
                .any(|(q, e)| q.dot(n) > 1.0 - SAME_EPS && (e - d).abs() <= SAME_EPS);
            if face && !seen {
                planes.push((n, d));
            }
        }
        (planes.len() >= 4).then_some(Solid { planes, lo, hi })
    }

    fn contains(&self, p: DVec3) -> bool {
        self.planes.iter().all(|(n, d)| n.dot(p) < *d)
    }

    /// Whether segment `a`–`b` passes through the brush shrunk by [`GRAZE`]: the parametric
    /// segment clipped by every plane keeps a piece of positive length.
    fn blocks(&self, a: DVec3, b: DVec3) -> bool {
        if a.min(b).cmpgt(self.hi).any() || a.max(b).cmplt(self.lo).any() {
            return false;
        }
        let (mut t0, mut t1) = (0.0f64, 1.0f64);
        for (n, d) in &self.planes {
            let (da, db) = (n.dot(a) - d + GRAZE, n.dot(b) - d + GRAZE);
            if da >= 0.0 && db >= 0.0 {
                return false;
            }
            if da >= 0.0 {
                t0 = t0.max(da / (da - db));
            } else if db >= 0.0 {
                t1 = t1.min(da / (da - db));
            }
            if t0 >= t1 {
                return false;
            }
        }
        true
    }
}

/// What a brush node is here (see the module's "Choices"), read from the extras the importer
/// wrote (src/import/map, `role`): `Some(true)` blocks sight (`solid`), `Some(false)` is
/// `func_detail*` and not an `ignore`d tool (its points are dropped), `None` is neither
/// (liquids, tools, triggers, doors, other brush entities).
fn classify(extras: Option<&serde_json::Value>) -> Option<bool> {
    let flag = |k: &str| extras.and_then(|e| e.get(k)).and_then(|v| v.as_bool()) == Some(true);
    let class = extras
        .and_then(|e| e.get("classname"))
        .and_then(|v| v.as_str());
    if flag("solid") {
        Some(true)
    } else if class.is_some_and(|c| c.starts_with("func_detail")) && !flag("ignore") {
        Some(false)
    } else {
        None
    }
}

/// The parts of a Quake BSP (29, BSP2 or 2PSB) that locate a point and read its PVS.
struct Bsp {
    planes: Vec<(DVec3, f64)>,
    /// Plane and children (front, back); a negative child `c` is leaf `-(c + 1)`.
    nodes: Vec<(usize, [i32; 2])>,
    /// Contents and visofs.
    leafs: Vec<(i32, i32)>,
    head: i32,
    visleafs: usize,
    vis: Vec<u8>,
}

impl Bsp {
    /// Layouts from ericw-tools' include/common/bspfile_q1.hh: a header of ident and 15 lumps
    /// (offset, length); planes 20 bytes, models 64 (headnode[0] at 36, visleafs at 52); nodes
    /// and leafs 24 and 28 bytes in BSP29 (i16 children), 44 and 44 in BSP2, 32 and 32 in 2PSB.
    fn read(b: &[u8]) -> Result<Bsp, String> {
        let i32at = |o: usize| i32::from_le_bytes(b[o..o + 4].try_into().unwrap());
        let f32at = |o: usize| f32::from_le_bytes(b[o..o + 4].try_into().unwrap()) as f64;
        let (node, leaf, wide) = match b.get(0..4) {
            Some([29, 0, 0, 0]) => (24, 28, false),
            Some(b"BSP2") => (44, 44, true),
            Some(b"2PSB") => (32, 32, true),
            other => return Err(format!("not a Quake 1 BSP: ident {other:?}")),
        };
        let lump = |k: usize, size: usize| {
            let (ofs, len) = (i32at(4 + 8 * k) as usize, i32at(8 + 8 * k) as usize);
            (0..len / size).map(move |i| ofs + i * size)
        };
        let v = |o: usize| DVec3::new(f32at(o), f32at(o + 4), f32at(o + 8));
        let planes = lump(1, 20).map(|o| (v(o), f32at(o + 12))).collect();
        let child = |o: usize, k: usize| match wide {
            true => i32at(o + 4 + 4 * k),
            false => i16::from_le_bytes([b[o + 4 + 2 * k], b[o + 5 + 2 * k]]) as i32,
        };
        let nodes = lump(5, node)
            .map(|o| (i32at(o) as usize, [child(o, 0), child(o, 1)]))
            .collect();
        let leafs = lump(10, leaf).map(|o| (i32at(o), i32at(o + 4))).collect();
        let model = lump(14, 64).next().ok_or("no models")?;
        let (vo, vl) = (i32at(4 + 8 * 4) as usize, i32at(8 + 8 * 4) as usize);
        Ok(Bsp {
            planes,
            nodes,
            leafs,
            head: i32at(model + 36),
            visleafs: i32at(model + 52) as usize,
            vis: b[vo..vo + vl].to_vec(),
        })
    }

    /// The leaf of model 0 holding `p` (map units); on a plane counts as behind, as in Quake.
    fn leaf_at(&self, p: DVec3) -> usize {
        let mut n = self.head;
        while n >= 0 {
            let (pl, ch) = self.nodes[n as usize];
            let (normal, dist) = self.planes[pl];
            n = ch[(normal.dot(p) - dist <= 0.0) as usize];
        }
        (-(n + 1)) as usize
    }

    /// Air: a leaf of the world's vis leafs, neither solid (-2) nor sky (-6).
    fn air(&self, leaf: usize) -> bool {
        leaf != 0 && leaf <= self.visleafs && !matches!(self.leafs[leaf].0, -2 | -6)
    }

    /// The decompressed row of `leaf` (bit i: leaf i + 1); `None` when it has none (visofs -1,
    /// which Quake reads as "sees everything", and so do we). RLE: a zero byte is followed by a
    /// count of zeros.
    fn row(&self, leaf: usize) -> Option<Vec<u8>> {
        let mut i = usize::try_from(self.leafs[leaf].1).ok()?;
        let n = self.visleafs.div_ceil(8);
        let mut out = Vec::with_capacity(n);
        while out.len() < n && i < self.vis.len() {
            if self.vis[i] == 0 {
                out.resize(out.len() + *self.vis.get(i + 1)? as usize, 0);
                i += 2;
            } else {
                out.push(self.vis[i]);
                i += 1;
            }
        }
        out.resize(n, 0);
        Some(out)
    }
}

/// Runs `bin args`, timed; the error names the tool and its last output.
fn run(bin: &Path, args: &[&Path]) -> Result<f64, String> {
    let start = Instant::now();
    let out = Command::new(bin)
        .args(args)
        .output()
        .map_err(|e| e.to_string())?;
    let secs = start.elapsed().as_secs_f64();
    let tail = String::from_utf8_lossy(&out.stdout);
    let tail: Vec<&str> = tail.lines().rev().take(3).collect();
    out.status
        .success()
        .then_some(secs)
        .ok_or(format!("{} failed: {tail:?}", bin.display()))
}

/// One kept point (map units, and metres), its cell and its leaf.
struct Pt {
    p: DVec3,
    m: DVec3,
    cell: usize,
    leaf: usize,
}

impl Pt {
    fn show(&self) -> String {
        format!("{} cell {} leaf {}", at(self.p), self.cell, self.leaf)
    }
}

/// A point in map units, to a tenth.
fn at(p: DVec3) -> String {
    format!("({:.1} {:.1} {:.1})", p.x, p.y, p.z)
}

/// Counts over unordered pairs, named by [`COUNTS`]; the misses are (point, point, whether the
/// sightline also misses every func_detail brush).
#[derive(Default)]
struct Tally {
    n: [u64; 12],
    ours_miss: Vec<(usize, usize, bool)>,
    vis_miss: Vec<(usize, usize, bool)>,
}

const COUNTS: [&str; 12] = [
    "pairs",
    "LOS",
    "ours",
    "vis",
    "visible to ours only",
    "visible to vis only",
    "LOS pairs ours lists one way only",
    "LOS pairs vis lists one way only",
    "LOS pairs also clear of func_detail",
    "of which vis misses",
    "pairs in one of our cells blocked only by a prop (props shape no cell)",
    "pairs in one cell or one leaf (convex air) with no LOS: must be 0",
];

impl Tally {
    fn add(mut self, o: Tally) -> Tally {
        self.n.iter_mut().zip(o.n).for_each(|(a, b)| *a += b);
        self.ours_miss.extend(o.ours_miss);
        self.vis_miss.extend(o.vis_miss);
        self
    }
}

/// Where a sample point is: kept (air to both), or why not. World-brush points in a cell or an
/// air leaf, and the two one-sided kinds, show where the tools disagree on the air.
fn kind(world: bool, detail: bool, cell: bool, air: bool) -> &'static str {
    match (cell, air) {
        _ if world && (cell || air) => "in a world brush, yet in a cell or an air leaf",
        _ if world => "in a world brush (both agree)",
        _ if detail => "in a func_detail* brush (dropped)",
        (true, true) => "kept",
        (false, false) => "outside the level (both agree)",
        (true, false) => "in a cell, but qbsp's leaf is solid",
        (false, true) => "no cell, but qbsp's leaf is air",
    }
}

/// One map: ours and theirs built and timed, the points sampled, the pairs counted; prints the
/// details and returns the summary table's row.
fn compare(path: &Path, qbsp: &Path, vis: &Path) -> Result<String, String> {
    let env = |k: &str| std::env::var(k).ok().and_then(|s| s.parse::<u64>().ok());
    let samples = env("PVS_SAMPLES").unwrap_or(4000);
    let seed = env("PVS_SEED").unwrap_or(1);
    let bytes = std::fs::read(path).map_err(|e| e.to_string())?;
    let base = path.parent().unwrap_or(Path::new("."));
    let opts = ImportOptions::default();
    let scene = (import_bytes(&bytes, path, Format::Map, base, &opts))
        .map_err(|d| d.message.clone())?
        .scene;
    // Metres (the scene's) to map units and back, as the importer maps them.
    let to_map = scene.to_file.ok_or("the importer gave no map axes")?;
    let to_metres = to_map.inverse();
    let (mut blocking, mut detail, mut blocking_nodes) = (Vec::new(), Vec::new(), Vec::new());
    for (i, n) in scene.nodes.iter().enumerate() {
        match (classify(n.extras.as_ref()), Solid::new(&scene, i)) {
            (Some(true), Some(s)) => {
                blocking.push(s);
                blocking_nodes.push(i);
            }
            (Some(false), Some(s)) => detail.push(s),
            _ => {}
        }
    }
    // The sampled box, in map units: the blocking brushes' box in metres, mapped back.
    let lo_m = (blocking.iter()).fold(DVec3::INFINITY, |a, s| a.min(s.lo));
    let hi_m = (blocking.iter()).fold(DVec3::NEG_INFINITY, |a, s| a.max(s.hi));
    let (a, b) = (to_map.transform_point3(lo_m), to_map.transform_point3(hi_m));
    let (lo, hi) = (a.min(b), a.max(b));

    // Ours: the whole job up to the PVS, as `portcullis convert` runs it.
    let start = Instant::now();
    let level = load(path, &LoadOptions::default()).map_err(|d| d.message.clone())?;
    let c = &level.cells;
    let pvs_start = Instant::now();
    let pvs = pvs(&level, Method::Full);
    let ours_s = start.elapsed().as_secs_f64();
    let pvs_s = pvs_start.elapsed().as_secs_f64();
    // The blocking brushes that shape our cells: props (loose brushes) lie inside cells.
    let props: std::collections::BTreeSet<usize> = c.props.iter().map(|p| p.node).collect();
    let structure: Vec<&Solid> = (blocking.iter().zip(&blocking_nodes))
        .filter(|(_, n)| !props.contains(n))
        .map(|(s, _)| s)
        .collect();

    // Theirs, in a scratch folder: qbsp writes out.bsp and out.prt, vis the visdata into out.bsp.
    let dir = std::env::temp_dir().join(format!("portcullis-pvs-vs-vis-{}", std::process::id()));
    std::fs::create_dir_all(&dir).map_err(|e| e.to_string())?;
    let bsp_path = dir.join("out.bsp");
    let extra = std::env::var("QBSP_ARGS").unwrap_or_default();
    let mut args: Vec<&Path> = extra.split_whitespace().map(Path::new).collect();
    args.extend([Path::new("-noverbose"), path, &bsp_path]);
    let qbsp_s = run(qbsp, &args)?;
    let vis_s = run(vis, &[Path::new("-noverbose"), &bsp_path])?;
    let bsp = Bsp::read(&std::fs::read(&bsp_path).map_err(|e| e.to_string())?)?;
    let _ = std::fs::remove_dir_all(&dir);

    // The points, each classified; examples of the disagreements kept for the report.
    let mut rng = rng::SplitMix64::new(seed);
    let mut kept = Vec::new();
    let mut kinds = std::collections::BTreeMap::<&str, (usize, Vec<String>)>::new();
    for _ in 0..samples {
        let q = lo + (hi - lo) * DVec3::new(rng.unit(), rng.unit(), rng.unit());
        let m = to_metres.transform_point3(q);
        let cell = c.cells.iter().position(|k| {
            m.cmpge(k.bounds.min - CELL_EPS).all()
                && m.cmple(k.bounds.max + CELL_EPS).all()
                && k.poly.contains(m, CELL_EPS)
        });
        let leaf = bsp.leaf_at(q);
        let world = blocking.iter().any(|s| s.contains(m));
        let det = detail.iter().any(|s| s.contains(m));
        let k = kind(world, det, cell.is_some(), bsp.air(leaf));
        let e = kinds.entry(k).or_default();
        e.0 += 1;
        if e.1.len() < EXAMPLES && k != "kept" && !k.ends_with("(both agree)") {
            let contents = bsp.leafs[leaf].0;
            e.1.push(format!(
                "{} cell {cell:?} leaf {leaf} contents {contents}",
                at(q)
            ));
        }
        if let (Some(cell), "kept") = (cell, k) {
            kept.push(Pt {
                p: q,
                m,
                cell,
                leaf,
            });
        }
    }

    // The pairs, in parallel by first point.
    let rows: Vec<Option<Vec<u8>>> = (0..=bsp.visleafs).map(|l| bsp.row(l)).collect();
    let vis_sees = |a: usize, b: usize| {
        rows[a]
            .as_ref()
            .is_none_or(|r| r[(b - 1) / 8] >> ((b - 1) % 8) & 1 == 1)
    };
    let tally = (0..kept.len())
        .into_par_iter()
        .map(|i| {
            let mut t = Tally::default();
            for j in i + 1..kept.len() {
                let (a, b) = (&kept[i], &kept[j]);
                let los = !blocking.iter().any(|s| s.blocks(a.m, b.m));
                let clear = los && !detail.iter().any(|s| s.blocks(a.m, b.m));
                let ours = [pvs.sees(a.cell, b.cell), pvs.sees(b.cell, a.cell)];
                let theirs = [vis_sees(a.leaf, b.leaf), vis_sees(b.leaf, a.leaf)];
                let (o, v) = (ours[0] || ours[1], theirs[0] || theirs[1]);
                let (wo, wv) = (los && ours[0] != ours[1], los && theirs[0] != theirs[1]);
                // In one leaf or one cell with no LOS: only a prop inside our cell may block.
                let one = !los && (a.cell == b.cell || a.leaf == b.leaf);
                let past_props = one
                    && a.leaf != b.leaf
                    && !structure.iter().any(|s| s.blocks(a.m, b.m));
                let odd = one && !past_props;
                #[rustfmt::skip]
                let n = [true, los, o, v, o && !v, v && !o, wo, wv, clear, clear && !v, past_props, odd];
                t.n.iter_mut().zip(n).for_each(|(c, x)| *c += x as u64);
                if los && !o {
                    t.ours_miss.push((i, j, clear));
                }
                if los && !v {
                    t.vis_miss.push((i, j, clear));
                }
            }
            t
        })
        .reduce(Tally::default, Tally::add);

    let name = path.file_name().unwrap_or_default().to_string_lossy();
    let (cells, leafs) = (c.cells.len(), bsp.visleafs);
    println!("## {name}\n\nours: {cells} cells; qbsp: {leafs} vis leafs");
    println!("{samples} samples in {}-{}, seed {seed}:", at(lo), at(hi));
    for (k, (n, examples)) in &kinds {
        println!("  {n:7}  {k}");
        examples
            .iter()
            .for_each(|e| println!("             e.g. {e}"));
    }
    for (label, n) in COUNTS.iter().zip(tally.n).skip(4) {
        println!("  {n:9}  {label}");
    }
    for (who, miss) in [("ours", &tally.ours_miss), ("vis", &tally.vis_miss)] {
        let mut miss = miss.clone();
        miss.sort_by_key(|m| !m.2); // those clear of detail too first
        for &(i, j, clear) in miss.iter().take(EXAMPLES) {
            let via = if clear { "" } else { " (through func_detail)" };
            let (a, b) = (kept[i].show(), kept[j].show());
            println!("  {who} misses: {a} to {b}{via}");
        }
    }
    println!();
    let r = |n: u64| n as f64 / tally.n[1].max(1) as f64;
    let [pairs, los, ours, vis, ..] = tally.n;
    Ok(format!(
        "| {name} | {} | {pairs} | {los} | {ours} | {vis} | {:.3} | {:.3} | {} | {} | {ours_s:.2} s ({pvs_s:.2} s) | {qbsp_s:.2} s | {vis_s:.2} s |",
        kept.len(), r(ours), r(vis), tally.ours_miss.len(), tally.vis_miss.len()
    ))
}

fn main() {
    let Some((dir, maps)) = testmaps::maps_to_bench() else {
        return;
    };
    let (Ok(qbsp), Ok(vis)) = (std::env::var("QBSP"), std::env::var("VIS")) else {
        eprintln!("set QBSP and VIS to ericw-tools' qbsp and vis binaries");
        return;
    };
    let mut rows = Vec::new();
    for name in maps {
        match compare(&dir.join(&name), Path::new(&qbsp), Path::new(&vis)) {
            Ok(row) => rows.push(row),
            Err(e) => eprintln!("{name}: {e}"),
        }
    }
    println!("| map | kept points | pairs | LOS | ours | vis | ours/LOS | vis/LOS | ours misses | vis misses | ours: all (pvs) | qbsp | vis |");
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    rows.iter().for_each(|r| println!("{r}"));
}
