//! ericw-tools' `testmaps/` (GPL, not shipped here: `../shared/levels/ericw-tools/testmaps`
//! beside the project, or `ERICW_TESTMAPS`), and brush maps turned into plain glTF levels.

use std::path::{Path, PathBuf};

use serde_json::Value;

/// The testmaps folder: `ERICW_TESTMAPS`, else the shared copy beside the project.
pub fn dir() -> PathBuf {
    std::env::var_os("ERICW_TESTMAPS")
        .map(PathBuf::from)
        .unwrap_or_else(|| {
            Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/levels/ericw-tools/testmaps")
        })
}

/// What a brush-map benchmark runs on: the maps folder and the `.map` names given on the
/// command line (E1M1 and qbspfeatures by default); `None`, said why, without the folder.
pub fn maps_to_bench() -> Option<(PathBuf, Vec<String>)> {
    let dir = dir();
    if !dir.is_dir() {
        eprintln!("set ERICW_TESTMAPS to ericw-tools' testmaps folder (the maps are not shipped)");
        return None;
    }
    let mut maps: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| a.ends_with(".map"))
        .collect();
    if maps.is_empty() {
        maps = vec!["E1M1-edited-ents.map".into(), "qbspfeatures.map".into()];
    }
    Some((dir, maps))
}

/// Writes `portcullis.toml` in `dir` with `[cells] detect_props = false`: a brush map has no
/// props (qbsp reads every world brush as structure, and the map says what is detail), and
/// the same brushes as untagged glTF or OBJ say so for the whole level.
pub fn no_props(dir: &Path) {
    std::fs::write(
        dir.join("portcullis.toml"),
        "[cells]\ndetect_props = false\n",
    )
    .unwrap();
}

/// A brush map written as the glTF level a DCC exporter would give of it, in `out`: one room
/// of closed meshes (the world brushes, no `solid` or `structure` tag), detail, doors and area
/// portals tagged as the importer tags them, the map's entities as nodes with their keys
/// (`player_start`, `occupant`); no portcullis annotation. Positions are f32, as in any
/// glTF.
pub fn as_plain_gltf(map: &Path, out: &Path) -> PathBuf {
    let converted = out.join("converted.gltf");
    portcullis::pipeline::convert_file(map, &converted)
        .unwrap_or_else(|d| panic!("{}: {d}", map.display()));
    let mut doc: Value = serde_json::from_slice(&std::fs::read(&converted).unwrap()).unwrap();
    if let Some(ext) = doc.get_mut("extensions").and_then(Value::as_object_mut) {
        ext.remove("PORTCULLIS_portals");
    }
    if let Some(used) = doc.get_mut("extensionsUsed").and_then(Value::as_array_mut) {
        used.retain(|e| e != "PORTCULLIS_portals");
    }
    for n in doc["nodes"].as_array_mut().unwrap() {
        if let Some(ext) = n.get_mut("extensions").and_then(Value::as_object_mut) {
            ext.remove("PORTCULLIS_portals");
        }
        if let Some(e) = n.get_mut("extras").and_then(Value::as_object_mut) {
            e.remove("solid");
            e.remove("structure");
        }
    }
    let name = map.file_stem().unwrap().to_string_lossy().to_string() + ".gltf";
    let path = out.join(name);
    std::fs::write(&path, serde_json::to_vec(&doc).unwrap()).unwrap();
    path
}

/// A brush map written as an OBJ a DCC tool would export of it, in `out`: every brush an
/// object under `world-room/` (`-detail`, `-ignore` by the importer's reading of it), every
/// entity with a place a small tetrahedron `NAME-occupant` where it stands. Positions are
/// written as f64 decimals.
pub fn as_obj(map: &Path, out: &Path) -> PathBuf {
    use std::fmt::Write;
    let bytes = std::fs::read(map).unwrap();
    let im = portcullis::import::import_bytes(
        &bytes,
        map,
        portcullis::scene::Format::Map,
        map.parent().unwrap(),
        &portcullis::import::ImportOptions::default(),
    )
    .unwrap_or_else(|d| panic!("{}: {d}", map.display()));
    let scene = &im.scene;
    let flag = |n: usize, key: &str| {
        scene.nodes[n]
            .extras
            .as_ref()
            .and_then(|e| e.get(key))
            .and_then(Value::as_bool)
            .unwrap_or(false)
    };
    let mut text = String::new();
    let mut next = 1usize;
    for n in 0..scene.nodes.len() {
        let mut corners: Vec<glam::DVec3> = Vec::new();
        let mut faces: Vec<[usize; 3]> = Vec::new();
        let name = if scene.nodes[n].mesh.is_some() {
            let suffix = if flag(n, "ignore") {
                "-ignore"
            } else if flag(n, "detail") {
                "-detail"
            } else {
                ""
            };
            let m = &scene.meshes[scene.nodes[n].mesh.unwrap()];
            corners = scene.world_positions(n);
            faces = m.triangles.iter().map(|t| t.map(|i| i as usize)).collect();
            // The importer's name, so the brushes come in the same canonical order.
            let name = scene.nodes[n].name.clone().unwrap_or_default();
            format!("world-room/{name}{suffix}")
        } else if flag(n, "occupant") || flag(n, "player_start") {
            // A tetrahedron whose box is centred on the entity: where the OBJ's marker stands.
            let p = scene.place(n);
            let e = 0.01;
            corners = [
                (1.0, 1.0, 1.0),
                (1.0, -1.0, -1.0),
                (-1.0, 1.0, -1.0),
                (-1.0, -1.0, 1.0),
            ]
            .map(|(x, y, z)| p + glam::DVec3::new(x, y, z) * e)
            .to_vec();
            faces = vec![[0, 1, 2], [0, 3, 1], [0, 2, 3], [1, 3, 2]];
            format!("entity_{n}-occupant")
        } else {
            String::new()
        };
        if corners.is_empty() {
            continue;
        }
        writeln!(text, "o {name}").unwrap();
        for p in &corners {
            writeln!(text, "v {} {} {}", p.x, p.y, p.z).unwrap();
        }
        for f in &faces {
            writeln!(text, "f {} {} {}", f[0] + next, f[1] + next, f[2] + next).unwrap();
        }
        next += corners.len();
    }
    let path = out.join(map.file_stem().unwrap().to_string_lossy().to_string() + ".obj");
    std::fs::write(&path, text).unwrap();
    path
}
