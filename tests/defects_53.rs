//! Issue 53: defects a new user hits, one test each (each failed before its fix).

mod common;

use common::sample;

fn portcullis() -> assert_cmd::Command {
    assert_cmd::Command::cargo_bin("portcullis").unwrap()
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
