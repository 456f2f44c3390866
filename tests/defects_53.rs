//! Issue 53: defects a new user hits, one test each (each failed before its fix).

mod common;

use common::sample;

fn portcullis() -> assert_cmd::Command {
    assert_cmd::Command::cargo_bin("portcullis").unwrap()
}

/// `check --sealed --format json` on `path`: its report.
fn sealed_report(path: &std::path::Path) -> serde_json::Value {
    let o = portcullis()
        .args(["check", "--sealed", "--format", "json"])
        .arg(path)
        .output()
        .unwrap();
    serde_json::from_slice(&o.stdout).unwrap()
}

/// Item 4: `view --sealed` on a leaking level writes the page and exits 1, as the documented
/// exit codes say for a level with errors; a clean level still exits 0.
#[test]
fn view_exits_1_when_the_level_has_errors() {
    let dir = tempfile::tempdir().unwrap();
    let page = dir.path().join("leak.html");
    let o = portcullis()
        .args(["view", "--sealed"])
        .arg(common::root().join("samples/broken/LEAK/level.gltf"))
        .arg("-o")
        .arg(&page)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("1 error"), "{err}");
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(page.exists(), "the page is written all the same");
    let clean = portcullis()
        .arg("view")
        .arg(sample("two_rooms.gltf"))
        .arg("-o")
        .arg(dir.path().join("clean.html"))
        .output()
        .unwrap();
    assert_eq!(clean.status.code(), Some(0));
}

/// Item 7: the commands that read levels list brush maps among their inputs, and `--tags`
/// lists every built-in preset.
#[test]
fn help_lists_brush_maps_and_every_preset() {
    for cmd in ["convert", "check", "inspect", "view", "vis"] {
        let o = portcullis().args([cmd, "--help"]).output().unwrap();
        let help = String::from_utf8_lossy(&o.stdout);
        assert!(
            help.contains(".map"),
            "`{cmd} --help` names no .map:\n{help}"
        );
        if cmd != "vis" || help.contains("--tags") {
            for preset in portcullis::tags::presets::names() {
                assert!(
                    help.contains(preset),
                    "`{cmd} --help` does not list the preset `{preset}`"
                );
            }
        }
    }
}

/// Item 8: `cull` on an empty level file says it is empty (`INPUT_EMPTY`), as every other
/// command does, not that it is not converted.
#[test]
fn cull_reports_an_empty_level_as_empty() {
    let dir = tempfile::tempdir().unwrap();
    let level = dir.path().join("empty.glb");
    std::fs::write(&level, b"").unwrap();
    let cameras = dir.path().join("cams.txt");
    std::fs::write(&cameras, "{\"eye\":[0,0,0],\"look\":[0,0,-1]}\n").unwrap();
    let o = portcullis()
        .arg("cull")
        .arg(&level)
        .arg("--cameras")
        .arg(&cameras)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("INPUT_EMPTY"), "{err}");
    assert!(!err.contains("CULL_NOT_CONVERTED"), "{err}");
    assert_eq!(o.status.code(), Some(2), "{err}");
}

/// A hollow box of six brushes (map units), walls `t` thick, air from `lo` to `hi`.
fn box_room(lo: [i64; 3], hi: [i64; 3], t: i64) -> String {
    let mut s = String::new();
    for axis in 0..3 {
        for side in [false, true] {
            let (mut a, mut b) = (
                [lo[0] - t, lo[1] - t, lo[2] - t],
                [hi[0] + t, hi[1] + t, hi[2] + t],
            );
            if side {
                a[axis] = hi[axis];
            } else {
                b[axis] = lo[axis];
            }
            s += &format!(
                "{{\n( {0} {1} {2} ) ( {0} {4} {2} ) ( {0} {1} {5} ) w 0 0 0 1 1\n( {3} {1} {2} ) ( {3} {1} {5} ) ( {3} {4} {2} ) w 0 0 0 1 1\n( {0} {1} {2} ) ( {0} {1} {5} ) ( {3} {1} {2} ) w 0 0 0 1 1\n( {0} {4} {2} ) ( {3} {4} {2} ) ( {0} {4} {5} ) w 0 0 0 1 1\n( {0} {1} {2} ) ( {3} {1} {2} ) ( {0} {4} {2} ) w 0 0 0 1 1\n( {0} {1} {5} ) ( {0} {4} {5} ) ( {3} {1} {5} ) w 0 0 0 1 1\n}}\n",
                a[0], a[1], a[2], b[0], b[1], b[2]
            );
        }
    }
    s
}

/// Item 2: every world brush of samples/brush_doors.map in one `func_group` with
/// `_portcullis_room "main"` (and, a second time, beside a sealed annex of its own room far
/// away): no empty `world` room, and the door is still a gate of the room it stands in, with
/// its reveal cell and its four door portals, as in the map as written (7 cells).
#[test]
fn a_door_stays_a_gate_of_the_func_group_room_it_stands_in() {
    let text = std::fs::read_to_string(sample("brush_doors.map")).unwrap();
    let grouped = text.replacen(
        "\"classname\" \"worldspawn\"",
        "\"classname\" \"func_group\"\n\"_portcullis_room\" \"main\"",
        1,
    );
    let grouped = format!("{{\n\"classname\" \"worldspawn\"\n}}\n{grouped}");
    let annex = format!(
        "{grouped}{{\n\"classname\" \"func_group\"\n\"_portcullis_room\" \"annex\"\n{}}}\n{{\n\"classname\" \"info_null\"\n\"origin\" \"3064 64 64\"\n}}\n",
        box_room([3000, 0, 0], [3128, 128, 128], 16)
    );
    let dir = tempfile::tempdir().unwrap();
    for (name, text, rooms) in [
        ("grouped.map", grouped, vec!["main", "main_area1"]),
        ("annex.map", annex, vec!["main", "annex", "main_area1"]),
    ] {
        let path = dir.path().join(name);
        std::fs::write(&path, text).unwrap();
        let o = portcullis()
            .args(["check", "--format", "json"])
            .arg(&path)
            .output()
            .unwrap();
        let out = String::from_utf8_lossy(&o.stdout);
        assert!(!out.contains("CELL_ROOM_EMPTY"), "{name}: {out}");
        assert_eq!(o.status.code(), Some(0), "{name}: {out}");
        let (t, c, p) = common::load_level(&path, None);
        let names: Vec<&str> = t.tagging.rooms.iter().map(|r| r.name.as_str()).collect();
        assert_eq!(names, rooms, "{name}");
        let annex = names.iter().position(|&n| n == "annex");
        let in_main = c.cells.iter().filter(|c| Some(c.room) != annex);
        assert_eq!(
            in_main.count(),
            7,
            "{name}: the door's reveal and the area portal's slabs"
        );
        assert_eq!(p.portals.iter().filter(|q| q.door).count(), 4, "{name}");
    }
}

/// One worldspawn brush, a 64-unit cube from `o` (map units), as text.
fn cube_map(o: [f64; 3]) -> String {
    let (x0, y0, z0) = (o[0], o[1], o[2]);
    let (x1, y1, z1) = (x0 + 64.0, y0 + 64.0, z0 + 64.0);
    let faces = [
        [[x1, y0, z0], [x1, y0, z1], [x1, y1, z0]],
        [[x0, y0, z0], [x0, y1, z0], [x0, y0, z1]],
        [[x0, y0, z0], [x0, y0, z1], [x1, y0, z0]],
        [[x0, y1, z0], [x1, y1, z0], [x0, y1, z1]],
        [[x0, y0, z0], [x1, y0, z0], [x0, y1, z0]],
        [[x0, y0, z1], [x0, y1, z1], [x1, y0, z1]],
    ];
    let mut t = String::from("{\n\"classname\" \"worldspawn\"\n{\n");
    for f in faces {
        for p in f {
            t += &format!("( {:?} {:?} {:?} ) ", p[0], p[1], p[2]);
        }
        t += "a 0 0 0 1 1\n";
    }
    t + "}\n}\n"
}

/// Item 9: a brush at 1e300 is too far out (not "collinear"), a brush past ±1,048,576 lies
/// beyond the map (not "encloses no volume"); a cube missing a face is open.
#[test]
fn a_brush_too_far_out_says_so() {
    let dir = tempfile::tempdir().unwrap();
    let open = cube_map([0.0; 3]).replacen(
        "( 0.0 0.0 0.0 ) ( 64.0 0.0 0.0 ) ( 0.0 64.0 0.0 ) a 0 0 0 1 1\n",
        "",
        1,
    );
    for (name, text, says, not) in [
        (
            "e300.map",
            cube_map([1e300; 3]),
            "1e300 units from the origin",
            "collinear",
        ),
        (
            "far.map",
            cube_map([2e6, 0.0, 0.0]),
            "lies beyond ±1048576 units",
            "encloses no volume",
        ),
        (
            "open.map",
            open,
            "is open: its planes do not close it",
            "encloses no volume",
        ),
    ] {
        let path = dir.path().join(name);
        std::fs::write(&path, text).unwrap();
        let o = portcullis().arg("check").arg(&path).output().unwrap();
        let err = String::from_utf8_lossy(&o.stdout) + String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{name}: {err}");
        assert!(
            err.contains("MAP_BRUSH_INVALID") && err.contains(says),
            "{name}: {err}"
        );
        assert!(!err.contains(not), "{name}: {err}");
    }
}

/// Item 10: a leak in a brush map is placed in map units too (what the editor shows), in the
/// text and in the JSON report; a glTF level, already in metres, gets no second position.
#[test]
fn a_leak_in_a_brush_map_is_placed_in_map_units() {
    let text = std::fs::read_to_string(sample("brush_doors.map")).unwrap();
    // The first brush is room A's floor (map z -16..0 under x, y 0..256): without it, room A
    // leaks through a hole whose middle is map (128, 128, 0).
    let i = text.find("{\n(").unwrap();
    let j = i + text[i..].find("}\n").unwrap() + 2;
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("floorless.map");
    std::fs::write(&path, format!("{}{}", &text[..i], &text[j..])).unwrap();
    let o = portcullis()
        .args(["check", "--sealed"])
        .arg(&path)
        .output()
        .unwrap();
    let out = String::from_utf8_lossy(&o.stdout) + String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{out}");
    assert!(
        out.contains("at (3.2512, 0.0000, -3.2512), (128.0, 128.0, 0.0) in the file's units"),
        "{out}"
    );
    let r = sealed_report(&path);
    let leak = &r["files"][0]["diagnostics"][0];
    assert_eq!(leak["code"], "LEAK");
    assert_eq!(
        leak["location"]["file_position"],
        serde_json::json!([128.0, 128.0, 0.0])
    );
    let r = sealed_report(&common::root().join("samples/broken/LEAK/level.gltf"));
    let leak = &r["files"][0]["diagnostics"][0];
    assert!(
        leak["location"]["position"].is_array() && leak["location"].get("file_position").is_none(),
        "{leak}"
    );
}

/// A brush of `class` from `lo` to `hi` (map units), as an entity.
fn brush_entity(class: &str, lo: [i64; 3], hi: [i64; 3]) -> String {
    let (a, b) = (lo, hi);
    format!(
        "{{\n\"classname\" \"{class}\"\n{{\n( {0} {1} {2} ) ( {0} {4} {2} ) ( {0} {1} {5} ) d 0 0 0 1 1\n( {3} {1} {2} ) ( {3} {1} {5} ) ( {3} {4} {2} ) d 0 0 0 1 1\n( {0} {1} {2} ) ( {0} {1} {5} ) ( {3} {1} {2} ) d 0 0 0 1 1\n( {0} {4} {2} ) ( {3} {4} {2} ) ( {0} {4} {5} ) d 0 0 0 1 1\n( {0} {1} {2} ) ( {3} {1} {2} ) ( {0} {4} {2} ) d 0 0 0 1 1\n( {0} {1} {5} ) ( {0} {4} {5} ) ( {3} {1} {5} ) d 0 0 0 1 1\n}}\n}}\n",
        a[0], a[1], a[2], b[0], b[1], b[2]
    )
}

/// Item 6: in a brush map a detail brush buried wholly in a wall (1.5 m deep in a 2.4 m
/// wall, past the half metre a wall may be thick and still show what lies in it) needs no
/// cell and raises no `CELL_GEOMETRY_OUTSIDE` (qbsp draws it nowhere either); one flush with
/// the wall's face is rendered by the cell it touches; geometry outside a glTF level's rooms
/// is still reported.
#[test]
fn detail_buried_in_a_wall_is_no_noise_and_detail_on_a_face_is_rendered() {
    let map = format!(
        "{{\n\"classname\" \"worldspawn\"\n{}}}\n{}{}{{\n\"classname\" \"info_player_start\"\n\"origin\" \"64 64 32\"\n}}\n",
        box_room([0, 0, 0], [128, 128, 128], 96),
        brush_entity("func_detail", [-80, 32, 32], [-60, 64, 64]),
        brush_entity("func_detail", [-16, 32, 32], [0, 64, 64]),
    );
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("detail.map");
    std::fs::write(&path, map).unwrap();
    let o = portcullis().arg("check").arg(&path).output().unwrap();
    let out = String::from_utf8_lossy(&o.stdout) + String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(0), "{out}");
    assert!(!out.contains("CELL_GEOMETRY_OUTSIDE"), "{out}");
    let (t, c, _) = common::load_level(&path, None);
    let node = |name: &str| {
        (0..t.scene.nodes.len())
            .find(|&n| t.scene.nodes[n].name.as_deref() == Some(name))
            .unwrap()
    };
    let (buried, flush) = (node("func_detail 1 brush 0"), node("func_detail 2 brush 0"));
    assert!(c.cells.iter().all(|c| !c.nodes.contains(&buried)));
    assert!(
        c.cells.iter().any(|c| c.nodes.contains(&flush)),
        "the flush brush is drawn"
    );
    let o = portcullis()
        .arg("check")
        .arg(common::root().join("samples/broken/CELL_GEOMETRY_OUTSIDE.gltf"))
        .output()
        .unwrap();
    let out = String::from_utf8_lossy(&o.stdout) + String::from_utf8_lossy(&o.stderr);
    assert!(out.contains("CELL_GEOMETRY_OUTSIDE"), "{out}");
}

/// The `CELL_BLOCK_OPEN` findings of `check --sealed` on `path`, and every code found.
fn open_blocks(path: &std::path::Path) -> (Vec<serde_json::Value>, Vec<String>) {
    let r = sealed_report(path);
    let diags = r["files"][0]["diagnostics"].as_array().unwrap().clone();
    let codes = diags
        .iter()
        .map(|d| d["code"].as_str().unwrap().to_string())
        .collect();
    let open = diags
        .into_iter()
        .filter(|d| d["code"] == "CELL_BLOCK_OPEN")
        .collect();
    (open, codes)
}

/// Item 3: a wall slab of samples/block_closet.gltf missing one triangle is named, with its
/// three open edges, beside the leak it causes; a crate missing one
/// (samples/broken/CELL_BLOCK_OPEN.gltf) is named too; the closed closet raises nothing.
#[test]
fn an_open_block_is_named_with_its_open_edges() {
    let mut d: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(sample("block_closet.gltf")).unwrap())
            .unwrap();
    let dir = tempfile::tempdir().unwrap();
    let closed = dir.path().join("closed.gltf");
    std::fs::write(&closed, d.to_string()).unwrap();
    // wall_east is node 7, mesh 5: its last triangle dropped.
    let indices = d["meshes"][5]["primitives"][0]["indices"].as_u64().unwrap() as usize;
    let count = d["accessors"][indices]["count"].as_u64().unwrap();
    d["accessors"][indices]["count"] = (count - 3).into();
    let holed = dir.path().join("holed.gltf");
    std::fs::write(&holed, d.to_string()).unwrap();
    for (path, node) in [
        (holed, "Level/closet-room/wall_east"),
        (
            common::root().join("samples/broken/CELL_BLOCK_OPEN.gltf"),
            "Level/closet-room/crate",
        ),
    ] {
        let (open, codes) = open_blocks(&path);
        assert_eq!(open.len(), 1, "{codes:?}");
        assert_eq!(open[0]["severity"], "warning");
        assert_eq!(open[0]["location"]["node"], node);
        let message = open[0]["message"].as_str().unwrap();
        assert!(message.contains("3 open edge(s)"), "{message}");
        assert_eq!(message.matches(" - ").count(), 3, "{message}");
        if node.ends_with("wall_east") {
            assert!(
                codes.iter().any(|c| c == "LEAK"),
                "the hole leaks: {codes:?}"
            );
        }
    }
    assert!(open_blocks(&closed).0.is_empty());
}

/// samples/block_door.gltf turned 30° about Y and moved 50 km, its vertices baked in f32
/// (4 to 8 mm apart out there).
fn far_in_f32() -> String {
    use base64::Engine;
    let b64 = base64::engine::general_purpose::STANDARD;
    let mut d: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(sample("block_door.gltf")).unwrap()).unwrap();
    let uri = d["buffers"][0]["uri"].as_str().unwrap().to_string();
    let mut buf = b64.decode(uri.split_once(',').unwrap().1).unwrap();
    let (c, s) = (30f64.to_radians().cos(), 30f64.to_radians().sin());
    let views = d["bufferViews"].clone();
    for a in d["accessors"].as_array_mut().unwrap() {
        if a["type"] != "VEC3" {
            continue;
        }
        let v = &views[a["bufferView"].as_u64().unwrap() as usize];
        let off = (v["byteOffset"].as_u64().unwrap_or(0) + a["byteOffset"].as_u64().unwrap_or(0))
            as usize;
        let (mut lo, mut hi) = ([f32::MAX; 3], [f32::MIN; 3]);
        for i in 0..a["count"].as_u64().unwrap() as usize {
            let at = off + 12 * i;
            let r = |k: usize| {
                f32::from_le_bytes(buf[at + 4 * k..at + 4 * k + 4].try_into().unwrap()) as f64
            };
            let (x, y, z) = (r(0), r(1), r(2));
            let p = [
                (c * x + s * z + 5e4) as f32,
                y as f32,
                (-s * x + c * z + 5e4) as f32,
            ];
            for k in 0..3 {
                buf[at + 4 * k..at + 4 * k + 4].copy_from_slice(&p[k].to_le_bytes());
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        a["min"] = serde_json::json!(lo);
        a["max"] = serde_json::json!(hi);
    }
    d["buffers"][0]["uri"] =
        format!("data:application/octet-stream;base64,{}", b64.encode(&buf)).into();
    d.to_string()
}

/// Item 5: a level baked into f32 50 km out, turned, leaks through rounding. The precision
/// warning says how far apart its coordinates are and how far out, that pieces meant to meet
/// miss by that much, and how to fix it; each leak's hint points at it.
#[test]
fn f32_precision_far_out_is_explained() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("far.gltf");
    std::fs::write(&path, far_in_f32()).unwrap();
    let r = sealed_report(&path);
    let diags = r["files"][0]["diagnostics"].as_array().unwrap();
    let capped = diags
        .iter()
        .find(|d| d["code"] == "TOLERANCE_CAPPED")
        .unwrap();
    let m = capped["message"].as_str().unwrap();
    assert!(
        m.contains("6.0e-3 m apart") && m.contains("50010 m from the origin"),
        "{m}"
    );
    assert!(m.contains("may miss by that much"), "{m}");
    let h = capped["hint"].as_str().unwrap();
    assert!(
        h.contains("node transform") && h.contains("nearer the origin"),
        "{h}"
    );
    let leaks: Vec<&serde_json::Value> = diags.iter().filter(|d| d["code"] == "LEAK").collect();
    assert!(!leaks.is_empty(), "rounding leaves gaps: {diags:?}");
    for l in leaks {
        assert!(
            l["hint"].as_str().unwrap().contains("see TOLERANCE_CAPPED"),
            "{l}"
        );
    }
}
