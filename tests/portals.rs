//! Portals on the third-party levels and samples, their invariants, and an oracle that does
//! not use the portal code: unobstructed segments between cells must leave through a portal.

mod common;

use common::{fixture, sample};
use glam::DVec3;
use parry3d_f64::query::{Ray, RayCast};
use portcullis::cells::CellSet;
use portcullis::diag::Code;
use portcullis::pipeline::Tagged;
use portcullis::portals::PortalSet;

fn load(path: &std::path::Path, preset: Option<&str>) -> (Tagged, CellSet, PortalSet) {
    common::load_level(path, preset)
}

/// Room-to-room pairs (not internal), as (portal, partner).
fn room_pairs(t: &Tagged, c: &CellSet, p: &PortalSet) -> Vec<(usize, usize)> {
    let _ = t;
    p.pairs()
        .filter(|&(i, _)| {
            let q = &p.portals[i];
            q.to.is_some_and(|to| c.cells[q.from].room != c.cells[to].room)
        })
        .collect()
}

fn bounds(poly: &[DVec3]) -> (DVec3, DVec3) {
    poly.iter().fold(
        (DVec3::splat(f64::MAX), DVec3::splat(f64::MIN)),
        |(a, b), p| (a.min(*p), b.max(*p)),
    )
}

#[test]
fn lportal_tutorial_simple_has_one_door_pair() {
    for file in ["lportal_tutorial_simple.glb", "lportal_tutorial_simple.obj"] {
        let (t, c, p) = load(&fixture(file), None);
        let pairs = room_pairs(&t, &c, &p);
        assert_eq!(pairs.len(), 1, "{file}");
        // Each room's door reveal is a cell of its own (tests/cells.rs): the two reveals meet
        // at x = 3, where the authored portal stands.
        let (door, back) = (&p.portals[pairs[0].0], &p.portals[pairs[0].1]);
        for q in [door, back] {
            let x = 3.0;
            let (lo, hi) = bounds(&q.polygon);
            let want = (DVec3::new(x, 0.1, -1.0), DVec3::new(x, 2.0, 1.0));
            // Within 1e-6 m, plus the precision of the file itself (the OBJ writes -0.999999).
            let tol = 1e-6 + 2e-9;
            assert!(
                (lo - want.0).abs().max_element() <= tol
                    && (hi - want.1).abs().max_element() <= tol,
                "{file}: {lo} .. {hi}"
            );
            assert!((q.area - 2.0 * 1.9).abs() < 1e-5);
        }
        let authored = door.authored.map(|n| t.scene.node_label(n));
        assert_eq!(authored.as_deref(), Some("portal_lounge"), "{file}");
        // No ceilings: the open tops are exterior portals, on the plane y = 2.
        let tops: Vec<_> = p
            .portals
            .iter()
            .filter(|q| q.to.is_none() && q.normal.y > 0.99)
            .collect();
        assert!(!tops.is_empty());
        for q in tops {
            assert!(q.polygon.iter().all(|v| (v.y - 2.0).abs() < 1e-5));
        }
        assert!(!t.diagnostics.has(Code::PORTAL_AUTHORED_UNMATCHED));
    }
}

#[test]
fn lportal_boxrooms_has_16_authored_pairs() {
    for file in ["lportal_boxrooms.glb", "lportal_boxrooms.obj"] {
        let (t, c, p) = load(&fixture(file), None);
        let pairs = room_pairs(&t, &c, &p);
        assert_eq!(pairs.len(), 16, "{file}");
        let (mut doors, mut walls) = (0, 0);
        for &(i, j) in &pairs {
            let (lo, hi) = bounds(&p.portals[i].polygon);
            let size = hi - lo;
            let mut dims = [size.x, size.y, size.z];
            dims.sort_by(f64::total_cmp);
            // f32 input through rotations: the walls themselves are off by up to ~1e-5 m.
            assert!(dims[0] < 1e-4);
            if (dims[1] - 0.8).abs() < 1e-4 && (dims[2] - 1.2).abs() < 1e-4 {
                doors += 1;
            } else if (dims[1] - 1.2).abs() < 1e-4 && (dims[2] - 3.6).abs() < 1e-4 {
                walls += 1;
            } else {
                panic!("{file}: unexpected opening {dims:?}");
            }
            assert!(p.portals[i].authored.is_some() && p.portals[j].authored.is_some());
        }
        // The level has 12 door-sized openings and 4 full-wall ones, matching its 12 `portal`
        // and 4 `portal_large` quads (the level notes say 10 and 6; the geometry says 12 and 4).
        assert_eq!((doors, walls), (12, 4), "{file}");
        assert!(
            !t.diagnostics.has(Code::PORTAL_AUTHORED_UNMATCHED),
            "{:?}",
            t.diagnostics
        );
    }
}

#[test]
fn panda3d_one_way_quads_make_12_two_way_pairs() {
    for file in ["panda3d_culling.glb", "panda3d_culling.obj"] {
        let (t, c, p) = load(&fixture(file), Some("panda3d"));
        let pairs: Vec<_> = room_pairs(&t, &c, &p)
            .into_iter()
            .filter(|&(i, j)| {
                let (a, b) = (p.portals[i].authored, p.portals[j].authored);
                a.is_some() && b.is_some() && a != b
            })
            .collect();
        assert_eq!(pairs.len(), 12, "{file}");
        for &(i, j) in &pairs {
            assert!(!p.portals[i].one_way && !p.portals[j].one_way);
            // portal_AtoB_K is on the portal from A to B.
            let name = t.scene.node_label(p.portals[i].authored.unwrap());
            let from_room = &t.tagging.rooms[c.cells[p.portals[i].from].room].name;
            let digits = name
                .trim_start_matches("portal_")
                .split("to")
                .next()
                .unwrap();
            assert_eq!(from_room, &format!("cell{digits}"), "{name}");
        }
        assert!(
            !t.diagnostics.has(Code::PORTAL_AUTHORED_UNMATCHED),
            "{file}"
        );
    }
}

#[test]
fn two_rooms_sample_door() {
    let (t, c, p) = load(&sample("two_rooms.gltf"), None);
    let pairs = room_pairs(&t, &c, &p);
    assert_eq!(pairs.len(), 1);
    let (lo, hi) = bounds(&p.portals[pairs[0].0].polygon);
    // The sample stores f32 positions: 2.2 is 2.2000000477 there.
    assert!(
        (lo - DVec3::new(4.0, 0.0, 1.5)).length() < 1e-6
            && (hi - DVec3::new(4.0, 2.2, 2.5)).length() < 1e-6,
        "{lo} .. {hi}"
    );
    assert_eq!(
        p.portals[pairs[0].0]
            .authored
            .map(|n| t.scene.node_label(n))
            .as_deref(),
        Some("lounge-portal")
    );
    // Closed rooms: nothing opens to the exterior.
    assert!(p.portals.iter().all(|q| q.to.is_some()));
}

/// Every portal: convex, planar, counter-clockwise seen from its source; partners mutual,
/// reversed and with swapped cells.
#[test]
fn portal_invariants_hold_everywhere() {
    for (file, preset) in common::levels_with_rooms() {
        let (_, c, p) = load(&file, preset);
        let eps = c.tolerance.distance * 10.0;
        for (i, q) in p.portals.iter().enumerate() {
            let n = q.polygon.len();
            assert!(n >= 3 && q.area > 0.0);
            let mut newell = DVec3::ZERO;
            for k in 0..n {
                newell += q.polygon[k].cross(q.polygon[(k + 1) % n]);
            }
            assert!(
                newell.normalize().dot(q.normal) < -0.999,
                "{}: portal {i} winding",
                file.display()
            );
            let d = q.normal.dot(q.polygon[0]);
            for v in &q.polygon {
                assert!((q.normal.dot(*v) - d).abs() <= eps, "not planar");
            }
            for k in 0..n {
                let (a, b, cc) = (q.polygon[k], q.polygon[(k + 1) % n], q.polygon[(k + 2) % n]);
                assert!(
                    (b - a).cross(cc - b).dot(q.normal) <= eps * (b - a).length().max(1.0),
                    "not convex"
                );
            }
            if let Some(j) = q.partner {
                let r = &p.portals[j];
                assert_eq!(r.partner, Some(i));
                if j != i {
                    assert_eq!(Some(q.from), r.to);
                    assert_eq!(Some(r.from), q.to);
                    assert_eq!(q.polygon.len(), r.polygon.len());
                }
            }
        }
    }
}

/// The oracle: for random segments between two different cells that hit none of the level's
/// triangles, the point where the segment leaves its first cell lies in a portal of that cell.
#[test]
fn unobstructed_segments_leave_cells_through_portals() {
    let mut total_checked = 0usize;
    for (file, preset) in common::levels_with_rooms() {
        let (t, c, p) = load(&file, preset);
        if c.cells.len() < 2 {
            continue;
        }
        let mesh = common::opaque_mesh(&t);
        let mut seed = 0x9e3779b97f4a7c15u64;
        let mut rnd = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        let sample_in = |cell: usize, rnd: &mut dyn FnMut() -> f64| -> DVec3 {
            let b = c.cells[cell].bounds;
            loop {
                let q = b.min + (b.max - b.min) * DVec3::new(rnd(), rnd(), rnd());
                if c.cells[cell].poly.contains_strictly(q, 1e-6) {
                    return q;
                }
            }
        };
        let eps = c.tolerance.distance * 100.0;
        let mut checked = 0usize;
        for _ in 0..400 {
            let a = (rnd() * c.cells.len() as f64) as usize % c.cells.len();
            let b = (rnd() * c.cells.len() as f64) as usize % c.cells.len();
            if a == b {
                continue;
            }
            let (pa, pb) = (sample_in(a, &mut rnd), sample_in(b, &mut rnd));
            let d = pb - pa;
            let len = d.length();
            if mesh.intersects_local_ray(&Ray::new(pa, d / len), len) {
                continue;
            }
            // Where the segment leaves cell a.
            let exit_t = c.cells[a]
                .poly
                .faces
                .iter()
                .filter(|f| f.plane.normal.dot(d) > 0.0)
                .map(|f| (f.plane.d - f.plane.normal.dot(pa)) / f.plane.normal.dot(d))
                .fold(f64::MAX, f64::min);
            let e = pa + d * exit_t;
            let through = p.portals.iter().filter(|q| q.from == a).any(|q| {
                let n = q.polygon.len();
                (q.normal.dot(e) - q.normal.dot(q.polygon[0])).abs() <= eps
                    && (0..n).all(|k| {
                        let (u, v) = (q.polygon[k], q.polygon[(k + 1) % n]);
                        // Counter-clockwise seen from the source: inside is to the left
                        // when looking along the direction of travel from behind.
                        (v - u).cross(e - u).dot(-q.normal) >= -eps * (v - u).length()
                    })
            });
            assert!(through, "{}: a clear segment from cell {a} to cell {b} leaves cell {a} at {e} through no portal", file.display());
            checked += 1;
        }
        total_checked += checked;
    }
    // The oracle must have something to judge: clear segments through doors exist.
    assert!(
        total_checked > 100,
        "only {total_checked} clear segments were checked"
    );
}

#[test]
fn zero_thickness_wall_with_a_door_and_a_window() {
    let (t, c, p) = load(&sample("door_window.gltf"), None);
    let pairs = room_pairs(&t, &c, &p);
    assert_eq!(pairs.len(), 2);
    let mut areas: Vec<f64> = pairs.iter().map(|&(i, _)| p.portals[i].area).collect();
    areas.sort_by(f64::total_cmp);
    assert!(
        (areas[0] - 1.0).abs() < 1e-6 && (areas[1] - 2.2).abs() < 1e-6,
        "{areas:?}"
    );
    for &(i, j) in &pairs {
        for v in p.portals[i].polygon.iter().chain(&p.portals[j].polygon) {
            assert!((v.x - 4.0).abs() < 1e-6);
        }
    }
    assert!(!t.diagnostics.has_errors(), "{:?}", t.diagnostics);
}

#[test]
fn a_door_through_a_thick_wall_is_bridged() {
    let (t, c, p) = load(&sample("thick_wall.gltf"), None);
    let pairs = room_pairs(&t, &c, &p);
    assert_eq!(
        pairs.len(),
        1,
        "{:?}",
        p.portals
            .iter()
            .map(|q| (q.from, q.to, q.area))
            .collect::<Vec<_>>()
    );
    let (i, j) = pairs[0];
    assert!((p.portals[i].area - 2.2).abs() < 1e-6);
    let xs = |k: usize| p.portals[k].polygon.iter().map(|v| v.x).fold(0.0, f64::max);
    let mut planes = [xs(i), xs(j)];
    planes.sort_by(f64::total_cmp);
    assert!(
        (planes[0] - 4.0).abs() < 1e-6 && (planes[1] - 4.3).abs() < 1e-6,
        "{planes:?}"
    );
    assert!(!t.diagnostics.has_errors(), "{:?}", t.diagnostics);
}

#[test]
fn a_non_convex_arched_opening_becomes_convex_pieces() {
    let (t, c, p) = load(&sample("arch.gltf"), None);
    let pairs = room_pairs(&t, &c, &p);
    assert!(
        pairs.len() >= 2,
        "a non-convex opening needs at least two convex portals"
    );
    let total: f64 = pairs.iter().map(|&(i, _)| p.portals[i].area).sum();
    // A 1 x 2 doorway under a half 8-gon of radius 1.
    let expected = 2.0 + 4.0 * (std::f64::consts::PI / 8.0).sin();
    assert!((total - expected).abs() < 1e-6, "{total} vs {expected}");
    // With the conservative shape, one convex hull instead.
    let mut t2 = t.clone();
    t2.config.portals.conservative = true;
    let p2 = portcullis::portals::build(&t2.scene, &t2.tagging, &c, &t2.config.portals);
    assert_eq!(room_pairs(&t2, &c, &p2).len(), 1);
}

#[test]
fn a_mirror_reflects_into_its_own_cell() {
    let (t, _, p) = load(&sample("mirror.gltf"), None);
    let mirrors: Vec<_> = p
        .portals
        .iter()
        .enumerate()
        .filter(|(_, q)| q.kind == portcullis::tags::rules::PortalKind::Mirror)
        .collect();
    assert_eq!(mirrors.len(), 1);
    let (i, m) = mirrors[0];
    assert_eq!(m.to, Some(m.from));
    assert_eq!(m.partner, Some(i));
    let tr = m.transform.expect("a mirror carries its reflection");
    assert!((tr.determinant() + 1.0).abs() < 1e-9);
    let q = tr.transform_point3(DVec3::new(3.0, 1.0, 2.0));
    assert!((q - DVec3::new(5.0, 1.0, 2.0)).length() < 1e-9, "{q}");
    assert!(!t.diagnostics.has_errors(), "{:?}", t.diagnostics);
}

#[test]
fn a_teleporter_pair_carries_inverse_rigid_transforms() {
    let (t, c, p) = load(&sample("teleporter.gltf"), None);
    let tps: Vec<usize> = (0..p.portals.len())
        .filter(|&i| p.portals[i].kind == portcullis::tags::rules::PortalKind::Teleporter)
        .collect();
    assert_eq!(tps.len(), 2);
    let (a, b) = (&p.portals[tps[0]], &p.portals[tps[1]]);
    assert_eq!(a.partner, Some(tps[1]));
    assert_eq!(b.partner, Some(tps[0]));
    assert_ne!(c.cells[a.from].room, c.cells[b.from].room);
    let (ta, tb) = (a.transform.unwrap(), b.transform.unwrap());
    assert!((ta.determinant() - 1.0).abs() < 1e-9, "rigid");
    assert!(
        (tb * ta).abs_diff_eq(glam::DMat4::IDENTITY, 1e-9),
        "partner is the inverse"
    );
    // The transform of the portal leaving room `a`.
    let ta = if t.tagging.rooms[c.cells[a.from].room].name == "a" {
        ta
    } else {
        tb
    };
    let centre = ta.transform_point3(DVec3::new(4.0, 1.0, 2.0));
    assert!(
        (centre - DVec3::new(10.0, 1.0, 2.0)).length() < 1e-9,
        "{centre}"
    );
    let dir = ta.transform_vector3(DVec3::X);
    assert!((dir - DVec3::X).length() < 1e-9, "{dir}");
    assert!(!t.diagnostics.has_errors(), "{:?}", t.diagnostics);
}

/// A quad's two triangles, counter-clockwise as given.
fn quad(a: DVec3, b: DVec3, c: DVec3, d: DVec3) -> Vec<[DVec3; 3]> {
    vec![[a, b, c], [a, c, d]]
}

/// An outward-facing box.
fn cube(lo: DVec3, hi: DVec3) -> Vec<[DVec3; 3]> {
    let p = |x: f64, y: f64, z: f64| DVec3::new(x, y, z);
    let (a, b) = (lo, hi);
    let mut t = Vec::new();
    t.extend(quad(
        p(a.x, a.y, a.z),
        p(a.x, a.y, b.z),
        p(a.x, b.y, b.z),
        p(a.x, b.y, a.z),
    ));
    t.extend(quad(
        p(b.x, a.y, a.z),
        p(b.x, b.y, a.z),
        p(b.x, b.y, b.z),
        p(b.x, a.y, b.z),
    ));
    t.extend(quad(
        p(a.x, a.y, a.z),
        p(b.x, a.y, a.z),
        p(b.x, a.y, b.z),
        p(a.x, a.y, b.z),
    ));
    t.extend(quad(
        p(a.x, b.y, a.z),
        p(a.x, b.y, b.z),
        p(b.x, b.y, b.z),
        p(b.x, b.y, a.z),
    ));
    t.extend(quad(
        p(a.x, a.y, a.z),
        p(a.x, b.y, a.z),
        p(b.x, b.y, a.z),
        p(b.x, a.y, a.z),
    ));
    t.extend(quad(
        p(a.x, a.y, b.z),
        p(b.x, a.y, b.z),
        p(b.x, b.y, b.z),
        p(a.x, b.y, b.z),
    ));
    t
}

/// One quad over a door that opens into two rooms is linked to both, and said to be a guess.
#[test]
fn an_authored_portal_over_two_rooms_is_ambiguous() {
    let v = DVec3::new;
    // The wall x = 4 (both faces), with a door z 1..3, y 0..2.
    let mut wall = Vec::new();
    for (z0, z1, y0, y1) in [
        (0.0, 1.0, 0.0, 3.0),
        (3.0, 4.0, 0.0, 3.0),
        (1.0, 3.0, 2.0, 3.0),
    ] {
        wall.extend(quad(
            v(4., y0, z0),
            v(4., y1, z0),
            v(4., y1, z1),
            v(4., y0, z1),
        ));
        wall.extend(quad(
            v(4., y0, z0),
            v(4., y0, z1),
            v(4., y1, z1),
            v(4., y1, z0),
        ));
    }
    let door = quad(v(4., 0., 1.), v(4., 2., 1.), v(4., 2., 3.), v(4., 0., 3.)); // faces +x
    let scene = common::scene_of(
        vec![
            (
                "kitchen-cell",
                None,
                cube(v(0., 0., 0.), v(4., 3., 4.)),
                None,
            ),
            (
                "Door",
                Some(0),
                door,
                Some(serde_json::json!({"portal": true})),
            ),
            (
                "lounge-cell",
                None,
                cube(v(4., 0., 0.), v(8., 3., 2.)),
                None,
            ),
            (
                "pantry-cell",
                None,
                cube(v(4., 0., 2.), v(8., 3., 4.)),
                None,
            ),
            ("Wall", None, wall, None),
        ],
        glam::DMat4::IDENTITY,
    );
    let rules = portcullis::tags::presets::load("default").unwrap();
    let tagging = portcullis::tags::recognise(&scene, &rules);
    assert_eq!(tagging.rooms.len(), 3);
    let cells = portcullis::cells::build(&scene, &tagging, &Default::default());
    let portals = portcullis::portals::build(&scene, &tagging, &cells, &Default::default());
    assert!(
        portals.diagnostics.has(Code::PORTAL_AUTHORED_AMBIGUOUS),
        "{:?}",
        portals.diagnostics
    );
    let linked = portals
        .portals
        .iter()
        .filter(|p| p.authored.is_some() && p.to.is_some())
        .count();
    assert!(linked >= 2);
}

/// Issue 29, item 2: the two-room sample under a node that mirrors it (scale -1 on x, as DCC
/// tools mirror an instance) has the mirror image's cells and portals, with no portal said
/// to face the wrong way: a negative determinant turns every winding round.
#[test]
fn a_mirrored_instance_is_the_mirror_image() {
    let dir = tempfile::tempdir().unwrap();
    let mut doc: serde_json::Value =
        serde_json::from_slice(&std::fs::read(sample("two_rooms.gltf")).unwrap()).unwrap();
    let scene = doc["scene"].as_u64().unwrap_or(0) as usize;
    let roots = doc["scenes"][scene]["nodes"].take();
    let nodes = doc["nodes"].as_array_mut().unwrap();
    nodes.push(serde_json::json!({"name": "mirror", "scale": [-1, 1, 1], "children": roots}));
    doc["scenes"][scene]["nodes"] = serde_json::json!([nodes.len() - 1]);
    let path = dir.path().join("mirrored.gltf");
    std::fs::write(&path, serde_json::to_vec(&doc).unwrap()).unwrap();

    let (t0, c0, p0) = load(&sample("two_rooms.gltf"), None);
    let (t1, c1, p1) = load(&path, None);
    let codes = |t: &Tagged| t.diagnostics.iter().map(|d| d.code).collect::<Vec<_>>();
    assert!(
        !codes(&t1).contains(&Code::PORTAL_AUTHORED_WRONG_WAY),
        "{:?}",
        codes(&t1)
    );
    assert_eq!(codes(&t0), codes(&t1));
    assert_eq!(c0.cells.len(), c1.cells.len());
    assert_eq!(p0.portals.len(), p1.portals.len());
    let mirror = |v: DVec3| DVec3::new(-v.x, v.y, v.z);
    let centre = |poly: &[DVec3]| poly.iter().sum::<DVec3>() / poly.len() as f64;
    for (a, b) in p0.portals.iter().zip(&p1.portals) {
        let (ca, cb) = (mirror(centre(&a.polygon)), centre(&b.polygon));
        assert!(ca.distance(cb) < 1e-9, "{ca} vs {cb}");
        assert!(mirror(a.normal).distance(b.normal) < 1e-9);
        assert_eq!((a.from, a.to), (b.from, b.to));
    }
}

/// A surface-built room (a one-sided shell facing in) with a shelf half through its wall, its
/// middle outside the shell: the room's cell renders the shelf (it was reported as lying in no
/// cell and rendered by none), as for a brush half in a wall (tests/brush_maps.rs).
#[test]
fn a_prop_with_its_middle_through_a_shell_wall_is_rendered_by_the_room() {
    let v = DVec3::new;
    let inward = |t: Vec<[DVec3; 3]>| t.into_iter().map(|[a, b, c]| [a, c, b]).collect();
    let scene = common::scene_of(
        vec![
            ("hall-room", None, Vec::new(), None),
            (
                "Shell",
                Some(0),
                inward(cube(v(0., 0., 0.), v(4., 3., 4.))),
                None,
            ),
            (
                "Shelf-detail",
                Some(0),
                cube(v(3.8, 1., 1.), v(4.4, 1.2, 2.)),
                None,
            ),
        ],
        glam::DMat4::IDENTITY,
    );
    let rules = portcullis::tags::presets::load("default").unwrap();
    let tagging = portcullis::tags::recognise(&scene, &rules);
    assert_eq!(tagging.rooms.len(), 1);
    let cells = portcullis::cells::build(&scene, &tagging, &Default::default());
    assert_eq!(cells.cells.len(), 1);
    assert!(
        cells.cells[0].nodes.contains(&2),
        "{:?}",
        cells.cells[0].nodes
    );
    assert!(
        !cells.diagnostics.has(Code::CELL_GEOMETRY_OUTSIDE),
        "{:?}",
        cells.diagnostics
    );
}
