//! `check --sightlines N` (issue 26): rays through the level's real triangles against the PVS.
//! No sample, shared level or generated building has a sightline its PVS misses; a converted
//! level whose stored PVS lost pairs by hand has each of those pairs reported (and exits 1),
//! and nothing else.

mod common;

use std::collections::BTreeSet;

use common::{fixture, sample};
use portcullis::diag::Code;
use portcullis::pipeline;
use portcullis::vis::Method;
use serde_json::Value;

fn audit(path: &std::path::Path, preset: Option<&str>) -> portcullis::check::sightlines::Audit {
    let level = common::built(path, preset);
    let pvs = pipeline::pvs(&level, Method::Full);
    pipeline::audit(&level, &pvs, 200)
}

fn missed(a: &portcullis::check::sightlines::Audit) -> Vec<String> {
    a.diagnostics
        .0
        .iter()
        .filter(|d| d.code == Code::PVS_MISSES_SIGHTLINE)
        .map(|d| d.message.clone())
        .collect()
}

#[test]
fn no_level_has_a_sightline_its_pvs_misses() {
    let dir = tempfile::tempdir().unwrap();
    // Every sample, whether or not the other tests take it.
    let mut levels = common::levels_and_samples();
    levels.push((fixture("MAP01_godot.glb"), None));
    levels.push((fixture("E1M2_godot.glb"), None));
    levels.push((fixture("E3M3_godot.glb"), None));
    levels.push((common::generated_building(dir.path(), 100, 7), None));
    let mut confirmed = 0;
    for (path, preset) in levels {
        let a = audit(&path, preset);
        let m = missed(&a);
        assert!(m.is_empty(), "{}: {}", path.display(), m.join("\n"));
        assert!(a.confirmed <= a.pairs);
        confirmed += a.confirmed;
        let info = a
            .diagnostics
            .0
            .iter()
            .filter(|d| d.code == Code::SIGHTLINES_CONFIRMED)
            .count();
        assert_eq!(info, 1, "{}", path.display());
    }
    assert!(
        confirmed > 10_000,
        "the rays confirmed only {confirmed} pairs"
    );
}

/// The rays see what the geometry shows: through a door, a window, a teleporter, a 2 m
/// tunnel (end to end), over a courtyard wall.
#[test]
fn rays_confirm_what_each_sample_shows() {
    for (name, pairs) in [
        ("two_rooms.gltf", 2),
        ("door_window.gltf", 2),
        ("thick_wall.gltf", 2),
        ("teleporter.gltf", 2),
        ("courtyard.gltf", 2),
        ("crawl_tunnel.gltf", 6),
    ] {
        let a = audit(&sample(name), None);
        assert_eq!((a.confirmed, a.pairs), (pairs, pairs), "{name}");
    }
}

/// A converted level's stored PVS with every pair out of one cell removed by hand (rewritten
/// as `lists`): `check --sightlines 200` reports removed pairs only, at least one, and exits 1;
/// the untouched file checks clean.
#[test]
fn pairs_removed_from_a_stored_pvs_are_reported() {
    let dir = tempfile::tempdir().unwrap();
    for (level, preset) in [
        (sample("door_window.gltf"), None),
        (fixture("lportal_boxrooms.glb"), None),
    ] {
        let out = dir.path().join("level.gltf");
        let mut cmd = assert_cmd::Command::cargo_bin("portcullis").unwrap();
        cmd.arg("convert").arg(&level).arg("-o").arg(&out);
        if let Some(t) = preset {
            cmd.args(["--tags", t]);
        }
        common::succeeds(&mut cmd);
        let check = |path: &std::path::Path| {
            let o = assert_cmd::Command::cargo_bin("portcullis")
                .unwrap()
                .args(["check", "--sightlines", "200", "--format", "json"])
                .arg(path)
                .output()
                .unwrap();
            let v: Value = serde_json::from_slice(&o.stdout).unwrap();
            let codes: Vec<(String, String)> = v["files"][0]["diagnostics"]
                .as_array()
                .unwrap()
                .iter()
                .map(|d| {
                    (
                        d["code"].as_str().unwrap().to_string(),
                        d["message"].as_str().unwrap().to_string(),
                    )
                })
                .collect();
            (o.status.code(), codes)
        };
        let (exit, codes) = check(&out);
        assert!(
            codes.iter().all(|(c, _)| c != "PVS_MISSES_SIGHTLINE"),
            "{}: {codes:?}",
            level.display()
        );
        assert_eq!(exit, Some(0), "{}: {codes:?}", level.display());
        assert!(codes.iter().any(|(c, _)| c == "SIGHTLINES_CONFIRMED"));

        // Every pair out of cell 0 but its own, removed.
        let mut doc: Value = serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
        let ext = &mut doc["extensions"]["PORTCULLIS_portals"];
        let cells = ext["cells"].as_array().unwrap().len();
        let pvs = pipeline::pvs(&common::built(&level, preset), Method::Full);
        assert_eq!(pvs.cells(), cells);
        let lists: Vec<Vec<usize>> = (0..cells)
            .map(|r| pvs.visible(r).filter(|&v| r != 0 || v == 0).collect())
            .collect();
        let removed: BTreeSet<usize> = pvs.visible(0).filter(|&v| v != 0).collect();
        assert!(!removed.is_empty());
        ext["visibility"] =
            serde_json::json!({ "method": "full", "encoding": "lists", "lists": lists });
        let cut = dir.path().join("cut.gltf");
        std::fs::write(&cut, serde_json::to_string(&doc).unwrap()).unwrap();
        let (exit, codes) = check(&cut);
        let reported: Vec<&String> = codes
            .iter()
            .filter(|(c, _)| c == "PVS_MISSES_SIGHTLINE")
            .map(|(_, m)| m)
            .collect();
        assert_eq!(exit, Some(1), "{}: {codes:?}", level.display());
        assert!(!reported.is_empty(), "{}", level.display());
        for m in &reported {
            assert!(m.starts_with("a sightline from cell 0 "), "{m}");
            let to: usize = m
                .split(" reaches cell ")
                .nth(1)
                .and_then(|r| r.split(' ').next())
                .and_then(|n| n.parse().ok())
                .unwrap();
            assert!(removed.contains(&to), "{m}");
        }
    }
}

/// The audit is the same with one thread or three: each cell's rays have their own generator
/// and the findings are gathered in cell order.
#[test]
fn the_audit_does_not_depend_on_the_thread_count() {
    let level = common::built(&fixture("lportal_boxrooms.glb"), None);
    let mut pvs = pipeline::pvs(&level, Method::Full);
    // Some findings to compare too: cell 0 sees only itself.
    for (k, w) in pvs.bits.row_mut(0).iter_mut().enumerate() {
        *w = u64::from(k == 0);
    }
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| pipeline::audit(&level, &pvs, 100))
    };
    let (one, three) = (run(1), run(3));
    assert!(!missed(&one).is_empty());
    assert_eq!(one.diagnostics.0, three.diagnostics.0);
    assert_eq!(one.lines, three.lines);
    assert_eq!((one.confirmed, one.pairs), (three.confirmed, three.pairs));
}

/// `vis --report` prints the ray-traced bound beside the sampled one: over it by 0% for every
/// method on the courtyard (each court sees the other, and rays find it), and no conservative
/// method misses a ray-traced pair on a shared level.
#[test]
fn vis_report_has_the_ray_traced_bound() {
    let run = |path: &std::path::Path| {
        let o = assert_cmd::Command::cargo_bin("portcullis")
            .unwrap()
            .args(["vis", "--report", "--samples", "100", "--rays", "400"])
            .arg(path)
            .output()
            .unwrap();
        assert_eq!(o.status.code(), Some(0));
        String::from_utf8(o.stdout).unwrap()
    };
    let court = run(&sample("courtyard.gltf"));
    for m in ["flood", "fast", "full"] {
        let row = court
            .lines()
            .find(|l| l.contains(&format!("| {m} |")))
            .unwrap();
        assert!(row.ends_with("| +0.0% | 400 |"), "{row}");
    }
    let boxes = run(&fixture("lportal_boxrooms.glb"));
    assert!(boxes.contains("over ray-traced"), "{boxes}");
    assert!(!boxes.contains("ray-traced pairs missing"), "{boxes}");
}
