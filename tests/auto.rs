//! `--tags auto`: rooms found in geometry nobody tagged (issue 54).

mod common;

use glam::{DMat4, DQuat, DVec3};
use portcullis::import::Imported;
use portcullis::pipeline::{self, Level};

/// Two triangles of the rectangle `a b c d`, wound so they face along `n`.
fn quad(a: DVec3, b: DVec3, c: DVec3, d: DVec3, n: DVec3) -> Vec<[DVec3; 3]> {
    let t = [[a, b, c], [a, c, d]];
    if (b - a).cross(c - a).dot(n) >= 0.0 {
        t.to_vec()
    } else {
        t.iter().map(|t| [t[0], t[2], t[1]]).collect()
    }
}

/// The inward faces of the box `lo..hi` but the sides named in `open` (0..6: -x +x -y +y -z +z).
fn room(lo: DVec3, hi: DVec3, open: &[usize]) -> Vec<[DVec3; 3]> {
    let mut out = Vec::new();
    for axis in 0..3 {
        for (s, at) in [(0, lo[axis]), (1, hi[axis])] {
            if open.contains(&(2 * axis + s)) {
                continue;
            }
            let (p, q) = ((axis + 1) % 3, (axis + 2) % 3);
            let corner = |u: f64, v: f64| {
                let mut c = DVec3::ZERO;
                (c[axis], c[p], c[q]) = (at, u, v);
                c
            };
            let (u0, u1, v0, v1) = (lo[p], hi[p], lo[q], hi[q]);
            let mut n = DVec3::ZERO;
            n[axis] = if s == 0 { 1.0 } else { -1.0 };
            out.extend(quad(
                corner(u0, v0),
                corner(u1, v0),
                corner(u1, v1),
                corner(u0, v1),
                n,
            ));
        }
    }
    out
}

/// A 12 x 3 x 5 m hall cut in two by a wall 0.2 m thick with a door 1 m wide and 2.1 m tall:
/// every surface one-sided, facing the air.
fn two_rooms() -> Vec<[DVec3; 3]> {
    let v = DVec3::new;
    let mut t = room(v(0.0, 0.0, 0.0), v(5.9, 3.0, 5.0), &[1]);
    t.extend(room(v(6.1, 0.0, 0.0), v(12.0, 3.0, 5.0), &[0]));
    // The door's passage: floor, lintel and jambs.
    t.extend(room(v(5.9, 0.0, 2.0), v(6.1, 2.1, 3.0), &[0, 1]));
    // The wall's two faces around the door.
    for (x, n) in [(5.9, -1.0), (6.1, 1.0)] {
        let n = DVec3::X * n;
        t.extend(quad(
            v(x, 0.0, 0.0),
            v(x, 3.0, 0.0),
            v(x, 3.0, 2.0),
            v(x, 0.0, 2.0),
            n,
        ));
        t.extend(quad(
            v(x, 0.0, 3.0),
            v(x, 3.0, 3.0),
            v(x, 3.0, 5.0),
            v(x, 0.0, 5.0),
            n,
        ));
        t.extend(quad(
            v(x, 2.1, 2.0),
            v(x, 3.0, 2.0),
            v(x, 3.0, 3.0),
            v(x, 2.1, 3.0),
            n,
        ));
    }
    t
}

fn auto_level(tris: Vec<[DVec3; 3]>, world: DMat4) -> Level {
    let scene = common::scene_of(vec![("shell", None, tris, None)], world);
    let config = portcullis::config::Config::default();
    let rules = portcullis::config::rule_set(&config, Some("auto")).unwrap();
    let imported = Imported {
        scene,
        diagnostics: Default::default(),
    };
    pipeline::build(pipeline::tag(imported, config, rules))
}

/// Area of the portals from cells of room `a` to cells of room `b`.
fn door_area(l: &Level, a: usize, b: usize) -> f64 {
    let room = |c: usize| l.cells.cells[c].room;
    (l.portals.portals.iter())
        .filter(|p| room(p.from) == a && p.to.is_some_and(|t| room(t) == b))
        .map(|p| p.area)
        .sum()
}

#[test]
fn a_wall_with_a_door_splits_the_air_into_two_rooms_joined_by_a_door_sized_portal() {
    let l = auto_level(two_rooms(), DMat4::IDENTITY);
    let g = l.tagging().generated.as_deref().expect("generated");
    assert_eq!(g.boxes.len(), 2, "rooms");
    let (a, b) = (g.first_room, g.first_room + 1);
    let area = door_area(&l, a, b);
    // The cells are bounded by the walls' own planes, so the portal is the door exactly,
    // not the door narrowed by a voxel on each side (1.87 m² at this level's 4.4 cm voxels).
    assert!((area - 2.1).abs() < 1e-6, "door portal {area} m², not 2.1");
    assert!(!l
        .diagnostics
        .0
        .iter()
        .any(|d| d.code == portcullis::diag::Code::TAG_NO_ROOMS));
}

#[test]
fn the_same_rooms_are_found_turned_and_moved() {
    let l = auto_level(two_rooms(), DMat4::IDENTITY);
    let rot = DQuat::from_axis_angle(DVec3::new(1.0, 2.0, 3.0).normalize(), 37f64.to_radians());
    let world = DMat4::from_rotation_translation(rot, DVec3::new(1e5, 1e5, -1e5));
    let m = auto_level(two_rooms(), world);
    let (g, h) = (
        l.tagging().generated.as_deref().unwrap(),
        m.tagging().generated.as_deref().unwrap(),
    );
    assert_eq!(g.boxes.len(), h.boxes.len(), "rooms");
    assert_eq!(l.cells.cells.len(), m.cells.cells.len(), "cells");
    assert_eq!(g.grid, h.grid);
    let (x, y) = (
        door_area(&l, g.first_room, g.first_room + 1),
        door_area(&m, h.first_room, h.first_room + 1),
    );
    assert!((x - y).abs() < 0.01 * x, "door {x} m² became {y} m²");
}

#[test]
fn a_closed_box_in_a_room_is_no_air_and_splits_nothing() {
    let v = DVec3::new;
    let mut t = room(v(0.0, 0.0, 0.0), v(8.0, 3.0, 6.0), &[]);
    // A crate: a closed mesh facing out, whose inside sees only its back faces.
    for k in common::blocks::box_tris(v(3.0, 0.0, 2.0), v(4.0, 1.0, 3.0)) {
        t.push(k);
    }
    let l = auto_level(t, DMat4::IDENTITY);
    let g = l.tagging().generated.as_deref().unwrap();
    assert_eq!(g.boxes.len(), 1, "one room");
    let inside = v(3.5, 0.5, 2.5);
    assert!(
        !l.cells.cells.iter().any(|c| c.poly.contains(inside, 1e-9)),
        "a cell reaches into the crate"
    );
    let air: f64 = l.cells.cells.iter().map(|c| c.volume).sum();
    // The room's 144 m³ less the crate's 1 m³, exactly: cells meet the walls.
    assert!((air - 143.0).abs() < 1e-6, "air {air} m³");
}

#[test]
fn a_level_with_tagged_rooms_is_read_as_tagged() {
    // samples/arch.gltf tags `west` and `east`; generating in the rest left slivers the PVS
    // did not join to them (40 missed sightlines).
    let l = common::built(&common::sample("arch.gltf"), Some("auto"));
    assert!(l.tagging().generated.is_none(), "rooms were generated");
    let names: Vec<&str> = l.tagging().rooms.iter().map(|r| r.name.as_str()).collect();
    assert!(
        names.contains(&"west") && names.contains(&"east"),
        "{names:?}"
    );
    assert!(names.iter().all(|n| !n.starts_with("auto-")), "{names:?}");
}

#[test]
fn a_closet_of_six_slabs_in_one_untagged_mesh_is_its_air_not_its_slabs() {
    // The slabs (closed, facing out) enclose more of their hull than the air does: read as a
    // room modelled as a solid, their insides became the cells and the closet none.
    let v = DVec3::new;
    let (lo, hi, w) = (v(0.0, 0.0, 0.0), v(2.0, 2.5, 2.0), 0.3);
    let mut t = Vec::new();
    for axis in 0..3 {
        for side in [0, 1] {
            let (mut a, mut b) = (lo - DVec3::splat(w), hi + DVec3::splat(w));
            if side == 0 {
                b[axis] = lo[axis];
            } else {
                a[axis] = hi[axis];
            }
            t.extend(common::blocks::box_tris(a, b));
        }
    }
    let l = auto_level(t, DMat4::IDENTITY);
    assert!(l.tagging().generated.is_some(), "no rooms generated");
    assert_eq!(l.cells.cells.len(), 1, "cells");
    let c = &l.cells.cells[0];
    assert!(
        (c.volume - 10.0).abs() < 1e-6,
        "air {} m³, not 10",
        c.volume
    );
    assert!(
        c.poly.contains(v(1.0, 1.25, 1.0), 1e-9),
        "the cell is not the closet"
    );
}

#[test]
fn the_space_over_a_roof_whose_walls_stop_at_it_joins_the_yards_on_either_side() {
    // Doom's sky hack: two yards under a sky at 8 m either side of a house whose walls stop
    // at its roof (4 m), with nothing over the roof. The roof's back faces the space above
    // it, so that space read as solid and no cell crossed it, yet a ray from one yard passes
    // over the roof into the other (12 missed pairs on Freedoom MAP01 merged).
    let v = DVec3::new;
    let mut t = room(v(0.0, 0.0, 0.0), v(10.0, 8.0, 10.0), &[1]);
    t.extend(room(v(20.0, 0.0, 0.0), v(30.0, 8.0, 10.0), &[0]));
    // The house: a room inside walls 0.5 m thick, with no tops (as a Doom line has none).
    t.extend(room(v(10.5, 0.0, 0.0), v(19.5, 4.0, 10.0), &[]));
    t.extend(quad(
        v(10.0, 0.0, 0.0),
        v(10.0, 4.0, 0.0),
        v(10.0, 4.0, 10.0),
        v(10.0, 0.0, 10.0),
        -DVec3::X,
    ));
    t.extend(quad(
        v(20.0, 0.0, 0.0),
        v(20.0, 4.0, 0.0),
        v(20.0, 4.0, 10.0),
        v(20.0, 0.0, 10.0),
        DVec3::X,
    ));
    let l = auto_level(t, DMat4::IDENTITY);
    let cell_at = |p: DVec3| {
        (0..l.cells.cells.len())
            .find(|&c| l.cells.cells[c].poly.contains_strictly(p, 1e-6))
            .unwrap_or_else(|| panic!("no cell holds {p}"))
    };
    let (a, b) = (cell_at(v(5.0, 6.0, 5.0)), cell_at(v(25.0, 6.0, 5.0)));
    cell_at(v(15.0, 6.0, 5.0));
    let pvs = pipeline::pvs(&l, portcullis::vis::Method::Full);
    assert!(
        pvs.visible(a).any(|c| c == b),
        "the far yard is not in the PVS"
    );
    let audit = pipeline::audit(&l, &pvs, 500);
    assert!(audit.confirmed > 0, "the audit confirmed no pair");
    let missed: Vec<_> = (audit.diagnostics.0.iter())
        .filter(|d| d.code == portcullis::diag::Code::PVS_MISSES_SIGHTLINE)
        .collect();
    assert!(missed.is_empty(), "{missed:?}");
}

/// A copy of `level` (a .gltf or .glb) with the `-room` suffix taken off the room nodes
/// `untag` picks: a level tagged in part.
fn untagged_in_part(level: &std::path::Path, out: &std::path::Path, untag: impl Fn(&str) -> bool) {
    let bytes = std::fs::read(level).unwrap();
    let (mut doc, bin) = common::read_gltf(&bytes);
    for n in doc["nodes"].as_array_mut().unwrap() {
        let Some(name) = n["name"].as_str().map(str::to_string) else {
            continue;
        };
        if let Some(base) = name.strip_suffix("-room").filter(|b| untag(b)) {
            n["name"] = serde_json::json!(base);
        }
    }
    // Buffers as data URIs, so the copy reads wherever it is written.
    if let Some(bin) = bin {
        use base64::Engine;
        let uri = format!(
            "data:application/octet-stream;base64,{}",
            base64::engine::general_purpose::STANDARD.encode(&bin)
        );
        doc["buffers"][0] = serde_json::json!({"byteLength": bin.len(), "uri": uri});
    } else if let Some(bs) = doc["buffers"].as_array_mut() {
        for b in bs {
            if let Some(uri) = b["uri"].as_str().filter(|u| !u.starts_with("data:")) {
                b["uri"] = serde_json::json!(level.parent().unwrap().join(uri));
            }
        }
    }
    std::fs::write(out, serde_json::to_vec(&doc).unwrap()).unwrap();
}

/// Tags win, and the rest is generated: samples/arch.gltf with its east room untagged reads
/// under `--tags auto` as the tagged west room's cell and a generated cell beyond the arch,
/// joined by the arch's portal, every node rendered, and no ray from either finds a pair the
/// PVS lacks (before, the east room's geometry lay in no cell).
#[test]
fn a_level_tagged_in_part_gets_rooms_generated_for_the_rest() {
    let dir = tempfile::tempdir().unwrap();
    for sample in ["arch.gltf", "thick_wall.gltf", "courtyard.gltf"] {
        let level = dir.path().join(sample);
        untagged_in_part(&common::sample(sample), &level, |name| name == "east");
        let mut built = common::built(&level, Some("auto"));
        let codes: Vec<String> = built
            .diagnostics
            .iter()
            .map(|d| d.code.to_string())
            .collect();
        assert!(
            !codes.iter().any(|c| c == "CELL_GEOMETRY_OUTSIDE"),
            "{sample}: {codes:?}"
        );
        let rooms: Vec<String> = (built.cells.cells.iter())
            .map(|c| built.tagged.tagging.rooms[c.room].name.clone())
            .collect();
        assert!(rooms.iter().any(|r| r == "west"), "{sample}: {rooms:?}");
        assert!(
            rooms.iter().any(|r| r.starts_with("auto-")),
            "{sample}: {rooms:?}"
        );
        let unreachable = |l: &Level| {
            l.diagnostics
                .iter()
                .filter(|d| d.code.to_string() == "GRAPH_UNREACHABLE")
                .count()
        };
        pipeline::check(&mut built, false);
        let mut tagged = common::built(&common::sample(sample), None);
        pipeline::check(&mut tagged, false);
        // No more cut off than the tagged level (courtyard's two courts, apart there, meet
        // through the generated air between them).
        assert!(unreachable(&built) <= unreachable(&tagged), "{sample}");
        let pvs = pipeline::pvs(&built, portcullis::vis::Method::Full);
        let audit = pipeline::audit(&built, &pvs, 500);
        let missed: Vec<String> = (audit.diagnostics.iter())
            .filter(|d| d.code.to_string() == "PVS_MISSES_SIGHTLINE")
            .map(|d| d.message.clone())
            .collect();
        assert!(missed.is_empty(), "{sample}: {missed:?}");
    }
}

/// The acceptance's partly tagged level: Freedoom MAP01 with its odd sectors untagged. Under
/// `--tags auto` the even sectors keep their cells and the rest is generated; 2,000 rays
/// from every cell find no pair the PVS lacks; no tagged cell is cut off that the fully tagged
/// reading reaches, and every generated cell is reached through a portal or opens to the sky.
#[test]
#[ignore = "a minute and a half: run with --ignored"]
fn freedoom_map01_half_tagged_loses_no_sightline() {
    let dir = tempfile::tempdir().unwrap();
    let level = dir.path().join("map01_half.gltf");
    let odd = |name: &str| {
        name.strip_prefix("sector_")
            .and_then(|n| n.parse::<u32>().ok())
            .is_some_and(|n| n % 2 == 1)
    };
    untagged_in_part(&common::fixture("MAP01_godot.glb"), &level, odd);
    let mut built = common::built(&level, Some("auto"));
    let generated = (built.cells.cells.iter())
        .filter(|c| built.tagged.tagging.rooms[c.room].name.starts_with("auto-"))
        .count();
    assert!(generated > 100, "only {generated} generated cells");
    let pvs = pipeline::pvs(&built, portcullis::vis::Method::Full);
    let audit = pipeline::audit(&built, &pvs, 2000);
    let missed = (audit.diagnostics.iter())
        .filter(|d| d.code.to_string() == "PVS_MISSES_SIGHTLINE")
        .count();
    eprintln!(
        "MAP01 half tagged: {} cells ({generated} generated), {missed} missed pairs",
        built.cells.cells.len()
    );
    assert_eq!(missed, 0);
    // Cells no portal path reaches from the largest part.
    let cut_off = |l: &Level| -> Vec<usize> {
        let n = l.cells.cells.len();
        let mut sets = (0..n).collect::<Vec<usize>>();
        fn find(s: &mut [usize], mut a: usize) -> usize {
            while s[a] != a {
                s[a] = s[s[a]];
                a = s[a];
            }
            a
        }
        for p in &l.portals.portals {
            if let Some(t) = p.to {
                let (a, b) = (find(&mut sets, p.from), find(&mut sets, t));
                sets[a.max(b)] = a.min(b);
            }
        }
        let roots: Vec<usize> = (0..n).map(|c| find(&mut sets, c)).collect();
        let mut size = std::collections::BTreeMap::<usize, usize>::new();
        roots.iter().for_each(|r| *size.entry(*r).or_default() += 1);
        let main = size
            .iter()
            .max_by_key(|(_, s)| **s)
            .map(|(r, _)| *r)
            .unwrap();
        (0..n).filter(|&c| roots[c] != main).collect()
    };
    let tagged = common::built(&common::fixture("MAP01_godot.glb"), None);
    let lost_in_full: std::collections::BTreeSet<String> = (cut_off(&tagged).into_iter())
        .map(|c| {
            tagged.tagged.tagging.rooms[tagged.cells.cells[c].room]
                .name
                .clone()
        })
        .collect();
    let opens = |c: usize| {
        built
            .portals
            .portals
            .iter()
            .any(|p| p.from == c && p.to.is_none())
    };
    for c in cut_off(&built) {
        let room = &built.tagged.tagging.rooms[built.cells.cells[c].room].name;
        match room.starts_with("auto-") {
            true => assert!(opens(c), "generated cell {c} of {room} is sealed off"),
            false => assert!(lost_in_full.contains(room), "tagged room {room} cut off"),
        }
    }
    pipeline::check(&mut built, false);
}
