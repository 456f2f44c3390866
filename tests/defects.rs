//! Issue 45: defects a new user hits, one test each (each failed before its fix).

mod common;

use common::sample;

fn portcullis() -> assert_cmd::Command {
    assert_cmd::Command::cargo_bin("portcullis").unwrap()
}

/// Item 5: `view` with a shard that holds no input writes no page, as `check`, `inspect` and
/// `vis` process nothing; the shard that holds it writes it.
#[test]
fn view_writes_nothing_for_an_empty_shard() {
    let dir = tempfile::tempdir().unwrap();
    let page = dir.path().join("page.html");
    let o = portcullis()
        .args(["view", "--shard", "2/2"])
        .arg(sample("two_rooms.gltf"))
        .arg("-o")
        .arg(&page)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(0));
    assert!(!page.exists(), "an empty shard wrote the page");
    assert!(String::from_utf8_lossy(&o.stderr).contains("shard 2/2: 0 of 1 inputs"));
    let o = portcullis()
        .args(["view", "--shard", "1/2"])
        .arg(sample("two_rooms.gltf"))
        .arg("-o")
        .arg(&page)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(0));
    assert!(page.exists());
}

/// Item 9: the command `view` suggests carries the options the user gave it.
#[test]
fn a_suggested_command_carries_the_users_options() {
    let dir = tempfile::tempdir().unwrap();
    let o = portcullis()
        .args(["view", "--tags", "godot", "--sealed"])
        .arg(sample("overlap_rooms.gltf"))
        .arg("-o")
        .arg(dir.path().join("page.html"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    let want = format!(
        "`portcullis check --tags godot --sealed {}`",
        sample("overlap_rooms.gltf").display()
    );
    assert!(err.contains(&want), "{err}");
}
