//! The debug outputs on the samples and third-party levels: the GLB parses, has a node per cell
//! and per portal, passes the Khronos validator and repeats byte for byte; the SVG plan is
//! well formed, has an outline per cell and highlights exactly the visible set asked for.

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

use common::{fixture, root, sample};
use glam::DVec3;
use portcullis::export::debug::{debug_glb, DebugExtras};
use portcullis::export::svg::{svg_map, PVS_HIDDEN_FILL, PVS_SOURCE_FILL, PVS_VISIBLE_FILL};
use portcullis::geom::aabb::Aabb;
use portcullis::geom::polyhedron::ConvexPolyhedron;
use portcullis::pipeline::Level;

fn levels() -> Vec<(PathBuf, Option<&'static str>)> {
    vec![
        (sample("two_rooms.gltf"), None),
        (sample("l_room.gltf"), None),
        (fixture("lportal_boxrooms.glb"), None),
        (fixture("panda3d_culling.glb"), Some("panda3d")),
    ]
}

fn load(path: &Path, preset: Option<&str>) -> Level {
    let (t, c, p) = common::load_level(path, preset);
    assert!(!c.cells.is_empty(), "{}: no cells", path.display());
    Level::new(t, c, p)
}

/// Runs the Khronos validator when it is installed; without it the check is skipped, except on
/// CI where a missing validator must not pass silently.
fn validate(file: &Path) {
    let dir = root();
    if !dir
        .join("tools/gltf-validate/node_modules/gltf-validator")
        .exists()
    {
        if std::env::var_os("CI").is_some() {
            panic!("CI is set but the glTF validator is not installed (cd tools/gltf-validate && npm ci)");
        }
        eprintln!(
            "note: skipping the Khronos validator on {} (run `npm ci` in tools/gltf-validate)",
            file.display()
        );
        return;
    }
    let out = Command::new("node")
        .current_dir(&dir)
        .arg("tools/gltf-validate/validate.js")
        .arg(file)
        .output()
        .expect("node runs");
    let stdout = String::from_utf8_lossy(&out.stdout);
    let report: serde_json::Value = serde_json::from_str(&stdout).unwrap_or_else(|e| {
        panic!(
            "{}: validator output is not JSON ({e}): {stdout}\n{}",
            file.display(),
            String::from_utf8_lossy(&out.stderr)
        )
    });
    assert_eq!(
        report["issues"]["numErrors"],
        0,
        "{}: {}",
        file.display(),
        report["issues"]
    );
    // Not required, but the writer is clean today and should stay so.
    assert_eq!(
        report["issues"]["numWarnings"],
        0,
        "{}: {}",
        file.display(),
        report["issues"]
    );
    assert!(out.status.success(), "{}: {}", file.display(), report);
}

#[test]
fn debug_glb_parses_validates_and_repeats() {
    let dir = tempfile::tempdir().unwrap();
    for (path, preset) in levels() {
        let level = load(&path, preset);
        let (t, c, p) = (&level.tagged, &level.cells, &level.portals);
        let bytes = debug_glb(&level, &DebugExtras::default());
        let again = debug_glb(&level, &DebugExtras::default());
        assert!(
            bytes == again,
            "{}: output not deterministic",
            path.display()
        );
        assert_eq!(bytes.len() % 4, 0);

        let gltf =
            gltf::Gltf::from_slice(&bytes).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        assert_eq!(gltf.nodes().count(), c.cells.len() + p.portals.len());
        assert_eq!(
            gltf.as_json().asset.generator.as_deref(),
            Some("portcullis"),
            "{}",
            path.display()
        );
        for (i, node) in gltf.nodes().enumerate() {
            let name = node.name().unwrap();
            if i < c.cells.len() {
                let room = &t.tagging.rooms[c.cells[i].room].name;
                assert_eq!(name, format!("cell {i} (room {room})"));
                let m = node.mesh().unwrap().primitives().next().unwrap().material();
                assert_eq!(m.alpha_mode(), gltf::material::AlphaMode::Blend);
                assert!(m.double_sided());
                assert_eq!(m.pbr_metallic_roughness().base_color_factor()[3], 0.25);
            } else {
                let k = i - c.cells.len();
                let q = &p.portals[k];
                let to = q.to.map_or("exterior".into(), |t| format!("cell {t}"));
                assert_eq!(name, format!("portal {k}: cell {} -> {to}", q.from));
            }
        }

        let stem = path.file_stem().unwrap().to_string_lossy();
        let file = dir.path().join(format!("{stem}.debug.glb"));
        std::fs::write(&file, &bytes).unwrap();
        validate(&file);
    }
}

#[test]
fn debug_glb_draws_leaks_missed_sightlines_and_overlaps() {
    let level = load(&sample("two_rooms.gltf"), None);
    let (c, p) = (&level.cells, &level.portals);
    let b = c.cells[0].bounds;
    let extras = DebugExtras {
        leaks: vec![
            vec![
                b.min,
                (b.min + b.max) * 0.5,
                b.max + DVec3::new(3.0, 0.0, 0.0),
            ],
            vec![b.min],
        ],
        overlaps: vec![ConvexPolyhedron::from_aabb(&Aabb {
            min: b.min,
            max: (b.min + b.max) * 0.5,
        })],
        sightlines: vec![vec![b.min, b.max]],
    };
    let bytes = debug_glb(&level, &extras);
    let gltf = gltf::Gltf::from_slice(&bytes).unwrap();
    let base = c.cells.len() + p.portals.len();
    assert_eq!(gltf.nodes().count(), base + 4);
    let leak = gltf.nodes().nth(base).unwrap();
    assert_eq!(leak.name(), Some("leak 0"));
    let prim = leak.mesh().unwrap().primitives().next().unwrap();
    assert_eq!(prim.mode(), gltf::mesh::Mode::LineStrip);
    // A one-point leak has nothing to draw but keeps its node, so indices stay predictable.
    assert!(gltf.nodes().nth(base + 1).unwrap().mesh().is_none());
    let ray = gltf.nodes().nth(base + 2).unwrap();
    assert_eq!(ray.name(), Some("missed sightline 0"));
    assert_eq!(
        ray.mesh().unwrap().primitives().next().unwrap().mode(),
        gltf::mesh::Mode::LineStrip
    );
    let overlap = gltf.nodes().nth(base + 3).unwrap();
    assert_eq!(overlap.name(), Some("overlap 0"));
    assert_eq!(
        overlap.mesh().unwrap().primitives().next().unwrap().mode(),
        gltf::mesh::Mode::Triangles
    );
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("extras.debug.glb");
    std::fs::write(&file, &bytes).unwrap();
    validate(&file);
}

/// Checks that every tag is closed in order (a tiny XML reader: enough for what we write,
/// which has no CDATA, comments or `>` inside attribute values).
fn assert_well_formed(svg: &str) {
    let mut stack: Vec<String> = Vec::new();
    let mut rest = svg;
    let mut roots = 0;
    while let Some(start) = rest.find('<') {
        let text = &rest[..start];
        assert!(!text.contains('>'), "stray '>' in text: {text:?}");
        let end = rest[start..].find('>').expect("unclosed tag") + start;
        let tag = &rest[start + 1..end];
        rest = &rest[end + 1..];
        if tag.starts_with('?') {
            assert!(tag.ends_with('?'));
            continue;
        }
        if let Some(name) = tag.strip_prefix('/') {
            assert_eq!(
                stack.pop().as_deref(),
                Some(name.trim()),
                "mismatched </{name}>"
            );
            continue;
        }
        let name = tag
            .split(|c: char| c.is_whitespace() || c == '/')
            .next()
            .unwrap()
            .to_string();
        if stack.is_empty() {
            roots += 1;
        }
        if !tag.ends_with('/') {
            stack.push(name);
        }
    }
    assert!(stack.is_empty(), "unclosed: {stack:?}");
    assert_eq!(roots, 1);
    for amp in svg.match_indices('&') {
        let after = &svg[amp.0..];
        assert!(
            ["&amp;", "&lt;", "&gt;", "&quot;", "&apos;"]
                .iter()
                .any(|e| after.starts_with(e)),
            "unescaped &"
        );
    }
}

/// The fill of each `<polygon id="cell-N" ...>`, by N.
fn cell_fills(svg: &str) -> Vec<String> {
    let mut out = Vec::new();
    for (n, line) in svg
        .lines()
        .filter(|l| l.starts_with("<polygon "))
        .enumerate()
    {
        assert!(line.contains(&format!(r#"id="cell-{n}""#)), "{line}");
        let fill = line.split(r#"fill=""#).nth(1).unwrap();
        out.push(fill[..fill.find('"').unwrap()].to_string());
    }
    out
}

#[test]
fn svg_map_is_well_formed_and_highlights_the_visible_set() {
    for (path, preset) in levels() {
        let level = load(&path, preset);
        let (t, c) = (&level.tagged, &level.cells);
        let svg = svg_map(&level, None);
        assert_eq!(svg, svg_map(&level, None), "not deterministic");
        assert!(svg.contains(r#"xmlns="http://www.w3.org/2000/svg""#));
        assert!(svg.contains("<title>"));
        assert_eq!(svg.matches("<svg").count(), 1);
        assert_eq!(svg.matches("</svg>").count(), 1);
        assert_well_formed(&svg);
        assert_eq!(svg.matches("<polygon").count(), c.cells.len());
        // Numbers carry at most three decimals.
        for tok in svg.split(|ch: char| !(ch.is_ascii_digit() || ch == '.')) {
            if let Some((_, frac)) = tok.split_once('.') {
                assert!(frac.len() <= 3, "{}: {tok}", path.display());
            }
        }
        // Every cell is labelled: `N room`, or its number alone where the label would not fit
        // (a door reveal).
        let mut full = 0;
        for (i, cell) in c.cells.iter().enumerate() {
            let label = format!(">{i} {}</text>", t.tagging.rooms[cell.room].name);
            if svg.contains(&label) {
                full += 1;
            } else {
                let short = format!(">{i}</text>");
                assert!(
                    svg.contains(&short),
                    "{}: no label for cell {i}",
                    path.display()
                );
                // The label would be wider than the cell: at ~1.1 hundredths of the map per
                // glyph, a cell a tenth of the map wide fits any `N room` of nine glyphs.
                let map = c
                    .cells
                    .iter()
                    .fold(portcullis::geom::aabb::Aabb::EMPTY, |a, x| {
                        a.union(&x.bounds)
                    })
                    .size();
                assert!(
                    cell.bounds.size().x < 0.1 * map.x.max(map.z),
                    "{}: cell {i} is wide but not named",
                    path.display()
                );
            }
        }
        assert!(full > 0, "{}: no full label", path.display());

        // Cell 0 sees every other odd cell; compare with it seeing nothing.
        let visible: Vec<usize> = (1..c.cells.len()).step_by(2).collect();
        let lit = svg_map(&level, Some((0, &visible)));
        let dark = svg_map(&level, Some((0, &[])));
        assert_well_formed(&lit);
        assert!(lit.contains("visible from cell 0"));
        let (lit, dark) = (cell_fills(&lit), cell_fills(&dark));
        assert_eq!(lit.len(), c.cells.len());
        let changed: Vec<usize> = (0..lit.len()).filter(|&i| lit[i] != dark[i]).collect();
        assert_eq!(changed, visible, "{}", path.display());
        assert_eq!(lit[0], PVS_SOURCE_FILL);
        for (i, fill) in lit.iter().enumerate().skip(1) {
            let want = if visible.contains(&i) {
                PVS_VISIBLE_FILL
            } else {
                PVS_HIDDEN_FILL
            };
            assert_eq!(fill, want, "{}: cell {i}", path.display());
        }
    }
}
