//! `convert --split-by-cell`, read as an engine that can only show and hide nodes reads it:
//! a plain glTF reader of the tests' own (`common::plain`) sees the same triangles (corners,
//! winding, material) as in the default output, each once, and those the input's own; the cells' `nodes` partition the
//! mesh nodes of the split ones; the file passes the Khronos validator and the extension's
//! schemas; `check` reads it as it reads the default output; and `convert` refuses to write it
//! again, leaving no file.

mod common;

use std::collections::HashMap;
use std::path::Path;

use serde_json::Value;

fn convert(input: &Path, preset: Option<&str>, out: &Path, args: &[&str]) {
    let mut cmd = assert_cmd::Command::cargo_bin("portcullis").unwrap();
    cmd.arg("convert").arg(input).arg("-o").arg(out).args(args);
    if let Some(p) = preset {
        cmd.args(["--tags", p]);
    }
    common::succeeds(&mut cmd);
}

/// `check`'s exit code and its report's counts line, for comparing two files' verdicts.
fn verdict(path: &Path) -> (Option<i32>, String) {
    let o = assert_cmd::Command::cargo_bin("portcullis")
        .unwrap()
        .args(["check", "--format", "json"])
        .arg(path)
        .output()
        .unwrap();
    let report: Value = serde_json::from_slice(&o.stdout).unwrap_or(Value::Null);
    let file = &report["files"][0];
    let mut codes: Vec<String> = (file["diagnostics"].as_array().into_iter().flatten())
        .map(|d| format!("{} {}", d["severity"], d["code"]))
        .collect();
    codes.sort();
    let counts = format!("{} cells, {} portals", file["cells"], file["portals"]);
    (o.status.code(), format!("{counts}: {}", codes.join(", ")))
}

/// What the split file holds, judged against the default output: returns how many parts it
/// wrote and how many triangles it judged.
fn judged(name: &str, input: &Path, preset: Option<&str>) -> (usize, usize) {
    let dir = tempfile::tempdir().unwrap();
    let (whole, split) = (dir.path().join("whole.glb"), dir.path().join("split.glb"));
    convert(input, preset, &whole, &[]);
    convert(input, preset, &split, &["--split-by-cell"]);

    // The same triangles, each once, as a viewer that knows nothing of the extension draws.
    let (a, b) = (common::plain::drawn(&whole), common::plain::drawn(&split));
    assert!(!a.is_empty(), "{name}: no triangles");
    assert_eq!(a.len(), b.len(), "{name}: triangle count");
    assert!(a == b, "{name}: the split file draws other triangles");
    // And the default output draws the input's own, where the input is glTF in one buffer.
    let gltf = input.extension().is_some_and(|e| e == "gltf" || e == "glb");
    let one_buffer = gltf && {
        let (doc, _) = common::read_gltf(&std::fs::read(input).unwrap());
        let b = doc["buffers"].as_array().cloned().unwrap_or_default();
        let uri = b.first().and_then(|b| b["uri"].as_str().map(str::to_owned));
        b.len() == 1 && uri.is_none_or(|u| u.starts_with("data:"))
    };
    if one_buffer {
        assert!(
            common::plain::drawn(input) == a,
            "{name}: the output draws other triangles"
        );
    }

    // Valid, by Khronos and by our schemas (the root object and every node's).
    if let Some(report) = common::khronos_validate(&split) {
        let errors = report["issues"]["numErrors"].as_u64().unwrap();
        assert_eq!(errors, 0, "{name}: {}", report["issues"]["messages"]);
    }
    let (doc, _) = common::plain::read(&split);
    let ours = &doc["extensions"]["PORTCULLIS_portals"];
    let errs = portcullis::schema::validate(portcullis::schema::Schema::Portals, ours);
    assert!(errs.is_empty(), "{name}: {errs:?}");
    let nodes = doc["nodes"].as_array().unwrap();
    for (i, n) in nodes.iter().enumerate() {
        let e = &n["extensions"]["PORTCULLIS_portals"];
        if !e.is_null() {
            let errs = portcullis::schema::validate(portcullis::schema::Schema::PortalsNode, e);
            assert!(errs.is_empty(), "{name}: node {i}: {errs:?}");
        }
    }

    // A split node gives up its mesh to its children, its parts; no cell names it, each part
    // has a mesh, is its parent's child and says which cells it lies in, and the cells that
    // name a part are exactly those.
    let mut part_of: HashMap<usize, usize> = HashMap::new();
    for (i, n) in nodes.iter().enumerate() {
        let e = &n["extensions"]["PORTCULLIS_portals"];
        let Some(parts) = e["parts"].as_array() else {
            continue;
        };
        assert!(n["mesh"].is_null(), "{name}: split node {i} keeps its mesh");
        assert!(e["mesh"].as_u64().is_some(), "{name}: node {i}");
        let children: Vec<u64> = (n["children"].as_array().into_iter().flatten())
            .filter_map(Value::as_u64)
            .collect();
        for p in parts {
            let p = p.as_u64().unwrap();
            assert!(children.contains(&p), "{name}: part {p} not a child of {i}");
            assert!(nodes[p as usize]["mesh"].as_u64().is_some(), "{name}: {p}");
            part_of.insert(p as usize, i);
        }
    }
    let cells = ours["cells"].as_array().unwrap();
    let mut naming: HashMap<usize, Vec<u64>> = HashMap::new();
    for (c, cell) in cells.iter().enumerate() {
        assert!(cell["draws"].is_null(), "{name}: cell {c} has a draw list");
        for n in cell["nodes"].as_array().into_iter().flatten() {
            let n = n.as_u64().unwrap() as usize;
            assert!(
                nodes[n]["mesh"].as_u64().is_some(),
                "{name}: cell {c} names {n}"
            );
            assert!(
                nodes[n]["extensions"]["PORTCULLIS_portals"]["parts"].is_null(),
                "{name}: cell {c} names the split node {n}"
            );
            naming.entry(n).or_default().push(c as u64);
        }
    }
    for &p in part_of.keys() {
        let e = &nodes[p]["extensions"]["PORTCULLIS_portals"];
        let listed: Vec<u64> = match (e["cell"].as_u64(), e["cells"].as_array()) {
            (Some(c), _) => vec![c],
            (None, Some(cs)) => cs.iter().map(|c| c.as_u64().unwrap()).collect(),
            _ => Vec::new(),
        };
        let named = naming.get(&p).cloned().unwrap_or_default();
        assert_eq!(listed, named, "{name}: part {p}'s cells");
    }
    assert!(
        ours["split"].is_null(),
        "{name}: split indices besides parts"
    );

    // `check` gives the split file the default output's verdict.
    assert_eq!(verdict(&whole), verdict(&split), "{name}: check's verdict");
    (part_of.len(), a.len())
}

/// Converting a split file again is refused, with no output left behind.
fn refused_again(split: &Path) {
    let out = split.with_file_name("again.glb");
    let o = assert_cmd::Command::cargo_bin("portcullis")
        .unwrap()
        .arg("convert")
        .arg(split)
        .arg("-o")
        .arg(&out)
        .output()
        .unwrap();
    assert_ne!(o.status.code(), Some(0));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("CONVERT_SPLIT_INPUT"), "{err}");
    assert!(!out.exists(), "a refused convert left {}", out.display());
}

#[test]
fn split_files_draw_the_same_triangles_and_cells_name_only_parts() {
    let mut split = 0;
    for (level, preset) in common::levels_and_samples() {
        let name = level.file_name().unwrap().to_string_lossy().to_string();
        let (parts, triangles) = judged(&name, &level, preset);
        eprintln!("{name}: {parts} parts, {triangles} triangles");
        split += (parts > 0) as usize;
    }
    assert!(split >= 10, "only {split} levels split any node");
    let dir = tempfile::tempdir().unwrap();
    let g = common::generated_building(dir.path(), 40, 1);
    let (parts, _) = judged("building of 40 rooms", &g, None);
    assert!(parts > 0);
}

#[test]
fn pillar_room_split_partitions_floor_walls_and_ceiling() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("pillar_room.glb");
    convert(
        &common::sample("pillar_room.gltf"),
        None,
        &out,
        &["--split-by-cell"],
    );
    let (doc, _) = common::plain::read(&out);
    let nodes = doc["nodes"].as_array().unwrap();
    for name in ["Floor", "Walls", "Ceiling"] {
        let n = nodes.iter().find(|n| n["name"] == name).unwrap();
        let parts = n["extensions"]["PORTCULLIS_portals"]["parts"].as_array();
        assert!(parts.is_some_and(|p| p.len() >= 4), "{name}: {n}");
    }
    refused_again(&out);
}

#[test]
#[ignore = "minutes: run with --release --ignored"]
fn shared_levels_split_by_cell() {
    for (rel, preset) in [
        ("ericw-tools/testmaps/E1M1-edited-ents.map", None),
        ("freedoom/freedoom2_MAP01.glb", Some("doom")),
        ("freedoom/freedoom1_E3M3.glb", Some("doom")),
    ] {
        if let Some(p) = common::shared(rel) {
            let (parts, triangles) = judged(rel, &p, preset);
            eprintln!("{rel}: {parts} parts, {triangles} triangles");
            assert!(parts > 0, "{rel}");
        }
    }
}
