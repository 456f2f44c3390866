//! Brush maps as one room of solid blocks (issue 41), side by side with ericw-tools' qbsp:
//! `ERICW_TESTMAPS=<ericw-tools>/testmaps cargo bench --bench brush_maps [MAP.map ...]` (the
//! maps are looked for in `../shared/levels/ericw-tools/testmaps` when it is unset)
//! (E1M1-edited-ents.map and qbspfeatures.map by default). For each map, what `portcullis check
//! --sealed MAP.map` does: read the map (src/import/map), tag it, build cells and portals, check;
//! five times, the median and the slowest. With `QBSP=<path to qbsp>` qbsp is run five times on
//! the same map (`qbsp -noverbose MAP OUT.bsp`) and its median printed beside, with its leaf and
//! portal counts from the .prt it writes. Each map is also written as glTF (one room of closed
//! meshes, its entities as occupants: tests/common/testmaps.rs) and timed the same way, for
//! "the same level, the same answer" (issue 51). `cargo bench --bench brush_maps -- grid 1000
//! 3000` runs the grid of rooms instead (issue 52, see `grid`; `GRID_DIR=<folder>` keeps its
//! files). docs/performance.md keeps the numbers.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

#[allow(unused_imports)]
#[path = "../tests/common/mod.rs"]
mod common;

use portcullis::diag::Code;
use portcullis::import::{import_bytes, ImportOptions};
use portcullis::pipeline::{check, load, LoadOptions};
use portcullis::scene::Format;

/// The map's brushes as the library reads them: one node with a mesh each (point entities,
/// rooms and the root have none).
fn brush_count(path: &Path) -> usize {
    let bytes = std::fs::read(path).expect("the map reads");
    let base = path.parent().unwrap_or(Path::new("."));
    let imported = import_bytes(&bytes, path, Format::Map, base, &ImportOptions::default())
        .unwrap_or_else(|d| panic!("{}: {d}", path.display()));
    imported
        .scene
        .nodes
        .iter()
        .filter(|n| n.mesh.is_some())
        .count()
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Our run: (median s, slowest s, cells, portals, leak).
fn ours(path: &Path) -> (f64, f64, usize, usize, bool) {
    let mut times = Vec::new();
    let mut last = (0, 0, false);
    for _ in 0..5 {
        let start = Instant::now();
        let mut level = load(path, &LoadOptions::default()).expect("the map reads");
        check(&mut level, true);
        times.push(start.elapsed().as_secs_f64());
        last = (
            level.cells.cells.len(),
            level.portals.portals.len(),
            level.diagnostics.has(Code::LEAK),
        );
    }
    let slowest = times.iter().copied().fold(0.0, f64::max);
    (median(times), slowest, last.0, last.1, last.2)
}

/// qbsp's run: (median s, leafs, portals) from its .prt, or None when it leaked.
fn qbsp(bin: &Path, map: &Path) -> (f64, Option<(usize, usize)>) {
    let dir = std::env::temp_dir().join(format!("portcullis-qbsp-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let out = dir.join("out.bsp");
    let mut times = Vec::new();
    for _ in 0..5 {
        let _ = std::fs::remove_file(dir.join("out.prt"));
        let start = Instant::now();
        let status = Command::new(bin)
            .arg("-noverbose")
            .arg(map)
            .arg(&out)
            .output()
            .expect("qbsp runs");
        times.push(start.elapsed().as_secs_f64());
        assert!(status.status.success(), "qbsp failed on {}", map.display());
    }
    let counts = std::fs::read_to_string(dir.join("out.prt"))
        .ok()
        .map(|prt| {
            let lines: Vec<&str> = prt.lines().collect();
            // PRT1: leafs, portals; PRT2: leafs, clusters, portals.
            let n = |i: usize| {
                lines
                    .get(i)
                    .and_then(|l| l.trim().parse().ok())
                    .unwrap_or(0)
            };
            if lines.first() == Some(&"PRT2") {
                (n(1), n(3))
            } else {
                (n(1), n(2))
            }
        });
    let _ = std::fs::remove_dir_all(&dir);
    (median(times), counts)
}

/// One run of the binary on `file` (`args` before it): seconds, peak resident MB (when
/// `/usr/bin/time` is there) and standard output.
fn run(args: &[&str], file: &Path, extra: &[&str]) -> (f64, Option<f64>, String) {
    let bin = env!("CARGO_BIN_EXE_portcullis");
    let timer = Path::new("/usr/bin/time");
    let mut cmd = if timer.exists() {
        let mut c = Command::new(timer);
        c.args(["-f", "%M", bin]);
        c
    } else {
        Command::new(bin)
    };
    cmd.args(args).arg(file).args(extra);
    let start = Instant::now();
    let out = cmd.output().expect("portcullis runs");
    let secs = start.elapsed().as_secs_f64();
    let err = String::from_utf8_lossy(&out.stderr);
    let kb = timer
        .exists()
        .then(|| err.lines().last()?.trim().parse::<f64>().ok())
        .flatten();
    (
        secs,
        kb.map(|k| k / 1024.0),
        String::from_utf8_lossy(&out.stdout).into(),
    )
}

/// Cells and portals of a level, as `check` counts them.
fn counts(path: &Path) -> (usize, usize) {
    let level = load(path, &LoadOptions::default()).expect("the level reads");
    (level.cells.cells.len(), level.portals.portals.len())
}

/// qbsp then vis (when given) once on `map`: qbsp's seconds, its leafs and portals from the
/// .prt (PRT1 or PRT2), and vis's seconds.
fn qbsp_vis_once(qbsp: &Path, vis: Option<&Path>, map: &Path) -> String {
    let dir = tempfile::tempdir().expect("a temporary folder");
    let bsp = dir.path().join("out.bsp");
    let start = Instant::now();
    let ok = Command::new(qbsp)
        .arg("-noverbose")
        .arg(map)
        .arg(&bsp)
        .output();
    let q = start.elapsed().as_secs_f64();
    let prt = std::fs::read_to_string(dir.path().join("out.prt")).unwrap_or_default();
    let lines: Vec<&str> = prt.lines().collect();
    let n = |i: usize| lines.get(i).map_or("?", |l| l.trim());
    let (leafs, portals) = if n(0) == "PRT2" {
        (n(1), n(3))
    } else {
        (n(1), n(2))
    };
    let v = match (vis, ok.is_ok() && !prt.is_empty()) {
        (Some(vis), true) => {
            let start = Instant::now();
            let _ = Command::new(vis).arg(&bsp).output();
            format!("{:.2} s", start.elapsed().as_secs_f64())
        }
        _ => "—".into(),
    };
    format!("{leafs}, {portals}, {q:.2} s | {v}")
}

/// `grid N...`: the grid of N rooms (tests/common/grid.rs) as one brush map and as glTF with
/// one room node per room, open and with a door in every doorway: cells, directed portals, the
/// wall time of `check --sealed` and of the whole `convert` (full PVS), and its peak memory;
/// with `QBSP` (and `VIS`) set, qbsp (and vis) once on the same map beside them.
fn grid(sizes: &[usize]) {
    let tmp = tempfile::tempdir().expect("a temporary folder");
    // `GRID_DIR=<folder>` keeps the generated maps and glTF there, to run by hand.
    let kept = std::env::var_os("GRID_DIR").map(PathBuf::from);
    let dir = kept.as_deref().unwrap_or(tmp.path());
    let qbsp = std::env::var("QBSP").ok().map(PathBuf::from);
    let vis = std::env::var("VIS").ok().map(PathBuf::from);
    println!("| rooms | doors | cells, map / glTF | portals, map / glTF | `check --sealed`, map / glTF | `convert`, map / glTF | qbsp: leafs, portals, time | vis |");
    println!("|---|---|---|---|---|---|---|---|");
    let mb = |m: Option<f64>| m.map_or(String::new(), |m| format!(", {m:.0} MB"));
    for &n in sizes {
        let g = common::grid::Grid::new(n);
        for doors in [false, true] {
            let map = dir.join(format!("grid{n}_{doors}.map"));
            let gltf = dir.join(format!("grid{n}_{doors}.gltf"));
            std::fs::write(&map, g.to_map(doors)).unwrap();
            std::fs::write(&gltf, g.to_gltf(doors)).unwrap();
            let (mc, mp) = counts(&map);
            let (gc, gp) = counts(&gltf);
            let (mcheck, _, _) = run(&["check", "--sealed"], &map, &[]);
            let (gcheck, _, _) = run(&["check", "--sealed"], &gltf, &[]);
            let out = tmp.path().join("out.glb");
            let (mconv, mmem, _) = run(&["convert"], &map, &["-o", out.to_str().unwrap()]);
            let (gconv, gmem, _) = run(&["convert"], &gltf, &["-o", out.to_str().unwrap()]);
            let theirs = match &qbsp {
                Some(q) => qbsp_vis_once(q, vis.as_deref(), &map),
                None => "(QBSP unset) | —".into(),
            };
            println!(
                "| {n} | {} | {mc} / {gc} | {mp} / {gp} | {mcheck:.2} s / {gcheck:.2} s | {mconv:.2} s{} / {gconv:.2} s{} | {theirs} |",
                if doors { "yes" } else { "no" },
                mb(mmem),
                mb(gmem)
            );
        }
    }
}

fn main() {
    let args: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| a != "--bench")
        .collect();
    if args.first().map(String::as_str) == Some("grid") {
        let sizes: Vec<usize> = args[1..].iter().filter_map(|a| a.parse().ok()).collect();
        grid(if sizes.is_empty() {
            &[1000, 3000]
        } else {
            &sizes
        });
        return;
    }
    let Some((dir, maps)) = common::testmaps::maps_to_bench() else {
        return;
    };
    let qbsp_bin = std::env::var("QBSP").ok().map(PathBuf::from);
    let tmp = tempfile::tempdir().expect("a temporary folder");
    println!("| map | brushes | ours: cells, portals | ours: median (slowest) of 5 | verdict | as glTF: cells, median, verdict | qbsp: leafs, portals | qbsp: median of 5 | qbsp verdict |");
    println!("|---|---|---|---|---|---|---|---|---|");
    for name in maps {
        let path = Path::new(&dir).join(&name);
        let brushes = brush_count(&path);
        let (med, slow, cells, portals, leak) = ours(&path);
        let verdict = |leak: bool| if leak { "LEAK" } else { "sealed" };
        let gltf = common::testmaps::as_plain_gltf(&path, tmp.path());
        let (g_med, _, g_cells, _, g_leak) = ours(&gltf);
        let g_verdict = verdict(g_leak);
        let verdict = verdict(leak);
        let (q_time, q_counts, q_verdict) = match &qbsp_bin {
            Some(bin) => {
                let (t, c) = qbsp(bin, &path);
                let v = if c.is_some() { "sealed" } else { "leak" };
                let counts = c.map_or("—".to_string(), |(l, p)| format!("{l}, {p}"));
                (format!("{t:.3} s"), counts, v.to_string())
            }
            None => ("(QBSP unset)".into(), "—".into(), "—".into()),
        };
        println!(
            "| {name} | {brushes} | {cells}, {portals} | {med:.3} s ({slow:.3} s) | {verdict} | {g_cells}, {g_med:.3} s, {g_verdict} | {q_counts} | {q_time} | {q_verdict} |"
        );
    }
}
