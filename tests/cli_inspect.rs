//! `portcullis inspect` end to end: exit codes, human and JSON output, malformed inputs.

mod common;

use std::path::Path;

use assert_cmd::Command;
use common::{fixture, gltf, n, root, sample, write};
use serde_json::Value;

fn portcullis() -> Command {
    let mut c = Command::cargo_bin("portcullis").unwrap();
    c.env("NO_COLOR", "1");
    c
}

fn inspect_json(args: &[&str]) -> (i32, Value) {
    let out = portcullis()
        .arg("inspect")
        .args(args)
        .args(["--format", "json"])
        .output()
        .unwrap();
    let code = out.status.code().expect("exited normally (no signal)");
    let v: Value = serde_json::from_slice(&out.stdout).unwrap_or_else(|e| {
        panic!(
            "not JSON ({e}): {}\n{}",
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        )
    });
    (code, v)
}

#[test]
fn inspect_sample_human() {
    let out = portcullis()
        .args(["inspect"])
        .arg(sample("two_rooms.gltf"))
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(0));
    let s = String::from_utf8(out.stdout).unwrap();
    assert!(s.contains("46 triangles"), "{s}");
    assert!(s.contains("rooms (2):"), "{s}");
    assert!(s.contains("kitchen -> lounge"), "{s}");
    assert!(s.contains("1 file, 0 errors, 0 warnings"), "{s}");
    assert!(!s.contains('\x1b'), "no colour in a pipe");
}

#[test]
fn inspect_json_reports_scene_and_tags() {
    let (code, v) = inspect_json(&[
        fixture("lportal_boxrooms.glb").to_str().unwrap(),
        fixture("lportal_tutorial_simple.obj").to_str().unwrap(),
    ]);
    assert_eq!(code, 0);
    let files = v["files"].as_array().unwrap();
    assert_eq!(files.len(), 2);
    assert_eq!(files[0]["scene"]["triangles"], 3352);
    assert_eq!(files[0]["tags"]["rooms"].as_array().unwrap().len(), 16);
    assert_eq!(files[0]["tags"]["portals"].as_array().unwrap().len(), 16);
    assert_eq!(files[0]["cells"].as_array().unwrap().len(), 16);
    assert_eq!(files[0]["cells"][0]["planes"], 6);
    assert_eq!(files[1]["scene"]["format"], "obj");
    assert_eq!(files[1]["tags"]["portals"][0]["source"], "kitchen");
    assert_eq!(files[1]["tags"]["portals"][0]["target"], "lounge");
    assert_eq!(v["summary"]["files"], 2);
    assert_eq!(v["summary"]["errors"], 0);
}

#[test]
fn preset_flag_and_bad_preset() {
    let (code, v) = inspect_json(&[
        fixture("panda3d_culling.glb").to_str().unwrap(),
        "--tags",
        "panda3d",
    ]);
    assert_eq!(code, 0);
    assert_eq!(
        v["files"][0]["tags"]["footprints"]
            .as_array()
            .unwrap()
            .len(),
        11
    );
    let out = portcullis()
        .arg("inspect")
        .arg(sample("two_rooms.gltf"))
        .args(["--tags", "unreal"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stdout).contains("TAGS_PRESET_UNKNOWN"));
}

#[test]
fn near_miss_warns_and_deny_warnings_fails() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(
        dir.path(),
        "near.gltf",
        &gltf(&[n("Kitchen_Room ", None, false), n("Floor", Some(0), true)]),
    );
    let out = portcullis().arg("inspect").arg(&p).output().unwrap();
    assert_eq!(out.status.code(), Some(0));
    let s = String::from_utf8(out.stdout).unwrap();
    assert!(s.contains("warning[TAG_NEAR_MISS]"), "{s}");
    assert!(s.contains("near.gltf#/nodes/0"), "{s}");
    let out = portcullis()
        .arg("inspect")
        .arg(&p)
        .args(["--deny", "warnings"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
}

#[test]
fn level_errors_exit_1() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(
        dir.path(),
        "bad_target.gltf",
        &gltf(&[n("room_a", None, false), n("portal_b", Some(0), true)]),
    );
    let (code, v) = inspect_json(&[p.to_str().unwrap()]);
    assert_eq!(code, 1);
    assert_eq!(
        v["files"][0]["diagnostics"][0]["code"],
        "TAG_UNKNOWN_TARGET"
    );
    assert_eq!(
        v["files"][0]["diagnostics"][0]["location"]["pointer"],
        "/nodes/1"
    );
}

#[test]
fn bad_config_and_missing_file_exit_2() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(dir.path(), "lvl.gltf", &gltf(&[n("room_a", None, true)]));
    write(dir.path(), "portcullis.toml", "[tags]\npreset = \"godt\"\n");
    let (code, v) = inspect_json(&[p.to_str().unwrap()]);
    assert_eq!(code, 2);
    assert_eq!(v["files"][0]["diagnostics"][0]["code"], "CONFIG_INVALID");
    let msg = v["files"][0]["diagnostics"][0]["message"].as_str().unwrap();
    assert!(msg.contains("/tags/preset"), "{msg}");
    let (code, v) = inspect_json(&[dir.path().join("nope.glb").to_str().unwrap()]);
    assert_eq!(code, 2);
    assert_eq!(v["files"][0]["diagnostics"][0]["code"], "IO_READ_FAILED");
    let (code, _) = inspect_json(&[dir.path().join("level.fbx").to_str().unwrap()]);
    assert_eq!(code, 2);
    // --config wins over the file next to the input.
    let good = write(dir.path(), "good.toml", "[tags]\npreset = \"godot\"\n");
    let (code, v) = inspect_json(&[p.to_str().unwrap(), "--config", good.to_str().unwrap()]);
    assert_eq!(code, 0);
    assert_eq!(v["files"][0]["tags"]["preset"], "godot");
}

/// Every file of the malformed set ends with a message naming the file and a code, and exit 2
/// (or 1 where the file reads but the level is wrong, such as NaN positions). None panics.
#[test]
fn malformed_inputs_fail_cleanly() {
    let dir = root().join("tests/fixtures/malformed");
    let mut seen = 0;
    for sub in ["gltf", "obj"] {
        let Ok(entries) = std::fs::read_dir(dir.join(sub)) else {
            continue;
        };
        let mut files: Vec<_> = entries.flatten().map(|e| e.path()).collect();
        files.sort();
        for f in files {
            if f.extension().and_then(|e| e.to_str()) == Some("bin") {
                continue;
            }
            seen += 1;
            let out = portcullis()
                .arg("inspect")
                .arg(&f)
                .args(["--format", "json"])
                .output()
                .unwrap();
            let code = out.status.code().expect("no signal");
            let name = f.file_name().unwrap().to_str().unwrap();
            assert!(
                code == 1 || code == 2,
                "{name}: exit {code}\n{}",
                String::from_utf8_lossy(&out.stderr)
            );
            let v: Value = serde_json::from_slice(&out.stdout).expect("JSON report");
            let d = &v["files"][0]["diagnostics"];
            let first_error = d
                .as_array()
                .unwrap()
                .iter()
                .find(|d| d["severity"] == "error")
                .unwrap_or_else(|| panic!("{name}: no error in {d}"));
            let file = first_error["location"]["file"].as_str().unwrap_or("");
            assert!(
                Path::new(file).file_name() == f.file_name(),
                "{name}: location names {file}"
            );
            assert!(first_error["message"].as_str().unwrap().len() > 10);
        }
    }
    assert!(seen >= 15, "the malformed set has {seen} files");
}

/// Issue 29, item 11: counts agree with their nouns ("renders 1 nodes" before).
#[test]
fn a_cell_rendering_one_node_says_node() {
    let o = portcullis()
        .arg("inspect")
        .arg(sample("bound_boxes.gltf"))
        .output()
        .unwrap();
    let text = String::from_utf8(o.stdout).unwrap();
    assert!(text.contains("renders 1 node"), "{text}");
    assert!(!text.contains("renders 1 nodes"), "{text}");
    let o = portcullis()
        .arg("inspect")
        .arg(sample("two_rooms.gltf"))
        .output()
        .unwrap();
    assert!(String::from_utf8(o.stdout)
        .unwrap()
        .contains("renders 4 nodes"));
}

/// Issue 29, item 10: `portcullis schema` lists and prints the extension's schema too.
#[test]
fn schema_lists_and_prints_the_extension_schema() {
    let o = portcullis().arg("schema").output().unwrap();
    assert_eq!(o.status.code(), Some(0));
    let list = String::from_utf8(o.stdout).unwrap();
    for name in [
        "config.schema.json",
        "tags.schema.json",
        "PORTCULLIS_portals.schema.json",
    ] {
        assert!(list.contains(name), "{list}");
    }
    let shipped: Value = serde_json::from_str(
        &std::fs::read_to_string(root().join("schemas/PORTCULLIS_portals.schema.json")).unwrap(),
    )
    .unwrap();
    for name in [
        "PORTCULLIS_portals.schema.json",
        "PORTCULLIS_portals",
        "portcullis_portals",
    ] {
        let o = portcullis().args(["schema", name]).output().unwrap();
        assert_eq!(o.status.code(), Some(0), "{name}");
        let printed: Value = serde_json::from_slice(&o.stdout).unwrap();
        assert_eq!(printed, shipped, "{name}");
    }
    let o = portcullis().args(["schema", "nope"]).output().unwrap();
    assert_eq!(o.status.code(), Some(2));
}

/// Issue 29, item 10: `inspect` reads the Quake portal files `vis` reads (the counts are the
/// file's own header: leaves, clusters, portals for PRT2), and under every level it builds it
/// says that `check` runs more checks than it does.
#[test]
fn inspect_reads_portal_files_and_says_it_runs_fewer_checks_than_check() {
    for name in ["qbspfeatures.prt", "light_general.prt"] {
        let path = root().join("tests/fixtures/prt").join(name);
        let text = std::fs::read_to_string(&path).unwrap();
        let header: Vec<usize> = text
            .lines()
            .skip(1)
            .take(3)
            .map(|l| l.trim().parse().unwrap())
            .collect();
        let (code, v) = inspect_json(&[path.to_str().unwrap()]);
        assert_eq!(code, 0, "{v:#}");
        let prt = &v["files"][0]["prt"];
        assert_eq!(prt["format"], "PRT2");
        assert_eq!(prt["leaves"], header[0]);
        assert_eq!(prt["cells"], header[1]);
        assert_eq!(prt["portals"], header[2]);
        assert_eq!(v["summary"]["unprocessed"], 0);
    }
    let (code, v) = inspect_json(&[sample("two_rooms.gltf").to_str().unwrap()]);
    assert_eq!(code, 0);
    assert!(v["files"][0]["checks"]
        .as_str()
        .unwrap()
        .contains("`portcullis check` also checks"));
    let human = portcullis()
        .arg("inspect")
        .arg(sample("two_rooms.gltf"))
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&human.stdout);
    assert!(text.contains("note: inspect reports"), "{text}");
}
