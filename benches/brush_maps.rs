//! Brush maps as one room of solid blocks (issue 41), side by side with ericw-tools' qbsp:
//! `ERICW_TESTMAPS=<ericw-tools>/testmaps cargo bench --bench brush_maps [MAP.map ...]` (the
//! maps are looked for in `../shared/levels/ericw-tools/testmaps` when it is unset)
//! (E1M1-edited-ents.map and qbspfeatures.map by default). For each map, what `portcullis check
//! --sealed MAP.map` does: read the map (src/import/map), tag it, build cells and portals, check;
//! five times, the median and the slowest. With `QBSP=<path to qbsp>` qbsp is run five times on
//! the same map (`qbsp -noverbose MAP OUT.bsp`) and its median printed beside, with its leaf and
//! portal counts from the .prt it writes. Each map is also written as glTF (one room of closed
//! meshes, its entities as occupants: tests/common/testmaps.rs) and timed the same way, for
//! "the same level, the same answer" (issue 51). docs/performance.md keeps the numbers.

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

fn main() {
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
