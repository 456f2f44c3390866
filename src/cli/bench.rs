//! `portcullis bench`: times every stage on generated buildings of several sizes and prints
//! one Markdown table, with the floor — reading and writing the same file with the gltf crate
//! alone — so "how close to the read/write floor" is a number, not a feeling.
//!
//! Each size runs in a child process (`bench --one N`), so its peak memory is its own.

use std::path::{Path, PathBuf};
use std::time::Instant;

use clap::Args;
use serde::{Deserialize, Serialize};

use portcullis::buildings::{self, GenOptions};
use portcullis::export::{gltf_out, output, OutFormat};

#[derive(Debug, Args)]
pub struct BenchArgs {
    /// Building sizes in rooms, comma-separated.
    #[arg(long, value_delimiter = ',', default_value = "10,100,1000,10000")]
    pub rooms: Vec<usize>,

    /// Layout seed of the generated buildings.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,

    /// PVS methods to time (comma-separated: flood, fast, full, sampled; `none` for none).
    #[arg(long, value_delimiter = ',', default_value = "flood,fast,full,sampled")]
    pub methods: Vec<String>,

    /// Folder for the generated levels (default: a temporary folder, removed afterwards).
    #[arg(long, value_name = "DIR")]
    pub keep: Option<PathBuf>,

    /// Runs of each size (and of the floor); each number is the fastest run's, which is what
    /// a busy machine's noise leaves least changed.
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..))]
    pub runs: u32,

    /// Also time the cells of one room of at least this many distinct planes (a stair hall,
    /// one cell per step); 0 leaves it out.
    #[arg(long, default_value_t = 500)]
    pub room_planes: usize,

    /// Run one size and print its measurements as JSON (used by the parent process).
    #[arg(long, hide = true)]
    pub one: Option<usize>,
}

/// Seconds per stage for one size, and the peak memory.
#[derive(Debug, Default, Serialize, Deserialize)]
struct Row {
    rooms: usize,
    triangles: usize,
    file_bytes: usize,
    cells: usize,
    portals: usize,
    floor: f64,
    import: f64,
    tags: f64,
    cells_s: f64,
    portals_s: f64,
    check: f64,
    export: f64,
    /// (method, seconds, visible pairs) for flood, fast, full and sampled.
    vis: Vec<(String, f64, usize)>,
    /// CPU seconds (every thread) of import, tags, cells, portals, check and export: on a
    /// shared machine they move less than wall times, and they show how parallel a stage is.
    cpu: Vec<f64>,
    /// Wall seconds of a whole `portcullis convert FILE -o OUT.glb --vis none` process, as a
    /// user runs it (start-up, reading, every stage, writing, exit).
    process: f64,
    /// Peak memory of the convert stages (import to export, no PVS).
    peak_rss_bytes: Option<u64>,
    /// Peak memory once every PVS method ran too.
    peak_with_pvs_bytes: Option<u64>,
    /// Views priced (cameras at cell centres, four looks each) and their sums.
    views: usize,
    draw: portcullis::runtime::ViewCost,
}

/// The process's peak resident memory (Linux `VmHWM`), if the platform says.
fn peak_rss() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}

fn timed<T>(f: impl FnOnce() -> T) -> (T, f64) {
    let t = Instant::now();
    let v = f();
    (v, t.elapsed().as_secs_f64())
}

/// CPU seconds this process has used so far, user and system, every thread.
#[cfg(unix)]
fn cpu_seconds() -> f64 {
    // SAFETY: getrusage only writes the struct it is given.
    let mut u: libc::rusage = unsafe { std::mem::zeroed() };
    if unsafe { libc::getrusage(libc::RUSAGE_SELF, &mut u) } != 0 {
        return 0.0;
    }
    let s = |t: libc::timeval| t.tv_sec as f64 + t.tv_usec as f64 * 1e-6;
    s(u.ru_utime) + s(u.ru_stime)
}

#[cfg(not(unix))]
fn cpu_seconds() -> f64 {
    0.0
}

/// [`timed`], with the CPU seconds the step used pushed onto `cpu`.
fn timed_cpu<T>(cpu: &mut Vec<f64>, f: impl FnOnce() -> T) -> (T, f64) {
    let c = cpu_seconds();
    let r = timed(f);
    cpu.push(cpu_seconds() - c);
    r
}

/// Reading and writing the file with the gltf crate alone (parse the GLB's JSON and BIN chunk
/// into the crate's document, serialise it back, write it), by `portcullis-floor`, the binary
/// built beside this one: a process of its own on the system allocator, as a program using
/// only the gltf crate would run.
fn floor(exe: &Path, dir: &Path, rooms: usize, seed: u64) -> Result<f64, String> {
    let floor = exe.with_file_name(format!("portcullis-floor{}", std::env::consts::EXE_SUFFIX));
    let out = std::process::Command::new(&floor)
        .arg(level_path(dir, rooms, seed))
        .arg(dir.join(format!("floor_{rooms}.glb")))
        .output()
        .map_err(|e| {
            format!(
                "error: cannot run `{}` ({e}); it is built with portcullis (`cargo build --release`)\n",
                floor.display()
            )
        })?;
    if !out.status.success() {
        return Err(String::from_utf8_lossy(&out.stderr).into_owned());
    }
    String::from_utf8_lossy(&out.stdout)
        .trim()
        .parse()
        .map_err(|e| format!("error: unreadable floor for {rooms} rooms: {e}\n"))
}

/// Wall seconds of `portcullis convert` on the level as its own process, without a PVS.
fn convert_process(exe: &Path, dir: &Path, rooms: usize, seed: u64) -> Result<f64, String> {
    let t = Instant::now();
    let out = std::process::Command::new(exe)
        .arg("convert")
        .arg(level_path(dir, rooms, seed))
        .arg("-o")
        .arg(dir.join(format!("process_{rooms}.glb")))
        .args(["--vis", "none"])
        .output()
        .map_err(|e| format!("error: cannot run `{}`: {e}\n", exe.display()))?;
    let t = t.elapsed().as_secs_f64();
    match out.status.code() {
        // 1: the level has findings; the conversion still ran to the end.
        Some(0 | 1) => Ok(t),
        _ => Err(String::from_utf8_lossy(&out.stderr).into_owned()),
    }
}

fn level_path(dir: &Path, rooms: usize, seed: u64) -> PathBuf {
    dir.join(format!("building_{rooms}_{seed}.glb"))
}

/// Writes the generated building of `rooms` rooms (kept between runs in `--keep DIR`).
fn generate(dir: &Path, rooms: usize, seed: u64) -> Result<(), String> {
    let path = level_path(dir, rooms, seed);
    if path.is_file() {
        return Ok(());
    }
    let scene = buildings::generate(&GenOptions {
        rooms,
        seed,
        props: true,
    });
    std::fs::write(&path, gltf_out::write_plain(&scene, OutFormat::Glb)).map_err(|e| e.to_string())
}

/// The methods `--methods` names, in the order given.
fn methods(names: &[String]) -> Result<Vec<portcullis::vis::Method>, String> {
    names
        .iter()
        .filter(|n| n.as_str() != "none")
        .map(|n| {
            portcullis::vis::Method::parse(n).ok_or_else(|| {
                format!("--methods: `{n}` is not flood, fast, full, sampled or none")
            })
        })
        .collect()
}

fn one(
    rooms: usize,
    seed: u64,
    dir: &Path,
    methods: &[portcullis::vis::Method],
) -> Result<Row, String> {
    // The parent generated the file, so this process's peak memory is the pipeline's alone.
    let input = level_path(dir, rooms, seed);
    let file_bytes = std::fs::metadata(&input).map_err(|e| e.to_string())?.len() as usize;
    let mut row = Row {
        rooms,
        file_bytes,
        ..Default::default()
    };
    let mut cpu = Vec::new();
    // As `convert` reads a level (huge pages while it is read and tagged).
    let reading = super::huge_pages::reading(&input);
    let (imported, t) = timed_cpu(&mut cpu, || {
        portcullis::import::import_path(&input, &portcullis::import::ImportOptions::default())
    });
    let imported = imported.map_err(|d| d.to_string())?;
    row.import = t;
    row.triangles = imported
        .scene
        .meshes
        .iter()
        .map(|m| m.triangles.len())
        .sum();
    let config = portcullis::config::Config::default();
    let rules = portcullis::config::rule_set(&config, None).map_err(|d| d.to_string())?;
    let (mut tagged, t) = timed_cpu(&mut cpu, || {
        portcullis::pipeline::tag(imported, config, rules)
    });
    drop(reading);
    row.tags = t;
    let (cells, t) = timed_cpu(&mut cpu, || portcullis::pipeline::build_cells(&mut tagged));
    row.cells_s = t;
    let (portals, t) = timed_cpu(&mut cpu, || {
        portcullis::pipeline::build_portals(&mut tagged, &cells)
    });
    row.portals_s = t;
    // As `convert` does, so the peak below is the convert's.
    super::alloc::release_free_memory();
    let mut level = portcullis::pipeline::Level::new(tagged, cells, portals);
    let (_, t) = timed_cpu(&mut cpu, || portcullis::pipeline::check(&mut level, false));
    row.check = t;
    row.cells = level.cells.cells.len();
    row.portals = level.portals.portals.len();
    let out = dir.join(format!("annotated_{rooms}.glb"));
    let (written, t) = timed_cpu(&mut cpu, || {
        let to = output::Output::file(&out, portcullis::export::Target::Glb);
        output::level(&level, None, &to).map_err(|d| d.to_string())
    });
    written?;
    row.export = t;
    row.cpu = cpu;
    // The convert's peak (no PVS), then the PVS methods' on top of it.
    row.peak_rss_bytes = peak_rss();
    (row.views, row.draw) = priced(&out)?;
    let graph = portcullis::vis::VisGraph::from_portal_set(
        level.cells.cells.len(),
        &level.portals,
        level.cells.tolerance.distance,
    );
    for &method in methods {
        let opts = portcullis::vis::VisOptions {
            method,
            ..Default::default()
        };
        let (pvs, t) = portcullis::vis::timed(&graph, &opts);
        row.vis
            .push((method.name().to_string(), t.as_secs_f64(), pvs.pairs()));
    }
    drop(graph);
    row.peak_with_pvs_bytes = peak_rss();
    Ok(row)
}

/// At most this many cells' centres are cameras (evenly spread over the cell indices).
const PRICED_CELLS: usize = 2500;

/// What the written level costs to draw ([`portcullis::runtime::Level::cost`]) from cameras at
/// cell centres (the centre of the cell's box), looking along ±x and ±z, fov 75°, 16:9: the
/// views whose camera lies in a cell, and their sums.
fn priced(out: &Path) -> Result<(usize, portcullis::runtime::ViewCost), String> {
    use portcullis::runtime::{
        Doors, DrawList, Level, Meshes, Trace, TraceOptions, View, ViewCost,
    };
    let level = Level::load(out).map_err(|e| e.to_string())?;
    let meshes = Meshes::load(out).map_err(|e| e.to_string())?;
    let doors = Doors::new(&level);
    let (mut trace, mut list, mut sum, mut views) = (
        Trace::default(),
        DrawList::default(),
        ViewCost::default(),
        0,
    );
    let step = level.cells().div_ceil(PRICED_CELLS).max(1);
    for c in (0..level.cells()).step_by(step) {
        let (lo, hi) = level.bounds(c);
        let eye = [0, 1, 2].map(|i| (lo[i] + hi[i]) / 2.0);
        for look in [
            [1.0, 0.0, 0.0],
            [0.0, 0.0, 1.0],
            [-1.0, 0.0, 0.0],
            [0.0, 0.0, -1.0],
        ] {
            let view = View::new(eye, look, [0.0, 1.0, 0.0], 75.0, 16.0 / 9.0, 0.05)
                .map_err(|e| e.to_string())?;
            level.trace(&view, &doors, &TraceOptions::default(), &mut trace);
            if trace.location.cell().is_none() {
                continue;
            }
            sum += level.cost(&meshes, &view, &trace, &mut list);
            views += 1;
        }
    }
    Ok((views, sum))
}

/// The draw table: per size, what a view submits by the draw lists, the visible cells' nodes
/// drawn whole, and frustum culling alone.
fn print_draw_table(rows: &[Row]) {
    println!("\nTriangles and draw calls submitted per view (cameras at up to {PRICED_CELLS} cell centres, four looks each, fov 75°, 16:9; every node's box frustum-culled): the draw lists, the visible cells' nodes whole, frustum culling alone.\n");
    println!("| rooms | triangles | views | draw lists | whole nodes | frustum only | whole / lists |\n|---|---|---|---|---|---|---|");
    for r in rows {
        let v = r.views.max(1) as f64;
        let s = |x: portcullis::runtime::Submitted| {
            format!(
                "{:.1} tris, {:.1} calls",
                x.triangles as f64 / v,
                x.calls as f64 / v
            )
        };
        println!(
            "| {} | {} | {} | {} | {} | {} | {:.2} |",
            r.rooms,
            r.triangles,
            r.views,
            s(r.draw.lists),
            s(r.draw.nodes),
            s(r.draw.frustum),
            r.draw.nodes.triangles as f64 / r.draw.lists.triangles.max(1) as f64
        );
    }
}

/// Each time the fastest of two runs', each peak the lower.
fn fastest(a: Option<Row>, b: Row) -> Row {
    let Some(a) = a else { return b };
    let min = f64::min;
    let peak = |x: Option<u64>, y: Option<u64>| match (x, y) {
        (Some(x), Some(y)) => Some(x.min(y)),
        (x, y) => x.or(y),
    };
    Row {
        floor: min(a.floor, b.floor),
        import: min(a.import, b.import),
        tags: min(a.tags, b.tags),
        cells_s: min(a.cells_s, b.cells_s),
        portals_s: min(a.portals_s, b.portals_s),
        check: min(a.check, b.check),
        export: min(a.export, b.export),
        cpu: a.cpu.iter().zip(&b.cpu).map(|(x, y)| x.min(*y)).collect(),
        process: min(a.process, b.process),
        vis: a
            .vis
            .iter()
            .zip(&b.vis)
            .map(|(x, y)| (x.0.clone(), min(x.1, y.1), x.2))
            .collect(),
        peak_rss_bytes: peak(a.peak_rss_bytes, b.peak_rss_bytes),
        peak_with_pvs_bytes: peak(a.peak_with_pvs_bytes, b.peak_with_pvs_bytes),
        ..b
    }
}

fn table(rows: &[Row]) -> String {
    let mut s = String::from(
        "| rooms | triangles | file | cells | portals | floor (gltf read+write) | import | tags | cells | portals | check | export | stages total (no PVS) | total / floor | convert process | process / floor | peak memory (convert) | memory / file |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    let mb = |b: f64| format!("{:.1} MB", b / 1e6);
    for r in rows {
        let total = r.import + r.tags + r.cells_s + r.portals_s + r.check + r.export;
        let peak = r.peak_rss_bytes.map(|b| b as f64);
        s.push_str(&format!(
            "| {} | {} | {} | {} | {} | {:.3} s | {:.3} s | {:.3} s | {:.3} s | {:.3} s | {:.3} s | {:.3} s | {:.3} s | {:.1} | {:.3} s | {:.1} | {} | {} |\n",
            r.rooms,
            r.triangles,
            mb(r.file_bytes as f64),
            r.cells,
            r.portals,
            r.floor,
            r.import,
            r.tags,
            r.cells_s,
            r.portals_s,
            r.check,
            r.export,
            total,
            total / r.floor.max(1e-9),
            r.process,
            r.process / r.floor.max(1e-9),
            peak.map_or("n/a".into(), mb),
            peak.map_or("n/a".into(), |p| format!("{:.1}", p / r.file_bytes as f64)),
        ));
    }
    s.push_str(
        "\nCPU seconds per stage (every thread; a stage on two threads can take twice its wall time):\n\n| rooms | import | tags | cells | portals | check | export | total |\n|---|---|---|---|---|---|---|---|\n",
    );
    for r in rows {
        let cells: Vec<String> = r.cpu.iter().map(|c| format!("{c:.3} s")).collect();
        s.push_str(&format!(
            "| {} | {} | {:.3} s |\n",
            r.rooms,
            cells.join(" | "),
            r.cpu.iter().sum::<f64>()
        ));
    }
    s
}

pub fn run(a: &BenchArgs) -> i32 {
    // Without --keep: a folder of our own under the system's temporary folder, removed at the end.
    let own = a.keep.is_none() && a.one.is_none();
    let dir: PathBuf = match &a.keep {
        Some(d) => d.clone(),
        None => std::env::temp_dir().join(format!("portcullis-bench-{}", std::process::id())),
    };
    if let Err(e) = std::fs::create_dir_all(&dir) {
        eprintln!("error: cannot make `{}`: {e}", dir.display());
        return 2;
    }
    let code = run_in(a, &dir);
    if own {
        let _ = std::fs::remove_dir_all(&dir);
    }
    code
}

fn run_in(a: &BenchArgs, dir: &Path) -> i32 {
    let methods = match methods(&a.methods) {
        Ok(m) => m,
        Err(e) => {
            eprintln!("error: {e}");
            return 2;
        }
    };
    if let Some(n) = a.one {
        return match one(n, a.seed, dir, &methods) {
            Ok(row) => {
                println!("{}", serde_json::to_string(&row).unwrap_or_default());
                0
            }
            Err(e) => {
                eprintln!("error: benchmark of {n} rooms failed: {e}");
                2
            }
        };
    }
    let Ok(exe) = std::env::current_exe() else {
        eprintln!("error: cannot find the portcullis executable to run each size");
        return 2;
    };
    let mut rows = Vec::new();
    for &n in &a.rooms {
        eprintln!("{n} rooms...");
        if let Err(e) = generate(dir, n, a.seed) {
            eprintln!("error: cannot write the {n}-room building: {e}");
            return 2;
        }
        match fastest_of_runs(a, dir, &exe, n) {
            Ok(best) => rows.extend(best),
            Err(e) => {
                eprint!("{e}");
                return 2;
            }
        }
    }
    let one_room = match one_room(dir, a.room_planes, a.runs) {
        Ok(r) => r,
        Err(e) => {
            eprintln!("error: the one-room benchmark failed: {e}");
            return 2;
        }
    };
    println!(
        "portcullis {} bench, {} thread(s), seed {}, fastest of {} run(s)\n",
        env!("CARGO_PKG_VERSION"),
        rayon::current_num_threads(),
        a.seed,
        a.runs
    );
    print!("{}", table(&rows));
    print_draw_table(&rows);
    if let Some(line) = one_room {
        println!("\n{line}");
    }
    if methods.is_empty() {
        return 0;
    }
    print_vis_table(&rows);
    0
}

/// The fastest of `a.runs` measurements of the `n`-room building, each in a child process of
/// its own (so one run's memory and caches do not flatter the next), with the floor measured
/// the same way; `None` for no runs. The error is the text to print, a line or a child's
/// stderr.
fn fastest_of_runs(a: &BenchArgs, dir: &Path, exe: &Path, n: usize) -> Result<Option<Row>, String> {
    let child = |what: &str| {
        let out = std::process::Command::new(exe)
            .args([
                "bench",
                what,
                &n.to_string(),
                "--seed",
                &a.seed.to_string(),
                "--methods",
                &a.methods.join(","),
                "--keep",
            ])
            .arg(dir)
            .output();
        match out {
            Ok(o) if o.status.success() => Ok(o.stdout),
            Ok(o) => Err(String::from_utf8_lossy(&o.stderr).into_owned()),
            Err(e) => Err(format!("error: cannot run `{}`: {e}\n", exe.display())),
        }
    };
    let mut best: Option<Row> = None;
    for _ in 0..a.runs {
        let row = child("--one").and_then(|out| {
            let mut r: Row = serde_json::from_slice(&out)
                .map_err(|e| format!("error: unreadable measurements for {n} rooms: {e}\n"))?;
            r.process = convert_process(exe, dir, n, a.seed)?;
            r.floor = floor(exe, dir, n, a.seed)?;
            Ok(r)
        });
        best = Some(fastest(best, row?));
    }
    Ok(best)
}

/// The visibility table: each method's time and pairs per size, and how far the full
/// method's pairs exceed the sampled lower bound.
fn print_vis_table(rows: &[Row]) {
    println!("\nVisibility (PVS) per method: time, and the visible (cell, cell) pairs it finds; sampled is a lower bound, every other method must contain it.\n");
    println!("| rooms | cells | flood | fast | full | sampled | full over sampled | peak memory (all methods) |\n|---|---|---|---|---|---|---|---|");
    for r in rows {
        let cell = |m: &str| {
            r.vis
                .iter()
                .find(|v| v.0 == m)
                .map_or("n/a".to_string(), |v| {
                    format!("{:.3} s, {} pairs", v.1, v.2)
                })
        };
        let pairs = |m: &str| r.vis.iter().find(|v| v.0 == m).map(|v| v.2 as f64);
        let over = match (pairs("full"), pairs("sampled")) {
            (Some(f), Some(s)) if s > 0.0 => format!("+{:.1}%", (f / s - 1.0) * 100.0),
            _ => "n/a".into(),
        };
        let peak = r
            .peak_with_pvs_bytes
            .map_or("n/a".into(), |b| format!("{:.1} MB", b as f64 / 1e6));
        println!(
            "| {} | {} | {} | {} | {} | {} | {over} | {peak} |",
            r.rooms,
            r.cells,
            cell("flood"),
            cell("fast"),
            cell("full"),
            cell("sampled")
        );
    }
}

/// The cells of one room of at least `planes` distinct planes ([`buildings::stair_hall`]): the 3D
/// decomposition's cost where a room is large, not where a building is. `None` for 0 planes.
fn one_room(dir: &Path, planes: usize, runs: u32) -> Result<Option<String>, String> {
    if planes == 0 {
        return Ok(None);
    }
    let path = dir.join(format!("stair_hall_{planes}.glb"));
    std::fs::write(
        &path,
        gltf_out::write_plain(&buildings::stair_hall(planes), OutFormat::Glb),
    )
    .map_err(|e| e.to_string())?;
    let tagged =
        portcullis::pipeline::load_tagged(&path, &Default::default()).map_err(|d| d.to_string())?;
    let mut best = f64::INFINITY;
    let mut cells = 0;
    for _ in 0..runs {
        let mut t = tagged.clone();
        let (set, s) = timed(|| portcullis::pipeline::build_cells(&mut t));
        best = best.min(s);
        cells = set.cells.len();
    }
    let steps = planes.saturating_sub(3).div_ceil(3).max(1);
    Ok(Some(format!(
        "One room of {} distinct planes (a stair hall of {steps} steps): {cells} cells in {best:.3} s.",
        3 * steps + 3
    )))
}
