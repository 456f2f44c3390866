//! A headless Bevy app with the plugin flies a camera along a path through converted levels;
//! each frame, the meshes its view keeps are exactly those that `portcullis cull` says the
//! visible cells draw, and a second camera without the plugin keeps them all.
//!
//! The levels are converted by the `portcullis` binary (`$PORTCULLIS`, or the workspace's
//! `target/debug/portcullis`, which `cargo build` makes); its `cull` gives the answers.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

use bevy::camera::visibility::NoCpuCulling;
use bevy::ecs::hierarchy::ChildOf;
use bevy::ecs::name::Name;
use bevy::mesh::Mesh3d;
use bevy::prelude::{Camera3d, Entity, GlobalTransform, Projection, Vec3};
use portcullis_bevy::headless;
use portcullis_bevy::portcullis_runtime::runtime::answer::CameraLine;
use portcullis_bevy::{PortalCamera, PortalNode, PortalPrimitive};
use serde_json::{json, Value};

mod common;
use common::{converted, cull, gltf_json, root, tempfile_dir};

/// Frames between the cameras of `stops`: eye and look moved in `steps` even steps, as a
/// camera flown from one to the next (through walls too, and out of every cell).
fn path(stops: &[CameraLine], steps: usize) -> Vec<CameraLine> {
    let lerp = |a: [f64; 3], b: [f64; 3], t: f64| [0, 1, 2].map(|i| a[i] + (b[i] - a[i]) * t);
    let mut out = Vec::new();
    for w in stops.windows(2) {
        for s in 0..steps {
            let t = s as f64 / steps as f64;
            let mut c = w[0];
            c.eye = lerp(w[0].eye, w[1].eye, t);
            c.look = lerp(w[0].look, w[1].look, t);
            if c.look.iter().all(|v| v.abs() < 1e-6) {
                c.look = w[1].look;
            }
            out.push(c);
        }
    }
    out
}

/// The camera's view as the plugin takes it from the camera: its global transform and
/// projection, each `f32` made `f64`, as one line of a cameras file.
fn camera_line(t: &GlobalTransform, p: &Projection) -> Value {
    let Projection::Perspective(p) = p else {
        panic!("a perspective camera")
    };
    let d = |v: Vec3| [v.x as f64, v.y as f64, v.z as f64];
    json!({"eye": d(t.translation()), "look": d(*t.forward()), "up": d(*t.up()),
           "fov_y": (p.fov as f64).to_degrees(), "aspect": p.aspect_ratio as f64, "near": p.near as f64})
}

/// What a mesh entity draws: its node and primitive, by the plugin's tags.
type Part = (u32, u32);

/// What `cull`'s draw list keeps of the level's parts: a node drawn whole, or a part of a
/// split node of which some range is drawn; parts of nodes no cell names are not the level's.
fn kept(
    draw: &Value,
    parts: &BTreeSet<Part>,
    named: &BTreeSet<u32>,
    never: &BTreeSet<u32>,
) -> BTreeSet<Part> {
    let whole: BTreeSet<u32> = draw["nodes"]
        .as_array()
        .unwrap()
        .iter()
        .map(|n| n.as_u64().unwrap() as u32)
        .collect();
    let ranges: BTreeSet<Part> = (draw["ranges"].as_array().unwrap().iter())
        .map(|r| (r[0].as_u64().unwrap() as u32, r[1].as_u64().unwrap() as u32))
        .collect();
    (parts.iter().copied())
        .filter(|p| !never.contains(&p.0))
        .filter(|p| !named.contains(&p.0) || whole.contains(&p.0) || ranges.contains(p))
        .collect()
}

fn fly(source: &Path, convert: &[&str], stops: &Path, steps: usize) {
    let dir = tempfile_dir();
    let Some(glb) = converted(source, convert, &dir) else {
        return;
    };
    let stops: Vec<CameraLine> = std::fs::read_to_string(stops)
        .unwrap()
        .lines()
        .filter_map(|l| CameraLine::parse(l).unwrap())
        .take(40)
        .collect();
    let frames = path(&stops, steps);

    let (mut app, level, _scene) = headless::app_with_level(&glb).expect("the level loads");
    let culled = headless::spawn_camera(app.world_mut(), level);
    app.world_mut().entity_mut(culled).insert(NoCpuCulling);
    let plain = app
        .world_mut()
        .spawn((Camera3d::default(), NoCpuCulling))
        .id();

    // The plugin's tags against the file: each tagged node entity's name is its node's.
    let json = gltf_json(&glb);
    let names = json["nodes"].as_array().unwrap();
    let world = app.world_mut();
    let mut parts: BTreeMap<Entity, Part> = BTreeMap::new();
    let mut q = world.query::<(Entity, &ChildOf, Option<&PortalPrimitive>, &Mesh3d)>();
    let tagged: Vec<(Entity, Entity, Option<u32>)> = q
        .iter(world)
        .map(|(e, c, p, _)| (e, c.parent(), p.map(|p| p.primitive)))
        .collect();
    for (e, parent, primitive) in tagged {
        let Some(node) = world.get::<PortalNode>(parent) else {
            continue;
        };
        let name = world.get::<Name>(parent).map(|n| n.as_str().to_string());
        assert_eq!(
            name.as_deref(),
            names[node.node as usize]["name"].as_str(),
            "node {}",
            node.node
        );
        parts.insert(
            e,
            (
                node.node,
                primitive.expect("a mesh entity of the level has its primitive"),
            ),
        );
    }
    assert!(!parts.is_empty(), "no mesh entity tagged");
    let all: BTreeSet<Part> = parts.values().copied().collect();
    let named: BTreeSet<u32> = (json["extensions"]["PORTCULLIS_portals"]["cells"]
        .as_array()
        .unwrap()
        .iter())
    .flat_map(|c| {
        c["nodes"]
            .as_array()
            .unwrap()
            .iter()
            .map(|n| n.as_u64().unwrap() as u32)
    })
    .collect();
    // No cell draws an authored portal's mesh or a split part no cell names.
    let ext = &json["extensions"]["PORTCULLIS_portals"];
    let portal_nodes = ext["portals"]
        .as_array()
        .unwrap()
        .iter()
        .filter_map(|p| p["node"].as_u64());
    let part_nodes = names.iter().flat_map(|n| {
        let parts = n["extensions"]["PORTCULLIS_portals"]["parts"]
            .as_array()
            .cloned();
        parts.into_iter().flatten().filter_map(|p| p.as_u64())
    });
    let never: BTreeSet<u32> = portal_nodes
        .chain(part_nodes)
        .map(|n| n as u32)
        .filter(|n| !named.contains(n))
        .collect();

    let mut lines = Vec::new();
    let mut shown = Vec::new();
    for c in &frames {
        headless::aim(app.world_mut(), culled, c, false).expect("a usable camera");
        app.update();
        let world = app.world();
        let (t, p) = (
            world.get::<GlobalTransform>(culled).unwrap(),
            world.get::<Projection>(culled).unwrap(),
        );
        let line = camera_line(t, p);
        // the plugin's view is the camera's: the eye and look the path set, within f32
        let close = |a: &Value, b: [f64; 3], scale: f64| {
            (0..3).all(|i| (a[i].as_f64().unwrap() - b[i]).abs() <= 1e-5 * scale)
        };
        let n = c.look.iter().map(|v| v * v).sum::<f64>().sqrt();
        let extent = c.eye.iter().fold(1.0f64, |m, v| m.max(v.abs()));
        assert!(close(&line["eye"], c.eye, extent), "{line} vs {c:?}");
        assert!(
            close(&line["look"], c.look.map(|v| v / n), 1.0),
            "{line} vs {c:?}"
        );
        lines.push(line.to_string());
        let raw = world
            .get::<bevy::camera::visibility::VisibleEntities>(culled)
            .unwrap();
        let raw = raw.get(std::any::TypeId::of::<Mesh3d>());
        assert!(
            raw.is_sorted(),
            "the view's list stays sorted for Bevy's renderer"
        );
        assert!(
            world.get::<PortalCamera>(culled).unwrap().culled,
            "the frame was not culled"
        );
        let kept_by = |cam| -> BTreeSet<Part> {
            headless::drawn_meshes(world, cam)
                .iter()
                .filter_map(|e| parts.get(e).copied())
                .collect()
        };
        assert_eq!(
            kept_by(plain),
            all,
            "the camera without the plugin keeps every mesh"
        );
        shown.push(kept_by(culled));
    }
    let answers = cull(&glb, &lines, &dir);
    let mut hidden = 0;
    for (i, (a, s)) in answers.iter().zip(&shown).enumerate() {
        let want = kept(&a["draw"], &all, &named, &never);
        assert_eq!(s, &want, "frame {i}: camera {}", lines[i]);
        hidden += all.len() - s.len();
    }
    assert!(
        hidden > 0,
        "no frame hid anything: the test would pass without the plugin"
    );
    eprintln!(
        "{}: {} frames, {} meshes, {:.1} hidden per frame",
        source.display(),
        frames.len(),
        all.len(),
        hidden as f64 / frames.len() as f64
    );
}

#[test]
fn a_camera_flown_through_two_rooms_hides_the_authored_portal_mesh() {
    let r = root();
    fly(
        &r.join("samples/two_rooms.gltf"),
        &[],
        &r.join("tests/vectors/two_rooms.cameras.jsonl"),
        2,
    );
}

#[test]
fn a_camera_flown_through_a_brush_map_split_by_cell_draws_what_cull_says() {
    let r = root();
    fly(
        &r.join("samples/brush_doors.map"),
        &["--split-by-cell"],
        &r.join("tests/vectors/brush_doors.cameras.jsonl"),
        4,
    );
}

#[test]
fn a_camera_flown_through_a_brush_map_draws_what_cull_says() {
    let r = root();
    fly(
        &r.join("samples/brush_doors.map"),
        &[],
        &r.join("tests/vectors/brush_doors.cameras.jsonl"),
        4,
    );
}

#[test]
fn a_camera_flown_through_freedoom_map01_split_by_cell_draws_what_cull_says() {
    let r = root();
    fly(
        &r.join("../shared/levels/freedoom/freedoom2_MAP01.glb"),
        &["--tags", "doom", "--split-by-cell"],
        &r.join("tests/vectors/freedoom2_MAP01.cameras.jsonl"),
        4,
    );
}

#[test]
fn a_camera_flown_through_freedoom_map01_by_draw_ranges_draws_what_cull_says() {
    let r = root();
    fly(
        &r.join("../shared/levels/freedoom/freedoom2_MAP01.glb"),
        &["--tags", "doom"],
        &r.join("tests/vectors/freedoom2_MAP01.cameras.jsonl"),
        2,
    );
}
