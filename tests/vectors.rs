//! The runtime's language-neutral test vectors (tests/vectors/, docs/guide.md "Test vectors"):
//! for every case of tests/vectors/manifest.json, the level is converted, `portcullis cull
//! LEVEL --cameras FILE --format jsonl --draw-lists` runs with the case's extra arguments (closed
//! doors), and every camera's answer must be the expected file's line, `stats` left out: the
//! camera's cell, location and nearest cell, the visible entries (matched by cell and transform,
//! in any order) with their depths, paths, `mirrored` and draw lists exactly, rectangles and
//! transforms within 1e-9. The manifest must cover every sample (samples/*.gltf, *.map). Cases of
//! levels under ../shared are skipped, with a message, when ../shared is missing.
//!
//! `PORTCULLIS_BLESS=1 cargo test --test vectors` rewrites the expected files from this build's
//! answers instead of comparing (after a deliberate change to the runtime, or after
//! `python3 scripts/make_vectors.py` wrote new cameras); review the diff before committing it.
//! Other implementations are checked against the same files by `scripts/check_vectors.py`.

mod common;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde::Deserialize;
use serde_json::Value;

#[derive(Debug, Clone, Deserialize)]
struct Case {
    name: String,
    /// Relative to the repository root.
    level: String,
    convert: Vec<String>,
    /// The rest relative to tests/vectors/.
    cameras: String,
    labels: Option<String>,
    cull: Vec<String>,
    expected: String,
}

#[derive(Debug, Deserialize)]
struct Manifest {
    cases: Vec<Case>,
}

fn vectors() -> PathBuf {
    common::root().join("tests/vectors")
}

fn manifest() -> Manifest {
    let path = vectors().join("manifest.json");
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{path:?}: {e}"));
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("{path:?}: {e}"))
}

/// How far a rectangle's or transform's number may be off: the output is rounded to 1e-9, so
/// two right answers can differ by one step of it (and the float that prints it).
fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-9 * (1.0 + 1e-6) * a.abs().max(b.abs()).max(1.0)
}

/// The first difference between `want` and `got` at `at`, if any; numbers under `rect` and
/// `transform` are compared with [`close`], visible entries as a set.
fn differ(at: &str, want: &Value, got: &Value, loose: bool) -> Option<String> {
    let show = |v: &Value| {
        let s = v.to_string();
        if s.len() > 200 {
            format!("{}...", &s[..200])
        } else {
            s
        }
    };
    let bad = || Some(format!("{at}: expected {}, got {}", show(want), show(got)));
    match (want, got) {
        (Value::Number(a), Value::Number(b)) if loose => {
            if close(a.as_f64().unwrap(), b.as_f64().unwrap()) {
                None
            } else {
                bad()
            }
        }
        (Value::Object(a), Value::Object(b)) => {
            for (k, v) in a {
                let Some(w) = b.get(k) else {
                    return Some(format!("{at}/{k}: missing (expected {})", show(v)));
                };
                let found = if k == "visible" {
                    visible_differ(&format!("{at}/{k}"), v, w)
                } else {
                    let loose = loose || k == "rect" || k == "transform";
                    differ(&format!("{at}/{k}"), v, w, loose)
                };
                if found.is_some() {
                    return found;
                }
            }
            (b.keys().find(|k| !a.contains_key(*k)))
                .map(|k| format!("{at}/{k}: not expected (got {})", show(&b[k])))
        }
        (Value::Array(a), Value::Array(b)) => {
            if a.len() != b.len() {
                return bad();
            }
            (a.iter().zip(b).enumerate())
                .find_map(|(i, (v, w))| differ(&format!("{at}/{i}"), v, w, loose))
        }
        _ if want == got => None,
        _ => bad(),
    }
}

/// Whether two visible entries are the same cell seen through the same transform.
fn same_entry(a: &Value, b: &Value) -> bool {
    a["cell"] == b["cell"]
        && match (a.get("transform"), b.get("transform")) {
            (None, None) => true,
            (Some(x), Some(y)) => differ("", x, y, true).is_none(),
            _ => false,
        }
}

fn visible_differ(at: &str, want: &Value, got: &Value) -> Option<String> {
    let (Some(a), Some(b)) = (want.as_array(), got.as_array()) else {
        return differ(at, want, got, false);
    };
    let mut used = vec![false; b.len()];
    for v in a {
        let key = format!(
            "{{cell {}{}}}",
            v["cell"],
            if v.get("transform").is_some() {
                ", transformed"
            } else {
                ""
            }
        );
        let Some(j) = (0..b.len()).find(|&j| !used[j] && same_entry(v, &b[j])) else {
            return Some(format!("{at}: {key} expected, not seen"));
        };
        used[j] = true;
        if let Some(d) = differ(&format!("{at}/{key}"), v, &b[j], false) {
            return Some(d);
        }
    }
    (0..b.len())
        .find(|&j| !used[j])
        .map(|j| format!("{at}: {{cell {}}} seen, not expected", b[j]["cell"]))
}

/// `cull`'s answers for a case, one per camera, `stats` left out.
fn answers(glb: &Path, case: &Case) -> Vec<Value> {
    let o = common::succeeds(
        assert_cmd::Command::cargo_bin("portcullis")
            .unwrap()
            .arg("cull")
            .arg(glb)
            .arg("--cameras")
            .arg(vectors().join(&case.cameras))
            .args(&case.cull)
            .args(["--format", "jsonl", "--draw-lists"]),
    );
    let text = String::from_utf8(o.stdout).unwrap();
    (text.lines())
        .map(|l| {
            let mut v: Value = serde_json::from_str(l).unwrap();
            v.as_object_mut().unwrap().shift_remove("stats");
            v
        })
        .collect()
}

/// What one case found: how many cameras, how many differ and the first difference.
fn run_case(glb: &Path, case: &Case, bless: bool) -> (usize, Option<String>) {
    let got = answers(glb, case);
    let path = vectors().join(&case.expected);
    if bless {
        let text: String = got.iter().map(|v| format!("{v}\n")).collect();
        std::fs::write(&path, text).unwrap();
        return (got.len(), None);
    }
    let text = std::fs::read_to_string(&path)
        .unwrap_or_else(|e| panic!("{path:?}: {e} (PORTCULLIS_BLESS=1 writes it)"));
    let want: Vec<Value> = (text.lines())
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    let labels: Vec<String> = (case.labels.as_ref())
        .and_then(|l| std::fs::read_to_string(vectors().join(l)).ok())
        .map(|t| t.lines().map(str::to_string).collect())
        .unwrap_or_default();
    if want.len() != got.len() {
        let n = got.len();
        return (n, Some(format!("{} answers, {} expected", n, want.len())));
    }
    let mut differing = 0;
    let mut first = None;
    for (i, (w, g)) in want.iter().zip(&got).enumerate() {
        if let Some(d) = differ("", w, g, false) {
            differing += 1;
            let label = labels.get(i).map_or("", String::as_str);
            first.get_or_insert(format!("camera {} ({label}): {d}", i + 1));
        }
    }
    let report = first.map(|f| format!("{differing} of {} cameras differ; first: {f}", got.len()));
    (got.len(), report)
}

#[test]
fn the_runtime_gives_the_vectors_answers() {
    let m = manifest();
    let bless = std::env::var("PORTCULLIS_BLESS").is_ok_and(|v| v == "1");
    let dir = tempfile::tempdir().unwrap();
    // Each level converted once, the cases of a level after it, each level on a thread.
    let mut by_level: BTreeMap<(String, Vec<String>), Vec<Case>> = BTreeMap::new();
    for c in &m.cases {
        let key = (c.level.clone(), c.convert.clone());
        by_level.entry(key).or_default().push(c.clone());
    }
    let root = common::root();
    let results: Vec<(String, usize, Option<String>)> = std::thread::scope(|s| {
        let jobs: Vec<_> = (by_level.iter().enumerate())
            .map(|(k, ((level, args), cases))| {
                let (root, dir) = (&root, dir.path());
                s.spawn(move || {
                    let input = root.join(level);
                    if level.starts_with("../shared/") && !input.exists() {
                        eprintln!("skipping {level}: ../shared is missing");
                        return Vec::new();
                    }
                    let glb = dir.join(format!("{k}.glb"));
                    let mut cmd = assert_cmd::Command::cargo_bin("portcullis").unwrap();
                    cmd.arg("convert")
                        .arg(&input)
                        .arg("-o")
                        .arg(&glb)
                        .args(args);
                    // Levels with warnings still convert (exit 1 with the output written).
                    let o = cmd.output().unwrap();
                    assert!(
                        glb.exists(),
                        "{level}: {}",
                        String::from_utf8_lossy(&o.stderr)
                    );
                    (cases.iter())
                        .map(|c| {
                            let (n, d) = run_case(&glb, c, bless);
                            (c.name.clone(), n, d)
                        })
                        .collect()
                })
            })
            .collect();
        jobs.into_iter().flat_map(|j| j.join().unwrap()).collect()
    });
    let cameras: usize = results.iter().map(|r| r.1).sum();
    let failed: Vec<String> = (results.iter())
        .filter_map(|(name, _, d)| d.as_ref().map(|d| format!("{name}: {d}")))
        .collect();
    eprintln!(
        "{} cases, {cameras} cameras{}",
        results.len(),
        if bless {
            ", expected files rewritten"
        } else {
            ""
        }
    );
    assert!(
        failed.is_empty(),
        "{} cases differ:\n{}",
        failed.len(),
        failed.join("\n")
    );
    assert!(cameras > 1000, "only {cameras} cameras");
}

/// Every sample is a case (run with the doors as the level has them), and every file the
/// manifest names is there.
#[test]
fn the_manifest_covers_every_sample() {
    let m = manifest();
    let mut samples: Vec<String> = std::fs::read_dir(common::sample(""))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "gltf" || e == "map"))
        .map(|p| format!("samples/{}", p.file_name().unwrap().to_string_lossy()))
        .collect();
    samples.sort();
    for s in &samples {
        assert!(
            m.cases.iter().any(|c| &c.level == s && c.cull.is_empty()),
            "{s} has no case in tests/vectors/manifest.json: run scripts/make_vectors.py"
        );
    }
    let mut names = std::collections::BTreeSet::new();
    for c in &m.cases {
        assert!(names.insert(&c.name), "case {} twice", c.name);
        assert!(
            c.level.starts_with("../shared/") || common::root().join(&c.level).exists(),
            "{}: no {}",
            c.name,
            c.level
        );
        let lines = |f: &str| match std::fs::read_to_string(vectors().join(f)) {
            Ok(t) => t.lines().count(),
            Err(e) => panic!("{}: tests/vectors/{f}: {e}", c.name),
        };
        let n = lines(&c.cameras);
        for f in [c.labels.as_ref(), Some(&c.expected)].into_iter().flatten() {
            assert_eq!(
                lines(f),
                n,
                "{}: {f} and {} differ in lines",
                c.name,
                c.cameras
            );
        }
    }
}
