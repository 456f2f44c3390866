//! Cells on samples with known answers, on the third-party levels, and under translation,
//! rotation and scale of the level.

mod common;

use common::{fixture, sample};
use glam::{DMat4, DQuat, DVec3};
use portcullis::cells::{CellSet, CellSource};
use portcullis::diag::Code;
use portcullis::pipeline::{build_cells, Tagged};

fn load(path: &std::path::Path, preset: Option<&str>) -> (Tagged, CellSet) {
    common::load_cells(path, preset)
}

fn room_cells<'a>(t: &Tagged, c: &'a CellSet, room: &str) -> Vec<&'a portcullis::cells::Cell> {
    let r = t
        .tagging
        .room_by_name(&t.rules, room)
        .unwrap_or_else(|| panic!("no room {room}"));
    c.room_cells[r].iter().map(|&i| &c.cells[i]).collect()
}

/// Every cell vertex is inside every plane of its cell (convexity), and faces are planar.
fn assert_convex(c: &CellSet) {
    let eps = c.tolerance.distance * 10.0;
    for (i, cell) in c.cells.iter().enumerate() {
        assert!(cell.poly.faces.len() >= 4, "cell {i}");
        for f in &cell.poly.faces {
            for p in &f.points {
                assert!(
                    f.plane.distance(*p).abs() <= eps,
                    "cell {i}: face not planar"
                );
            }
        }
        for v in cell.poly.vertices(eps) {
            for f in &cell.poly.faces {
                assert!(f.plane.distance(v) <= eps, "cell {i}: not convex");
            }
        }
        assert!(cell.volume > 0.0);
    }
}

/// Cells of one room never overlap each other.
fn assert_room_cells_disjoint(c: &CellSet) {
    for cells in &c.room_cells {
        for (k, &a) in cells.iter().enumerate() {
            for &b in &cells[k + 1..] {
                let x = c.cells[a]
                    .poly
                    .intersection(&c.cells[b].poly, c.tolerance.distance);
                let v = x.map(|x| x.volume()).unwrap_or(0.0);
                assert!(v < 1e-6, "cells {a} and {b} overlap by {v}");
            }
        }
    }
}

fn assert_box(cell: &portcullis::cells::Cell, min: [f64; 3], max: [f64; 3], tol: f64) {
    let b = cell.bounds;
    for k in 0..3 {
        assert!(
            (b.min[k] - min[k]).abs() < tol && (b.max[k] - max[k]).abs() < tol,
            "{b:?} vs {min:?}..{max:?}"
        );
    }
    let v = (max[0] - min[0]) * (max[1] - min[1]) * (max[2] - min[2]);
    assert!(
        (cell.volume - v).abs() < tol * v.max(1.0),
        "volume {} vs {v}",
        cell.volume
    );
}

#[test]
fn two_box_rooms() {
    let (t, c) = load(&sample("two_rooms.gltf"), None);
    assert_eq!(c.cells.len(), 2);
    let k = room_cells(&t, &c, "kitchen");
    let l = room_cells(&t, &c, "lounge");
    assert_box(k[0], [0., 0., 0.], [4., 3., 4.], 1e-9);
    assert_box(l[0], [4., 0., 0.], [8., 3., 4.], 1e-9);
    assert_eq!(k[0].source, CellSource::Hull);
    // The table is a prop of the kitchen, rendered there.
    let table = t
        .scene
        .walk()
        .into_iter()
        .find(|&n| t.scene.node_label(n) == "Table-detail")
        .unwrap();
    assert!(k[0].nodes.contains(&table));
    assert!(!l[0].nodes.contains(&table));
    assert!(
        !t.diagnostics.has(Code::CELL_OVERLAP),
        "{:?}",
        t.diagnostics
    );
    assert_convex(&c);
}

/// Non-convex rooms split into the known number of convex cells whose volumes sum to the
/// room's (computed here from the room shell itself by the divergence theorem).
#[test]
fn non_convex_rooms_split_into_convex_cells() {
    for (file, cells, volume) in [
        ("l_room.gltf", 2, 81.0),
        ("u_room.gltf", 3, 135.0),
        ("pillar_room.gltf", 4, 105.0),
        ("sloped_hall.gltf", 1, 336.0),
    ] {
        let (t, c) = load(&sample(file), None);
        assert_eq!(c.cells.len(), cells, "{file}");
        // The shell faces inward, so its signed volume is minus the room's.
        let mut shell = 0.0;
        for n in t.scene.walk() {
            let Some(m) = t.scene.nodes[n].mesh else {
                continue;
            };
            let w = t.scene.world_positions(n);
            for tri in &t.scene.meshes[m].triangles {
                let [a, b, cc] = tri.map(|i| w[i as usize]);
                shell += a.dot(b.cross(cc)) / 6.0;
            }
        }
        assert!(
            (-shell - volume).abs() < 1e-9 * volume,
            "{file}: shell volume {shell}"
        );
        let sum: f64 = c.cells.iter().map(|x| x.volume).sum();
        assert!(
            (sum - volume).abs() <= 1e-9 * volume,
            "{file}: cells sum to {sum}, room {volume}"
        );
        assert_convex(&c);
        assert_room_cells_disjoint(&c);
        if cells > 1 {
            assert!(c.cells.iter().all(|x| x.source == CellSource::Split));
        }
        assert!(!t.diagnostics.has_errors(), "{file}: {:?}", t.diagnostics);
    }
}

#[test]
fn bound_boxes_are_the_cells_of_a_one_mesh_level() {
    let (t, c) = load(&sample("bound_boxes.gltf"), None);
    assert_eq!(c.cells.len(), 2);
    let k = room_cells(&t, &c, "kitchen");
    let l = room_cells(&t, &c, "lounge");
    assert_box(k[0], [0., 0., 0.], [4., 3., 4.], 1e-9);
    assert_box(l[0], [4., 0., 0.], [8., 3., 4.], 1e-9);
    assert_eq!(k[0].source, CellSource::Bound);
    // The one building mesh is rendered by both cells.
    let building = t
        .scene
        .walk()
        .into_iter()
        .find(|&n| t.scene.node_label(n) == "building")
        .unwrap();
    assert!(k[0].nodes.contains(&building) && l[0].nodes.contains(&building));
    assert!(!t.diagnostics.has_errors(), "{:?}", t.diagnostics);
}

/// Each LPortal room is a floor slab and 0.2 m wall blocks (closed boxes): the room is the air
/// between the blocks (issue 41), so each room is the air inside its walls and the door reveal
/// between two of its wall blocks, two cells; the reveals of the two rooms meet at x = 3.
#[test]
fn lportal_tutorial_simple_has_a_cell_per_room_and_per_door_reveal() {
    for file in ["lportal_tutorial_simple.glb", "lportal_tutorial_simple.obj"] {
        let (t, c) = load(&fixture(file), None);
        assert_eq!(c.cells.len(), 4, "{file}");
        // f32 input through rotation matrices: the data itself is off by up to 5e-7 m.
        let k = room_cells(&t, &c, "kitchen");
        let l = room_cells(&t, &c, "lounge");
        assert_eq!((k.len(), l.len()), (2, 2), "{file}");
        assert_box(k[0], [-2.8, 0.1, -2.8], [2.8, 2., 2.8], 1e-5);
        assert_box(k[1], [2.8, 0.1, -1.], [3., 2., 1.], 1e-5);
        assert_box(l[0], [3.2, 0.1, -2.8], [8.8, 2., 2.8], 1e-5);
        assert_box(l[1], [3., 0.1, -1.], [3.2, 2., 1.], 1e-5);
        // The mesh outside every room sits inside the kitchen and is rendered there.
        let cam = t
            .scene
            .walk()
            .into_iter()
            .find(|&n| t.scene.node_path(n).ends_with("Camera/MeshInstance"))
            .unwrap();
        assert!(room_cells(&t, &c, "kitchen")[0].nodes.contains(&cam));
        assert!(!t.diagnostics.has(Code::CELL_GEOMETRY_OUTSIDE));
        assert_convex(&c);
    }
}

/// 16 rooms of 4 x 4 m around 0.2 m wall blocks, 1.2 m high: one cell each, 3.6 m across the
/// walls and 3.6 m long, or 3.8 to 4 m where a side has no wall (a full-wall portal).
#[test]
fn lportal_boxrooms_has_16_cells_and_no_overlaps() {
    for file in ["lportal_boxrooms.glb", "lportal_boxrooms.obj"] {
        let (t, c) = load(&fixture(file), None);
        assert_eq!(c.cells.len(), 16, "{file}");
        assert!(
            !t.diagnostics.has(Code::CELL_OVERLAP),
            "{file}: {:?}",
            t.diagnostics
        );
        for r in 0..16 {
            assert_eq!(c.room_cells[r].len(), 1);
            let v = c.cells[c.room_cells[r][0]].volume;
            assert!(
                v > 3.6 * 3.6 * 1.2 - 1e-4 && v < 3.6 * 4.0 * 1.2 + 1e-4,
                "{}: {v}",
                t.tagging.rooms[r].name
            );
        }
        // Overlap oracle independent of the check: pairwise intersection volumes.
        for a in 0..16 {
            for b in a + 1..16 {
                let v = c.cells[a]
                    .poly
                    .intersection(&c.cells[b].poly, 1e-6)
                    .map(|x| x.volume())
                    .unwrap_or(0.0);
                assert!(v < 4.8 * c.tolerance.distance * 2.0, "{a} {b} overlap {v}");
            }
        }
        assert_convex(&c);
    }
}

#[test]
fn panda3d_footprints_become_cells_that_cover_them() {
    for file in ["panda3d_culling.glb", "panda3d_culling.obj"] {
        let (t, c) = load(&fixture(file), Some("panda3d"));
        assert_eq!(t.tagging.rooms.len(), 11);
        assert_convex(&c);
        assert_room_cells_disjoint(&c);
        for (r, room) in t.tagging.rooms.iter().enumerate() {
            assert!(!c.room_cells[r].is_empty(), "{}", room.name);
            assert!(c.room_cells[r]
                .iter()
                .all(|&i| c.cells[i].source == CellSource::Footprint));
            // Every footprint triangle (raised 1 cm) is inside a cell of its room.
            let w = t.scene.world_positions(room.footprints[0]);
            let m = t.scene.nodes[room.footprints[0]].mesh.unwrap();
            let mut fp_area = 0.0;
            for tri in &t.scene.meshes[m].triangles {
                let [a, b, cc] = tri.map(|i| w[i as usize]);
                let centre = (a + b + cc) / 3.0 + DVec3::Y * 0.01;
                assert!(
                    c.room_cells[r]
                        .iter()
                        .any(|&i| c.cells[i].poly.contains(centre, 1e-6)),
                    "{file}: {}: footprint triangle at {centre} in no cell",
                    room.name
                );
                let n = (b - a).cross(cc - a);
                fp_area += 0.5 * n.y.abs();
            }
            // ... and the cells' plan area is the footprint's: they cover it exactly.
            let plan_area: f64 = c.room_cells[r]
                .iter()
                .map(|&i| {
                    let poly = &c.cells[i].poly;
                    poly.faces
                        .iter()
                        .filter(|f| f.plane.normal.y < -1e-6)
                        .map(|f| plan_area(&f.points))
                        .sum::<f64>()
                })
                .sum();
            assert!(
                (plan_area - fp_area).abs() < 1e-5 * fp_area.max(1.0),
                "{}: {plan_area} vs {fp_area}",
                room.name
            );
        }
    }
}

fn plan_area(pts: &[DVec3]) -> f64 {
    let mut a = 0.0;
    for (i, p) in pts.iter().enumerate() {
        let q = pts[(i + 1) % pts.len()];
        a += p.x * q.z - q.x * p.z;
    }
    0.5 * a.abs()
}

fn transformed(t: &Tagged, m: DMat4) -> (Tagged, CellSet) {
    let mut t2 = t.clone();
    for n in &mut t2.scene.nodes {
        n.world = m * n.world;
    }
    t2.config.cells.up = m
        .transform_vector3(DVec3::from_array(t.config.cells.up))
        .normalize()
        .to_array();
    t2.diagnostics = Default::default();
    let c = build_cells(&mut t2);
    (t2, c)
}

/// The same cells, up to the transform, after moving, turning or scaling the level.
#[test]
fn cells_are_invariant_under_translation_rotation_and_scale() {
    let rot = DQuat::from_euler(glam::EulerRot::XYZ, 0.3, -1.1, 0.7);
    let transforms = [
        DMat4::from_translation(DVec3::new(1e5, -3e4, 2e5)),
        DMat4::from_quat(rot),
        DMat4::from_rotation_y(std::f64::consts::FRAC_PI_2),
        DMat4::from_scale(DVec3::splat(1e-3)),
        DMat4::from_scale(DVec3::splat(1e3)),
    ];
    for (file, preset) in [
        ("two_rooms.gltf", None),
        ("l_room.gltf", None),
        ("pillar_room.gltf", None),
        ("bound_boxes.gltf", None),
    ] {
        let (t, c) = load(&sample(file), preset);
        for m in &transforms {
            let scale = m.transform_vector3(DVec3::X).length();
            let (_, c2) = transformed(&t, *m);
            assert_eq!(c.cells.len(), c2.cells.len(), "{file} under {m:?}");
            assert_eq!(c.room_cells, c2.room_cells, "{file}");
            let tol = 1e-6 * scale * 10.0;
            for (a, b) in c.cells.iter().zip(&c2.cells) {
                assert!(
                    (a.volume * scale.powi(3) - b.volume).abs() <= 1e-6 * b.volume,
                    "{file}: {} vs {}",
                    a.volume,
                    b.volume
                );
                let vb = b.poly.vertices(tol);
                for v in a.poly.vertices(1e-9) {
                    let w = m.transform_point3(v);
                    assert!(
                        vb.iter()
                            .any(|u| u.distance(w) <= tol.max(1e-9 * w.length())),
                        "{file}: vertex {w} missing"
                    );
                }
            }
        }
    }
}

/// Every floor triangle of the building (an upward-facing triangle of `levelgeo` with room
/// above it) lies in the cells of exactly one room.
#[test]
fn panda3d_floor_triangles_lie_in_exactly_one_room() {
    let (t, c) = load(&fixture("panda3d_culling.glb"), Some("panda3d"));
    let geo = t
        .scene
        .walk()
        .into_iter()
        .find(|&n| t.scene.node_label(n) == "levelgeo")
        .unwrap();
    let w = t.scene.world_positions(geo);
    let m = t.scene.nodes[geo].mesh.unwrap();
    let mut floors = 0;
    for tri in &t.scene.meshes[m].triangles {
        let [a, b, cc] = tri.map(|i| w[i as usize]);
        let n = (b - a).cross(cc - a).normalize_or_zero();
        if n.y < 0.9 {
            continue;
        }
        let p = (a + b + cc) / 3.0 + DVec3::Y * 0.01;
        let rooms: std::collections::BTreeSet<usize> = c
            .cells
            .iter()
            .filter(|cell| cell.poly.contains(p, 1e-6))
            .map(|cell| cell.room)
            .collect();
        // Only the roof, the top of the building, has no room above it.
        let top = w.iter().map(|v| v.y).fold(f64::MIN, f64::max);
        if rooms.is_empty() {
            assert!(p.y > top - 0.05, "floor triangle at {p} is in no room");
            continue;
        }
        floors += 1;
        assert_eq!(
            rooms.len(),
            1,
            "floor triangle at {p} is in rooms {rooms:?}"
        );
    }
    assert!(floors > 20, "{floors} floor triangles");
}

/// Without the panda3d preset, the `cellN` floors are rooms made only of floor: they are
/// extruded the same way, giving the same cells.
#[test]
fn panda3d_floors_without_the_preset_give_the_same_cells() {
    let (_, a) = load(&fixture("panda3d_culling.glb"), Some("panda3d"));
    let (t, b) = load(&fixture("panda3d_culling.glb"), None);
    assert_eq!(a.cells.len(), b.cells.len());
    for (x, y) in a.cells.iter().zip(&b.cells) {
        assert!((x.volume - y.volume).abs() < 1e-9 * x.volume);
    }
    assert!(t.diagnostics.has(Code::CELL_ROOM_FROM_FLOOR));
    assert!(!t.diagnostics.has_errors());
}

/// `--split-geometry`: a mesh spanning cells is cut along the cell planes; the pieces lie in
/// their cells and together have exactly the mesh's area.
#[test]
fn split_geometry_partitions_surfaces_between_cells() {
    for file in ["l_room.gltf", "u_room.gltf", "pillar_room.gltf"] {
        let (t, c) = load(&sample(file), None);
        let pieces = portcullis::cells::split_geometry(&t.scene, &c);
        assert!(!pieces.is_empty(), "{file}");
        let area = |tris: &mut dyn Iterator<Item = [DVec3; 3]>| -> f64 {
            tris.map(|t| 0.5 * (t[1] - t[0]).cross(t[2] - t[0]).length())
                .sum()
        };
        let nodes: std::collections::BTreeSet<usize> = pieces.iter().map(|p| p.node).collect();
        for n in nodes {
            let w = t.scene.world_positions(n);
            let m = t.scene.nodes[n].mesh.unwrap();
            let whole = area(
                &mut t.scene.meshes[m]
                    .triangles
                    .iter()
                    .map(|tri| tri.map(|i| w[i as usize])),
            );
            let parts = area(
                &mut pieces
                    .iter()
                    .filter(|p| p.node == n)
                    .flat_map(|p| p.triangles.iter().copied()),
            );
            assert!(
                (whole - parts).abs() <= 1e-9 * whole,
                "{file}: {} area {whole} split into {parts}",
                t.scene.node_label(n)
            );
        }
        for p in &pieces {
            for tri in &p.triangles {
                let centre = (tri[0] + tri[1] + tri[2]) / 3.0;
                assert!(
                    c.cells[p.cell].poly.contains(centre, 1e-9),
                    "{file}: piece outside its cell"
                );
            }
        }
    }
}

/// Where nothing is above a footprint and the level's top is too close (a terrace on the roof),
/// it rises to the level's own storey height, the median clearance above its footprints, not
/// to a length in metres: the same cells, scaled, whatever the level's unit.
#[test]
fn footprints_with_nothing_above_rise_to_the_levels_storey_height() {
    use serde_json::json;
    let v = DVec3::new;
    // Two triangles over x in [x0, x0 + 4], z in [0, 4] at height y, facing up (or down).
    let quad = |y: f64, x0: f64, down: bool| {
        let (a, b, c, d) = (
            v(x0, y, 0.0),
            v(x0 + 4.0, y, 0.0),
            v(x0 + 4.0, y, 4.0),
            v(x0, y, 4.0),
        );
        if down {
            vec![[a, b, c], [a, c, d]]
        } else {
            vec![[a, c, b], [a, d, c]]
        }
    };
    for s in [1e-3, 1.0, 1e3] {
        let parts: Vec<common::Part> = vec![
            ("hall-room", None, vec![], None),
            (
                "hall_floor",
                None,
                quad(0.0, 0.0, false),
                Some(json!({"footprint": "hall"})),
            ),
            ("roof", None, quad(2.5, 0.0, true), None),
            ("terrace-room", None, vec![], None),
            (
                "terrace_floor",
                None,
                quad(2.5, 4.0, false),
                Some(json!({"footprint": "terrace"})),
            ),
        ];
        let mut t = common::tagged(common::scene_of(parts, DMat4::from_scale(DVec3::splat(s))));
        let c = build_cells(&mut t);
        for (room, floor) in [("hall", 0.0), ("terrace", 2.5)] {
            let cells = room_cells(&t, &c, room);
            assert_eq!(cells.len(), 1, "scale {s}: {room}");
            let b = cells[0].bounds;
            let want = [floor * s, (floor + 2.5) * s];
            let ok = (b.min.y - want[0]).abs() <= 1e-9 * s && (b.max.y - want[1]).abs() <= 1e-9 * s;
            assert!(
                ok,
                "scale {s}: {room} spans {}..{} along up, not {}..{}",
                b.min.y, b.max.y, want[0], want[1]
            );
        }
    }
}

/// Issue 29, item 9: a prop or stray mesh outside every room (a copy of the sample's table 26 m
/// away) makes no cell and is reported as geometry in no cell, whether it is tagged as a
/// prop, left untagged at the root, or left under a room's node; no cell renders it.
#[test]
fn geometry_outside_every_room_is_reported_and_rendered_by_no_cell() {
    let dir = tempfile::tempdir().unwrap();
    let base: serde_json::Value =
        serde_json::from_slice(&std::fs::read(sample("two_rooms.gltf")).unwrap()).unwrap();
    let index = |doc: &serde_json::Value, name: &str| {
        doc["nodes"]
            .as_array()
            .unwrap()
            .iter()
            .position(|n| n["name"] == name)
            .unwrap()
    };
    for (name, parent) in [
        ("Crate-detail", "Level"),
        ("Crate", "Level"),
        ("Crate", "kitchen-room"),
        ("Crate", "lounge-room"),
        ("Crate-detail", "kitchen-room"),
    ] {
        let mut doc = base.clone();
        let mut crate_node = doc["nodes"][index(&doc, "Table-detail")].clone();
        crate_node["name"] = name.into();
        crate_node["translation"] = serde_json::json!([30.0, 0.0, 30.0]);
        let nodes = doc["nodes"].as_array_mut().unwrap();
        nodes.push(crate_node);
        let new = nodes.len() - 1;
        let p = index(&doc, parent);
        doc["nodes"][p]["children"]
            .as_array_mut()
            .unwrap()
            .push(new.into());
        let path = dir.path().join("outside.gltf");
        std::fs::write(&path, serde_json::to_vec(&doc).unwrap()).unwrap();
        let (t, c) = load(&path, None);
        let what = format!("{name} under {parent}");
        assert_eq!(c.cells.len(), 2, "{what}");
        let outside: Vec<_> = t
            .diagnostics
            .iter()
            .filter(|d| d.code == Code::CELL_GEOMETRY_OUTSIDE)
            .collect();
        assert_eq!(outside.len(), 1, "{what}: {:?}", t.diagnostics);
        assert!(outside[0].message.contains(name), "{what}");
        let id = t
            .scene
            .nodes
            .iter()
            .position(|n| n.name.as_deref() == Some(name))
            .unwrap();
        assert!(
            c.cells.iter().all(|cell| !cell.nodes.contains(&id)),
            "{what}"
        );
    }
}
