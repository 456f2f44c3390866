//! Rooms of any 3D shape: the samples with known answers (soffit, platform, stairs, mezzanine,
//! door reveal, crawl tunnel, vault, arched passage), the same levels turned about X and about
//! an oblique axis, and an oracle that shares no code with the cell stage, run on every sample,
//! third-party level and generated building: points classified by casting rays against each
//! room's own triangles must lie in exactly one of the room's cells (inside) or in none
//! (outside), and a closed room's cells add up to its volume by the divergence theorem.

mod common;

use common::rays::{
    bounds, classify, is_closed, open_edges, room_triangles, segment_distance, signed_volume,
};
use common::rng::SplitMix64 as Rng;
use common::{fixture, levels_with_rooms, sample};
use glam::{DMat4, DQuat, DVec3};
use portcullis::cells::{CellSet, CellSource};
use portcullis::pipeline::{build_cells, build_portals, load_tagged, LoadOptions, Tagged};

fn load(path: &std::path::Path, preset: Option<&str>) -> (Tagged, CellSet) {
    common::load_cells(path, preset)
}

/// A room's known answer: name, cells, volume (m³).
type Known = (&'static str, usize, f64);

/// The 3D samples: file, and per room its known answer.
const SAMPLES_3D: &[(&str, &[Known])] = &[
    ("soffit_hall.gltf", &[("hall", 2, 153.0)]),
    ("platform_hall.gltf", &[("hall", 2, 148.5)]),
    ("stair_hall.gltf", &[("stair", 4, 96.0)]),
    ("mezzanine_hall.gltf", &[("hall", 3, 315.9)]),
    ("door_reveal.gltf", &[("west", 2, 49.1), ("east", 1, 48.0)]),
    (
        "crawl_tunnel.gltf",
        &[("west", 1, 48.0), ("tunnel", 1, 2.0), ("east", 1, 48.0)],
    ),
    // 8 x (6 x 4 + the upper half of a regular 16-gon of radius 3, 8 x 3² x sin(pi / 8) / 2).
    (
        "vaulted_hall.gltf",
        &[("nave", 1, 8.0 * (24.0 + 36.0 * 0.382_683_432_365_089_8))],
    ),
    // 48 + the passage: 0.5 x (1 x 2 + the upper half of a regular 16-gon of radius 0.5,
    // 8 x 0.5² x sin(pi / 8) / 2).
    (
        "arch_passage.gltf",
        &[
            ("west", 2, 48.0 + 0.5 * (2.0 + 0.382_683_432_365_089_8)),
            ("east", 1, 48.0),
        ],
    ),
];

fn room_index(t: &Tagged, name: &str) -> usize {
    t.tagging
        .room_by_name(&t.rules, name)
        .unwrap_or_else(|| panic!("no room {name}"))
}

#[test]
fn three_d_samples_have_their_known_cells_and_pass_check_sealed() {
    for (file, rooms) in SAMPLES_3D {
        let (t, c) = load(&sample(file), None);
        for (room, cells, volume) in *rooms {
            let r = room_index(&t, room);
            assert_eq!(c.room_cells[r].len(), *cells, "{file}: cells of {room}");
            let v: f64 = c.room_cells[r].iter().map(|&i| c.cells[i].volume).sum();
            // Within the f32 rounding of the stored corners (3.3 is not exact); the oracle
            // below holds the cells to the triangles' own volume within 1e-9.
            assert!(
                (v - volume).abs() <= 1e-7 * volume,
                "{file}: {room} has volume {v}, not {volume}"
            );
        }
        let out = assert_cmd::Command::cargo_bin("portcullis")
            .unwrap()
            .args(["check", "--sealed", "--format", "json"])
            .arg(sample(file))
            .output()
            .unwrap();
        let text = String::from_utf8_lossy(&out.stdout);
        assert!(
            out.status.success(),
            "{file}: check --sealed failed: {text}"
        );
        assert!(!text.contains("LEAK"), "{file}: {text}");
    }
}

/// The door reveal and the arched passage belong to the west room: the reveal's far end meets
/// the east room with exactly the opening, and the reveal meets its own room with a full face.
#[test]
fn a_reveal_meets_the_other_room_with_the_exact_opening() {
    for (file, far_x, area) in [
        ("door_reveal.gltf", 4.5, 2.2),
        ("arch_passage.gltf", 4.5, 2.0 + 0.382_683_432_365_089_8),
    ] {
        let mut t = load_tagged(&sample(file), &LoadOptions::default()).unwrap();
        let c = build_cells(&mut t);
        let p = build_portals(&mut t, &c);
        let (west, east) = (room_index(&t, "west"), room_index(&t, "east"));
        let between: Vec<_> = p
            .portals
            .iter()
            .filter(|q| {
                q.to.is_some_and(|to| c.cells[q.from].room == west && c.cells[to].room == east)
            })
            .collect();
        let total: f64 = between.iter().map(|q| q.area).sum();
        assert!(
            (total - area).abs() < 1e-6,
            "{file}: west -> east {total} m², not {area}"
        );
        for q in &between {
            assert!(
                q.polygon.iter().all(|v| (v.x - far_x).abs() < 1e-6),
                "{file}: a west -> east portal is not at the reveal's far end: {:?}",
                q.polygon
            );
        }
        let inside: f64 = p
            .portals
            .iter()
            .filter(|q| {
                q.to.is_some_and(|to| c.cells[q.from].room == west && c.cells[to].room == west)
            })
            .map(|q| q.area)
            .sum();
        assert!(
            (inside - 2.0 * area).abs() < 1e-6,
            "{file}: internal portals {inside} m²"
        );
    }
}

/// The same cells, up to the rotation, with the level turned 90° about X and 37° about an
/// oblique axis ([cells] up turned along).
#[test]
fn three_d_samples_are_the_same_turned() {
    let turns = [
        DMat4::from_rotation_x(std::f64::consts::FRAC_PI_2),
        DMat4::from_quat(DQuat::from_axis_angle(
            DVec3::new(1.0, 2.0, 3.0).normalize(),
            37f64.to_radians(),
        )),
    ];
    for (file, _) in SAMPLES_3D {
        let (t, c) = load(&sample(file), None);
        for m in &turns {
            let mut t2 = t.clone();
            for n in &mut t2.scene.nodes {
                n.world = *m * n.world;
            }
            t2.config.cells.up = m
                .transform_vector3(DVec3::from_array(t.config.cells.up))
                .to_array();
            t2.diagnostics = Default::default();
            let c2 = build_cells(&mut t2);
            assert_eq!(c.room_cells, c2.room_cells, "{file} turned");
            for (a, b) in c.cells.iter().zip(&c2.cells) {
                assert!(
                    (a.volume - b.volume).abs() <= 1e-9 * a.volume,
                    "{file}: volumes"
                );
                let vb = b.poly.vertices(1e-9);
                for v in a.poly.vertices(1e-9) {
                    let w = m.transform_point3(v);
                    assert!(
                        vb.iter().any(|u| u.distance(w) <= 1e-6),
                        "{file}: vertex {w} of a cell of room {} missing when turned",
                        a.room
                    );
                }
            }
            let p2 = build_portals(&mut t2, &c2);
            assert!(
                !p2.portals.iter().any(|q| q.to.is_none()),
                "{file} turned: an exterior opening"
            );
        }
    }
}

/// A room modelled as a solid (every triangle facing out) is read as the room it bounds: as
/// many cells, the same volume (which of two equal cuts comes first may change with the
/// triangles' winding, so the cells themselves may differ).
#[test]
fn outward_facing_rooms_get_as_many_cells_and_the_same_volume() {
    for file in [
        "l_room.gltf",
        "u_room.gltf",
        "stair_hall.gltf",
        "mezzanine_hall.gltf",
    ] {
        let (t, c) = load(&sample(file), None);
        let mut t2 = t.clone();
        for m in &mut t2.scene.meshes {
            for tri in &mut m.triangles {
                tri.swap(1, 2);
            }
        }
        t2.diagnostics = Default::default();
        let c2 = build_cells(&mut t2);
        for r in 0..c.room_cells.len() {
            assert_eq!(
                c.room_cells[r].len(),
                c2.room_cells[r].len(),
                "{file} facing out"
            );
            let v =
                |c: &CellSet| -> f64 { c.room_cells[r].iter().map(|&i| c.cells[i].volume).sum() };
            let (a, b) = (v(&c), v(&c2));
            assert!(
                (a - b).abs() <= 1e-9 * a,
                "{file} facing out: {a} vs {b} m³"
            );
        }
        let judged = oracle_with(&t2, &c2, 200, file, false);
        assert!(judged > 100, "{file} facing out: {judged} points judged");
    }
}

// --- The oracle: nothing below calls the cell stage's geometry.

/// A cell's volume from its face polygons (divergence theorem).
fn cell_volume(c: &portcullis::cells::Cell) -> f64 {
    let mut v = 0.0;
    for f in &c.poly.faces {
        for w in f.points[1..].windows(2) {
            v += f.points[0].dot(w[0].cross(w[1])) / 6.0;
        }
    }
    v.abs()
}

/// How deep `p` is inside a cell: the least distance to its face planes, negative outside.
fn depth(c: &portcullis::cells::Cell, p: DVec3) -> f64 {
    c.poly
        .faces
        .iter()
        .map(|f| f.plane.d - f.plane.normal.dot(p))
        .fold(f64::INFINITY, f64::min)
}

/// Runs the oracle on every room whose cells come from its own surface; returns the number of
/// points judged.
fn oracle(t: &Tagged, c: &CellSet, points_per_room: usize, what: &str) -> usize {
    oracle_with(t, c, points_per_room, what, true)
}

/// The oracle; `facing_in` false reads every room as a solid (surfaces facing out).
fn oracle_with(
    t: &Tagged,
    c: &CellSet,
    points_per_room: usize,
    what: &str,
    facing_in: bool,
) -> usize {
    let mut judged = 0;
    let mut rng = Rng::from_state(0x5EED);
    for r in 0..t.tagging.rooms.len() {
        let cells: Vec<&portcullis::cells::Cell> =
            c.room_cells[r].iter().map(|&i| &c.cells[i]).collect();
        if cells.is_empty()
            || cells
                .iter()
                .any(|x| matches!(x.source, CellSource::Bound | CellSource::Footprint))
        {
            continue;
        }
        let mut tris = room_triangles(t, c, r);
        if !facing_in {
            for tri in &mut tris {
                tri.swap(1, 2);
            }
        }
        // Parity only reads a single closed shell around the air: one that faces in.
        let closed = is_closed(&tris) && signed_volume(&tris) < 0.0;
        let (lo, hi) = bounds(&tris);
        let size = hi - lo;
        let margin = 1e-6 * size.max_element() + 10.0 * c.tolerance.distance;
        let name = &t.tagging.rooms[r].name;
        // Points near an opening's rim are left out: whether the air beside a hole with no wall
        // at its rim is this room's or the neighbour's is not for rays to say.
        let rims = if closed {
            Vec::new()
        } else {
            open_edges(&tris)
        };
        let away = 0.05 * size.max_element();
        if closed {
            let room = -signed_volume(&tris);
            let sum: f64 = cells.iter().map(|x| cell_volume(x)).sum();
            assert!(
                (sum - room).abs() <= 1e-9 * room,
                "{what}: room {name}: cells {sum} m³, room {room} m³"
            );
        }
        for _ in 0..points_per_room {
            let p = lo + size * DVec3::new(rng.unit(), rng.unit(), rng.unit());
            if rims.iter().any(|&(a, b)| segment_distance(p, a, b) < away) {
                continue;
            }
            let Some(inside) = classify(&tris, closed, p) else {
                continue;
            };
            let deep = cells.iter().filter(|x| depth(x, p) > margin).count();
            let near = cells.iter().filter(|x| depth(x, p) > -margin).count();
            if inside {
                if near == 0 && cells.iter().all(|x| depth(x, p) < -margin) {
                    // In the air by the rays but in no cell, and not within the margin of one.
                    panic!("{what}: room {name}: inside point {p} is in no cell");
                }
                assert!(
                    deep <= 1,
                    "{what}: room {name}: inside point {p} is in {deep} cells"
                );
            } else {
                assert_eq!(
                    deep, 0,
                    "{what}: room {name}: outside point {p} is in a cell"
                );
            }
            judged += 1;
        }
    }
    judged
}

/// Levels whose rooms the oracle cannot judge, and why: it judges a room's cells against
/// parity on the room's own triangles, which says nothing where a cell is the designer's own
/// (a bound or a footprint) or where every point is near a room's open rim.
const NOT_JUDGED: [(&str, &str); 4] = [
    ("bound_boxes.gltf", "every room is its bound box"),
    ("panda3d_culling.glb", "every room is an extruded floor"),
    ("panda3d_culling.obj", "every room is an extruded floor"),
    (
        "courtyard.gltf",
        "two courts open to the sky: every point is near the open top",
    ),
];

/// Issue 45, item 11: the oracle says how much it judged, and every level it can judge is
/// judged (at least 5 points), so the test cannot pass having checked nothing.
#[test]
fn ray_oracle_on_samples_and_third_party_levels() {
    let mut levels = levels_with_rooms();
    for (file, _) in SAMPLES_3D {
        levels.push((sample(file), None));
    }
    let mut total = 0;
    for (path, preset) in levels {
        let (t, c) = load(&path, preset);
        let judged = oracle(&t, &c, 400, &path.display().to_string());
        eprintln!("{}: {judged} points judged", path.display());
        let name = path.file_name().unwrap().to_str().unwrap();
        match NOT_JUDGED.iter().find(|(n, _)| *n == name) {
            Some((_, why)) => assert_eq!(judged, 0, "{name} is listed as not judged ({why})"),
            None => assert!(judged >= 5, "{name}: only {judged} points judged"),
        }
        total += judged;
    }
    assert!(total > 5000, "{total} points judged in all");
}

#[test]
fn ray_oracle_on_doom_maps() {
    for file in ["E1M2_godot.glb", "MAP01_godot.glb"] {
        let (t, c) = load(&fixture(file), None);
        let judged = oracle(&t, &c, 200, file);
        eprintln!(
            "{file}: {} rooms, {} cells, {judged} points judged",
            t.tagging.rooms.len(),
            c.cells.len()
        );
        assert!(judged > 500, "{file}: only {judged} points could be judged");
    }
}

/// The benchmark's big room (`portcullis bench --room-planes`): a stair hall of N steps is N
/// cells at any size, and the oracle holds on it.
#[test]
fn the_benchmark_stair_hall_is_one_cell_per_step() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("stairs.glb");
    let scene = portcullis::buildings::stair_hall(90);
    let fmt = portcullis::export::target::OutFormat::Glb;
    std::fs::write(
        &path,
        portcullis::export::gltf_out::write_plain(&scene, fmt),
    )
    .unwrap();
    let (t, c) = load(&path, None);
    // 90 planes: 29 steps (3 x 29 + 3 = 90).
    assert_eq!(c.cells.len(), 29);
    let judged = oracle(&t, &c, 600, "stair hall");
    assert!(judged > 100, "{judged} points judged");
}

#[test]
fn ray_oracle_on_generated_buildings() {
    for (rooms, seed) in [(12, 3), (40, 9)] {
        let dir = tempfile::tempdir().unwrap();
        let path = common::generated_building(dir.path(), rooms, seed);
        let (t, c) = load(&path, None);
        let judged = oracle(&t, &c, 100, &format!("gen {rooms} rooms seed {seed}"));
        assert!(judged > 10 * rooms, "only {judged} points judged");
    }
}

/// No sliver cells (issue 25): every cell of every sample and third-party level with rooms is
/// at least a tenth of the level's shortest edge thick, thickness taken as three times its
/// volume over its surface (the inscribed ball's radius for a cell that holds one; a slab of
/// thickness h gives under h). Volumes here from the divergence theorem, areas from the faces'
/// cross products, the shortest edge from every triangle of the scene. A bound mesh is the
/// designer's own cell, however thin (samples/wedge_room.gltf's 4 cm wedge), and is not judged.
#[test]
fn no_cell_is_thinner_than_a_tenth_of_the_shortest_edge() {
    let mut levels = common::levels_and_samples();
    levels.push((fixture("E1M2_godot.glb"), None));
    levels.push((fixture("MAP01_godot.glb"), None));
    // the thinnest cell of all, as a share of its level's shortest edge (README's Numerics)
    let mut thinnest = (f64::INFINITY, String::new());
    for (path, preset) in levels {
        let (t, c) = load(&path, preset);
        let s = &t.scene;
        let mut shortest = f64::INFINITY;
        for n in s.walk() {
            let Some(m) = s.nodes[n].mesh else { continue };
            let mesh = &s.meshes[m];
            let w = s.nodes[n].world;
            for tri in &mesh.triangles {
                let p = tri.map(|i| w.transform_point3(mesh.positions[i as usize]));
                for k in 0..3 {
                    let l = p[k].distance(p[(k + 1) % 3]);
                    if l > 0.0 {
                        shortest = shortest.min(l);
                    }
                }
            }
        }
        for (i, cell) in c.cells.iter().enumerate() {
            if cell.source == portcullis::cells::CellSource::Bound {
                continue;
            }
            let area: f64 = cell
                .poly
                .faces
                .iter()
                .map(|f| {
                    let q = &f.points;
                    (1..q.len().saturating_sub(1))
                        .map(|j| (q[j] - q[0]).cross(q[j + 1] - q[0]).length() / 2.0)
                        .sum::<f64>()
                })
                .sum();
            let thick = 3.0 * cell_volume(cell) / area;
            if thick / shortest < thinnest.0 {
                thinnest = (
                    thick / shortest,
                    path.file_name().unwrap().to_string_lossy().into(),
                );
            }
            assert!(
                thick >= shortest / 10.0,
                "{}: cell {i} is {thick} m thick, the shortest edge {shortest} m",
                path.display()
            );
        }
    }
    eprintln!(
        "the thinnest cell is {:.2} of its level's shortest edge ({})",
        thinnest.0, thinnest.1
    );
}
