//! Quake portal files: the fixtures parse to the graphs the reference files describe, the PVS
//! contains the reference lower bound and has no more pairs than Quake's vis found, malformed
//! files give diagnostics with line numbers (never a panic), and export re-imports to the same
//! visibility.

mod common;

use std::path::{Path, PathBuf};

use assert_cmd::Command;
use portcullis::diag::Code;
use portcullis::prt::{self, PrtFormat};
use portcullis::vis::{self, Method, Pvs, VisOptions};

fn prt_fixture(name: &str) -> PathBuf {
    common::root().join("tests/fixtures/prt").join(name)
}

fn reference(path: &Path, cells: usize) -> Pvs {
    Pvs::parse_text(&std::fs::read_to_string(path).unwrap(), cells).unwrap()
}

/// The checks of issue 7 on one portal file: nesting, the lower bound inside full, and no
/// more pairs than vis.
fn check_file(prt_path: &Path, samples: usize) {
    let (file, diags) = prt::read(prt_path).unwrap();
    assert!(diags.iter().all(|d| !d.is_error()));
    let g = file.graph(None);
    let run = |m| {
        vis::compute(
            &g,
            &VisOptions {
                method: m,
                samples,
                ..Default::default()
            },
        )
    };
    let [flood, fast, full, sampled] = Method::ALL.map(run);
    assert!(
        sampled.is_subset_of(&full),
        "{:?}",
        sampled.missing_from(&full)
    );
    assert!(full.is_subset_of(&fast));
    assert!(fast.is_subset_of(&flood));
    let stem = prt_path.with_extension("");
    let lb = reference(&stem.with_extension("lb_pvs.txt"), g.cells);
    let vis_ref = reference(&stem.with_extension("vis_pvs.txt"), g.cells);
    let missing = lb.missing_from(&full);
    assert!(
        missing.is_empty(),
        "{}: lower-bound pairs missing from full: {:?}",
        prt_path.display(),
        &missing[..missing.len().min(10)]
    );
    assert!(
        full.pairs() <= vis_ref.pairs(),
        "{}: full has {} pairs, vis {}",
        prt_path.display(),
        full.pairs(),
        vis_ref.pairs()
    );
}

#[test]
fn fixtures_parse_to_the_documented_graphs() {
    for (name, cells, leaves, portals) in [
        ("qbspfeatures.prt", 18, 157, 37),
        ("light_general.prt", 65, 351, 142),
    ] {
        let (f, diags) = prt::read(&prt_fixture(name)).unwrap();
        assert!(diags.is_empty(), "{diags:?}");
        assert_eq!(f.format, PrtFormat::Prt2);
        assert_eq!(
            (f.cells, f.leaves, f.portals.len()),
            (cells, leaves, portals)
        );
        assert!(f.leaf_cluster.iter().all(|&c| c < cells));
        assert_eq!(f.graph(None).portals.len(), 2 * portals);
    }
}

/// Every line of a portal file is one polygon both ways, so every directed portal has its
/// reverse (what lets the flow use symmetry).
#[test]
fn every_prt_portal_has_its_reverse() {
    for name in ["qbspfeatures.prt", "light_general.prt"] {
        let (f, _) = prt::read(&prt_fixture(name)).unwrap();
        let g = f.graph(None);
        for (i, p) in g.portals.iter().enumerate() {
            let r = g.reverse[i].unwrap_or_else(|| panic!("{name}: portal {i} has no reverse"));
            assert_eq!((g.portals[r].from, g.portals[r].to), (p.to, p.from));
            assert_eq!(g.reverse[r], Some(i));
        }
    }
}

#[test]
fn full_contains_the_lower_bound_on_the_fixtures() {
    check_file(&prt_fixture("qbspfeatures.prt"), 500);
    check_file(&prt_fixture("light_general.prt"), 300);
}

/// The benchmark files: run with `cargo test --release --test prt -- --ignored`.
#[test]
#[ignore]
fn full_contains_the_lower_bound_on_the_benchmark_files() {
    for name in ["e3m4", "base1"] {
        let p = Path::new("../shared/prt").join(format!("{name}.prt"));
        let p = if p.exists() {
            p
        } else {
            Path::new("/work/shared/prt").join(format!("{name}.prt"))
        };
        check_file(&p, 200);
    }
}

#[test]
fn the_cli_prints_one_line_per_cell() {
    let out = Command::cargo_bin("portcullis")
        .unwrap()
        .args(["vis", "--method", "full"])
        .arg(prt_fixture("qbspfeatures.prt"))
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8(out.stdout).unwrap();
    assert_eq!(text.lines().count(), 18);
    let ours = Pvs::parse_text(&text, 18).unwrap();
    // On this small map vis, the lower bound and full agree exactly.
    assert_eq!(
        ours,
        reference(&prt_fixture("qbspfeatures.vis_pvs.txt"), 18)
    );
    let report = Command::cargo_bin("portcullis")
        .unwrap()
        .args(["vis", "--report", "--samples", "50"])
        .arg(prt_fixture("qbspfeatures.prt"))
        .output()
        .unwrap();
    let r = String::from_utf8(report.stdout).unwrap();
    for m in ["flood", "fast", "full", "sampled"] {
        assert!(r.contains(&format!("| {m} |")), "{r}");
    }
}

#[test]
fn prt1_and_prt1_am_parse() {
    let prt1 = "PRT1\n2\n1\n4 0 1 (0 0 0) (0 1 0) (0 1 1) (0 0 1)\n";
    let (f, d) = prt::parse(prt1, Path::new("a.prt")).unwrap();
    assert!(d.is_empty());
    assert_eq!(
        (f.format, f.cells, f.portals.len()),
        (PrtFormat::Prt1, 2, 1)
    );
    let am = "PRT1-AM\n2\n1\n3\n4 0 1 ( 0 0 0 ) ( 0 1 0 ) ( 0 1 1 ) ( 0 0 1 )\n0 1 1\n";
    let (f, d) = prt::parse(am, Path::new("a.prt")).unwrap();
    assert!(d.is_empty(), "{d:?}");
    assert_eq!(f.format, PrtFormat::Prt1Am);
    assert_eq!(f.leaf_cluster, vec![0, 1, 1]);
    // The plane faces into the first cell: the directed portal 1 → 0 travels along it.
    let g = f.graph(None);
    let p10 = g.portals.iter().find(|p| p.from == 1).unwrap();
    let n = (p10.winding[0] - p10.winding[1]).cross(p10.winding[2] - p10.winding[1]);
    assert!(n.dot(p10.plane.normal) > 0.0);
}

#[test]
fn malformed_files_give_diagnostics_with_lines() {
    let cases: &[(&str, Code, usize)] = &[
        ("PRT9\n1\n0\n", Code::PRT_UNKNOWN_FORMAT, 1),
        ("PRT1\nx\n0\n", Code::PRT_SYNTAX, 2),
        (
            "PRT1\n2\n2\n4 0 1 (0 0 0) (0 1 0) (0 1 1) (0 0 1)\n",
            Code::PRT_SYNTAX,
            5,
        ),
        (
            "PRT1\n2\n1\n4 0 7 (0 0 0) (0 1 0) (0 1 1) (0 0 1)\n",
            Code::PRT_BAD_INDEX,
            4,
        ),
        (
            "PRT1\n2\n1\n4 0 1 (0 0 0) (0 1 0) (0 1 1)\n",
            Code::PRT_SYNTAX,
            4,
        ),
        ("PRT1\n2\n1\n2 0 1 (0 0 0) (0 1 0)\n", Code::PRT_SYNTAX, 4),
        (
            "PRT1\n2\n1\n3 0 1 (0 0 0) (0 nan 0) (0 1 1)\n",
            Code::PRT_SYNTAX,
            4,
        ),
        ("PRT2\n2\n1\n0\n0 1\n", Code::PRT_SYNTAX, 5),
        ("PRT2\n2\n1\n0\n0 5 -1\n", Code::PRT_BAD_INDEX, 5),
        ("PRT1-AM\n1\n0\n2\n0 4\n", Code::PRT_BAD_INDEX, 5),
        ("PRT1\n99999999999\n0\n", Code::PRT_SYNTAX, 2),
    ];
    for (text, code, line) in cases {
        let e = prt::parse(text, Path::new("bad.prt")).unwrap_err();
        assert_eq!(e.code, *code, "{text:?}: {}", e.message);
        assert_eq!(
            e.location.source.line,
            Some(*line),
            "{text:?}: {}",
            e.message
        );
        assert!(e.hint.is_some());
    }
    assert_eq!(
        prt::parse("", Path::new("e.prt")).unwrap_err().code,
        Code::INPUT_EMPTY
    );
    // Warnings, not errors: a degenerate portal and text after the end.
    let (_, d) = prt::parse(
        "PRT1\n2\n1\n3 0 1 (0 0 0) (1 1 1) (2 2 2)\nextra\n",
        Path::new("w.prt"),
    )
    .unwrap();
    let codes: Vec<Code> = d.iter().map(|d| d.code).collect();
    assert!(
        codes.contains(&Code::PRT_PORTAL_DEGENERATE) && codes.contains(&Code::PRT_TRAILING_DATA)
    );
    // No prefix of a real file panics.
    let text = std::fs::read_to_string(prt_fixture("light_general.prt")).unwrap();
    for cut in (0..text.len()).step_by(97) {
        let _ = prt::parse(&text[..cut], Path::new("cut.prt"));
    }
    // Through the command line: exit 2 with the code and the line.
    let dir = tempfile::tempdir().unwrap();
    let bad = common::write(
        dir.path(),
        "bad.prt",
        "PRT1\n2\n1\n4 0 9 (0 0 0) (0 1 0) (0 1 1) (0 0 1)\n",
    );
    let out = Command::cargo_bin("portcullis")
        .unwrap()
        .arg("vis")
        .arg(&bad)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("PRT_BAD_INDEX") && err.contains(":4"), "{err}");
}

#[test]
fn export_round_trips_to_the_same_visibility() {
    let dir = tempfile::tempdir().unwrap();
    for (level, preset) in [
        (common::fixture("lportal_boxrooms.glb"), None),
        (common::fixture("panda3d_culling.glb"), Some("panda3d")),
        (common::sample("door_window.gltf"), None),
    ] {
        let (_, c, p) = common::load_level(&level, preset);
        let out = dir.path().join("level.prt");
        let mut cmd = Command::cargo_bin("portcullis").unwrap();
        cmd.arg("convert").arg(&level).arg("-o").arg(&out);
        if let Some(t) = preset {
            cmd.args(["--tags", t]);
        }
        let r = cmd.output().unwrap();
        assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
        let (file, diags) = prt::read(&out).unwrap();
        assert!(diags.is_empty(), "{diags:?}");
        assert_eq!(file.cells, c.cells.len());
        let two_way = p.pairs().filter(|&(i, _)| {
            let q = &p.portals[i];
            !q.closed && !q.one_way && q.transform.is_none() && q.to.is_some()
        });
        assert_eq!(file.portals.len(), two_way.count());
        let opts = VisOptions::default();
        // A .prt file has no outside (Quake's exterior is solid): the file's PVS is the
        // level's with its openings to the exterior walled up.
        let mut walled = p.clone();
        for q in walled.portals.iter_mut().filter(|q| q.to.is_none()) {
            q.closed = true;
        }
        let direct = vis::of_level(c.cells.len(), &walled, c.tolerance.distance, &opts);
        let again = vis::compute(&file.graph(Some(c.tolerance.distance)), &opts);
        // A PRT portal is one polygon; a pair across a thick wall (each side on its own
        // cell's face) is two, and only the direct PVS sees through both.
        let thin = p.pairs().all(|(i, j)| {
            let (a, b) = (&p.portals[i], &p.portals[j]);
            a.polygon
                .iter()
                .all(|v| b.normal.dot(*v - b.polygon[0]).abs() <= 1e-6)
        });
        if thin
            && p.portals
                .iter()
                .all(|q| !q.one_way && !q.closed && q.transform.is_none())
        {
            assert_eq!(direct, again, "{}", level.display());
        }
    }
}
