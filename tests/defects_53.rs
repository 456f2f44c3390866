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
