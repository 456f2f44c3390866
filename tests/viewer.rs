//! `portcullis view` and `check --html` in a real browser: Debian's headless Chromium driven by
//! playwright-core (tools/browser-test/check_page.mjs), both set up by scripts/test.sh. For
//! every sample and two shared levels the page opens from a file URL with no console error and
//! no network request, its counts are the extension's that `convert` writes, selecting a cell
//! lights exactly that cell's stored PVS row, and its screenshot shows the level. Without the
//! browser the tests are skipped, except under CI=true, where they fail.

mod common;

use std::path::{Path, PathBuf};

use assert_cmd::Command;
use serde_json::Value;

fn portcullis() -> Command {
    let mut c = Command::cargo_bin("portcullis").unwrap();
    c.env("NO_COLOR", "1");
    c
}

/// The driver and the browser, or `None` (outside CI) to skip.
fn driver() -> Option<(PathBuf, PathBuf)> {
    let script = common::root().join("tools/browser-test/check_page.mjs");
    let module = common::root().join("tools/browser-test/node_modules/playwright-core");
    let chromium =
        PathBuf::from(std::env::var_os("CHROMIUM").unwrap_or_else(|| "/usr/bin/chromium".into()));
    if module.is_dir() && chromium.exists() {
        return Some((script, chromium));
    }
    assert!(
        std::env::var_os("CI").is_none(),
        "CI=true but the browser tests cannot run: run scripts/test.sh (it installs Debian's \
         chromium and playwright-core into tools/browser-test/node_modules)"
    );
    eprintln!("skipped: no chromium or playwright-core (scripts/test.sh sets them up)");
    None
}

/// Opens `page` in the browser, selects `cells`, takes a screenshot to `shot`.
fn open(page: &Path, shot: &Path, cells: &[usize]) -> Value {
    let (script, chromium) = driver().expect("checked by the caller");
    let out = std::process::Command::new("node")
        .arg(script)
        .arg(page)
        .arg(shot)
        .args(cells.iter().map(|c| c.to_string()))
        .env("CHROMIUM", chromium)
        .output()
        .expect("node runs");
    let text = String::from_utf8_lossy(&out.stdout);
    serde_json::from_str(text.trim()).unwrap_or_else(|e| {
        panic!(
            "driver output is not JSON ({e}): {text}\n{}",
            String::from_utf8_lossy(&out.stderr)
        )
    })
}

/// The extension `convert` writes for `level`: (cells, portals, stored PVS rows).
fn converted(level: &Path, preset: Option<&str>, dir: &Path) -> (usize, usize, Vec<Vec<usize>>) {
    let out = dir.join("level.glb");
    let mut cmd = portcullis();
    cmd.arg("convert").arg(level).arg("-o").arg(&out);
    if let Some(p) = preset {
        cmd.args(["--tags", p]);
    }
    let o = cmd.output().unwrap();
    assert!(out.exists(), "{}", String::from_utf8_lossy(&o.stderr));
    // Read as an engine would: the runtime's loader.
    let level = portcullis::runtime::Level::load(&out).unwrap();
    let cells = level.cells();
    let rows = (0..cells)
        .map(|c| (0..cells).filter(|&v| level.pvs_sees(c, v)).collect())
        .collect();
    (cells, level.portals(), rows)
}

fn view(level: &Path, preset: Option<&str>, page: &Path) {
    let mut cmd = portcullis();
    cmd.arg("view").arg(level).arg("-o").arg(page);
    if let Some(p) = preset {
        cmd.args(["--tags", p]);
    }
    common::succeeds(&mut cmd);
}

fn levels() -> Vec<(PathBuf, Option<&'static str>)> {
    let mut v: Vec<(PathBuf, Option<&'static str>)> = common::levels_and_samples()
        .into_iter()
        .filter(|(p, _)| p.starts_with(common::root().join("samples")))
        .collect();
    v.push((common::fixture("MAP01_godot.glb"), None));
    v.push((common::fixture("panda3d_culling.glb"), Some("panda3d")));
    // A level nobody tagged, its rooms generated (`--tags auto`), when ../shared is beside.
    v.extend(
        shared_untagged()
            .into_iter()
            .take(1)
            .map(|p| (p, Some("auto"))),
    );
    v
}

/// The shared third-party levels with no tags that docs/auto.md shows, when they are there.
fn shared_untagged() -> Vec<PathBuf> {
    let dir = common::root().join("../shared/levels/godot");
    let found: Vec<PathBuf> = ["living_room.glb", "occlusion_room.glb"]
        .iter()
        .map(|n| dir.join(n))
        .filter(|p| p.exists())
        .collect();
    if found.is_empty() {
        eprintln!("skipped the auto levels: ../shared/levels/godot is missing");
    }
    found
}

#[test]
fn every_page_opens_offline_with_the_extensions_counts_and_pvs() {
    if driver().is_none() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    for (level, preset) in levels() {
        let name = level.file_name().unwrap().to_string_lossy().into_owned();
        let (cells, portals, rows) = converted(&level, preset, dir.path());
        let page = dir.path().join(format!("{name}.html"));
        view(&level, preset, &page);
        // Page size: at most 1.5 MB beyond the level's own bytes.
        let size = std::fs::metadata(&page).unwrap().len();
        let own = std::fs::metadata(&level).unwrap().len();
        assert!(size <= 1_500_000 + own, "{name}: {size} bytes");
        // A few cells, spread over the level.
        let picks: Vec<usize> = if cells == 0 {
            Vec::new()
        } else {
            let mut p = vec![0, cells / 2, cells - 1];
            p.dedup();
            p
        };
        let shot = dir.path().join(format!("{name}.png"));
        let r = open(&page, &shot, &picks);
        assert_eq!(r["errors"], serde_json::json!([]), "{name}: {r}");
        assert_eq!(r["ready"], true, "{name}");
        assert_eq!(r["cells"], cells, "{name}");
        assert_eq!(r["portals"], portals, "{name}");
        for c in picks {
            let lit: Vec<usize> =
                serde_json::from_value(r["selected"][c.to_string()].clone()).unwrap();
            let mut lit = lit;
            lit.sort_unstable();
            assert_eq!(lit, rows[c], "{name}: cell {c}");
        }
        // Not a blank canvas: a good share of it is not background, in many colours.
        let differ = r["shot"]["differ"].as_u64().unwrap();
        let pixels = r["shot"]["pixels"].as_u64().unwrap();
        assert!(
            differ * 50 > pixels,
            "{name}: only {differ} of {pixels} pixels drawn"
        );
        assert!(r["shot"]["colours"].as_u64().unwrap() > 8, "{name}: {r}");
        eprintln!("{name}: ready in {} ms, {size} bytes", r["readyMs"]);
    }
}

#[test]
fn check_html_lists_the_leak_beside_the_view() {
    if driver().is_none() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let page = dir.path().join("report.html");
    let o = portcullis()
        .arg("check")
        .arg(common::sample("broken/LEAK/level.gltf"))
        .arg("--html")
        .arg(&page)
        .output()
        .unwrap();
    assert_eq!(
        o.status.code(),
        Some(1),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let r = open(&page, &dir.path().join("report.png"), &[]);
    assert_eq!(r["errors"], serde_json::json!([]), "{r}");
    let listed = r["diagnostics"].as_str().unwrap();
    assert!(listed.contains("error[LEAK]"), "{listed}");
    assert!(listed.contains("opens to the exterior"), "{listed}");
}

/// The README's screenshot is the one this test makes (regenerate with
/// `PORTCULLIS_SCREENSHOT=docs/view.png cargo test --test viewer -- --ignored`).
#[test]
#[ignore = "writes docs/view.png; run by hand to refresh the README's screenshot"]
fn readme_screenshot() {
    if driver().is_none() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let page = dir.path().join("view.html");
    view(&common::fixture("lportal_boxrooms.glb"), None, &page);
    let target = std::env::var_os("PORTCULLIS_SCREENSHOT")
        .map(PathBuf::from)
        .unwrap_or_else(|| common::root().join("docs/view.png"));
    let r = open(&page, &target, &[]);
    assert_eq!(r["errors"], serde_json::json!([]), "{r}");
}

/// docs/auto.md's pictures: the shared untagged levels under `--tags auto`, one colour per
/// generated room (regenerate with `cargo test --release --test viewer -- --ignored auto_`).
#[test]
#[ignore = "writes docs/auto_*.png; run by hand to refresh docs/auto.md's pictures"]
fn auto_screenshots() {
    if driver().is_none() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    for level in shared_untagged() {
        let stem = level.file_stem().unwrap().to_string_lossy().into_owned();
        let page = dir.path().join(format!("{stem}.html"));
        view(&level, Some("auto"), &page);
        let r = open(
            &page,
            &common::root().join(format!("docs/auto_{stem}.png")),
            &[],
        );
        assert_eq!(r["errors"], serde_json::json!([]), "{r}");
    }
}

/// A generated building of 400 rooms opens and becomes interactive; the time is reported, not
/// asserted (timings belong to benchmarks).
#[test]
fn a_400_room_building_opens() {
    if driver().is_none() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let level = common::generated_building(dir.path(), 400, 3);
    let page = dir.path().join("big.html");
    view(&level, None, &page);
    let r = open(&page, &dir.path().join("big.png"), &[0]);
    assert_eq!(r["errors"], serde_json::json!([]), "{r}");
    let size = std::fs::metadata(&page).unwrap().len();
    let own = std::fs::metadata(&level).unwrap().len();
    assert!(
        size <= 1_500_000 + own,
        "{size} bytes for a {own}-byte level"
    );
    eprintln!(
        "400-room building: {} cells, interactive in {} ms, {} bytes",
        r["cells"],
        r["readyMs"],
        std::fs::metadata(&page).unwrap().len()
    );
}
