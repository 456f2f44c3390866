//! A converted file keeps its source's verdict: `check` on what `convert` wrote (the stored
//! cells, portals, occupants and exemptions) finds what `check` on the source finds, for every
//! shared brush map and every sample. What is compared is the check stage's own findings
//! (portals, transforms, the graph, loops, leaks, occupants in no cell), code by code with
//! their counts, sealed: the build's own notes (pockets filled, geometry in no cell) are not
//! stored, so they are not asked for.

mod common;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use portcullis::diag::Diagnostics;
use portcullis::pipeline::{self, GateOptions, LoadOptions};

/// The codes the check stage reports, with how often.
fn verdict(d: &Diagnostics) -> BTreeMap<String, usize> {
    let mut out = BTreeMap::new();
    for x in d.iter() {
        let code = x.code.to_string();
        let checked = ["PORTAL_", "TRANSFORM_", "GRAPH_", "LEAK"]
            .iter()
            .any(|p| code.starts_with(p))
            || code == "PLAYER_START_OUTSIDE"
            || code == "OCCUPANT_OUTSIDE";
        if checked {
            *out.entry(code).or_default() += 1;
        }
    }
    out
}

/// The source's verdict and the converted file's, or `None` when the source cannot be read.
fn both(input: &Path, dir: &Path) -> Option<(BTreeMap<String, usize>, BTreeMap<String, usize>)> {
    let opts = LoadOptions::default();
    let mut level = pipeline::load(input, &opts).ok()?;
    let out = dir.join("converted.glb");
    let target = portcullis::export::output::Output::gltf(&out).unwrap();
    portcullis::export::output::level(&level, None, &target)
        .unwrap_or_else(|d| panic!("{}: {d}", input.display()));
    pipeline::check(&mut level, true);
    let source = verdict(&level.diagnostics);
    let tagged = pipeline::load_tagged(&out, &opts).unwrap();
    let gate = GateOptions {
        sealed: true,
        ..Default::default()
    };
    let checked = pipeline::check_file(tagged, &gate, &out);
    assert!(
        checked.annotated,
        "{}: the converted file is judged as stored",
        input.display()
    );
    Some((source, verdict(&checked.diagnostics)))
}

fn maps(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap().flatten() {
            let p = e.path();
            if p.is_dir() {
                stack.push(p);
            } else if p.extension().is_some_and(|x| x == "map") {
                out.push(p);
            }
        }
    }
    out.sort();
    out
}

fn judge(inputs: &[PathBuf]) -> (usize, Vec<String>) {
    let tmp = tempfile::tempdir().unwrap();
    let (mut judged, mut differ) = (0, Vec::new());
    for input in inputs {
        let Some((source, stored)) = both(input, tmp.path()) else {
            continue;
        };
        judged += 1;
        if source != stored {
            differ.push(format!(
                "{}: source {source:?}, converted {stored:?}",
                input.display()
            ));
        }
    }
    (judged, differ)
}

#[test]
fn every_shared_brush_map_converted_keeps_its_verdict() {
    let dir = common::testmaps::dir();
    if !dir.is_dir() {
        eprintln!(
            "skipped: ericw-tools' testmaps are not at {} (CI has ../shared beside the clone)",
            dir.display()
        );
        return;
    }
    let all = maps(&dir);
    let (judged, differ) = judge(&all);
    eprintln!("{judged} brush maps judged, {} differ", differ.len());
    // E1M1-edited-ents is among them: its ambient_drone stands in a wall.
    assert!(judged > 200, "only {judged} of {} maps read", all.len());
    assert!(differ.is_empty(), "{}", differ.join("\n"));
}

#[test]
fn every_sample_converted_keeps_its_verdict() {
    let all = common::sample_levels();
    let (judged, differ) = judge(&all);
    eprintln!("{judged} samples judged, {} differ", differ.len());
    assert!(judged >= 30, "only {judged} samples read");
    assert!(differ.is_empty(), "{}", differ.join("\n"));
}
