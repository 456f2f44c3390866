//! `portcullis convert`: annotated glTF that the Khronos validator accepts, whose extension
//! follows its schema, that keeps everything else of the input, byte-identical across runs,
//! and written so that a failure leaves nothing behind.

mod common;

use std::path::{Path, PathBuf};

use assert_cmd::Command;
use base64::Engine;
use common::{fixture, khronos_validate, read_gltf, sample};
use portcullis::schema::{validate, Schema};
use serde_json::{json, Value};

fn portcullis() -> Command {
    let mut c = Command::cargo_bin("portcullis").unwrap();
    c.env("NO_COLOR", "1");
    c
}

fn convert(input: &Path, out: &Path, extra: &[&str]) -> std::process::Output {
    portcullis()
        .arg("convert")
        .arg(input)
        .arg("-o")
        .arg(out)
        .args(extra)
        .output()
        .unwrap()
}

/// The command exited 0; otherwise fail with what it printed.
fn assert_ok(o: &std::process::Output) {
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
}

/// `convert INPUTS... --out-dir DIR`.
fn convert_to_dir(inputs: &[&Path], dir: &Path) -> std::process::Output {
    portcullis()
        .arg("convert")
        .args(inputs)
        .arg("--out-dir")
        .arg(dir)
        .output()
        .unwrap()
}

fn every_input() -> Vec<(PathBuf, Vec<&'static str>)> {
    let mut v: Vec<(PathBuf, Vec<&'static str>)> =
        std::fs::read_dir(common::root().join("samples"))
            .unwrap()
            .flatten()
            .map(|e| e.path())
            .filter(|p| {
                matches!(
                    p.extension().and_then(|e| e.to_str()),
                    Some("gltf" | "obj" | "map")
                )
            })
            .map(|p| (p, vec![]))
            .collect();
    for f in [
        "lportal_tutorial_simple.glb",
        "lportal_tutorial_simple.obj",
        "lportal_boxrooms.glb",
        "lportal_boxrooms.obj",
        "navigation_level_mesh.obj",
        "living_room.glb",
        "occlusion_room.glb",
        "gi_zdm2.glb",
        "pandora.obj",
        "E1M2_godot.glb",
        "MAP01_godot.glb",
    ] {
        v.push((fixture(f), vec![]));
    }
    v.push((fixture("panda3d_culling.glb"), vec!["--tags", "panda3d"]));
    v.push((fixture("panda3d_culling.obj"), vec!["--tags", "panda3d"]));
    v.sort();
    v
}

fn check_extension(doc: &Value, what: &str) {
    let used = doc["extensionsUsed"].as_array().expect("extensionsUsed");
    assert!(used.iter().any(|u| u == "PORTCULLIS_portals"), "{what}");
    assert!(
        doc.get("extensionsRequired").is_none_or(|r| !r
            .as_array()
            .unwrap()
            .iter()
            .any(|u| u == "PORTCULLIS_portals")),
        "{what}: never required"
    );
    let ext = &doc["extensions"]["PORTCULLIS_portals"];
    let errs = validate(Schema::Portals, ext);
    assert!(errs.is_empty(), "{what}: {errs:?}");
    for n in doc["nodes"].as_array().into_iter().flatten() {
        if let Some(e) = n
            .get("extensions")
            .and_then(|e| e.get("PORTCULLIS_portals"))
        {
            let errs = validate(Schema::PortalsNode, e);
            assert!(errs.is_empty(), "{what}: {errs:?}");
        }
    }
    // Internal consistency: indices in range, partners mutual.
    let cells = ext["cells"].as_array().map_or(0, Vec::len);
    let portals = ext["portals"].as_array().cloned().unwrap_or_default();
    for (i, p) in portals.iter().enumerate() {
        for c in p["cells"].as_array().unwrap() {
            assert!((c.as_u64().unwrap() as usize) < cells, "{what}");
        }
        if let Some(j) = p.get("partner").and_then(Value::as_u64) {
            assert_eq!(
                portals[j as usize]["partner"].as_u64(),
                Some(i as u64),
                "{what}: partners mutual"
            );
        }
    }
}

#[test]
fn every_output_validates_and_follows_the_schema() {
    let dir = tempfile::tempdir().unwrap();
    for (input, extra) in every_input() {
        for ext in ["glb", "gltf"] {
            let name = format!("{}.{ext}", input.file_name().unwrap().to_str().unwrap());
            let out = dir.path().join(&name);
            let o = convert(&input, &out, &extra);
            assert!(
                o.status.code() == Some(0) || o.status.code() == Some(1),
                "{name}: {}",
                String::from_utf8_lossy(&o.stderr)
            );
            let (doc, _) = read_gltf(&std::fs::read(&out).unwrap());
            check_extension(&doc, &name);
            // The gltf crate reads it back (our extension is not required).
            gltf::Gltf::from_slice(&std::fs::read(&out).unwrap())
                .unwrap_or_else(|e| panic!("{name}: {e}"));
            if let Some(report) = khronos_validate(&out) {
                assert_eq!(
                    report["issues"]["numErrors"], 0,
                    "{name}: {}",
                    report["issues"]["messages"]
                );
            }
        }
    }
}

/// Every buffer view's bytes, from a document and its buffers.
fn views(doc: &Value, bin: Option<&[u8]>, base: &Path) -> Vec<Vec<u8>> {
    let buffers: Vec<Vec<u8>> = doc["buffers"]
        .as_array()
        .into_iter()
        .flatten()
        .map(|b| match b.get("uri").and_then(Value::as_str) {
            Some(u) if u.starts_with("data:") => {
                let data = u.split_once(',').unwrap().1;
                base64::engine::general_purpose::STANDARD
                    .decode(data)
                    .unwrap()
            }
            Some(u) => std::fs::read(base.join(u)).unwrap(),
            None => bin.unwrap().to_vec(),
        })
        .collect();
    doc["bufferViews"]
        .as_array()
        .into_iter()
        .flatten()
        .map(|v| {
            let b = &buffers[v["buffer"].as_u64().unwrap() as usize];
            let off = v.get("byteOffset").and_then(Value::as_u64).unwrap_or(0) as usize;
            let len = v["byteLength"].as_u64().unwrap() as usize;
            b[off..off + len].to_vec()
        })
        .collect()
}

/// The document without what convert may change: our extension (and what it appends last:
/// the buffer view of its visibility, the accessor and view of its split indices),
/// extensionsUsed, and the buffer plumbing (buffer URIs, buffer views' buffer and offset).
fn comparable(doc: &Value) -> Value {
    let mut d = doc.clone();
    let ours = |p: &str| {
        d.pointer(&format!("/extensions/PORTCULLIS_portals/{p}"))?
            .as_u64()
    };
    let (pvs, split) = (ours("visibility/bufferView"), ours("split/indices"));
    let o = d.as_object_mut().unwrap();
    let mut appended = pvs.into_iter().count();
    if let Some(a) = split {
        let acc = o["accessors"].as_array_mut().unwrap();
        assert_eq!(
            a as usize,
            acc.len() - 1,
            "the split indices' accessor comes last"
        );
        acc.pop();
        if acc.is_empty() {
            o.remove("accessors");
        }
        appended += 1;
    }
    if appended > 0 {
        let vs = o["bufferViews"].as_array_mut().unwrap();
        if let Some(k) = pvs {
            assert_eq!(
                k as usize,
                vs.len() - appended,
                "the visibility's view comes first of ours"
            );
        }
        vs.truncate(vs.len() - appended);
        if vs.is_empty() {
            o.remove("bufferViews");
        }
    }
    o.remove("extensionsUsed");
    if let Some(e) = o.get_mut("extensions").and_then(Value::as_object_mut) {
        e.remove("PORTCULLIS_portals");
        if e.is_empty() {
            o.remove("extensions");
        }
    }
    o.remove("buffers");
    if let Some(vs) = o.get_mut("bufferViews").and_then(Value::as_array_mut) {
        for v in vs {
            let v = v.as_object_mut().unwrap();
            v.remove("buffer");
            v.remove("byteOffset");
        }
    }
    if let Some(ns) = o.get_mut("nodes").and_then(Value::as_array_mut) {
        for n in ns {
            let n = n.as_object_mut().unwrap();
            if let Some(e) = n.get_mut("extensions").and_then(Value::as_object_mut) {
                e.remove("PORTCULLIS_portals");
                if e.is_empty() {
                    n.remove("extensions");
                }
            }
        }
    }
    d
}

fn assert_round_trip(input: &Path, extra: &[&str]) {
    let dir = tempfile::tempdir().unwrap();
    let bytes = std::fs::read(input).unwrap();
    let (doc_in, bin_in) = read_gltf(&bytes);
    let views_in = views(&doc_in, bin_in.as_deref(), input.parent().unwrap());
    for ext in ["glb", "gltf"] {
        let out = dir.path().join(format!("out.{ext}"));
        let o = convert(input, &out, extra);
        assert!(
            o.status.code().unwrap() <= 1,
            "{}",
            String::from_utf8_lossy(&o.stderr)
        );
        let (doc_out, bin_out) = read_gltf(&std::fs::read(&out).unwrap());
        assert_eq!(
            comparable(&doc_in),
            comparable(&doc_out),
            "{} -> {ext}",
            input.display()
        );
        let mut views_out = views(&doc_out, bin_out.as_deref(), dir.path());
        views_out.truncate(views_in.len());
        assert_eq!(views_in, views_out, "{} -> {ext}: data", input.display());
        if let Some(report) = khronos_validate(&out) {
            assert_eq!(
                report["issues"]["numErrors"], 0,
                "{}",
                report["issues"]["messages"]
            );
        }
    }
    assert_eq!(
        std::fs::read(input).unwrap(),
        bytes,
        "the input is never modified"
    );
}

#[test]
fn round_trip_keeps_everything_of_the_third_party_glbs() {
    for f in [
        "lportal_tutorial_simple.glb",
        "lportal_boxrooms.glb",
        "living_room.glb",
        "occlusion_room.glb",
        "gi_zdm2.glb",
    ] {
        assert_round_trip(&fixture(f), &[]);
    }
    assert_round_trip(&fixture("panda3d_culling.glb"), &["--tags", "panda3d"]);
}

/// A level with an animation, a skin, a textured material, a camera, a light extension and
/// extras: all of it survives.
#[test]
fn round_trip_keeps_animations_skins_textures_and_extensions() {
    let mut bin: Vec<u8> = Vec::new();
    let f = |bin: &mut Vec<u8>, xs: &[f32]| {
        xs.iter()
            .for_each(|x| bin.extend_from_slice(&x.to_le_bytes()))
    };
    f(&mut bin, &[0., 0., 0., 1., 0., 0., 0., 1., 0.]); // positions: 36 bytes
    f(&mut bin, &[0., 0., 1., 0., 0., 1.]); // uv: 24
    bin.extend_from_slice(&[0u8; 12]); // joints (u8 x4 x3): 12
    f(&mut bin, &[1., 0., 0., 0., 1., 0., 0., 0., 1., 0., 0., 0.]); // weights: 48
    f(
        &mut bin,
        &[
            1., 0., 0., 0., 0., 1., 0., 0., 0., 0., 1., 0., 0., 0., 0., 1.,
        ],
    ); // inverse bind: 64
    f(&mut bin, &[0., 1.]); // times: 8
    f(&mut bin, &[0., 0., 0., 0., 1., 0.]); // translations: 24
    let png = base64::engine::general_purpose::STANDARD.decode(
        "iVBORw0KGgoAAAANSUhEUgAAAAEAAAABCAYAAAAfFcSJAAAADUlEQVR4nGP4z8DwHwAFAAH/iZk9HQAAAABJRU5ErkJggg==",
    ).unwrap();
    let uri = format!(
        "data:application/octet-stream;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(&bin)
    );
    let doc = json!({
        "asset": {"version": "2.0", "extras": {"author": "test"}},
        "extensionsUsed": ["KHR_lights_punctual", "VENDOR_custom"],
        "extensions": {"KHR_lights_punctual": {"lights": [{"type": "point", "color": [1, 0.5, 0.2]}]}},
        "scene": 0,
        "scenes": [{"nodes": [0, 1, 2, 3]}],
        "nodes": [
            {"name": "skinned", "mesh": 0, "skin": 0, "extras": {"note": "a prop: one triangle is no room"}},
            {"name": "joint", "translation": [0, 0, 0]},
            {"name": "cam", "camera": 0, "extensions": {"VENDOR_custom": {"x": 1}}},
            {"name": "lamp", "extensions": {"KHR_lights_punctual": {"light": 0}}}
        ],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "TEXCOORD_0": 1, "JOINTS_0": 2, "WEIGHTS_0": 3}, "material": 0}]}],
        "skins": [{"joints": [1], "inverseBindMatrices": 4}],
        "animations": [{"channels": [{"sampler": 0, "target": {"node": 1, "path": "translation"}}],
                        "samplers": [{"input": 5, "output": 6}]}],
        "cameras": [{"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.1}}],
        "materials": [{"name": "painted", "pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}],
        "textures": [{"source": 0, "sampler": 0}],
        "samplers": [{"magFilter": 9729}],
        "images": [{"uri": format!("data:image/png;base64,{}", base64::engine::general_purpose::STANDARD.encode(&png))}],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]},
            {"bufferView": 1, "componentType": 5126, "count": 3, "type": "VEC2"},
            {"bufferView": 2, "componentType": 5121, "count": 3, "type": "VEC4"},
            {"bufferView": 3, "componentType": 5126, "count": 3, "type": "VEC4"},
            {"bufferView": 4, "componentType": 5126, "count": 1, "type": "MAT4"},
            {"bufferView": 5, "componentType": 5126, "count": 2, "type": "SCALAR", "min": [0], "max": [1]},
            {"bufferView": 6, "componentType": 5126, "count": 2, "type": "VEC3"}
        ],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 36},
            {"buffer": 0, "byteOffset": 36, "byteLength": 24},
            {"buffer": 0, "byteOffset": 60, "byteLength": 12},
            {"buffer": 0, "byteOffset": 72, "byteLength": 48},
            {"buffer": 0, "byteOffset": 120, "byteLength": 64},
            {"buffer": 0, "byteOffset": 184, "byteLength": 8},
            {"buffer": 0, "byteOffset": 192, "byteLength": 24}
        ],
        "buffers": [{"byteLength": bin.len(), "uri": uri}]
    });
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("rich.gltf");
    std::fs::write(&input, serde_json::to_vec_pretty(&doc).unwrap()).unwrap();
    assert_round_trip(&input, &[]);
}

/// A file converted again (its own output as input, as `--in-place` on a converted file
/// does) comes out byte for byte as it went in: the earlier annotation's appended views,
/// accessor and bytes are dropped, not kept beside the new ones.
#[test]
fn converting_an_output_again_gives_the_same_bytes() {
    let dir = tempfile::tempdir().unwrap();
    let mut judged = 0;
    for (input, extra) in every_input() {
        if input.extension().is_some_and(|e| e == "map" || e == "obj") {
            continue;
        }
        for ext in ["glb", "gltf"] {
            let (a, b) = (
                dir.path().join(format!("a.{ext}")),
                dir.path().join(format!("b.{ext}")),
            );
            let o = convert(&input, &a, &extra);
            if o.status.code() != Some(0) {
                continue;
            }
            let o = convert(&a, &b, &extra);
            assert_ok(&o);
            assert!(
                std::fs::read(&a).unwrap() == std::fs::read(&b).unwrap(),
                "{} -> {ext}: converting the output again changed it",
                input.display()
            );
            let copy = dir.path().join(format!("c.{ext}"));
            std::fs::copy(&a, &copy).unwrap();
            let o = portcullis()
                .arg("convert")
                .arg(&copy)
                .arg("--in-place")
                .args(&extra)
                .output()
                .unwrap();
            assert_ok(&o);
            assert!(
                std::fs::read(&a).unwrap() == std::fs::read(&copy).unwrap(),
                "{} -> {ext}: --in-place",
                input.display()
            );
            judged += 1;
        }
    }
    assert!(judged >= 20, "only {judged} conversions judged");
}

#[test]
fn output_is_byte_identical_across_runs() {
    let dir = tempfile::tempdir().unwrap();
    for (input, extra) in [
        (fixture("lportal_boxrooms.glb"), vec![]),
        (fixture("panda3d_culling.obj"), vec!["--tags", "panda3d"]),
        (sample("l_room.gltf"), vec![]),
    ] {
        let a = dir.path().join("a.glb");
        let b = dir.path().join("b.glb");
        let mut c = portcullis();
        c.env("RAYON_NUM_THREADS", "2")
            .arg("convert")
            .arg(&input)
            .arg("-o")
            .arg(&a)
            .args(&extra);
        c.output().unwrap();
        let mut c = portcullis();
        c.env("RAYON_NUM_THREADS", "1")
            .arg("convert")
            .arg(&input)
            .arg("-o")
            .arg(&b)
            .args(&extra);
        c.output().unwrap();
        assert_eq!(
            std::fs::read(&a).unwrap(),
            std::fs::read(&b).unwrap(),
            "{}",
            input.display()
        );
    }
}

#[test]
fn inputs_are_never_overwritten_and_failures_leave_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("level.gltf");
    std::fs::copy(sample("two_rooms.gltf"), &input).unwrap();
    let before = std::fs::read(&input).unwrap();
    let o = convert(&input, &input, &[]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("OUTPUT_WOULD_OVERWRITE_INPUT"));
    assert_eq!(std::fs::read(&input).unwrap(), before);
    // A folder that does not exist: exit 2, nothing written anywhere.
    let o = convert(&input, &dir.path().join("missing/out.glb"), &[]);
    assert_eq!(o.status.code(), Some(2));
    // An output path that is a folder: the write fails after the temporary was made.
    let blocked = dir.path().join("blocked.glb");
    std::fs::create_dir(&blocked).unwrap();
    std::fs::write(blocked.join("keep"), b"x").unwrap();
    let o = convert(&input, &blocked, &[]);
    assert_eq!(o.status.code(), Some(2));
    let names: Vec<String> = std::fs::read_dir(dir.path())
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(
        names.len(),
        2,
        "only the input and the folder remain: {names:?}"
    );
    // --in-place replaces the input by its annotated version.
    let o = portcullis()
        .arg("convert")
        .arg(&input)
        .arg("--in-place")
        .output()
        .unwrap();
    assert_ok(&o);
    let (doc, _) = read_gltf(&std::fs::read(&input).unwrap());
    check_extension(&doc, "in place");
    // Converting the annotated file again gives the same file (the old annotation is replaced).
    let again = dir.path().join("again.gltf");
    convert(&input, &again, &[]);
    let (doc2, _) = read_gltf(&std::fs::read(&again).unwrap());
    assert_eq!(doc, doc2);
}

#[test]
fn out_dir_converts_many_files() {
    let dir = tempfile::tempdir().unwrap();
    let o = convert_to_dir(
        &[&sample("two_rooms.gltf"), &sample("l_room.gltf")],
        dir.path(),
    );
    assert_ok(&o);
    assert!(dir.path().join("two_rooms.glb").is_file() && dir.path().join("l_room.glb").is_file());
}

/// Convert, read the annotation back, and compare with the level computed in memory.
#[test]
fn the_annotation_reads_back_as_the_same_level() {
    use portcullis::pipeline::{build_cells, build_portals, load_tagged, LoadOptions};
    let dir = tempfile::tempdir().unwrap();
    for (input, preset) in [
        (fixture("lportal_boxrooms.glb"), None),
        (fixture("panda3d_culling.glb"), Some("panda3d")),
        (sample("l_room.gltf"), None),
        (sample("mirror.gltf"), None),
    ] {
        let out = dir.path().join("out.glb");
        let mut args = vec![];
        if let Some(p) = preset {
            args = vec!["--tags", p];
        }
        convert(&input, &out, &args);
        let (doc, _) = read_gltf(&std::fs::read(&out).unwrap());
        let a = portcullis::format::read::annotation(&doc)
            .expect("annotated")
            .expect("parses");
        let nodes = doc["nodes"].as_array().unwrap().len();
        assert!(portcullis::format::read::consistency(&a, nodes).is_empty());
        // The records read and write one format: serialized again, the annotation read back
        // is the annotation written (names, order, what is left out, every number).
        let ext = &doc["extensions"]["PORTCULLIS_portals"];
        assert_eq!(
            &serde_json::to_value(&a).unwrap(),
            ext,
            "{}",
            input.display()
        );
        assert_eq!(
            serde_json::to_string(&a).unwrap(),
            serde_json::to_string(ext).unwrap()
        );
        let mut t = load_tagged(
            &input,
            &LoadOptions {
                preset: preset.map(str::to_string),
                ..Default::default()
            },
        )
        .unwrap();
        let cells = build_cells(&mut t);
        let portals = build_portals(&mut t, &cells);
        assert_eq!(a.cells.len(), cells.cells.len());
        for (r, c) in a.cells.iter().zip(&cells.cells) {
            assert_eq!(r.room, t.tagging.rooms[c.room].name);
            assert_eq!(r.planes.len(), c.poly.faces.len());
            for (p, f) in r.planes.iter().zip(&c.poly.faces) {
                let n = f.plane.normal;
                for (x, y) in p.iter().zip([n.x, n.y, n.z, f.plane.d]) {
                    assert!((x - y).abs() <= 1e-9);
                }
            }
        }
        assert_eq!(a.portals.len(), portals.portals.len());
        for (r, p) in a.portals.iter().zip(&portals.portals) {
            assert_eq!((r.from(), r.to()), (p.from, p.to));
            assert_eq!(
                (r.one_way, r.closed, r.internal, r.partner),
                (p.one_way, p.closed, p.internal, p.partner)
            );
            assert_eq!(r.transform.is_some(), p.transform.is_some());
            for (x, y) in r.polygon.iter().zip(&p.polygon) {
                assert!((glam::DVec3::from_array(*x) - *y).length() <= 2e-9);
            }
        }
    }
}

/// `inspect` on an annotated file summarises the annotation; `--validate` checks it, and a
/// changed level makes it stale.
#[test]
fn inspect_summarises_and_validates_annotations() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("a.gltf");
    convert(&sample("two_rooms.gltf"), &out, &[]);
    let inspect = |p: &Path| {
        let o = portcullis()
            .arg("inspect")
            .arg(p)
            .args(["--validate", "--format", "json"])
            .output()
            .unwrap();
        (
            o.status.code().unwrap(),
            serde_json::from_slice::<Value>(&o.stdout).unwrap(),
        )
    };
    let (code, v) = inspect(&out);
    assert_eq!(code, 0);
    assert_eq!(v["files"][0]["annotation"]["cells"], 2);
    assert_eq!(v["files"][0]["annotation"]["stale"], false);
    // Break a partner index: invalid.
    let mut doc: Value = serde_json::from_slice(&std::fs::read(&out).unwrap()).unwrap();
    doc["extensions"]["PORTCULLIS_portals"]["portals"][0]["partner"] = json!(0);
    let bad = dir.path().join("bad.gltf");
    std::fs::write(&bad, serde_json::to_vec(&doc).unwrap()).unwrap();
    let (code, v) = inspect(&bad);
    assert_eq!(code, 1);
    assert!(v["files"][0]["diagnostics"]
        .as_array()
        .unwrap()
        .iter()
        .any(|d| d["code"] == "ANNOTATION_INVALID"));
    // Move a node: the annotation is stale.
    let mut doc: Value = serde_json::from_slice(&std::fs::read(&out).unwrap()).unwrap();
    doc["nodes"][0]["translation"] = json!([0.5, 0, 0]);
    let moved = dir.path().join("moved.gltf");
    std::fs::write(&moved, serde_json::to_vec(&doc).unwrap()).unwrap();
    let (_, v) = inspect(&moved);
    assert_eq!(v["files"][0]["annotation"]["stale"], true);
}

/// `-` reads standard input and writes standard output, for pipes after an exporter.
#[test]
fn pipes_in_and_out() {
    for (input, fmt) in [
        (sample("two_rooms.gltf"), "glb"),
        (sample("two_rooms.obj"), "gltf"),
        (fixture("lportal_boxrooms.glb"), "glb"),
    ] {
        let o = common::succeeds(
            portcullis()
                .args(["convert", "-", "-o", "-", "--out-format", fmt])
                .write_stdin(std::fs::read(&input).unwrap()),
        );
        let (doc, _) = read_gltf(&o.stdout);
        check_extension(&doc, &input.display().to_string());
        assert_eq!(o.stdout.starts_with(b"glTF"), fmt == "glb");
        let cells = doc["extensions"]["PORTCULLIS_portals"]["cells"]
            .as_array()
            .unwrap()
            .len();
        assert!(cells >= 2);
    }
}

fn has_empty_array(v: &Value, at: &str) -> Option<String> {
    match v {
        Value::Array(a) if a.is_empty() => Some(at.to_string()),
        Value::Array(a) => a
            .iter()
            .enumerate()
            .find_map(|(i, x)| has_empty_array(x, &format!("{at}/{i}"))),
        Value::Object(o) => o
            .iter()
            .find_map(|(k, x)| has_empty_array(x, &format!("{at}/{k}"))),
        _ => None,
    }
}

/// The extension leaves out what a level does not need, each rule checked.
#[test]
fn the_extension_leaves_out_what_is_not_needed() {
    let dir = tempfile::tempdir().unwrap();
    let ext_of = |input: &Path| -> Value {
        let out = dir.path().join("x.gltf");
        convert(input, &out, &[]);
        let (doc, _) = read_gltf(&std::fs::read(&out).unwrap());
        doc["extensions"]["PORTCULLIS_portals"].clone()
    };
    // Every room one cell: no rooms array. Plain portals: no transform, no kind, no flags.
    let e = ext_of(&sample("two_rooms.gltf"));
    assert!(e.get("rooms").is_none());
    for p in e["portals"].as_array().unwrap() {
        for key in ["transform", "kind", "oneWay", "closed", "internal"] {
            assert!(p.get(key).is_none(), "{key} on a plain portal: {p}");
        }
    }
    // A split room: the rooms array lists its cells, and its internal portals say so.
    let e = ext_of(&sample("l_room.gltf"));
    assert_eq!(e["rooms"][0]["cells"], json!([0, 1]));
    assert!(e["portals"]
        .as_array()
        .unwrap()
        .iter()
        .any(|p| p["internal"] == true));
    // Only a mirror carries a transform.
    let e = ext_of(&sample("mirror.gltf"));
    for p in e["portals"].as_array().unwrap() {
        assert_eq!(
            p.get("transform").is_some(),
            p.get("kind") == Some(&json!("mirror"))
        );
    }
    // A level without rooms: no cells, no portals, and never an empty array.
    let e = ext_of(&fixture("navigation_level_mesh.obj"));
    assert!(e.get("cells").is_none() && e.get("portals").is_none());
    for input in [
        sample("two_rooms.gltf"),
        sample("l_room.gltf"),
        fixture("navigation_level_mesh.obj"),
        fixture("lportal_boxrooms.glb"),
    ] {
        assert_eq!(
            has_empty_array(&ext_of(&input), ""),
            None,
            "{}",
            input.display()
        );
    }
}

/// Overlapping rooms are reported, and the debug output draws where they overlap.
#[test]
fn overlaps_are_reported_and_drawn() {
    let dir = tempfile::tempdir().unwrap();
    let mut doc: Value =
        serde_json::from_slice(&std::fs::read(sample("bound_boxes.gltf")).unwrap()).unwrap();
    let nodes = doc["nodes"].as_array_mut().unwrap();
    let lounge = nodes
        .iter_mut()
        .find(|n| n["name"] == "lounge-cell")
        .unwrap();
    lounge["translation"] = json!([-1.0, 0.0, 0.0]);
    let input = dir.path().join("overlap.gltf");
    std::fs::write(&input, serde_json::to_vec(&doc).unwrap()).unwrap();
    let debug = dir.path().join("debug.glb");
    let o = convert(
        &input,
        &dir.path().join("out.glb"),
        &["--debug", debug.to_str().unwrap()],
    );
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("CELL_OVERLAP") && err.contains("12.0000 m³"),
        "{err}"
    );
    let g = gltf::Gltf::from_slice(&std::fs::read(&debug).unwrap()).unwrap();
    assert!(g
        .document
        .nodes()
        .any(|n| n.name().is_some_and(|s| s.starts_with("overlap"))));
}

/// A quoted glob is expanded by portcullis itself.
#[test]
fn globs_are_expanded() {
    let dir = tempfile::tempdir().unwrap();
    let pattern = common::root().join("samples/*_room.gltf");
    let o = convert_to_dir(&[&pattern], dir.path());
    assert_ok(&o);
    for n in ["l_room.glb", "u_room.glb", "pillar_room.glb"] {
        assert!(dir.path().join(n).is_file(), "{n}");
    }
}

/// With a PVS through mirrors or teleporters, convert says how far sightlines were followed
/// (as `vis` does); without a PVS, or without transformed portals, it says nothing of it.
#[test]
fn convert_notes_the_transform_depth_of_the_pvs() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("o.glb");
    let note = "VIS_TRANSFORM_DEPTH";
    let stderr = |o: &std::process::Output| String::from_utf8_lossy(&o.stderr).into_owned();
    let o = convert(&sample("teleporter.gltf"), &out, &["--vis", "full"]);
    assert_ok(&o);
    assert!(stderr(&o).contains(note), "{}", stderr(&o));
    let o = convert(&sample("teleporter.gltf"), &out, &["--vis", "none"]);
    assert_ok(&o);
    assert!(!stderr(&o).contains(note), "{}", stderr(&o));
    let o = convert(&sample("two_rooms.gltf"), &out, &["--vis", "full"]);
    assert_ok(&o);
    assert!(!stderr(&o).contains(note), "{}", stderr(&o));
}

/// A .glb read from a file lets its BIN chunk go after import and writes it back from the
/// file: the output is the same as from the bytes held in memory, and a file changed in the
/// meantime is an error with nothing written, never a mix of old and new.
#[test]
fn a_released_bin_chunk_is_read_back_from_an_unchanged_file_only() {
    use portcullis::export::output::{self, Output};
    use portcullis::export::Target;
    use portcullis::pipeline;
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("level.glb");
    std::fs::copy(fixture("lportal_boxrooms.glb"), &input).unwrap();
    let bytes = std::fs::read(&input).unwrap();
    let run = |t: pipeline::Tagged, out: &Path, target| {
        output::level(&pipeline::build(t), None, &Output::file(out, target))
    };
    for format in [Target::Glb, Target::Gltf] {
        let out = dir.path().join(match format {
            Target::Glb => "out.glb",
            _ => "out.gltf",
        });
        let from_file = pipeline::load_tagged(&input, &Default::default()).unwrap();
        let src = from_file.scene.gltf.as_ref().unwrap();
        assert!(
            src.bin_file.as_ref().is_some_and(|b| b.released) && src.buffers[0].is_empty(),
            "the BIN chunk was not let go"
        );
        run(from_file, &out, format).unwrap();
        let released = std::fs::read(&out).unwrap();
        // The same level from bytes in memory keeps its buffers.
        let imported = portcullis::import::import_bytes(
            &bytes,
            &input,
            portcullis::scene::Format::Glb,
            dir.path(),
            &Default::default(),
        )
        .unwrap();
        assert!(!imported.scene.gltf.as_ref().unwrap().buffers[0].is_empty());
        let held = {
            let mut t = pipeline::load_tagged(&input, &Default::default()).unwrap();
            t.scene.gltf = imported.scene.gltf.clone();
            output::level(&pipeline::build(t), None, &Output::memory(&out, format)).unwrap()
        };
        assert!(released == held, "{format:?}: bytes differ");
    }
    // Changed after import: the export fails and leaves no output.
    let t = pipeline::load_tagged(&input, &Default::default()).unwrap();
    let mut changed = bytes.clone();
    changed.extend_from_slice(&[0; 4]);
    std::fs::write(&input, &changed).unwrap();
    let out = dir.path().join("changed.glb");
    let err = run(t, &out, Target::Glb).unwrap_err();
    assert!(
        err.message.contains("changed while it was being converted"),
        "{}",
        err.message
    );
    assert!(!out.exists());
    let left: Vec<_> = std::fs::read_dir(dir.path()).unwrap().flatten().collect();
    assert!(left
        .iter()
        .all(|e| !e.file_name().to_string_lossy().ends_with(".tmp")));
}

/// A level's JSON text is let go once parsed and read back from the file for the export: the
/// output is the same as from the text held in memory, and a text changed in the meantime,
/// even to one of the same length, is an error with nothing written.
#[test]
fn a_released_json_text_is_read_back_from_an_unchanged_file_only() {
    use portcullis::export::output::{self, Output};
    use portcullis::export::Target;
    use portcullis::pipeline;
    let dir = tempfile::tempdir().unwrap();
    let run = |t: pipeline::Tagged, out: &Path| {
        output::level(&pipeline::build(t), None, &Output::file(out, Target::Glb))
    };
    for (from, name) in [
        (sample("door_window.gltf"), "level.gltf"),
        (fixture("lportal_boxrooms.glb"), "level.glb"),
    ] {
        let input = dir.path().join(name);
        std::fs::copy(&from, &input).unwrap();
        let bytes = std::fs::read(&input).unwrap();
        let out = dir.path().join("out.glb");
        let from_file = pipeline::load_tagged(&input, &Default::default()).unwrap();
        run(from_file, &out).unwrap();
        let released = std::fs::read(&out).unwrap();
        let imported = portcullis::import::import_bytes(
            &bytes,
            &input,
            portcullis::import::sniff_format(&bytes).unwrap(),
            dir.path(),
            &Default::default(),
        )
        .unwrap();
        let held = {
            let mut t = pipeline::load_tagged(&input, &Default::default()).unwrap();
            t.scene.gltf = imported.scene.gltf.clone();
            output::level(
                &pipeline::build(t),
                None,
                &Output::memory(&out, Target::Glb),
            )
            .unwrap()
        };
        assert!(released == held, "{name}: bytes differ");

        // One letter of the text changed after import, the length kept.
        let t = pipeline::load_tagged(&input, &Default::default()).unwrap();
        let at = bytes.windows(7).position(|w| w == b"\"asset\"").unwrap() + 1;
        let mut changed = bytes.clone();
        changed[at] = b'A';
        std::fs::write(&input, &changed).unwrap();
        let out = dir.path().join("changed.glb");
        let err = run(t, &out).unwrap_err();
        assert!(
            err.message.contains("changed while it was being converted"),
            "{name}: {}",
            err.message
        );
        assert!(!out.exists(), "{name}");
        let left: Vec<_> = std::fs::read_dir(dir.path()).unwrap().flatten().collect();
        assert!(left
            .iter()
            .all(|e| !e.file_name().to_string_lossy().ends_with(".tmp")));
    }
}

/// Issue 29, item 11: a file that failed while being written is not reported as unreadable.
#[test]
fn a_failed_output_is_not_called_unreadable() {
    let dir = tempfile::tempdir().unwrap();
    // A folder where the file should go: the arguments check out, the write fails.
    let out = dir.path().join("out.glb");
    std::fs::create_dir(&out).unwrap();
    let o = convert(&sample("two_rooms.gltf"), &out, &[]);
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("OUTPUT_FAILED"), "{err}");
    assert!(err.contains("1 could not be processed"), "{err}");
    assert!(!err.contains("could not be read"), "{err}");
    assert!(out.is_dir());
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
}

/// Issue 29, item 8: a room's priority (extras `priority`, for nested rooms) is stored on its
/// cells, which the schema accepts and the runtime reads; with every room at the default it
/// is left out.
#[test]
fn room_priority_is_stored_on_the_cells_when_set() {
    let dir = tempfile::tempdir().unwrap();
    let mut doc: Value =
        serde_json::from_slice(&std::fs::read(sample("two_rooms.gltf")).unwrap()).unwrap();
    let plain = dir.path().join("plain.gltf");
    assert_ok(&convert(&sample("two_rooms.gltf"), &plain, &[]));
    let (out, _) = read_gltf(&std::fs::read(&plain).unwrap());
    check_extension(&out, "plain");
    assert!(!serde_json::to_string(&out["extensions"])
        .unwrap()
        .contains("\"priority\""));

    let kitchen = doc["nodes"]
        .as_array()
        .unwrap()
        .iter()
        .position(|n| n["name"] == "kitchen-room")
        .unwrap();
    doc["nodes"][kitchen]["extras"] = json!({"priority": 3});
    let input = dir.path().join("ranked.gltf");
    std::fs::write(&input, serde_json::to_vec(&doc).unwrap()).unwrap();
    let ranked = dir.path().join("ranked.glb");
    assert_ok(&convert(&input, &ranked, &[]));
    let (out, _) = read_gltf(&std::fs::read(&ranked).unwrap());
    check_extension(&out, "ranked");
    for c in out["extensions"]["PORTCULLIS_portals"]["cells"]
        .as_array()
        .unwrap()
    {
        let want = if c["room"] == "kitchen" {
            json!(3)
        } else {
            Value::Null
        };
        assert_eq!(c["priority"], want, "{c}");
    }
    portcullis::runtime::Level::load(&ranked).expect("the runtime reads it");
}
