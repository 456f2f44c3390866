//! Brush maps read as rooms of solid blocks (issue 41): every world brush a closed mesh of one
//! room, tagged `solid` as a brush map's importer tags them, `func_detail` brushes detail,
//! point entities as nodes at their origins (`info_player_start` a player start). The map is
//! read by the tests' own reader (tests/common/map.rs), which shares no code with the crate.
//!
//! The verdicts are qbsp's: a map it writes a portal file for is sealed (no `LEAK` under
//! `--sealed`), a map it finds a leak in gives `LEAK`. Small maps written here run always;
//! ericw-tools' own test maps (their verdicts from its tests/test_qbsp*.cc) run when
//! `ERICW_TESTMAPS` names its `testmaps/` folder (`cargo test --release --test brush_maps --
//! --ignored`): the maps are not the project's to ship.

mod common;

use std::time::Instant;

use common::brush_level::{brush_use, level, Use};
use common::map::{self, Entity};
use glam::DVec3;
use portcullis::cells::CellSet;
use portcullis::diag::Code;
use portcullis::pipeline::{build_cells, build_portals, Tagged};

/// Cells, portals and whether `check --sealed` finds a leak.
fn verdict(entities: &[Entity]) -> (Tagged, CellSet, bool, Vec<(String, DVec3)>) {
    let (mut t, points) = level(entities);
    let c = build_cells(&mut t);
    let p = build_portals(&mut t, &c);
    common::check_parts(&mut t, &c, &p, true);
    let leak = t.diagnostics.has(Code::LEAK);
    (t, c, leak, points)
}

/// A box brush in the Quake format (three points a face, the normal out of the brush).
fn box_brush(lo: [f64; 3], hi: [f64; 3]) -> String {
    let mut out = String::from("{\n");
    let axes = [DVec3::X, DVec3::Y, DVec3::Z];
    for k in 0..3 {
        for (sign, at) in [(1.0, hi), (-1.0, lo)] {
            let n = axes[k] * sign;
            let (a, b) = (axes[(k + 1) % 3], axes[(k + 2) % 3]);
            // a × b = axes[k]: swap for the negative face so the cross points out.
            let (a, b) = if sign > 0.0 { (a, b) } else { (b, a) };
            let q =
                DVec3::from_array(lo) * (DVec3::ONE - axes[k]) + DVec3::from_array(at) * axes[k];
            let (p0, p1, p2) = (q + a * 16.0, q, q + b * 16.0);
            debug_assert!((p0 - p1).cross(p2 - p1).dot(n) > 0.0);
            out += &format!(
                "( {} {} {} ) ( {} {} {} ) ( {} {} {} ) stone 0 0 0 1 1\n",
                p0.x, p0.y, p0.z, p1.x, p1.y, p1.z, p2.x, p2.y, p2.z
            );
        }
    }
    out + "}\n"
}

/// A 256 x 256 x 128 unit room of 16 unit brushes, a player start inside; `gap` cuts a
/// 16 unit slot through the east wall, `detail` fills it with a func_detail brush.
fn room_map(gap: bool, detail: bool) -> String {
    let t = 16.0;
    let mut world = String::from("{\n\"classname\" \"worldspawn\"\n");
    let mut add = |lo: [f64; 3], hi: [f64; 3]| world += &box_brush(lo, hi);
    add([-t, -t, -t], [256.0 + t, 256.0 + t, 0.0]);
    add([-t, -t, 128.0], [256.0 + t, 256.0 + t, 128.0 + t]);
    add([-t, -t, 0.0], [0.0, 256.0 + t, 128.0]);
    add([0.0, -t, 0.0], [256.0, 0.0, 128.0]);
    add([0.0, 256.0, 0.0], [256.0, 256.0 + t, 128.0]);
    if gap {
        add([256.0, -t, 0.0], [256.0 + t, 120.0, 128.0]);
        add([256.0, 136.0, 0.0], [256.0 + t, 256.0 + t, 128.0]);
    } else {
        add([256.0, -t, 0.0], [256.0 + t, 256.0 + t, 128.0]);
    }
    world += "}\n";
    if detail {
        world += "{\n\"classname\" \"func_detail\"\n";
        world += &box_brush([256.0, 120.0, 0.0], [256.0 + t, 136.0, 128.0]);
        world += "}\n";
    }
    world + "{\n\"classname\" \"info_player_start\"\n\"origin\" \"128 128 64\"\n}\n"
}

#[test]
fn a_sealed_brush_room_is_one_cell_with_no_leak() {
    let (t, c, leak, _) = verdict(&map::parse(&room_map(false, false)).unwrap());
    assert!(!leak, "{:?}", t.diagnostics);
    assert_eq!(c.cells.len(), 1);
    let inch3 = 0.0254f64.powi(3);
    assert!((c.cells[0].volume - 256.0 * 256.0 * 128.0 * inch3).abs() < 1e-6);
}

#[test]
fn a_slot_through_a_brush_wall_leaks_from_the_player_start() {
    let (t, _, leak, _) = verdict(&map::parse(&room_map(true, false)).unwrap());
    assert!(leak, "{:?}", t.diagnostics);
    let d = t.diagnostics.iter().find(|d| d.code == Code::LEAK).unwrap();
    assert!(d.message.contains("from player start"), "{}", d.message);
}

/// A `func_detail` pillar half in a wall (its middle in the wall, a quarter of it in the room)
/// is rendered by the cell it reaches into, not reported as lying in no cell.
#[test]
fn detail_with_its_middle_in_a_wall_is_rendered_by_the_cell_it_reaches() {
    let mut text = room_map(false, false);
    text += "{\n\"classname\" \"func_detail\"\n";
    text += &box_brush([248.0, 100.0, 0.0], [272.0, 140.0, 128.0]);
    text += "}\n";
    let (t, c, leak, _) = verdict(&map::parse(&text).unwrap());
    assert!(!leak);
    assert_eq!(c.cells.len(), 1);
    let pillar = t.tagging.rooms[0].detail[0];
    assert!(c.cells[0].nodes.contains(&pillar));
    assert!(
        !t.diagnostics.has(Code::CELL_GEOMETRY_OUTSIDE),
        "{:?}",
        t.diagnostics
    );
}

#[test]
fn detail_does_not_seal_a_brush_map() {
    let (t, _, leak, _) = verdict(&map::parse(&room_map(true, true)).unwrap());
    assert!(leak, "{:?}", t.diagnostics);
}

fn testmap(name: &str) -> Vec<Entity> {
    let dir = common::ericw_testmaps();
    let text = std::fs::read_to_string(dir.join(name)).unwrap();
    map::parse(&text).unwrap()
}

#[test]
#[ignore = "needs ericw-tools' testmaps (ERICW_TESTMAPS or ../shared/levels/ericw-tools)"]
fn ericw_testmaps_get_qbsps_verdicts() {
    // (map, leaks) as ericw-tools' tests state them (tests/test_qbsp.cc, test_qbsp_q2.cc).
    for (name, leaks) in [
        ("qbspfeatures.map", false),
        ("base1leak.map", false),
        ("E1M1-edited-ents.map", false),
        ("q1_detail_non_sealing.map", true),
        ("q1_cube.map", true),
    ] {
        let start = Instant::now();
        let (t, c, leak, _) = verdict(&testmap(name));
        // A leak is found from the player start (its path begins there, or the start itself
        // stands in the void), as qbsp's leak file begins at an entity.
        let from_start = t
            .diagnostics
            .iter()
            .any(|d| d.code == Code::LEAK && d.message.contains("player_start"));
        assert_eq!(from_start, leaks, "{name}");
        eprintln!(
            "{name}: {} cells, leak {leak}, {:.2} s",
            c.cells.len(),
            start.elapsed().as_secs_f64()
        );
        assert_eq!(
            leak,
            leaks,
            "{name}: {:?}",
            t.diagnostics
                .iter()
                .filter(|d| d.code == Code::LEAK)
                .take(3)
                .map(|d| d.message.clone())
                .collect::<Vec<_>>()
        );
    }
}

/// On real maps (E1M1, LibreQuake's e3m4 of 3,441 brushes, a jam map): every point entity
/// whose origin lies outside all world brushes is in a cell, and no point sampled in a cell
/// lies in a world brush.
#[test]
#[ignore = "needs ericw-tools' testmaps (ERICW_TESTMAPS or ../shared/levels/ericw-tools)"]
fn real_maps_entities_are_in_cells_and_cells_are_not_in_brushes() {
    for name in [
        "E1M1-edited-ents.map",
        "LibreQuake/lq1/maps/src/e3/e3m4.map",
        "retrojam1_ericw.map",
    ] {
        let entities = testmap(name);
        let (_, c, leak, points) = verdict(&entities);
        assert!(!leak, "{name} is sealed");
        let brushes: Vec<&map::Brush> = entities
            .iter()
            .flat_map(|e| {
                e.brushes
                    .iter()
                    .filter(move |b| brush_use(e, b) == Use::Structure)
            })
            .collect();
        let back = |p: DVec3| DVec3::new(p.x, -p.z, p.y) / 0.0254;
        let in_cell = |p: DVec3, m: f64| {
            c.cells
                .iter()
                .any(|cell| cell.poly.faces.iter().all(|f| f.plane.distance(p) < m))
        };
        let mut outside = 0;
        for (class, p) in &points {
            let q = back(*p);
            if brushes.iter().any(|b| b.contains(q, -0.01)) {
                continue;
            }
            outside += 1;
            assert!(in_cell(*p, 1e-6), "{name}: {class} at {q} is in no cell");
        }
        let mut rng = common::rng::SplitMix64::new(1);
        let mut sampled = 0;
        for cell in &c.cells {
            let (lo, hi) = (cell.bounds.min, cell.bounds.max);
            for _ in 0..40 {
                let p = lo + (hi - lo) * DVec3::new(rng.unit(), rng.unit(), rng.unit());
                if !cell.poly.faces.iter().all(|f| f.plane.distance(p) < -1e-4) {
                    continue;
                }
                sampled += 1;
                let q = back(p);
                assert!(
                    !brushes.iter().any(|b| b.contains(q, 1e-3)),
                    "{name}: cell point {q} lies in a brush"
                );
            }
        }
        eprintln!(
            "{name}: {} cells, {outside} point entities outside the brushes in cells, {sampled} cell points in no brush",
            c.cells.len()
        );
        assert!(outside > 50 && sampled > 1000, "{name}");
    }
}
