//! The Doom maps against the ground truth from their WADs (`*_portals.json`: every two-sided
//! linedef with its two sectors and its opening polygon). The openings come from the map data,
//! not from our geometry, so they share nothing with the cell and portal stages.

mod common;

use std::collections::HashMap;

use common::{fixture, load_level};
use glam::DVec3;
use serde_json::Value;

/// The area of a planar polygon (Newell).
fn area(poly: &[DVec3]) -> f64 {
    let mut n = DVec3::ZERO;
    for (i, a) in poly.iter().enumerate() {
        n += a.cross(poly[(i + 1) % poly.len()]);
    }
    n.length() / 2.0
}

/// Sector pair (by name, in order) to summed opening area.
type Openings = HashMap<(String, String), f64>;

fn pair(a: &str, b: &str) -> (String, String) {
    if a < b {
        (a.to_string(), b.to_string())
    } else {
        (b.to_string(), a.to_string())
    }
}

/// The open linedefs of the ground truth, by sector pair.
fn ground_truth(file: &str) -> Openings {
    let text = std::fs::read_to_string(fixture(file)).unwrap();
    let json: Value = serde_json::from_str(&text).unwrap();
    let mut out = Openings::new();
    for p in json["portals"].as_array().unwrap() {
        if p["closed"].as_bool().unwrap() {
            continue;
        }
        let poly: Vec<DVec3> = p["polygon"]
            .as_array()
            .unwrap()
            .iter()
            .map(|q| {
                let v: Vec<f64> = q
                    .as_array()
                    .unwrap()
                    .iter()
                    .map(|x| x.as_f64().unwrap())
                    .collect();
                DVec3::new(v[0], v[1], v[2])
            })
            .collect();
        let (a, b) = (p["front"].as_str().unwrap(), p["back"].as_str().unwrap());
        *out.entry(pair(a, b)).or_default() += area(&poly);
    }
    out
}

/// Every open linedef of the map is a portal between its two sectors with the opening's area
/// (within 5 %, or 0.01 m² for slivers), no portal joins two sectors that share no open
/// linedef, and no two sectors' cells overlap: E3M3 draws two small sectors standing in a
/// courtyard's air, and the courtyard's cells are cut around them (issue 43), so their open
/// sides are portals too.
#[test]
fn doom_portals_match_the_maps_openings() {
    for (level, truth) in [
        ("E1M2_godot.glb", "freedoom1_E1M2_portals.json"),
        ("MAP01_godot.glb", "freedoom2_MAP01_portals.json"),
        ("E3M3_godot.glb", "freedoom1_E3M3_portals.json"),
    ] {
        let truth = ground_truth(truth);
        let (t, c, p) = load_level(&fixture(level), None);
        let sector = |cell: usize| {
            let name = &t.tagging.rooms[c.cells[cell].room].name;
            name.strip_suffix("-room").unwrap_or(name).to_string()
        };
        let mut ours = Openings::new();
        for (i, _) in p.pairs() {
            let portal = &p.portals[i];
            let Some(to) = portal.to else { continue };
            let (a, b) = (sector(portal.from), sector(to));
            if a != b {
                *ours.entry(pair(&a, &b)).or_default() += portal.area;
            }
        }
        let missing: Vec<_> = truth.keys().filter(|k| !ours.contains_key(*k)).collect();
        let wrong_area: Vec<_> = truth
            .iter()
            .filter_map(|(k, want)| {
                let got = ours.get(k)?;
                ((got - want).abs() > 0.05 * want + 0.01).then_some((k, *want, *got))
            })
            .collect();
        let extra: Vec<_> = ours.keys().filter(|k| !truth.contains_key(*k)).collect();
        eprintln!(
            "{level}: {} sector pairs open in the map, {} missing, {} with another area, {} portals between sectors the map does not open to each other",
            truth.len(),
            missing.len(),
            wrong_area.len(),
            extra.len()
        );
        assert!(missing.is_empty(), "{level}: missing openings {missing:?}");
        assert!(
            wrong_area.is_empty(),
            "{level}: areas (want, got) {wrong_area:?}"
        );
        // A sliver where two sectors' corners touch is tolerated, no more.
        assert!(
            extra.len() <= 2,
            "{level}: portals the map has not: {extra:?}"
        );
        let eps = c.tolerance.distance;
        for a in 0..c.cells.len() {
            for b in a + 1..c.cells.len() {
                let (x, y) = (&c.cells[a], &c.cells[b]);
                if (0..3).any(|k| {
                    x.bounds.min[k] >= y.bounds.max[k] - eps
                        || y.bounds.min[k] >= x.bounds.max[k] - eps
                }) {
                    continue;
                }
                let shared = x
                    .poly
                    .intersection(&y.poly, eps)
                    .map_or(0.0, |p| p.volume());
                assert!(
                    shared <= 1e-3,
                    "{level}: cells {a} and {b} overlap by {shared} m³"
                );
            }
        }
    }
}

/// Issue 29, item 4: the Doom maps as a WAD converter writes them (`sector_N` nodes carrying
/// `extras.doom_sector`, no tag suffix) give, under `--tags doom`, the same rooms, cells and
/// portals as the `_godot` copies under the default rules; by names alone or by the extras
/// alone. Under the default rules they tag nothing, and the report names the preset. The
/// preset's one rule beyond names, the sky flat as open sky, is given to the `_godot` reading
/// too; without it that reading has fewer portals (the sky ceilings close their cells).
#[test]
fn the_doom_preset_reads_plain_sector_nodes() {
    use portcullis::pipeline::{build_cells, build_portals};
    for level in ["E1M2_godot.glb", "MAP01_godot.glb"] {
        let (godot, _, closed) = load_level(&fixture(level), None);
        let mut sky = portcullis::config::Config::default();
        sky.tags.sky = portcullis::tags::presets::spec("doom").unwrap().sky;
        let mut with_sky = common::tagged_with(godot.scene.clone(), sky, None);
        let cells = build_cells(&mut with_sky);
        let portals = build_portals(&mut with_sky, &cells);
        assert!(
            portals.portals.len() > closed.portals.len(),
            "{level}: the sky opens {} portals against {}",
            portals.portals.len(),
            closed.portals.len()
        );
        let plain = |keep_names: bool, keep_extras: bool, preset: &str| {
            let mut scene = godot.scene.clone();
            for n in &mut scene.nodes {
                n.name = match n.name.as_deref() {
                    Some(s) if s.ends_with("-room") && keep_names => {
                        Some(s.trim_end_matches("-room").to_string())
                    }
                    Some(s) if s.ends_with("-room") => None,
                    other => other.map(str::to_string),
                };
                if !keep_extras {
                    n.extras = None;
                }
            }
            common::tagged_with(scene, Default::default(), Some(preset))
        };
        let rooms = |t: &portcullis::pipeline::Tagged| {
            let mut v: Vec<String> = t.tagging.rooms.iter().map(|r| r.name.clone()).collect();
            v.sort();
            v
        };
        for (names, extras) in [(true, true), (true, false), (false, true)] {
            let mut t = plain(names, extras, "doom");
            assert_eq!(
                rooms(&t),
                rooms(&godot),
                "{level} names {names} extras {extras}"
            );
            let c = build_cells(&mut t);
            let p = build_portals(&mut t, &c);
            assert_eq!(c.cells.len(), cells.cells.len(), "{level}");
            assert_eq!(p.portals.len(), portals.portals.len(), "{level}");
        }
        let t = plain(true, true, "default");
        assert!(t.tagging.rooms.is_empty());
        let hint = t
            .diagnostics
            .iter()
            .find(|d| d.code == portcullis::diag::Code::TAGS_PRESET_SUGGESTED)
            .and_then(|d| d.hint.clone())
            .unwrap_or_default();
        assert!(hint.contains("--tags doom"), "{level}: {:?}", t.diagnostics);
    }
}
