//! A run of `convert` that exits non-zero leaves no main output: arguments are checked before
//! work starts, a level with errors is not written (its `--debug` and `--svg` still are), and
//! two inputs never race for one output file.

mod common;

use std::path::Path;

use assert_cmd::Command;
use common::sample;

fn convert(args: &[&std::ffi::OsStr], cwd: &Path) -> std::process::Output {
    Command::cargo_bin("portcullis")
        .unwrap()
        .env("NO_COLOR", "1")
        .current_dir(cwd)
        .arg("convert")
        .args(args)
        .output()
        .unwrap()
}

fn os(s: &str) -> &std::ffi::OsStr {
    s.as_ref()
}

/// The files a run left in `dir`, sorted.
fn left(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = walk(dir)
        .into_iter()
        .map(|p| p.strip_prefix(dir).unwrap().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

fn walk(dir: &Path) -> Vec<std::path::PathBuf> {
    let mut v = Vec::new();
    for e in std::fs::read_dir(dir).unwrap().flatten() {
        let p = e.path();
        if p.is_dir() {
            v.extend(walk(&p));
        } else {
            v.push(p);
        }
    }
    v
}

#[test]
fn a_sealed_level_that_leaks_is_not_written_but_its_debug_output_is() {
    let dir = tempfile::tempdir().unwrap();
    let leak = sample("broken/LEAK/level.gltf");
    let o = convert(
        &[
            leak.as_os_str(),
            os("--sealed"),
            os("-o"),
            os("out.glb"),
            os("--debug"),
            os("d.glb"),
            os("--svg"),
            os("m.svg"),
            os("--prt"),
            os("p.prt"),
        ],
        dir.path(),
    );
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("LEAK"), "{err}");
    assert!(err.contains("nothing written to `out.glb`"), "{err}");
    assert_eq!(left(dir.path()), ["d.glb", "m.svg"], "{err}");
}

#[test]
fn warnings_denied_leave_no_output_and_allowed_warnings_do() {
    // A level with a warning and no error: written, unless warnings are denied.
    let dir = tempfile::tempdir().unwrap();
    let level = sample("broken/GRAPH_UNREACHABLE.gltf");
    let plain = convert(&[level.as_os_str(), os("-o"), os("a.glb")], dir.path());
    let err = String::from_utf8_lossy(&plain.stderr);
    assert_eq!(plain.status.code(), Some(0), "{err}");
    assert!(err.contains("warning["), "{err}");
    let denied = convert(
        &[
            level.as_os_str(),
            os("-o"),
            os("b.glb"),
            os("--deny"),
            os("warnings"),
        ],
        dir.path(),
    );
    assert_eq!(denied.status.code(), Some(1));
    assert_eq!(left(dir.path()), ["a.glb"]);
}

#[test]
fn a_cell_index_beyond_the_level_fails_before_anything_is_written() {
    let dir = tempfile::tempdir().unwrap();
    let level = sample("two_rooms.gltf");
    let o = convert(
        &[
            level.as_os_str(),
            os("-o"),
            os("out.glb"),
            os("--svg"),
            os("m.svg"),
            os("--pvs-of"),
            os("9"),
        ],
        dir.path(),
    );
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("--pvs-of 9: the level has 2 cells"), "{err}");
    assert!(left(dir.path()).is_empty(), "{:?}", left(dir.path()));
}

#[test]
fn a_missing_output_folder_is_refused_before_work_starts() {
    let level = sample("two_rooms.gltf");
    for flag in ["--debug", "--svg", "--prt", "-o"] {
        let dir = tempfile::tempdir().unwrap();
        let bad = match flag {
            "--svg" => "no/such/dir/m.svg",
            "--prt" => "no/such/dir/p.prt",
            _ => "no/such/dir/d.glb",
        };
        let mut args = vec![level.as_os_str(), os(flag), os(bad)];
        if flag != "-o" {
            args.extend([os("-o"), os("out.glb")]);
        }
        let o = convert(&args, dir.path());
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{flag}: {err}");
        assert!(
            err.contains("`no/such/dir` does not exist"),
            "{flag}: {err}"
        );
        assert!(
            left(dir.path()).is_empty(),
            "{flag}: {:?}",
            left(dir.path())
        );
    }
}

#[test]
fn out_dir_refuses_two_inputs_of_the_same_name_before_any_output() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = (dir.path().join("a"), dir.path().join("b"));
    std::fs::create_dir_all(&a).unwrap();
    std::fs::create_dir_all(&b).unwrap();
    std::fs::create_dir_all(dir.path().join("out")).unwrap();
    let two_rooms = std::fs::read(sample("two_rooms.gltf")).unwrap();
    std::fs::write(a.join("level.gltf"), &two_rooms).unwrap();
    std::fs::write(b.join("level.gltf"), &two_rooms).unwrap();
    std::fs::copy(sample("two_rooms.obj"), a.join("level.obj")).unwrap();
    for pair in [
        ["a/level.gltf", "b/level.gltf"],
        ["a/level.gltf", "a/level.obj"],
    ] {
        let o = convert(
            &[os(pair[0]), os(pair[1]), os("--out-dir"), os("out")],
            dir.path(),
        );
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{pair:?}: {err}");
        assert!(
            err.contains(&format!(
                "`{}` and `{}` would both be written to `out/level.glb`",
                pair[0], pair[1]
            )),
            "{err}"
        );
        assert!(
            std::fs::read_dir(dir.path().join("out"))
                .unwrap()
                .next()
                .is_none(),
            "{pair:?}"
        );
    }
    // Different names in one folder are both written.
    std::fs::copy(sample("two_rooms.obj"), b.join("other.obj")).unwrap();
    let o = convert(
        &[
            os("a/level.gltf"),
            os("b/other.obj"),
            os("--out-dir"),
            os("out"),
        ],
        dir.path(),
    );
    assert_eq!(o.status.code(), Some(0));
    assert_eq!(left(&dir.path().join("out")), ["level.glb", "other.glb"]);
}

/// `-o` names the level's own file: an extension portcullis writes only beside it (an SVG map,
/// an HTML page) or not at all is refused before any work, and nothing is written.
#[test]
fn an_output_that_is_not_a_level_format_is_refused_and_nothing_written() {
    let level = sample("two_rooms.gltf");
    for out in ["map.svg", "page.html", "level.txt"] {
        let dir = tempfile::tempdir().unwrap();
        let o = convert(&[level.as_os_str(), os("-o"), os(out)], dir.path());
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{out}: {err}");
        assert!(
            err.contains("error[OUTPUT_FORMAT_UNKNOWN]")
                && err.contains(&format!(
                    "cannot write `{out}`: portcullis writes .gltf, .glb and .usda"
                )),
            "{out}: {err}"
        );
        assert!(left(dir.path()).is_empty(), "{out}: {:?}", left(dir.path()));
    }
}
