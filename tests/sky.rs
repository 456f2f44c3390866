//! The open sky: a material the rules name as sky (the doom preset's `F_SKY1`) bounds its room
//! and is drawn, but sight passes through it to the outside. Doom's sky hack leaves a lower sky
//! sector's ceiling as the only surface between it and the void over it; drawn single-sided and
//! facing down, that ceiling hides nothing from above, so a camera that sees the void over it
//! sees the sector's floor through it, and culling must not hide it (the browser test's camera
//! 11 on MAP01, js/portcullis-three/test/browser.test.js).

mod common;

use std::path::Path;

use serde_json::Value;

/// `level` converted with `--tags doom` (and `config`, when given) into `dir`: the extension.
fn converted(level: &Path, dir: &Path, config: Option<&Path>) -> (Value, std::path::PathBuf) {
    let out = dir.join("level.glb");
    let mut cmd = assert_cmd::Command::cargo_bin("portcullis").unwrap();
    cmd.arg("convert")
        .arg(level)
        .args(["--tags", "doom", "-o"])
        .arg(&out);
    if let Some(c) = config {
        cmd.arg("--config").arg(c);
    }
    common::succeeds(&mut cmd);
    let (doc, _) = common::read_gltf(&std::fs::read(&out).unwrap());
    (doc["extensions"]["PORTCULLIS_portals"].clone(), out)
}

/// The cells of room `room`.
fn cells_of(ext: &Value, room: &str) -> Vec<u64> {
    (ext["cells"].as_array().unwrap().iter().enumerate())
        .filter(|(_, c)| c["room"] == room)
        .map(|(i, _)| i as u64)
        .collect()
}

/// The area of the exterior openings of `cells` lying flat at height `y` (within a millimetre).
fn sky_openings(ext: &Value, cells: &[u64], y: f64) -> f64 {
    let mut area = 0.0;
    for p in ext["portals"].as_array().unwrap() {
        let c = p["cells"].as_array().unwrap();
        if c.len() != 1 || !cells.contains(&c[0].as_u64().unwrap()) {
            continue;
        }
        let pts: Vec<[f64; 3]> = (p["polygon"].as_array().unwrap().iter())
            .map(|q| [0, 1, 2].map(|k| q[k].as_f64().unwrap()))
            .collect();
        if pts.iter().any(|q| (q[1] - y).abs() > 1e-3) {
            continue;
        }
        // The shoelace formula on the floor plan.
        let twice: f64 = (0..pts.len())
            .map(|i| {
                let (a, b) = (pts[i], pts[(i + 1) % pts.len()]);
                a[0] * b[2] - b[0] * a[2]
            })
            .sum();
        area += twice.abs() / 2.0;
    }
    area
}

/// The cells `cull` says the camera sees (the outside left out).
fn seen(level: &Path, dir: &Path, camera: &str) -> Vec<u64> {
    let cams = common::write(dir, "cameras.jsonl", camera);
    let mut cmd = assert_cmd::Command::cargo_bin("portcullis").unwrap();
    cmd.arg("cull").arg(level).arg("--cameras").arg(&cams);
    let o = common::succeeds(cmd.args(["--format", "jsonl"]));
    let answer: Value = serde_json::from_slice(&o.stdout).unwrap();
    (answer["visible"].as_array().unwrap().iter())
        .filter_map(|v| v["cell"].as_u64())
        .collect()
}

/// MAP01's sector_190 is 3 cm tall (floor 5.5 m, an `F_SKY1` ceiling at 5.53125 m) under the
/// void; from the eye in sector_157's cell the void over it is seen through an opening, and the
/// sector's floor through its ceiling. Without the preset's sky the ceiling closed the cells,
/// no trace entered them and Chromium drew 11,518 pixels of that floor that culling hid.
#[test]
fn a_doom_sky_ceiling_is_an_opening_the_void_over_it_sees_in_through() {
    let Some(map01) = common::shared("freedoom/freedoom2_MAP01.glb") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let (ext, out) = converted(&map01, dir.path(), None);
    let sector = cells_of(&ext, "sector_190");
    assert!(!sector.is_empty(), "sector_190 has cells");
    let open = sky_openings(&ext, &sector, 5.53125);
    // The sector's floor plan, 40 m by 38 m at most, is open to the sky over most of it.
    assert!(
        open > 100.0,
        "sector_190's sky ceiling opens {open} m² to the outside"
    );
    let camera = r#"{"eye":[21,6.625,-42.875],"look":[0,0,-1]}"#;
    let visible = seen(&out, dir.path(), camera);
    assert!(
        sector.iter().any(|c| visible.contains(c)),
        "the eye over sector_190 sees none of its cells {sector:?}: {visible:?}"
    );

    // The same level with the sky turned off in a configuration: the ceiling closes the sector
    // again (the opening comes from the rule, not from the geometry).
    let config = common::write(dir.path(), "portcullis.toml", "[tags]\nsky = \"\"\n");
    let other = tempfile::tempdir().unwrap();
    let (closed, _) = converted(&map01, other.path(), Some(&config));
    let sector = cells_of(&closed, "sector_190");
    assert_eq!(sky_openings(&closed, &sector, 5.53125), 0.0);
}

/// A sky pattern that is not a regular expression is refused with the rule named `sky`.
#[test]
fn a_bad_sky_pattern_is_an_error_naming_it() {
    let dir = tempfile::tempdir().unwrap();
    let config = common::write(dir.path(), "portcullis.toml", "[tags]\nsky = \"(\"\n");
    let mut cmd = assert_cmd::Command::cargo_bin("portcullis").unwrap();
    let o = cmd
        .arg("inspect")
        .arg(common::sample("two_rooms.gltf"))
        .arg("--config")
        .arg(&config)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    let err = format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(
        err.contains("TAGS_RULE_INVALID") && err.contains("`sky`"),
        "{err}"
    );
}
