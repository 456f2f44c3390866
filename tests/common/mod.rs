//! Helpers shared by the integration tests: tiny glTF levels built in code, so each test says
//! exactly which names, extras and materials it is about.
#![allow(dead_code)]

pub mod blocks;
pub mod grid;
pub mod plain;
pub mod rays;
/// The crate's own generator (crate-private there), so seeded cases repeat its sequences.
#[path = "../../src/rng.rs"]
pub mod rng;
pub mod testmaps;

use std::path::{Path, PathBuf};

use base64::Engine;
use serde_json::{json, Value};

pub fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

pub fn fixture(name: &str) -> PathBuf {
    root().join("tests/fixtures/third_party").join(name)
}

pub fn sample(name: &str) -> PathBuf {
    root().join("samples").join(name)
}

/// One node of a test level.
#[derive(Clone, Debug)]
pub struct N {
    pub name: &'static str,
    pub parent: Option<usize>,
    /// Give the node a unit quad mesh.
    pub mesh: bool,
    pub material: Option<&'static str>,
    pub extras: Option<Value>,
}

pub fn n(name: &'static str, parent: Option<usize>, mesh: bool) -> N {
    N {
        name,
        parent,
        mesh,
        material: None,
        extras: None,
    }
}

impl N {
    pub fn material(mut self, m: &'static str) -> N {
        self.material = Some(m);
        self
    }
    pub fn extras(mut self, e: Value) -> N {
        self.extras = Some(e);
        self
    }
}

/// A glTF document (JSON text with an embedded buffer) whose mesh nodes each draw one quad.
pub fn gltf(nodes: &[N]) -> String {
    let mut blob = Vec::new();
    for p in [[0f32, 0., 0.], [1., 0., 0.], [1., 1., 0.], [0., 1., 0.]] {
        for c in p {
            blob.extend_from_slice(&c.to_le_bytes());
        }
    }
    for i in [0u16, 1, 2, 0, 2, 3] {
        blob.extend_from_slice(&i.to_le_bytes());
    }
    let mut materials: Vec<&str> = Vec::new();
    let mut meshes = Vec::new();
    let mut jnodes: Vec<Value> = Vec::new();
    for nd in nodes {
        let mut o = json!({"name": nd.name});
        if nd.mesh {
            let mut prim = json!({"attributes": {"POSITION": 0}, "indices": 1});
            if let Some(m) = nd.material {
                if !materials.contains(&m) {
                    materials.push(m);
                }
                prim["material"] = json!(materials.iter().position(|x| *x == m).unwrap());
            }
            meshes.push(json!({"primitives": [prim]}));
            o["mesh"] = json!(meshes.len() - 1);
        }
        if let Some(e) = &nd.extras {
            o["extras"] = e.clone();
        }
        jnodes.push(o);
    }
    let mut roots = Vec::new();
    for (i, nd) in nodes.iter().enumerate() {
        match nd.parent {
            Some(p) => {
                let kids = jnodes[p]
                    .as_object_mut()
                    .unwrap()
                    .entry("children")
                    .or_insert_with(|| json!([]));
                kids.as_array_mut().unwrap().push(json!(i));
            }
            None => roots.push(i),
        }
    }
    let uri = format!(
        "data:application/octet-stream;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(&blob)
    );
    let mut doc = json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": roots}],
        "nodes": jnodes,
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]},
            {"bufferView": 1, "componentType": 5123, "count": 6, "type": "SCALAR"}
        ],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 48},
            {"buffer": 0, "byteOffset": 48, "byteLength": 12}
        ],
        "buffers": [{"byteLength": blob.len(), "uri": uri}]
    });
    if !meshes.is_empty() {
        doc["meshes"] = json!(meshes);
    }
    if !materials.is_empty() {
        doc["materials"] = json!(materials
            .iter()
            .map(|m| json!({"name": m}))
            .collect::<Vec<_>>());
    }
    serde_json::to_string_pretty(&doc).unwrap()
}

/// Writes `text` as `name` into `dir` and returns the path.
pub fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

/// Runs the Khronos glTF-Validator (tools/gltf-validate) on a file and returns its report.
/// `None` when the validator is not installed; under CI that is a failure, not a skip.
pub fn khronos_validate(path: &Path) -> Option<Value> {
    let dir = root().join("tools/gltf-validate");
    if !dir.join("node_modules/gltf-validator").exists() {
        if std::env::var_os("CI").is_some() {
            panic!("the glTF validator is not installed (run scripts/test.sh, which runs npm ci)");
        }
        eprintln!(
            "note: glTF validator not installed; skipping validation of {}",
            path.display()
        );
        return None;
    }
    let out = std::process::Command::new("node")
        .arg(dir.join("validate.js"))
        .arg(path)
        .output()
        .expect("node runs");
    let report: Value = serde_json::from_slice(&out.stdout).unwrap_or_else(|e| {
        panic!(
            "validator output is not JSON ({e}): {}",
            String::from_utf8_lossy(&out.stderr)
        )
    });
    Some(report)
}

/// Reads a .gltf or .glb into its JSON document and BIN chunk.
pub fn read_gltf(bytes: &[u8]) -> (Value, Option<Vec<u8>>) {
    if bytes.starts_with(b"glTF") {
        let glb = gltf::binary::Glb::from_slice(bytes).expect("valid GLB");
        let json: Value = serde_json::from_slice(&glb.json).unwrap();
        (json, glb.bin.map(|b| b.into_owned()))
    } else {
        (serde_json::from_slice(bytes).unwrap(), None)
    }
}

/// Imports, tags, and builds the cells of a level.
pub fn load_cells(
    path: &Path,
    preset: Option<&str>,
) -> (portcullis::pipeline::Tagged, portcullis::cells::CellSet) {
    use portcullis::pipeline::{build_cells, load_tagged, LoadOptions};
    let opts = LoadOptions {
        preset: preset.map(str::to_string),
        ..Default::default()
    };
    let mut t = load_tagged(path, &opts).unwrap_or_else(|d| panic!("{}: {d}", path.display()));
    let c = build_cells(&mut t);
    (t, c)
}

/// Writes the building `portcullis gen --rooms N --seed S` makes to `dir/g.glb`.
pub fn generated_building(dir: &Path, rooms: usize, seed: u64) -> PathBuf {
    let path = dir.join("g.glb");
    succeeds(
        assert_cmd::Command::cargo_bin("portcullis")
            .unwrap()
            .args([
                "gen",
                "--rooms",
                &rooms.to_string(),
                "--seed",
                &seed.to_string(),
                "-o",
            ])
            .arg(&path),
    );
    path
}

/// Imports, tags, and builds the cells and portals of a level, as `convert` does.
pub fn load_level(
    path: &Path,
    preset: Option<&str>,
) -> (
    portcullis::pipeline::Tagged,
    portcullis::cells::CellSet,
    portcullis::portals::PortalSet,
) {
    use portcullis::pipeline::{build_cells, build_portals, load_tagged, LoadOptions};
    let opts = LoadOptions {
        preset: preset.map(str::to_string),
        ..Default::default()
    };
    let mut t = load_tagged(path, &opts).unwrap_or_else(|d| panic!("{}: {d}", path.display()));
    let c = build_cells(&mut t);
    let p = build_portals(&mut t, &c);
    (t, c, p)
}

/// [`load_level`] as one built level.
pub fn built(path: &Path, preset: Option<&str>) -> portcullis::pipeline::Level {
    let (t, c, p) = load_level(path, preset);
    portcullis::pipeline::Level::new(t, c, p)
}

/// The checks of `check` on a tagged level and its cells and portals; the findings are
/// appended to `t.diagnostics`, the leak paths returned.
pub fn check_parts(
    t: &mut portcullis::pipeline::Tagged,
    c: &portcullis::cells::CellSet,
    p: &portcullis::portals::PortalSet,
    sealed: bool,
) -> Vec<Vec<glam::DVec3>> {
    let mut level = portcullis::pipeline::Level::new(t.clone(), c.clone(), p.clone());
    let leaks = portcullis::pipeline::check(&mut level, sealed);
    t.diagnostics = level.diagnostics;
    leaks
}

/// (name, parent index, mesh triangles, extras) of one node of a scene built in code.
pub type Part<'a> = (&'a str, Option<usize>, Vec<[glam::DVec3; 3]>, Option<Value>);

/// A scene built in code, every node placed by `world` (its triangles are mesh-local); the
/// path says OBJ so positions count as exact decimal input, not f32.
pub fn scene_of(parts: Vec<Part>, world: glam::DMat4) -> portcullis::scene::Scene {
    let mut b = blocks::Builder::new(world);
    for (name, parent, tris, extras) in parts {
        b.node(name, parent, tris, extras, glam::DVec3::ZERO);
    }
    b.scene
}

/// Every triangle that blocks sight (not authored portals, footprints or bounds), in world
/// space, for ray-cast oracles that must not reuse the portal code.
pub fn opaque_mesh(t: &portcullis::pipeline::Tagged) -> parry3d_f64::shape::TriMesh {
    let skip: std::collections::HashSet<usize> = t
        .tagging
        .portals
        .iter()
        .map(|q| q.node)
        .chain(t.tagging.footprints.iter().map(|f| f.node))
        .chain(t.tagging.bounds.iter().map(|b| b.node))
        .collect();
    let (mut verts, mut idx) = (Vec::new(), Vec::new());
    for n in t.scene.walk() {
        let Some(m) = t.scene.nodes[n].mesh.filter(|_| !skip.contains(&n)) else {
            continue;
        };
        let w = t.scene.world_positions(n);
        for tri in &t.scene.meshes[m].triangles {
            let base = verts.len() as u32;
            verts.extend(tri.iter().map(|&i| w[i as usize]));
            idx.push([base, base + 1, base + 2]);
        }
    }
    parry3d_f64::shape::TriMesh::new(verts, idx).expect("a level with triangles")
}

/// The samples and third-party levels that have rooms, with the tag preset each needs.
pub fn levels_with_rooms() -> Vec<(PathBuf, Option<&'static str>)> {
    let mut v = vec![
        (fixture("lportal_tutorial_simple.glb"), None),
        (fixture("lportal_tutorial_simple.obj"), None),
        (fixture("lportal_boxrooms.glb"), None),
        (fixture("lportal_boxrooms.obj"), None),
        (fixture("panda3d_culling.glb"), Some("panda3d")),
        (fixture("panda3d_culling.obj"), Some("panda3d")),
    ];
    for s in [
        "two_rooms.gltf",
        "l_room.gltf",
        "u_room.gltf",
        "pillar_room.gltf",
        "bound_boxes.gltf",
        "door_window.gltf",
        "thick_wall.gltf",
        "arch.gltf",
        "mirror.gltf",
        "teleporter.gltf",
        "sloped_hall.gltf",
        "courtyard.gltf",
        "offset_holes.gltf",
    ] {
        v.push((sample(s), None));
    }
    v
}

/// [`levels_with_rooms`] and every other sample (.gltf, .obj) besides.
pub fn levels_and_samples() -> Vec<(PathBuf, Option<&'static str>)> {
    let mut levels = levels_with_rooms();
    let mut samples: Vec<PathBuf> = std::fs::read_dir(sample(""))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "gltf" || e == "obj"))
        .collect();
    samples.sort();
    for s in samples {
        if !levels.iter().any(|(l, _)| *l == s) {
            levels.push((s, None));
        }
    }
    levels
}

/// Every sample level (`samples/*.gltf`, `.glb`, `.obj`, `.map`; not `samples/broken`), sorted.
pub fn sample_levels() -> Vec<PathBuf> {
    let mut all: Vec<PathBuf> = std::fs::read_dir(root().join("samples"))
        .unwrap()
        .flatten()
        .map(|e| e.path())
        .filter(|p| {
            p.extension()
                .is_some_and(|x| ["gltf", "glb", "obj", "map"].iter().any(|e| x == *e))
        })
        .collect();
    all.sort();
    all
}

/// A level of `../shared/levels` (`rel` below it), or `None` with a message when `../shared`
/// is not beside the clone (the tests that need it skip).
pub fn shared(rel: &str) -> Option<PathBuf> {
    shared_path(&Path::new("levels").join(rel))
}

/// A file or folder of `../shared` (`rel` below it, e.g. `bsp`), or `None` with a message.
pub fn shared_path(rel: &Path) -> Option<PathBuf> {
    let p = root().join("../shared").join(rel);
    if p.exists() {
        Some(p)
    } else {
        eprintln!(
            "skipped: {} is missing (../shared is not beside the clone)",
            p.display()
        );
        None
    }
}

/// Runs a portcullis command that must succeed (exit 0), showing its stderr if it does not.
pub fn succeeds(cmd: &mut assert_cmd::Command) -> std::process::Output {
    let o = cmd.output().unwrap();
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    o
}

/// A scene built in code, tagged with the default configuration as `convert` tags a level.
pub fn tagged(scene: portcullis::scene::Scene) -> portcullis::pipeline::Tagged {
    tagged_with(scene, Default::default(), None)
}

/// A scene tagged with `config` and a preset (`--tags`), as `convert` tags a level.
pub fn tagged_with(
    scene: portcullis::scene::Scene,
    config: portcullis::config::Config,
    preset: Option<&str>,
) -> portcullis::pipeline::Tagged {
    let rules = portcullis::config::rule_set(&config, preset).unwrap();
    let imported = portcullis::import::Imported {
        scene,
        diagnostics: Default::default(),
    };
    portcullis::pipeline::tag(imported, config, rules)
}

/// The corners of the convex region `n · p <= d` of `planes` (within `tol`): every three
/// planes' meeting point that lies behind the rest, found by Cramer's rule, sharing no code
/// with the library's polyhedra.
pub fn corners(planes: &[(glam::DVec3, f64)], tol: f64) -> Vec<glam::DVec3> {
    let mut out = Vec::new();
    for i in 0..planes.len() {
        for j in i + 1..planes.len() {
            for k in j + 1..planes.len() {
                let (a, b, c) = (planes[i], planes[j], planes[k]);
                let det = a.0.dot(b.0.cross(c.0));
                if det.abs() < 1e-9 {
                    continue;
                }
                let p = (b.0.cross(c.0) * a.1 + c.0.cross(a.0) * b.1 + a.0.cross(b.0) * c.1) / det;
                if planes.iter().all(|(n, d)| n.dot(p) - d <= tol) {
                    out.push(p);
                }
            }
        }
    }
    out
}
