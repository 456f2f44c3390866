//! Brush maps read directly (issue 42, first part): `src/import/map`'s brushes against the
//! box volumes the maps' own face points give, every brush closed and facing out, the verdicts
//! of qbsp on maps written here, and malformed maps that must end in a code, a line and exit
//! 2, never a panic.

mod common;

use glam::DVec3;
use portcullis::import::{import_bytes, ImportOptions};
use portcullis::scene::Format;

fn read(text: &str) -> portcullis::import::Imported {
    import_bytes(
        text.as_bytes(),
        std::path::Path::new("t.map"),
        Format::Map,
        std::path::Path::new("."),
        &ImportOptions::default(),
    )
    .unwrap_or_else(|d| panic!("{d}"))
}

/// Signed volume of a closed triangle list (divergence theorem about its first corner).
fn volume(tris: &[[DVec3; 3]]) -> f64 {
    let o = tris[0][0];
    tris.iter()
        .map(|t| (t[0] - o).dot((t[1] - o).cross(t[2] - o)) / 6.0)
        .sum()
}

/// The volumes (m³, Quake units to metres) of a map's brushes when every brush is a box on the
/// axes: each face's three points share the coordinate the face stands on, so a brush spans,
/// along each axis, from the least to the greatest of the coordinates its faces stand on there.
/// The map's own numbers, read without the importer.
fn box_volumes(text: &str) -> Vec<f64> {
    let mut out = Vec::new();
    let mut faces: Vec<[[f64; 3]; 3]> = Vec::new();
    for line in text.lines().map(str::trim) {
        if line.starts_with('(') {
            let nums: Vec<f64> = line
                .split(')')
                .take(3)
                .map(|p| p.trim_start_matches([' ', '(']).to_string())
                .flat_map(|p| {
                    p.split_whitespace()
                        .map(|x| x.parse::<f64>().unwrap())
                        .collect::<Vec<_>>()
                })
                .collect();
            faces.push([
                [nums[0], nums[1], nums[2]],
                [nums[3], nums[4], nums[5]],
                [nums[6], nums[7], nums[8]],
            ]);
        } else if line == "}" && !faces.is_empty() {
            let mut v = 1.0;
            for k in 0..3 {
                let on: Vec<f64> = faces
                    .iter()
                    .filter(|f| f[0][k] == f[1][k] && f[1][k] == f[2][k])
                    .map(|f| f[0][k])
                    .collect();
                let (lo, hi) = on
                    .iter()
                    .fold((f64::MAX, f64::MIN), |(a, b), &x| (a.min(x), b.max(x)));
                v *= (hi - lo) * 0.0254;
            }
            out.push(v);
            faces.clear();
        }
    }
    out
}

/// The importer's mesh volumes of `text` against its box volumes: the same list.
fn brush_volumes_agree(text: &str, what: &str) -> usize {
    let im = read(text);
    let mut want = box_volumes(text);
    let mut got: Vec<f64> = im
        .scene
        .meshes
        .iter()
        .map(|m| {
            let t: Vec<[DVec3; 3]> = m
                .triangles
                .iter()
                .map(|t| t.map(|i| m.positions[i as usize]))
                .collect();
            volume(&t)
        })
        .collect();
    want.sort_by(f64::total_cmp);
    got.sort_by(f64::total_cmp);
    assert_eq!(got.len(), want.len(), "{what}: brushes");
    for (g, w) in got.iter().zip(&want) {
        assert!((g - w).abs() <= 1e-9 + 1e-9 * w.abs(), "{what}: {g} vs {w}");
    }
    got.len()
}

#[test]
fn the_sample_map_has_the_oracles_brushes_and_two_rooms_through_a_door() {
    let path = common::sample("brush_rooms.map");
    let text = std::fs::read_to_string(&path).unwrap();
    assert_eq!(brush_volumes_agree(&text, "brush_rooms.map"), 10);
    let (t, c, p) = common::load_level(&path, None);
    // Two rooms of air and the door reveal in the 16 unit wall; the crate is detail.
    assert_eq!(c.cells.len(), 3);
    let inch = 0.0254f64;
    let total: f64 = c.cells.iter().map(|c| c.volume).sum();
    let air = (2.0 * 256.0 * 256.0 * 128.0 + 16.0 * 64.0 * 96.0) * inch.powi(3);
    assert!((total - air).abs() < 1e-6 * air, "{total} vs {air}");
    let door = 64.0 * 96.0 * inch * inch;
    let between: Vec<_> = p.portals.iter().filter(|q| q.to.is_some()).collect();
    assert_eq!(between.len(), 4);
    assert!(between.iter().all(|q| (q.area - door).abs() < 1e-6));
    assert_eq!(t.tagging.player_starts.len(), 1);
    assert!(
        t.tagging.rooms[0].detail.len() == 1,
        "the func_detail crate"
    );
}

/// On real maps (angled brushes, Quake 2 contents): every brush the importer makes is a closed
/// mesh (each edge met once each way, vertices matched by position) enclosing positive volume
/// with its triangles facing out.
#[test]
fn real_maps_brushes_are_closed_and_face_out() {
    let dir = common::testmaps::dir();
    if !dir.join("qbspfeatures.map").is_file() {
        eprintln!(
            "skipped: ericw-tools' testmaps are not at {}",
            dir.display()
        );
        return;
    }
    for name in ["E1M1-edited-ents.map", "qbspfeatures.map", "base1leak.map"] {
        let im = read(&std::fs::read_to_string(dir.join(name)).unwrap());
        assert!(!im.scene.meshes.is_empty(), "{name}");
        for (k, m) in im.scene.meshes.iter().enumerate() {
            let key = |i: u32| m.positions[i as usize].to_array().map(f64::to_bits);
            let mut edges = std::collections::HashMap::new();
            for t in &m.triangles {
                for e in 0..3 {
                    *edges
                        .entry((key(t[e]), key(t[(e + 1) % 3])))
                        .or_insert(0i32) += 1;
                }
            }
            for ((a, b), n) in &edges {
                assert_eq!(edges.get(&(*b, *a)), Some(n), "{name}: brush {k} is open");
            }
            let t: Vec<[DVec3; 3]> = m
                .triangles
                .iter()
                .map(|t| t.map(|i| m.positions[i as usize]))
                .collect();
            assert!(volume(&t) > 0.0, "{name}: brush {k} faces in or is flat");
        }
    }
}

/// `portcullis check` on a map written into a temporary folder: exit code and output.
fn check(text: &[u8], flags: &[&str]) -> (i32, String) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("m.map");
    std::fs::write(&path, text).unwrap();
    let out = assert_cmd::Command::cargo_bin("portcullis")
        .unwrap()
        .arg("check")
        .args(flags)
        .arg(&path)
        .output()
        .unwrap();
    let text =
        String::from_utf8_lossy(&out.stdout).to_string() + &String::from_utf8_lossy(&out.stderr);
    (out.status.code().unwrap_or(-1), text)
}

#[test]
fn malformed_maps_give_a_code_a_line_and_exit_2() {
    let face = "( 0 0 0 ) ( 0 1 0 ) ( 0 0 1 ) t 0 0 0 1 1\n";
    let cases: Vec<(&str, String, &str, Option<usize>)> = vec![
        (
            "unbalanced braces",
            format!("{{\n\"classname\" \"worldspawn\"\n{{\n{face}"),
            "MAP_SYNTAX",
            Some(4),
        ),
        (
            "a stray closing brace",
            "}\n".to_string(),
            "MAP_SYNTAX",
            Some(1),
        ),
        (
            "three collinear plane points",
            "{\n{\n( 0 0 0 ) ( 1 1 1 ) ( 2 2 2 ) t 0 0 0 1 1\n}\n}\n".to_string(),
            "MAP_BRUSH_INVALID",
            Some(3),
        ),
        (
            "a brush of three planes",
            "{\n\"classname\" \"worldspawn\"\n{\n( 0 0 0 ) ( 0 1 0 ) ( 0 0 1 ) a 0 0 0 1 1\n( 0 0 0 ) ( 0 0 1 ) ( 1 0 0 ) a 0 0 0 1 1\n( 0 0 0 ) ( 1 0 0 ) ( 0 1 0 ) a 0 0 0 1 1\n}\n}\n".to_string(),
            "MAP_BRUSH_INVALID",
            Some(3),
        ),
        (
            "NaN",
            "{\n{\n( 0 0 nan ) ( 0 1 0 ) ( 0 0 1 ) t 0 0 0 1 1\n}\n}\n".to_string(),
            "MAP_SYNTAX",
            Some(3),
        ),
        (
            "unknown texture syntax",
            "{\n{\n( 0 0 0 ) ( 0 1 0 ) ( 0 0 1 ) t < 1 0 0 > 0 0 0 1 1\n}\n}\n".to_string(),
            "MAP_SYNTAX",
            Some(3),
        ),
        (
            "a brush of 1,025 faces (the most is 1,024)",
            format!("{{\n\"classname\" \"worldspawn\"\n{{\n{}}}\n}}\n", face.repeat(1025)),
            "MAP_BRUSH_INVALID",
            Some(3),
        ),
        ("0 bytes", String::new(), "INPUT_EMPTY", None),
        ("not text", String::new(), "MAP_SYNTAX", None),
    ];
    for (what, text, code, line) in cases {
        let bytes = if what == "not text" {
            vec![0x7b, 0x0a, 0xff, 0xfe]
        } else {
            text.into_bytes()
        };
        let (exit, out) = check(&bytes, &[]);
        assert_eq!(exit, 2, "{what}: {out}");
        assert!(out.contains(&format!("[{code}]")), "{what}: {out}");
        if let Some(l) = line {
            assert!(
                out.contains(&format!("m.map:{l}")),
                "{what}: line {l} in {out}"
            );
        }
        assert!(!out.contains("panicked"), "{what}: {out}");
        if what.contains("1,025") {
            assert!(out.contains("has 1025 faces, more than the 1024"), "{out}");
        }
    }
}

#[test]
fn check_sealed_gives_qbsps_verdicts_on_maps_written_here() {
    let sample = std::fs::read_to_string(common::sample("brush_rooms.map")).unwrap();
    let (exit, out) = check(sample.as_bytes(), &["--sealed"]);
    assert_eq!(exit, 0, "{out}");
    // The same map with the east wall's brush gone: a leak from the player start.
    let lines: Vec<&str> = sample.lines().collect();
    let wall = lines
        .iter()
        .position(|l| l.starts_with("( 544 0 0 ) "))
        .expect("the east wall");
    let open = wall - 1;
    let close = open + lines[open..].iter().position(|l| *l == "}").unwrap();
    let leaky: String = lines[..open]
        .iter()
        .chain(&lines[close + 1..])
        .map(|l| format!("{l}\n"))
        .collect();
    let (exit, out) = check(leaky.as_bytes(), &["--sealed"]);
    assert_eq!(exit, 1, "{out}");
    assert!(
        out.contains("[LEAK]") && out.contains("from player start"),
        "{out}"
    );

    // `--pts`: the leak as qbsp's point file, in map units (Z up), a point at most every 2
    // units from the player start (128 128 40) out through the missing wall (x > 544).
    let dir = tempfile::tempdir().unwrap();
    let (map, pts) = (dir.path().join("leaky.map"), dir.path().join("leaky.pts"));
    std::fs::write(&map, &leaky).unwrap();
    let run = |map: &std::path::Path| {
        assert_cmd::Command::cargo_bin("portcullis")
            .unwrap()
            .args(["check", "--sealed", "--pts"])
            .arg(&pts)
            .arg(map)
            .output()
            .unwrap()
    };
    assert_eq!(run(&map).status.code(), Some(1));
    let points: Vec<DVec3> = std::fs::read_to_string(&pts)
        .unwrap()
        .lines()
        .map(|l| {
            let v: Vec<f64> = l.split(' ').map(|x| x.parse().unwrap()).collect();
            DVec3::new(v[0], v[1], v[2])
        })
        .collect();
    assert!(points.len() > 200, "{}", points.len());
    assert!(points[0].distance(DVec3::new(128.0, 128.0, 40.0)) < 1e-3);
    assert!(points.last().unwrap().x > 544.0);
    assert!(points.windows(2).all(|w| w[0].distance(w[1]) <= 2.0 + 1e-3));
    assert!(
        points.iter().all(|p| p.z > 0.0 && p.z < 128.0),
        "inside the room's height"
    );
    // Sealed: no point file is written.
    std::fs::remove_file(&pts).unwrap();
    assert_eq!(
        run(&common::sample("brush_rooms.map")).status.code(),
        Some(0)
    );
    assert!(!pts.exists());
}

#[test]
fn map_scale_sets_the_metres_per_unit() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("rooms.map");
    std::fs::copy(common::sample("brush_rooms.map"), &path).unwrap();
    let volume = |dir: &std::path::Path| {
        let (_, c) = common::load_cells(&dir.join("rooms.map"), None);
        c.cells.iter().map(|c| c.volume).sum::<f64>()
    };
    let inches = volume(dir.path());
    std::fs::write(
        dir.path().join("portcullis.toml"),
        "[import]\nmap_scale = 0.03125\n",
    )
    .unwrap();
    let scaled = volume(dir.path());
    let ratio = (0.03125f64 / 0.0254).powi(3);
    assert!(
        (scaled / inches - ratio).abs() < 1e-9,
        "{scaled} / {inches}"
    );
}

/// samples/brush_doors.map: rooms A, B, C through two doorways (64 x 96 units in 16 unit
/// walls), a `func_door` filling the first, a 4 unit `func_areaportal` in the middle of the
/// second. Each gate's air is a cell of its own; the portals on its faces are the gate's (a
/// door's close with it), and closing them at run time hides what lies beyond.
#[test]
fn doors_and_area_portals_in_a_brush_map_own_the_portals_they_fill() {
    use portcullis::runtime::{Doors, Level, Location, Trace, TraceOptions, View};
    let path = common::sample("brush_doors.map");
    let (t, c, p) = common::load_level(&path, None);
    let inch = 0.0254f64;
    // Three rooms, the door's reveal, and the area portal's reveal in three slabs.
    assert_eq!(c.cells.len(), 7);
    let total: f64 = c.cells.iter().map(|c| c.volume).sum();
    let air = (3.0 * 256.0 * 256.0 * 128.0 + 2.0 * 16.0 * 64.0 * 96.0) * inch.powi(3);
    assert!((total - air).abs() < 1e-6 * air, "{total} vs {air}");
    let node = |name: &str| {
        (0..t.scene.nodes.len())
            .find(|&n| t.scene.nodes[n].name.as_deref() == Some(name))
            .unwrap()
    };
    let (door, gate) = (
        node("func_door 1 brush 0"),
        node("func_areaportal 2 brush 0"),
    );
    let doorway = 64.0 * 96.0 * inch * inch;
    // Map x of each portal (scene x is map x in metres), sorted.
    let xs = |f: &dyn Fn(&portcullis::portals::Portal) -> bool| {
        let mut v: Vec<f64> = p
            .portals
            .iter()
            .filter(|q| f(q))
            .map(|q| {
                assert!((q.area - doorway).abs() < 1e-6, "a portal is the doorway");
                (q.polygon[0].x / inch * 1e6).round() / 1e6
            })
            .collect();
        v.sort_by(f64::total_cmp);
        v
    };
    assert_eq!(
        xs(&|q| q.door && q.authored == Some(door)),
        [256.0, 256.0, 272.0, 272.0]
    );
    assert_eq!(
        xs(&|q| !q.door && q.authored == Some(gate)),
        [534.0, 534.0, 538.0, 538.0]
    );
    assert_eq!(p.portals.iter().filter(|q| q.door).count(), 4);
    assert_eq!(p.portals.len(), 12);
    // The area portal cuts the map into two areas, two rooms: A and B (the door between
    // them), the larger, keep `world`; C is `world_area1`; the area portal's cell joins one
    // of them (the area it touches first by cell number: its two neighbours are equal slabs,
    // so either). The one portal pair between the rooms is on one face of the area portal.
    let names: Vec<&str> = t.tagging.rooms.iter().map(|r| r.name.as_str()).collect();
    assert_eq!(names, ["world", "world_area1"]);
    assert_eq!(t.tagging.rooms[1].area_of, Some(0));
    let between: Vec<_> = p.portals.iter().filter(|q| !q.internal).collect();
    let face = xs(&|q| !q.internal);
    assert!(
        face == [534.0, 534.0] || face == [538.0, 538.0],
        "one pair of portals on a face of the area portal: {face:?}"
    );
    assert!(between.iter().all(|q| q.authored == Some(gate)));
    let start = t.tagging.player_starts[0].node;
    let at = t.scene.nodes[start].world.w_axis.truncate();
    let start_cell = (0..c.cells.len())
        .find(|&i| c.cells[i].poly.contains(at, 1e-9))
        .unwrap();
    assert_eq!(c.cells[start_cell].room, 0, "the start is in room A, world");

    // In the written glTF: the door's portals say `door` and name its node; in the runtime,
    // a camera in room A sees room C down the line of doorways until the door closes.
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("doors.glb");
    portcullis::pipeline::convert_file(&path, &out).unwrap();
    let (doc, _) = common::read_gltf(&std::fs::read(&out).unwrap());
    let ext = &doc["extensions"]["PORTCULLIS_portals"];
    let records = ext["portals"].as_array().unwrap();
    let door_portals: Vec<usize> = (0..records.len())
        .filter(|&i| records[i]["door"] == true)
        .collect();
    assert_eq!(door_portals.len(), 4);
    for &i in &door_portals {
        let n = records[i]["node"].as_u64().unwrap() as usize;
        assert_eq!(doc["nodes"][n]["name"], "func_door 1 brush 0");
    }
    let level = Level::load(&out).unwrap();
    let mut doors = Doors::new(&level);
    // Map (64, 128, 48): in room A, looking along +x through both doorways.
    let eye = [64.0 * inch, 48.0 * inch, -128.0 * inch];
    let view = View::new(eye, [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], 60.0, 1.0, 0.01).unwrap();
    let mut trace = Trace::default();
    level.trace(&view, &doors, &TraceOptions::default(), &mut trace);
    let room_c = level.locate(DVec3::new(700.0 * inch, 48.0 * inch, -128.0 * inch), None);
    let Location::Inside(room_c) = room_c else {
        panic!("room C's middle is in a cell: {room_c:?}")
    };
    let sees = |trace: &Trace, cell: usize| trace.visible().iter().any(|s| s.cell == Some(cell));
    assert!(sees(&trace, room_c), "room C through both open doorways");
    for &i in &door_portals {
        doors.set(&level, i, true);
    }
    level.trace(&view, &doors, &TraceOptions::default(), &mut trace);
    assert!(!sees(&trace, room_c), "the closed door hides room C");
    assert_eq!(trace.visible().len(), 1, "only room A with the door closed");
}

/// Which brushes are gates, by the conventions of each format: doors and lifts by class, area
/// portals by class (Quake 2), contents (Quake 2) or a portal face (id Tech 4 `visportal`,
/// Quake 3 `areaportal`, whatever its other faces); a visportal brush is never a wall.
#[test]
fn doors_lifts_and_area_portals_are_known_in_every_format() {
    let quake = |class: &str, tex: &str| {
        let faces: Vec<String> = [
            ("( 64 0 1 ) ( 64 1 0 ) ( 64 0 0 )", tex),
            ("( 0 1 0 ) ( 0 0 1 ) ( 0 0 0 )", "wall"),
            ("( 1 64 0 ) ( 0 64 1 ) ( 0 64 0 )", "wall"),
            ("( 0 0 1 ) ( 1 0 0 ) ( 0 0 0 )", "wall"),
            ("( 0 1 64 ) ( 1 0 64 ) ( 0 0 64 )", "wall"),
            ("( 1 0 0 ) ( 0 1 0 ) ( 0 0 0 )", "wall"),
        ]
        .iter()
        .map(|(p, t)| format!("{p} {t} 0 0 0 1 1"))
        .collect();
        format!(
            "{{\n\"classname\" \"worldspawn\"\n}}\n{{\n\"classname\" \"{class}\"\n{{\n{}\n}}\n}}\n",
            faces.join("\n")
        )
    };
    let doom3 = |tex: &str| {
        let faces: Vec<String> = [
            ("1 0 0 -64", tex),
            ("-1 0 0 0", "textures/common/nodraw"),
            ("0 1 0 -64", "textures/common/nodraw"),
            ("0 -1 0 0", "textures/common/nodraw"),
            ("0 0 1 -64", "textures/common/nodraw"),
            ("0 0 -1 0", "textures/common/nodraw"),
        ]
        .iter()
        .map(|(p, t)| format!("( {p} ) ( ( 0.0078125 0 0 ) ( 0 0.0078125 0 ) ) \"{t}\" 0 0 0"))
        .collect();
        format!(
            "Version 2\n{{\n\"classname\" \"worldspawn\"\n{{\nbrushDef3\n{{\n{}\n}}\n}}\n}}\n",
            faces.join("\n")
        )
    };
    let flags = |text: &str| {
        let im = read(text);
        let n = im.scene.nodes.iter().find(|n| n.mesh.is_some()).unwrap();
        let e = n.extras.as_ref().unwrap();
        let on = |k: &str| e.get(k) == Some(&serde_json::Value::Bool(true));
        (on("door"), on("area_portal"), on("solid"))
    };
    assert_eq!(flags(&quake("func_door", "door")), (true, false, false));
    assert_eq!(
        flags(&quake("func_door_secret", "door")),
        (true, false, false)
    );
    assert_eq!(flags(&quake("func_plat", "plat")), (true, false, false));
    assert_eq!(
        flags(&quake("func_areaportal", "trigger")),
        (false, true, false)
    );
    assert_eq!(flags(&quake("func_wall", "wall")), (false, false, false));
    assert_eq!(
        flags(&quake("worldspawn", "common/areaportal")),
        (false, true, false)
    );
    assert_eq!(flags(&quake("worldspawn", "wall")), (false, false, true));
    assert_eq!(
        flags(&doom3("textures/editor/visportal")),
        (false, true, false)
    );
    assert_eq!(
        flags(&doom3("textures/base_wall/lfwall13f3")),
        (false, false, true)
    );

    // id Tech 4 writes a brush entity's brushes about its origin: a door at x = 1000.
    let world = doom3("textures/base_wall/lfwall13f3");
    let door = world
        .replacen(
            "\"worldspawn\"",
            "\"func_door\"\n\"origin\" \"1000 0 0\"",
            1,
        )
        .replacen(
            "Version 2\n",
            "Version 2\n{\n\"classname\" \"worldspawn\"\n}\n",
            1,
        );
    let im = read(&door);
    let n = im.scene.nodes.iter().find(|n| n.mesh.is_some()).unwrap();
    let xs: Vec<f64> = im.scene.meshes[n.mesh.unwrap()]
        .positions
        .iter()
        .map(|p| p.x / 0.0254)
        .collect();
    let (lo, hi) = xs
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, b), &x| (a.min(x), b.max(x)));
    assert!(
        (lo - 1000.0).abs() < 1e-9 && (hi - 1064.0).abs() < 1e-9,
        "{lo}..{hi}"
    );
}

/// Quake 2 areas as qbsp makes them, on the maps whose area counts ericw-tools' own tests state
/// (`tests/test_qbsp_q2.cc`: `dareas.size()` less the reserved area 0): each area is a room, and
/// rooms meet only at the area portals. On q2_areaportals.map the player start's area borders
/// the light's alone and the light's borders two, as qbsp's area portal lists say.
#[test]
fn quake2_areas_are_the_rooms_qbsp_makes() {
    let dir = common::testmaps::dir();
    if !dir.join("q2_areaportal.map").is_file() {
        eprintln!(
            "skipped: ericw-tools' testmaps are not at {}",
            dir.display()
        );
        return;
    }
    for (name, areas) in [
        ("q2_areaportal.map", 2),
        ("q2_areaportal_with_detail.map", 2),
        ("q2_areaportals.map", 3),
        ("q2_double_areaportal.map", 3),
        ("q2_areaportal_split.map", 2),
    ] {
        let (t, c, p) = common::load_level(&dir.join(name), None);
        assert_eq!(t.tagging.rooms.len(), areas, "{name}: rooms");
        let between: Vec<_> = p
            .portals
            .iter()
            .filter(|q| q.to.is_some() && c.cells[q.from].room != c.cells[q.to.unwrap()].room)
            .collect();
        assert!(!between.is_empty(), "{name}");
        for q in between {
            let n = q
                .authored
                .expect("a portal between areas is an area portal's");
            let class = t.scene.nodes[n].extras.as_ref().unwrap()["classname"].clone();
            assert_eq!(class, "func_areaportal", "{name}");
        }
        if name == "q2_areaportals.map" {
            let room_of = |class: &str| {
                let n = (0..t.scene.nodes.len())
                    .find(|&n| t.scene.nodes[n].name.as_deref() == Some(class))
                    .unwrap();
                let at = t.scene.nodes[n].world.w_axis.truncate();
                let cell = (0..c.cells.len())
                    .find(|&i| c.cells[i].poly.contains(at, 1e-9))
                    .unwrap_or_else(|| panic!("{class} is in a cell"));
                c.cells[cell].room
            };
            let neighbours = |r: usize| {
                let mut v: Vec<usize> = p
                    .portals
                    .iter()
                    .filter(|q| c.cells[q.from].room == r)
                    .filter_map(|q| q.to.map(|to| c.cells[to].room))
                    .filter(|&o| o != r)
                    .collect();
                v.sort_unstable();
                v.dedup();
                v
            };
            let (start, light, grenades) = (
                room_of("info_player_start"),
                room_of("light"),
                room_of("ammo_grenades"),
            );
            assert_eq!(neighbours(start), [light]);
            let mut both = vec![start, grenades];
            both.sort_unstable();
            assert_eq!(neighbours(light), both);
        }
    }
}

/// A glTF written from a brush map (doors, area portals, areas) passes the Khronos validator,
/// says it was read with the `quake` preset, and `check` on it, given no preset, reads it so:
/// its stored annotation (checked against the schema) is the level it was made from.
#[test]
fn a_gltf_written_from_a_brush_map_reads_back_as_the_same_level() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("doors.glb");
    let run = |args: &[&std::ffi::OsStr]| {
        assert_cmd::Command::cargo_bin("portcullis")
            .unwrap()
            .args(args)
            .output()
            .unwrap()
    };
    let sample = common::sample("brush_doors.map");
    let made = run(&[
        "convert".as_ref(),
        sample.as_os_str(),
        "-o".as_ref(),
        out.as_os_str(),
    ]);
    assert!(made.status.success());
    let (doc, _) = common::read_gltf(&std::fs::read(&out).unwrap());
    assert_eq!(doc["extensions"]["PORTCULLIS_portals"]["tags"], "quake");
    if let Some(report) = common::khronos_validate(&out) {
        assert_eq!(report["issues"]["numErrors"], 0, "{report}");
    }
    let checked = run(&["check".as_ref(), out.as_os_str()]);
    let text = String::from_utf8_lossy(&checked.stderr).to_string()
        + &String::from_utf8_lossy(&checked.stdout);
    assert!(checked.status.success(), "{text}");
    assert!(!text.contains("ANNOTATION_STALE"), "{text}");
    assert!(text.contains("7 cells, 12 portals (stored): ok"), "{text}");
}

/// Quake 3 brush primitives (`brushDef`): the sample map rewritten in them reads as the same
/// brushes (the oracle's volumes) and the same level (3 cells, the doorway's portals); a face's
/// detail contents (Radiant writes 134217728) make its brush detail, even in a `func_group`.
#[test]
fn quake3_brush_primitives_read_as_the_same_brushes() {
    let quake = std::fs::read_to_string(common::sample("brush_rooms.map")).unwrap();
    let mut q3 = String::new();
    let mut depth = 0;
    for line in quake.lines() {
        match line {
            "{" => {
                depth += 1;
                q3 += if depth == 2 {
                    "{\nbrushDef\n{\n"
                } else {
                    "{\n"
                };
            }
            "}" => {
                q3 += if depth == 2 { "}\n}\n" } else { "}\n" };
                depth -= 1;
            }
            l if l.starts_with('(') => {
                // `( p ) ( p ) ( p ) TEX 0 0 0 1 1` -> `( p ) ( p ) ( p ) ( ( m ) ( m ) ) TEX 0 0 0`
                let cut = l.rfind(')').unwrap() + 1;
                let tex = l[cut..].split_whitespace().next().unwrap();
                let contents = if tex == "crate" { "134217728" } else { "0" };
                q3 += &format!(
                    "{} ( ( 0.03125 0 0 ) ( 0 0.03125 0 ) ) {tex} {contents} 0 0\n",
                    &l[..cut]
                );
            }
            l => q3 += &format!("{l}\n"),
        }
    }
    // The crate's entity is a plain func_group here: only its contents make it detail.
    let q3 = q3.replace("\"func_detail\"", "\"func_group\"");
    assert!(q3.contains("brushDef") && !q3.contains("func_detail"));
    assert_eq!(brush_volumes_agree(&q3, "brushDef"), 10);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("q3.map");
    std::fs::write(&path, &q3).unwrap();
    let (t, c, p) = common::load_level(&path, None);
    assert_eq!(c.cells.len(), 3);
    assert_eq!(p.portals.iter().filter(|q| q.to.is_some()).count(), 4);
    assert_eq!(
        t.tagging.rooms[0].detail.len(),
        1,
        "the crate, by its contents"
    );
}
