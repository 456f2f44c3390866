//! The plugin's answers are `portcullis cull`'s on 500 random cameras per shared level (the
//! Freedoom maps with the doom preset, the brush maps as `.map`): each camera set on a Bevy
//! camera, one headless frame run, and the answer read off its `PortalCamera`, against the
//! JSON line `cull --draw-lists --format jsonl` prints for it.

use bevy::asset::Assets;
use portcullis_bevy::headless;
use portcullis_bevy::portcullis_runtime::runtime::answer::{answer, CameraLine};
use portcullis_bevy::portcullis_runtime::runtime::DrawList;
use portcullis_bevy::{PortalCamera, PortalLevel};
use serde_json::{json, Value};

mod common;
use common::{converted, cull, gltf_json, root, tempfile_dir};

/// splitmix64: a seeded PRNG, uniform in [0, 1).
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// `n` cameras with eyes anywhere in the cells' bounds grown by a metre (in cells, on their
/// faces, in walls, outside), looks of any direction off the vertical, and now and then another
/// lens or a 1 m near plane.
fn cameras(level: &Value, n: usize, seed: u64) -> Vec<Value> {
    let cells = level["extensions"]["PORTCULLIS_portals"]["cells"]
        .as_array()
        .unwrap();
    let (mut lo, mut hi) = ([f64::MAX; 3], [f64::MIN; 3]);
    for c in cells {
        for i in 0..3 {
            lo[i] = lo[i].min(c["bounds"]["min"][i].as_f64().unwrap() - 1.0);
            hi[i] = hi[i].max(c["bounds"]["max"][i].as_f64().unwrap() + 1.0);
        }
    }
    let mut r = Rng(seed);
    (0..n)
        .map(|_| {
            let eye = [0, 1, 2].map(|i| lo[i] + (hi[i] - lo[i]) * r.next());
            let look = loop {
                let v = [r.next() * 2.0 - 1.0, r.next() - 0.5, r.next() * 2.0 - 1.0];
                if v[0].abs() + v[2].abs() > 0.1 {
                    break v;
                }
            };
            let mut c = json!({"eye": eye, "look": look});
            match (r.next() * 10.0) as u32 {
                0 => c["near"] = json!(1.0),
                1 => {
                    c["fov_y"] = json!(90.0);
                    c["aspect"] = json!(1.0);
                }
                _ => {}
            }
            c
        })
        .collect()
}

/// Whether two answers agree: equal, numbers within 1e-9.
fn agree(a: &Value, b: &Value) -> bool {
    match (a, b) {
        (Value::Number(x), Value::Number(y)) => {
            (x.as_f64().unwrap() - y.as_f64().unwrap()).abs() <= 1e-9
        }
        (Value::Array(x), Value::Array(y)) => {
            x.len() == y.len() && x.iter().zip(y).all(|(a, b)| agree(a, b))
        }
        (Value::Object(x), Value::Object(y)) => {
            x.len() == y.len() && x.iter().all(|(k, v)| y.get(k).is_some_and(|w| agree(v, w)))
        }
        _ => a == b,
    }
}

fn compare(rel: &str, args: &[&str], seed: u64) {
    let source = root().join("..").join("shared/levels").join(rel);
    let dir = tempfile_dir();
    let Some(glb) = converted(&source, args, &dir) else {
        return;
    };
    let list = cameras(&gltf_json(&glb), 500, seed);
    let text: Vec<String> = list.iter().map(Value::to_string).collect();
    let want = cull(&glb, &text, &dir);

    let (mut app, level, _) = headless::app_with_level(&glb).expect("the level loads");
    let camera = headless::spawn_camera(app.world_mut(), level.clone());
    let mut draw = DrawList::default();
    let mut seen = 0;
    for (i, (line, want)) in text.iter().zip(&want).enumerate() {
        let c = CameraLine::parse(line).unwrap().unwrap();
        headless::aim(app.world_mut(), camera, &c, true).unwrap();
        app.update();
        let world = app.world();
        let l = &world
            .resource::<Assets<PortalLevel>>()
            .get(&level)
            .unwrap()
            .level;
        let got = answer(
            &world.get::<PortalCamera>(camera).unwrap().trace,
            Some((l, &mut draw)),
        );
        assert!(
            agree(want, &got),
            "{rel} camera {i} {line}:\n cull  {want}\n bevy  {got}"
        );
        seen += want["visible"].as_array().unwrap().len();
    }
    assert!(
        seen > list.len(),
        "{rel}: the cameras see no more than one entry each"
    );
    eprintln!(
        "{rel}: {} cameras agree, {seen} visible entries",
        list.len()
    );
}

#[test]
fn freedoom_map01() {
    compare("freedoom/freedoom2_MAP01.glb", &["--tags", "doom"], 1);
}

#[test]
fn freedoom_e1m2() {
    compare("freedoom/freedoom1_E1M2.glb", &["--tags", "doom"], 2);
}

#[test]
fn freedoom_e3m3() {
    compare("freedoom/freedoom1_E3M3.glb", &["--tags", "doom"], 3);
}

#[test]
fn brush_map_e1m1() {
    compare("ericw-tools/testmaps/E1M1-edited-ents.map", &[], 4);
}

#[test]
fn brush_map_e3m4() {
    compare(
        "ericw-tools/testmaps/LibreQuake/lq1/maps/src/e3/e3m4.map",
        &[],
        5,
    );
}

#[test]
fn brush_map_retrojam1() {
    compare("ericw-tools/testmaps/retrojam1_ericw.map", &[], 6);
}
