//! Nothing changes for a level unless the changelog says so: what `convert` writes (cells,
//! portals, PVS, draw lists: the whole file), what `vis FILE.prt` prints and what `vis MAP.bsp`
//! writes are hashed and compared with `tests/fixtures/output_hashes.txt`, recorded by an
//! earlier binary. A refactor keeps every hash; a deliberate change re-records them
//! (`PORTCULLIS_BLESS=1 cargo test --release --test same_output -- --include-ignored`) and
//! names each level whose output changed, and why, in CHANGELOG.md.
//!
//! The heavy levels (retrojam1, gi_zdm2 and pandora read untagged) are an explicit run.

mod common;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

const HASHES: &str = "tests/fixtures/output_hashes.txt";

/// One run whose output is hashed: a name for the table, the command's arguments, and what
/// its output is.
struct Case {
    name: String,
    args: Vec<String>,
    /// `None`: the command's standard output; `Some(file)`: that file, written by the run.
    output: Option<PathBuf>,
    /// A file copied into the run's folder first (a `.bsp` that `vis` rewrites in place).
    copy: Option<PathBuf>,
}

fn convert(name: &str, input: &Path, flags: &[&str]) -> Case {
    let mut args: Vec<String> = vec!["convert".into()];
    args.extend(flags.iter().map(|s| s.to_string()));
    args.push(input.display().to_string());
    args.extend(["-o".into(), "out.glb".into()]);
    Case {
        name: name.into(),
        args,
        output: Some("out.glb".into()),
        copy: None,
    }
}

fn shared(rel: &str) -> Option<PathBuf> {
    let p = common::root().join("../shared").join(rel);
    p.exists().then_some(p)
}

/// Every sample, the third-party fixtures, the shared Doom and brush maps, Quake portal files
/// and qbsp's `.bsp` files (`heavy`: the explicit run's levels instead).
fn cases(heavy: bool, scratch: &Path) -> (Vec<Case>, Vec<String>) {
    let mut out = Vec::new();
    let mut missing = Vec::new();
    let fixture = common::fixture;
    if heavy {
        for (name, rel, flags) in [
            (
                "retrojam1",
                "levels/ericw-tools/testmaps/retrojam1_ericw.map",
                &[][..],
            ),
            (
                "gi_zdm2 auto",
                "levels/godot/gi_zdm2.glb",
                &["--tags", "auto"][..],
            ),
            (
                "pandora auto",
                "levels/sauerbraten/pandora.obj",
                &["--tags", "auto"][..],
            ),
        ] {
            match shared(rel) {
                Some(p) => out.push(convert(name, &p, flags)),
                None => missing.push(rel.to_string()),
            }
        }
        return (out, missing);
    }
    let samples = common::sample_levels();
    for s in samples {
        let name = format!("sample {}", s.file_name().unwrap().to_string_lossy());
        out.push(convert(&name, &s, &[]));
    }
    for (name, file, flags) in [
        ("MAP01 godot", "MAP01_godot.glb", &[][..]),
        ("E1M2 godot", "E1M2_godot.glb", &[][..]),
        ("E3M3 godot", "E3M3_godot.glb", &[][..]),
        (
            "lportal tutorial glb",
            "lportal_tutorial_simple.glb",
            &[][..],
        ),
        (
            "lportal tutorial obj",
            "lportal_tutorial_simple.obj",
            &[][..],
        ),
        ("lportal boxrooms glb", "lportal_boxrooms.glb", &[][..]),
        ("lportal boxrooms obj", "lportal_boxrooms.obj", &[][..]),
        (
            "panda3d glb",
            "panda3d_culling.glb",
            &["--tags", "panda3d"][..],
        ),
        (
            "panda3d obj",
            "panda3d_culling.obj",
            &["--tags", "panda3d"][..],
        ),
        (
            "living_room auto",
            "living_room.glb",
            &["--tags", "auto"][..],
        ),
        (
            "occlusion_room auto",
            "occlusion_room.glb",
            &["--tags", "auto"][..],
        ),
        (
            "navigation mesh auto",
            "navigation_level_mesh.obj",
            &["--tags", "auto"][..],
        ),
    ] {
        out.push(convert(name, &fixture(file), flags));
    }
    for (name, rel, flags) in [
        (
            "MAP01 doom",
            "levels/freedoom/freedoom2_MAP01.glb",
            &["--tags", "doom"][..],
        ),
        (
            "E1M2 doom",
            "levels/freedoom/freedoom1_E1M2.glb",
            &["--tags", "doom"][..],
        ),
        (
            "E3M3 doom",
            "levels/freedoom/freedoom1_E3M3.glb",
            &["--tags", "doom"][..],
        ),
        (
            "E1M1 map",
            "levels/ericw-tools/testmaps/E1M1-edited-ents.map",
            &[][..],
        ),
        (
            "e3m4 map",
            "levels/ericw-tools/testmaps/LibreQuake/lq1/maps/src/e3/e3m4.map",
            &[][..],
        ),
        (
            "qbspfeatures map",
            "levels/ericw-tools/testmaps/qbspfeatures.map",
            &[][..],
        ),
        (
            "E1M1 plain glTF",
            "levels/ericw-tools/gltf/E1M1-edited-ents.gltf",
            &[][..],
        ),
    ] {
        match shared(rel) {
            Some(p) => out.push(convert(name, &p, flags)),
            None => missing.push(rel.to_string()),
        }
    }
    let building = common::generated_building(scratch, 100, 7);
    out.push(convert("generated building, 100 rooms", &building, &[]));
    for prt in ["qbspfeatures", "light_general", "e3m4", "base1"] {
        let rel = format!("prt/{prt}.prt");
        match shared(&rel) {
            Some(p) => out.push(Case {
                name: format!("vis {prt}.prt"),
                args: vec!["vis".into(), p.display().to_string()],
                output: None,
                copy: None,
            }),
            None => missing.push(rel),
        }
    }
    for bsp in ["qbspfeatures", "light_general", "E1M1-edited-ents", "e3m4"] {
        let (b, p) = (format!("bsp/{bsp}.bsp"), format!("bsp/{bsp}.prt"));
        match (shared(&b), shared(&p)) {
            (Some(b), Some(p)) => out.push(Case {
                name: format!("vis {bsp}.bsp"),
                args: vec![
                    "vis".into(),
                    "map.bsp".into(),
                    "--prt".into(),
                    p.display().to_string(),
                ],
                output: Some("map.bsp".into()),
                copy: Some(b),
            }),
            _ => missing.push(b),
        }
    }
    (out, missing)
}

/// The hash of one case's output, with the run's exit status.
fn run(case: &Case) -> String {
    let dir = tempfile::tempdir().unwrap();
    if let Some(src) = &case.copy {
        std::fs::copy(src, dir.path().join("map.bsp")).unwrap();
    }
    let out = assert_cmd::Command::cargo_bin("portcullis")
        .unwrap()
        .current_dir(dir.path())
        .args(&case.args)
        .output()
        .unwrap();
    let bytes = match &case.output {
        None => out.stdout.clone(),
        Some(f) => std::fs::read(dir.path().join(f)).unwrap_or_default(),
    };
    format!(
        "{:016x} exit {}",
        xxhash_rust::xxh3::xxh3_64(&bytes),
        out.status.code().unwrap_or(-1)
    )
}

fn recorded() -> BTreeMap<String, String> {
    let text = std::fs::read_to_string(common::root().join(HASHES)).unwrap_or_default();
    text.lines()
        .filter(|l| !l.starts_with('#') && !l.trim().is_empty())
        .filter_map(|l| l.split_once('\t'))
        .map(|(k, v)| (k.to_string(), v.to_string()))
        .collect()
}

fn judge(heavy: bool) {
    let scratch = tempfile::tempdir().unwrap();
    let (cases, missing) = cases(heavy, scratch.path());
    if !missing.is_empty() {
        eprintln!(
            "skipped {} cases: not found under ../shared ({})",
            missing.len(),
            missing.join(", ")
        );
    }
    let got: Vec<(String, String)> = std::thread::scope(|s| {
        let chunks: Vec<_> = cases
            .chunks(cases.len().div_ceil(2).max(1))
            .map(|chunk| {
                s.spawn(move || {
                    chunk
                        .iter()
                        .map(|c| (c.name.clone(), run(c)))
                        .collect::<Vec<_>>()
                })
            })
            .collect();
        chunks.into_iter().flat_map(|h| h.join().unwrap()).collect()
    });
    let mut table = recorded();
    if std::env::var_os("PORTCULLIS_BLESS").is_some() {
        for (k, v) in &got {
            table.insert(k.clone(), v.clone());
        }
        let mut text = String::from(
            "# Output hashes (xxh3-64 of the written file or printed PVS, and the exit status) by\n\
             # tests/same_output.rs; re-record with PORTCULLIS_BLESS=1 and say why in CHANGELOG.md.\n",
        );
        for (k, v) in &table {
            text += &format!("{k}\t{v}\n");
        }
        std::fs::write(common::root().join(HASHES), text).unwrap();
        eprintln!("recorded {} hashes", got.len());
        return;
    }
    let mut differ = Vec::new();
    for (k, v) in &got {
        match table.get(k) {
            Some(r) if r == v => {}
            Some(r) => differ.push(format!("{k}: recorded {r}, now {v}")),
            None => differ.push(format!("{k}: no recorded hash (now {v})")),
        }
    }
    eprintln!("{} outputs compared, {} differ", got.len(), differ.len());
    assert!(!got.is_empty(), "no case ran");
    // With ../shared present every case runs: 64 outputs, or the 3 heavy ones.
    if missing.is_empty() {
        assert!(
            got.len() >= if heavy { 3 } else { 64 },
            "only {} outputs",
            got.len()
        );
    }
    assert!(differ.is_empty(), "{}", differ.join("\n"));
}

#[test]
fn every_level_writes_the_recorded_output() {
    judge(false);
}

#[test]
#[ignore = "heavy levels (about 4 minutes): cargo test --release --test same_output -- --ignored"]
fn every_heavy_level_writes_the_recorded_output() {
    judge(true);
}
