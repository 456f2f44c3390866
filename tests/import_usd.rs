//! USD import (cargo feature `usd`): the .usda copies of the third-party levels give the same
//! rooms, cells and portals as their .glb copies; unit/up-axis conversion, instancing,
//! visibility, purposes, tags and portal lights; broken files and a missing usd-core end with
//! one clear message and exit 2.
//!
//! Needs usd-core in the project's `.venv` (scripts/test.sh makes it) or in `VIRTUAL_ENV`.
#![cfg(feature = "usd")]

mod common;

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use assert_cmd::Command;
use common::{fixture, load_level};
use glam::DVec3;
use portcullis::cells::CellSet;
use portcullis::diag::Code;
use portcullis::pipeline::Tagged;
use portcullis::portals::PortalSet;

fn usd(name: &str) -> PathBuf {
    common::root().join("tests/fixtures/usd").join(name)
}

fn portcullis() -> Command {
    let mut c = Command::cargo_bin("portcullis").unwrap();
    c.env("NO_COLOR", "1");
    c
}

/// Everything compared between two copies of one level, in terms that do not depend on node
/// order: room names, cells per room with their volumes and bounds, portals by the rooms they
/// join with their polygons, flood reachability and the full PVS between rooms.
struct Level {
    rooms: Vec<String>,
    cells: Vec<(String, f64, DVec3, DVec3)>,
    portals: Vec<(String, String, Vec<DVec3>)>,
    reach: Vec<(String, BTreeSet<String>)>,
    /// The full PVS, by room: each cell's room with the rooms it sees.
    pvs: Vec<(String, BTreeSet<String>)>,
}

fn room_of(t: &Tagged, c: &CellSet, cell: Option<usize>) -> String {
    match cell {
        Some(i) => t.tagging.rooms[c.cells[i].room].name.clone(),
        None => "<exterior>".to_string(),
    }
}

fn summarise(t: &Tagged, c: &CellSet, p: &PortalSet) -> Level {
    let mut rooms: Vec<String> = t.tagging.rooms.iter().map(|r| r.name.clone()).collect();
    rooms.sort();
    let mut cells: Vec<_> = c
        .cells
        .iter()
        .map(|x| {
            (
                t.tagging.rooms[x.room].name.clone(),
                x.volume,
                x.bounds.min,
                x.bounds.max,
            )
        })
        .collect();
    cells.sort_by(|a, b| {
        (&a.0, a.2.x, a.2.y, a.2.z)
            .partial_cmp(&(&b.0, b.2.x, b.2.y, b.2.z))
            .unwrap()
    });
    let mut portals: Vec<_> = p
        .portals
        .iter()
        .map(|q| {
            (
                room_of(t, c, Some(q.from)),
                room_of(t, c, q.to),
                q.polygon.clone(),
            )
        })
        .collect();
    portals.sort_by(|a, b| {
        let ca = centroid(&a.2);
        let cb = centroid(&b.2);
        (&a.0, &a.1, ca.x, ca.y, ca.z)
            .partial_cmp(&(&b.0, &b.1, cb.x, cb.y, cb.z))
            .unwrap()
    });
    let mut reach = Vec::new();
    for (i, cell) in c.cells.iter().enumerate() {
        let mut seen = BTreeSet::from([i]);
        let mut stack = vec![i];
        while let Some(k) = stack.pop() {
            for q in p.portals.iter().filter(|q| q.from == k && !q.closed) {
                if let Some(to) = q.to {
                    if seen.insert(to) {
                        stack.push(to);
                    }
                }
            }
        }
        let names = seen.iter().map(|&k| room_of(t, c, Some(k))).collect();
        reach.push((t.tagging.rooms[cell.room].name.clone(), names));
    }
    reach.sort();
    let full = portcullis::vis::of_level(
        c.cells.len(),
        p,
        c.tolerance.distance,
        &portcullis::vis::VisOptions::default(),
    );
    let mut pvs: Vec<(String, BTreeSet<String>)> = (0..c.cells.len())
        .map(|i| {
            let seen = full.visible(i).map(|k| room_of(t, c, Some(k))).collect();
            (room_of(t, c, Some(i)), seen)
        })
        .collect();
    pvs.sort();
    Level {
        rooms,
        cells,
        portals,
        reach,
        pvs,
    }
}

fn centroid(poly: &[DVec3]) -> DVec3 {
    poly.iter().copied().sum::<DVec3>() / poly.len().max(1) as f64
}

/// Every vertex of `a` has one of `b` within `tol`, and the other way round.
fn same_polygon(a: &[DVec3], b: &[DVec3], tol: f64) -> bool {
    let near = |x: &[DVec3], y: &[DVec3]| x.iter().all(|p| y.iter().any(|q| p.distance(*q) <= tol));
    near(a, b) && near(b, a)
}

fn assert_same(what: &str, a: &Level, b: &Level, tol: f64) {
    assert_eq!(a.rooms, b.rooms, "{what}: rooms");
    assert_eq!(a.cells.len(), b.cells.len(), "{what}: cell count");
    for (x, y) in a.cells.iter().zip(&b.cells) {
        assert_eq!(x.0, y.0, "{what}: cell rooms");
        assert!(
            (x.1 - y.1).abs() <= tol * x.1.max(1.0),
            "{what}: volume of a cell of {}: {} vs {}",
            x.0,
            x.1,
            y.1
        );
        assert!(
            x.2.distance(y.2) <= tol && x.3.distance(y.3) <= tol,
            "{what}: bounds of a cell of {}: {:?} vs {:?}",
            x.0,
            (x.2, x.3),
            (y.2, y.3)
        );
    }
    assert_eq!(a.portals.len(), b.portals.len(), "{what}: portal count");
    for (x, y) in a.portals.iter().zip(&b.portals) {
        assert_eq!((&x.0, &x.1), (&y.0, &y.1), "{what}: portal rooms");
        assert!(
            same_polygon(&x.2, &y.2, tol),
            "{what}: portal {} -> {}: {:?} vs {:?}",
            x.0,
            x.1,
            x.2,
            y.2
        );
    }
    assert_eq!(a.reach, b.reach, "{what}: flood reachability");
    assert_eq!(a.pvs, b.pvs, "{what}: full PVS");
}

/// The level without its exterior openings.
fn interior(mut l: Level) -> Level {
    l.portals.retain(|p| p.1 != "<exterior>");
    l
}

fn level(path: &Path, preset: Option<&str>) -> (Level, Tagged) {
    let (t, c, p) = load_level(path, preset);
    (summarise(&t, &c, &p), t)
}

#[test]
fn third_party_usda_copies_match_their_glb() {
    for (name, preset, rooms) in [
        ("lportal_tutorial_simple", None, 2),
        ("lportal_boxrooms", None, 16),
        ("panda3d_culling", Some("panda3d"), 11),
    ] {
        let (glb, _) = level(&fixture(&format!("{name}.glb")), preset);
        let (usda, t) = level(&fixture(&format!("{name}.usda")), preset);
        assert_eq!(usda.rooms.len(), rooms, "{name}: {:?}", usda.rooms);
        assert!(!usda.portals.is_empty(), "{name}: no portals");
        assert!(
            !t.diagnostics
                .iter()
                .any(|d| d.code.as_str().starts_with("USD_")),
            "{name}: {:?}",
            t.diagnostics
        );
        // glb positions are f32 like USD points; transforms differ only in rounding.
        assert_same(name, &glb, &usda, 1e-4);
    }
}

#[test]
fn z_up_centimetres_give_the_cells_of_the_y_up_metre_twin() {
    let (y, _) = level(&usd("rooms_y_m.usda"), None);
    let (z, t) = level(&usd("rooms_z_cm.usda"), None);
    assert_eq!(y.rooms, ["a", "b", "c"]);
    assert_eq!(y.cells.len(), 3);
    // Y-up metres: the rooms are 3 m tall along +Y and 12 m long along +X.
    let top = y.cells.iter().map(|c| c.3.y).fold(f64::MIN, f64::max);
    assert!((top - 3.0).abs() < 1e-6, "{top}");
    assert!(y.portals.iter().any(|p| p.0 == "a" && p.1 == "b"));
    assert_same("z-up cm", &y, &z, 1e-5);
    assert!(!t.diagnostics.has(Code::USD_UNITS_ASSUMED));
}

#[test]
fn an_instanced_room_gives_the_result_of_its_flattened_copy() {
    let (flat, tf) = level(&usd("rooms_flat.usda"), None);
    let (inst, ti) = level(&usd("rooms_instanced.usda"), None);
    assert_eq!(inst.rooms, ["a", "b", "c"]);
    assert_same("instanced", &flat, &inst, 1e-9);
    // Instance proxies share their prototype's meshes: stored once.
    assert_eq!(tf.scene.meshes.len(), 12);
    assert_eq!(ti.scene.meshes.len(), 4);
    assert_eq!(ti.scene.triangle_count(), tf.scene.triangle_count());
}

#[test]
fn a_portal_light_is_a_light_not_a_portal() {
    let (lvl, t) = level(&usd("portal_light.usda"), None);
    assert_eq!(lvl.rooms, ["a"]);
    assert!(t.tagging.portals.is_empty(), "{:?}", t.tagging.portals);
    assert!(t
        .scene
        .walk()
        .iter()
        .all(|&n| t.scene.nodes[n].name.as_deref() != Some("portal_window")));
    let d = t
        .diagnostics
        .iter()
        .find(|d| d.code == Code::USD_PORTAL_LIGHT_IGNORED)
        .expect("portal light reported");
    assert_eq!(
        d.location.source.prim.as_deref(),
        Some("/World/room_a/portal_window")
    );
    assert!(!t.diagnostics.has(Code::TAG_PORTAL_NO_MESH));
}

#[test]
fn tags_come_from_custom_data_and_custom_attributes() {
    let (lvl, t) = level(&usd("tags_and_hidden.usda"), None);
    // Kitchen by customData `portcullis:room`, Lounge by a custom attribute `room`; the
    // invisible and the guide rooms are left out.
    assert_eq!(lvl.rooms, ["kitchen", "lounge"]);
    assert_eq!(t.tagging.portals.len(), 1);
    let p = &t.tagging.portals[0];
    assert_eq!(p.target_name.as_deref(), Some("lounge"));
    assert!(p.one_way);
    assert!(p.path.ends_with("Kitchen/DoorQuad"), "{}", p.path);
    assert!(t.diagnostics.has(Code::USD_PRIMS_HIDDEN));
    assert!(t.diagnostics.has(Code::USD_GPRIM_UNSUPPORTED));
    let s = &t.scene;
    let find = |name: &str| {
        s.walk()
            .into_iter()
            .find(|&n| s.nodes[n].name.as_deref() == Some(name))
            .unwrap_or_else(|| panic!("{name}"))
    };
    // holeIndices: the rug's second face is a hole.
    let rug = &s.meshes[s.nodes[find("rug")].mesh.unwrap()];
    assert_eq!(rug.triangles.len(), 2);
    // leftHanded: the panel, drawn counter-clockwise seen from +z, faces -z.
    let panel_node = find("panel");
    let panel = &s.meshes[s.nodes[panel_node].mesh.unwrap()];
    let [a, b, c] = panel.triangles[0].map(|i| panel.positions[i as usize]);
    assert!((b - a).cross(c - a).z < 0.0);
    // The prim path is the source of every node.
    assert_eq!(
        s.nodes[panel_node].source.prim.as_deref(),
        Some("/World/Lounge/panel")
    );
    // The Lounge is moved by its translate op.
    let w = s.world_positions_used(find("rug"));
    assert!(w.iter().all(|p| p.x > 4.0), "{w:?}");
}

#[test]
fn a_broken_usda_ends_with_the_usd_error_and_exit_2() {
    let out = portcullis()
        .arg("inspect")
        .arg(usd("broken.usda"))
        .output()
        .unwrap();
    let err =
        String::from_utf8_lossy(&out.stderr).to_string() + &String::from_utf8_lossy(&out.stdout);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("USD_OPEN_FAILED"), "{err}");
    assert!(err.contains("parse error"), "{err}");
    assert!(!err.contains("Traceback"), "{err}");
}

#[test]
fn a_missing_usd_core_says_how_to_install_it() {
    let empty = tempfile::tempdir().unwrap();
    let out = portcullis()
        .arg("inspect")
        .arg("--python-venv")
        .arg(empty.path())
        .arg(usd("rooms_y_m.usda"))
        .env_remove("PYTHONPATH")
        .output()
        .unwrap();
    let err =
        String::from_utf8_lossy(&out.stderr).to_string() + &String::from_utf8_lossy(&out.stdout);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("USD_CORE_MISSING"), "{err}");
    assert!(
        err.contains(&format!(
            "pip install usd-core=={}",
            portcullis::import::usd::USD_CORE_VERSION
        )),
        "{err}"
    );
    assert!(!err.contains("Traceback"), "{err}");
}

#[test]
fn the_test_script_installs_the_pinned_usd_core() {
    let script = std::fs::read_to_string(common::root().join("scripts/test.sh")).unwrap();
    assert!(script.contains(&format!(
        "usd-core=={}",
        portcullis::import::usd::USD_CORE_VERSION
    )));
}

#[test]
fn a_level_written_as_usda_reads_back_the_same() {
    let dir = tempfile::tempdir().unwrap();
    for (name, preset) in [
        ("lportal_tutorial_simple.glb", None),
        ("panda3d_culling.glb", Some("panda3d")),
    ] {
        let out = dir.path().join(name.replace(".glb", ".usda"));
        let mut cmd = portcullis();
        cmd.arg("convert").arg(fixture(name)).arg("-o").arg(&out);
        if let Some(p) = preset {
            cmd.arg("--tags").arg(p);
        }
        let o = cmd.output().unwrap();
        assert!(
            o.status.code().is_some_and(|c| c < 2),
            "{}",
            String::from_utf8_lossy(&o.stderr)
        );
        let (a, _) = level(&fixture(name), preset);
        let (b, t) = level(&out, preset);
        assert_same(name, &a, &b, 1e-4);
        // The annotation is not level geometry, and converting again replaces it.
        assert!(t
            .scene
            .walk()
            .iter()
            .all(|&n| t.scene.nodes[n].name.as_deref() != Some("PortcullisAnnotation")));
        let again = dir.path().join("again.usda");
        let mut cmd = portcullis();
        cmd.arg("convert").arg(&out).arg("-o").arg(&again);
        if let Some(p) = preset {
            cmd.arg("--tags").arg(p);
        }
        assert!(cmd.output().unwrap().status.code().is_some_and(|c| c < 2));
        let text = std::fs::read_to_string(&again).unwrap();
        assert_eq!(
            text.matches("def Scope \"PortcullisAnnotation\"").count(),
            1
        );
        assert_eq!(
            text.matches("portcullis:polygon").count(),
            b.portals.len(),
            "{name}"
        );
    }
}

#[test]
fn usdc_and_usdz_copies_read_like_the_usda() {
    let (a, _) = level(&usd("rooms_y_m.usda"), None);
    for f in ["rooms_y_m.usdc", "rooms_y_m.usdz"] {
        let (b, _) = level(&usd(f), None);
        assert_same(f, &a, &b, 1e-12);
    }
}

#[test]
fn a_venv_without_usd_core_says_how_to_install_it() {
    // A venv-shaped folder whose site-packages lacks pxr, for any Python 3 version.
    let venv = tempfile::tempdir().unwrap();
    for minor in 8..=20 {
        std::fs::create_dir_all(
            venv.path()
                .join(format!("lib/python3.{minor}/site-packages")),
        )
        .unwrap();
    }
    let out = portcullis()
        .arg("inspect")
        .arg(usd("rooms_y_m.usda"))
        .env("VIRTUAL_ENV", venv.path())
        .env_remove("PYTHONPATH")
        .output()
        .unwrap();
    let err =
        String::from_utf8_lossy(&out.stderr).to_string() + &String::from_utf8_lossy(&out.stdout);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("USD_CORE_MISSING"), "{err}");
    assert!(err.contains("No module named 'pxr'"), "{err}");
    assert!(err.contains("from VIRTUAL_ENV"), "{err}");
    assert!(!err.contains("Traceback"), "{err}");
}

#[test]
fn a_point_instancer_places_its_prototypes_and_only_there() {
    let (lvl, t) = level(&usd("point_instancer.usda"), None);
    assert_eq!(lvl.rooms, ["a"]);
    let s = &t.scene;
    let crates: Vec<usize> = s
        .walk()
        .into_iter()
        .filter(|&n| s.nodes[n].name.as_deref() == Some("crate"))
        .collect();
    // Three instances, one of them invisible; the prototype itself is not drawn.
    assert_eq!(crates.len(), 2);
    let mesh = s.nodes[crates[0]].mesh;
    assert!(mesh.is_some());
    assert_eq!(s.nodes[crates[1]].mesh, mesh, "instances share the mesh");
    let mut centres: Vec<DVec3> = crates
        .iter()
        .map(|&n| {
            let w = s.world_positions_used(n);
            w.iter().copied().sum::<DVec3>() / w.len() as f64
        })
        .collect();
    centres.sort_by(|a, b| a.x.total_cmp(&b.x));
    // instancer at x + 1, positions (1,0,1) and (2,0,2), the prototype lifted by 0.25
    assert!(
        centres[0].distance(DVec3::new(2.0, 0.25, 1.0)) < 1e-6,
        "{centres:?}"
    );
    assert!(
        centres[1].distance(DVec3::new(3.0, 0.25, 2.0)) < 1e-6,
        "{centres:?}"
    );
    // The crates are props of the room, inside its cell.
    assert!(t.tagging.rooms[0].structure.len() + t.tagging.rooms[0].detail.len() >= 6);
}

#[test]
fn a_usd_level_converts_to_a_valid_annotated_glb() {
    let dir = tempfile::tempdir().unwrap();
    for (input, twin) in [
        (usd("rooms_z_cm.usda"), usd("rooms_y_m.usda")),
        (
            fixture("lportal_boxrooms.usda"),
            fixture("lportal_boxrooms.glb"),
        ),
    ] {
        let out = dir.path().join("out.glb");
        common::succeeds(portcullis().arg("convert").arg(&input).arg("-o").arg(&out));
        if let Some(report) = common::khronos_validate(&out) {
            assert_eq!(
                report["issues"]["numErrors"], 0,
                "{}",
                report["issues"]["messages"]
            );
        }
        // Node transforms are baked into the written meshes: the same cells and portals
        // between rooms. (Exterior openings may be cut into other convex pieces: the baked f32
        // positions differ from the original f32 ones in the last bit.)
        let (a, _) = level(&twin, None);
        let (b, _) = level(&out, None);
        assert_same(
            &input.display().to_string(),
            &interior(a),
            &interior(b),
            1e-4,
        );
    }
}

#[test]
fn a_missing_reference_is_reported() {
    let (_, t) = level(&usd("missing_reference.usda"), None);
    let d = t
        .diagnostics
        .iter()
        .find(|d| d.code == Code::USD_COMPOSITION_ERROR)
        .expect("composition error reported");
    assert!(d.message.contains("no_such_room.usda"), "{}", d.message);
}

#[test]
fn broken_meshes_are_reported_and_the_rest_of_the_level_is_read() {
    let (lvl, t) = level(&usd("bad_meshes.usda"), None);
    assert_eq!(lvl.rooms, ["a"]);
    assert_eq!(lvl.cells.len(), 1);
    let with = |code: Code| t.diagnostics.iter().filter(|d| d.code == code).count();
    assert_eq!(with(Code::USD_MESH_INVALID), 2, "{:?}", t.diagnostics);
    assert_eq!(with(Code::GEOM_NON_FINITE), 1);
    assert_eq!(with(Code::GEOM_DEGENERATE_TRIANGLES), 1);
    let s = &t.scene;
    let mesh_of = |name: &str| {
        s.walk()
            .into_iter()
            .find(|&n| s.nodes[n].name.as_deref() == Some(name))
            .and_then(|n| s.nodes[n].mesh)
    };
    assert_eq!(mesh_of("out_of_range"), None);
    assert_eq!(mesh_of("short_indices"), None);
    assert_eq!(s.meshes[mesh_of("nan_point").unwrap()].triangles.len(), 1);
    assert_eq!(s.meshes[mesh_of("two_corners").unwrap()].triangles.len(), 1);
    let invalid = t
        .diagnostics
        .iter()
        .find(|d| d.code == Code::USD_MESH_INVALID)
        .unwrap();
    assert!(invalid
        .location
        .source
        .prim
        .as_deref()
        .is_some_and(|p| p.starts_with("/World/room_a/")));
}
