//! Every stage of a conversion, each PVS method and the read+write floor, on generated buildings
//! (and the sightline audit on the Doom maps of tests/fixtures),
//! with divan's statistics: `cargo bench --bench stages`. Sizes 10, 100 and 1 000 rooms by
//! default; `PORTCULLIS_BENCH_ROOMS=10000` (comma-separated) for others. The targets of the
//! performance issue are checked with `portcullis bench`, which prints the same stages as one
//! table with the peak memory and the whole-process time (docs/performance.md); this is for
//! comparing two builds stage by stage. It runs on the system allocator (the binary's jemalloc
//! and huge pages are the binary's, not the library's), so its times are the library's as a
//! caller that links it would see them.

use std::path::PathBuf;

use divan::Bencher;

#[allow(dead_code, unused_imports)]
#[path = "../src/rng.rs"]
mod rng;
#[path = "../src/bin/portcullis-floor/round_trip.rs"]
mod round_trip;
use portcullis::buildings::{self, GenOptions};
use portcullis::cells::CellSet;
use portcullis::export::output::{self, Output};
use portcullis::export::{gltf_out, OutFormat, Target};
use portcullis::pipeline::{self, Tagged};
use portcullis::vis::{Method, VisGraph, VisOptions};

fn main() {
    divan::main();
}

/// The building sizes benchmarked.
fn sizes() -> Vec<usize> {
    match std::env::var("PORTCULLIS_BENCH_ROOMS") {
        Ok(v) => v.split(',').filter_map(|s| s.trim().parse().ok()).collect(),
        Err(_) => vec![10, 100, 1000],
    }
}

/// The generated building of `rooms` rooms (seed 1, with props), written once into the target
/// folder and kept for later runs.
fn level(rooms: usize) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("bench_levels");
    let path = dir.join(format!("building_{rooms}_1.glb"));
    if !path.is_file() {
        std::fs::create_dir_all(&dir).unwrap();
        let scene = buildings::generate(&GenOptions {
            rooms,
            seed: 1,
            props: true,
        });
        let tmp = dir.join(format!(".building_{rooms}_1.{}.tmp", std::process::id()));
        std::fs::write(&tmp, gltf_out::write_plain(&scene, OutFormat::Glb)).unwrap();
        std::fs::rename(&tmp, &path).unwrap();
    }
    path
}

/// Where a benchmark writes its output.
fn output(name: &str, rooms: usize) -> PathBuf {
    PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(format!("bench_{name}_{rooms}.glb"))
}

fn tagged(rooms: usize) -> Tagged {
    pipeline::load_tagged(&level(rooms), &Default::default()).unwrap()
}

fn with_cells(rooms: usize) -> (Tagged, CellSet) {
    let mut t = tagged(rooms);
    let cells = pipeline::build_cells(&mut t);
    (t, cells)
}

fn with_portals(rooms: usize) -> pipeline::Level {
    let (mut t, cells) = with_cells(rooms);
    let portals = pipeline::build_portals(&mut t, &cells);
    pipeline::Level::new(t, cells, portals)
}

/// Reading and writing the same file with the gltf crate alone.
#[divan::bench(args = sizes(), sample_count = 10)]
fn floor(b: Bencher, rooms: usize) {
    let (input, out) = (level(rooms), output("floor", rooms));
    b.bench(|| round_trip::read_write(&input, &out).unwrap());
}

#[divan::bench(args = sizes(), sample_count = 10)]
fn import(b: Bencher, rooms: usize) {
    let input = level(rooms);
    b.bench(|| portcullis::import::import_path(&input, &Default::default()).unwrap());
}

#[divan::bench(args = sizes(), sample_count = 10)]
fn tags(b: Bencher, rooms: usize) {
    let input = level(rooms);
    let config = portcullis::config::Config::default();
    let rules = portcullis::config::rule_set(&config, None).unwrap();
    b.with_inputs(|| portcullis::import::import_path(&input, &Default::default()).unwrap())
        .bench_values(|imported| pipeline::tag(imported, config.clone(), rules.clone()));
}

#[divan::bench(args = sizes(), sample_count = 10)]
fn cells(b: Bencher, rooms: usize) {
    b.with_inputs(|| tagged(rooms))
        .bench_refs(pipeline::build_cells);
}

#[divan::bench(args = sizes(), sample_count = 10)]
fn portals(b: Bencher, rooms: usize) {
    b.with_inputs(|| with_cells(rooms))
        .bench_refs(|(t, cells)| pipeline::build_portals(t, cells));
}

#[divan::bench(args = sizes(), sample_count = 10)]
fn check(b: Bencher, rooms: usize) {
    b.with_inputs(|| with_portals(rooms))
        .bench_refs(|level| pipeline::check(level, false));
}

#[divan::bench(args = sizes(), sample_count = 10)]
fn export(b: Bencher, rooms: usize) {
    let level = with_portals(rooms);
    let out = output("export", rooms);
    b.bench(|| output::level(&level, None, &Output::file(&out, Target::Glb)).unwrap());
}

/// A PVS method, as a type: divan names each benchmark of a generic function by its type.
trait PvsMethod {
    const METHOD: Method;
}

struct Flood;
struct Fast;
struct Full;
struct Sampled;

impl PvsMethod for Flood {
    const METHOD: Method = Method::Flood;
}
impl PvsMethod for Fast {
    const METHOD: Method = Method::Fast;
}
impl PvsMethod for Full {
    const METHOD: Method = Method::Full;
}
impl PvsMethod for Sampled {
    const METHOD: Method = Method::Sampled;
}

/// Each PVS method on the level's portal graph.
#[divan::bench(types = [Flood, Fast, Full, Sampled], args = sizes(), sample_count = 10)]
fn pvs<M: PvsMethod>(b: Bencher, rooms: usize) {
    let level = with_portals(rooms);
    let (cells, portals) = (&level.cells, &level.portals);
    let graph = VisGraph::from_portal_set(cells.cells.len(), portals, cells.tolerance.distance);
    let opts = VisOptions {
        method: M::METHOD,
        ..Default::default()
    };
    b.bench(|| portcullis::vis::compute(&graph, &opts));
}

/// `check --sightlines 200` (the audit alone, the PVS built beforehand) on the two Doom maps:
/// MAP01 (479 cells, 4 607 triangles) and E1M2 (868 cells, 8 243 triangles). The target: at
/// most 5 s for a 400-cell level of about 8 000 triangles on 2 cores.
#[divan::bench(args = ["MAP01_godot.glb", "E1M2_godot.glb"], sample_count = 5)]
fn sightlines(b: Bencher, level: &str) {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures/third_party")
        .join(level);
    let level = pipeline::load(&path, &Default::default()).unwrap();
    let pvs = pipeline::pvs(&level, portcullis::vis::Method::Full);
    b.bench(|| pipeline::audit(&level, &pvs, 200));
}

/// The converted level a `cull` benchmark traces: a Doom map of tests/fixtures, or the
/// generated building of `building_N` (converted once, kept in the target folder).
fn converted(name: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("bench_levels");
    let out = dir.join(format!("cull_{}.glb", name.trim_end_matches(".glb")));
    if !out.is_file() {
        let input = match name.strip_prefix("building_") {
            Some(n) => level(n.parse().unwrap()),
            None => PathBuf::from(env!("CARGO_MANIFEST_DIR"))
                .join("tests/fixtures/third_party")
                .join(name),
        };
        std::fs::create_dir_all(&dir).unwrap();
        pipeline::convert_file(&input, &out).unwrap();
    }
    out
}

/// One runtime trace per iteration (`Level::trace`), cameras cycling through 512 random views
/// from cell centres, looking level in a random direction (75° vertical, 16:9, near 0.05 m).
/// The targets of the runtime issue: median at most 20 µs per view on a 400-cell level
/// (MAP01, 479 cells) and at most 100 µs on the 10 000-room building.
#[divan::bench(args = ["MAP01_godot.glb", "E1M2_godot.glb", "building_10000"], sample_count = 2000, sample_size = 1)]
fn cull(b: Bencher, level: &str) {
    use portcullis::runtime::{Doors, Level, Trace, TraceOptions, View};
    let lvl = Level::load(&converted(level)).unwrap();
    let mut rng = rng::SplitMix64::new(27);
    let views: Vec<View> = (0..512)
        .map(|_| {
            let (lo, hi) = lvl.bounds(rng.below(lvl.cells()));
            let eye = [0, 1, 2].map(|k| (lo[k] + hi[k]) / 2.0);
            let a = rng.unit() * std::f64::consts::TAU;
            View::new(
                eye,
                [a.cos(), 0.0, a.sin()],
                [0.0, 1.0, 0.0],
                75.0,
                16.0 / 9.0,
                0.05,
            )
            .unwrap()
        })
        .collect();
    let doors = Doors::new(&lvl);
    let opts = TraceOptions::default();
    let mut trace = Trace::default();
    for v in &views {
        lvl.trace(v, &doors, &opts, &mut trace);
    }
    let mut i = 0;
    b.bench_local(|| {
        lvl.trace(&views[i % views.len()], &doors, &opts, &mut trace);
        i += 1;
        trace.visible().len()
    });
}
