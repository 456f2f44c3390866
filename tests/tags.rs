//! Tag recognition on the third-party levels, the samples and tiny levels built in code.

mod common;

use std::collections::BTreeSet;

use common::{fixture, gltf, n, sample, write};
use portcullis::diag::Code;
use portcullis::pipeline::{load_tagged, LoadOptions, Tagged};
use portcullis::tags::rules::{PortalKind, VolumeHint};
use serde_json::json;

fn load(path: &std::path::Path, preset: Option<&str>) -> Tagged {
    let opts = LoadOptions {
        preset: preset.map(str::to_string),
        ..Default::default()
    };
    load_tagged(path, &opts).unwrap_or_else(|d| panic!("{}: {d}", path.display()))
}

fn room_names(t: &Tagged) -> BTreeSet<String> {
    t.tagging.rooms.iter().map(|r| r.name.clone()).collect()
}

/// (source room, target room, node name) of every portal.
fn portal_links(t: &Tagged) -> BTreeSet<(String, String, String)> {
    let name = |r: Option<usize>| {
        r.map(|r| t.tagging.rooms[r].name.clone())
            .unwrap_or_default()
    };
    t.tagging
        .portals
        .iter()
        .map(|p| {
            (
                name(p.source_room),
                name(p.target_room),
                t.scene.node_label(p.node),
            )
        })
        .collect()
}

#[test]
fn lportal_tutorial_simple_has_kitchen_and_lounge_and_one_portal() {
    for file in ["lportal_tutorial_simple.glb", "lportal_tutorial_simple.obj"] {
        let t = load(&fixture(file), None);
        assert_eq!(
            room_names(&t),
            BTreeSet::from(["kitchen".to_string(), "lounge".to_string()]),
            "{file}"
        );
        let links = portal_links(&t);
        assert_eq!(
            links,
            BTreeSet::from([(
                "kitchen".to_string(),
                "lounge".to_string(),
                "portal_lounge".to_string()
            )]),
            "{file}"
        );
        let kitchen = &t.tagging.rooms[t.tagging.room_by_name(&t.rules, "kitchen").unwrap()];
        // Floor + 5 walls bound the kitchen; the portal quad is not structure.
        assert_eq!(kitchen.structure.len(), 6, "{file}");
        // The camera's mesh sits outside every room.
        assert!(
            t.tagging
                .unassigned
                .iter()
                .any(|u| u.path.ends_with("Camera/MeshInstance")),
            "{file}: {:?}",
            t.tagging.unassigned
        );
        assert!(!t.diagnostics.has_errors(), "{file}: {:?}", t.diagnostics);
        assert!(t.tagging.near_misses.is_empty(), "{file}");
    }
}

#[test]
fn lportal_boxrooms_has_16_rooms_and_16_resolving_portals() {
    for file in ["lportal_boxrooms.glb", "lportal_boxrooms.obj"] {
        for preset in [None, Some("lportal")] {
            let t = load(&fixture(file), preset);
            assert_eq!(t.tagging.rooms.len(), 16, "{file} {preset:?}");
            let expected: BTreeSet<String> = (0..4)
                .flat_map(|x| (0..4).map(move |y| format!("myroom_x{x}y{y}")))
                .collect();
            assert_eq!(room_names(&t), expected);
            assert_eq!(t.tagging.portals.len(), 16, "{file} {preset:?}");
            for p in &t.tagging.portals {
                let target = p.target_room.expect("target resolves");
                let source = p.source_room.expect("source resolves");
                assert_ne!(source, target);
                // The portal is named after its target room.
                assert_eq!(
                    t.scene.node_label(p.node),
                    format!("portal_{}", t.tagging.rooms[target].name)
                );
                // LPortal puts a portal inside its source room.
                assert!(p
                    .path
                    .contains(&format!("room_{}/", t.tagging.rooms[source].name)));
                assert!(!p.one_way);
            }
            assert!(!t.diagnostics.has_errors(), "{:?}", t.diagnostics);
            assert!(
                t.tagging.near_misses.is_empty(),
                "{:?}",
                t.tagging.near_misses
            );
        }
    }
}

#[test]
fn panda3d_culling_has_11_footprint_cells_and_24_one_way_portals() {
    for file in ["panda3d_culling.glb", "panda3d_culling.obj"] {
        let t = load(&fixture(file), Some("panda3d"));
        assert_eq!(t.tagging.rooms.len(), 11, "{file}");
        assert_eq!(t.tagging.footprints.len(), 11, "{file}");
        for r in &t.tagging.rooms {
            assert_eq!(r.volume, VolumeHint::Footprint, "{}", r.name);
            assert_eq!(r.footprints, vec![r.node]);
        }
        let expected: BTreeSet<String> = (1..=11).map(|i| format!("cell{i}")).collect();
        assert_eq!(room_names(&t), expected);
        assert_eq!(t.tagging.portals.len(), 24, "{file}");
        for p in &t.tagging.portals {
            assert!(p.one_way);
            let name = t.scene.node_label(p.node);
            // portal_AtoB_K: A and B resolve to cellA and cellB.
            let digits: Vec<&str> = name
                .trim_start_matches("portal_")
                .split(['t', 'o', '_'])
                .filter(|s| !s.is_empty())
                .collect();
            let src = &t.tagging.rooms[p.source_room.expect("source resolves")].name;
            let dst = &t.tagging.rooms[p.target_room.expect("target resolves")].name;
            assert_eq!(src, &format!("cell{}", digits[0]), "{name}");
            assert_eq!(dst, &format!("cell{}", digits[1]), "{name}");
        }
        // levelgeo is the building: one mesh in no room (the cells stage assigns it).
        assert!(t
            .tagging
            .unassigned
            .iter()
            .any(|u| u.path.ends_with("levelgeo")));
        assert!(!t.diagnostics.has_errors(), "{:?}", t.diagnostics);
    }
}

#[test]
fn panda3d_under_the_default_preset_still_links_cells() {
    let t = load(&fixture("panda3d_culling.glb"), None);
    assert_eq!(t.tagging.rooms.len(), 11);
    assert_eq!(t.tagging.portals.len(), 24);
    assert!(t
        .tagging
        .portals
        .iter()
        .all(|p| p.one_way && p.source_room.is_some() && p.target_room.is_some()));
}

#[test]
fn glb_and_obj_copies_agree() {
    for (stem, preset) in [
        ("lportal_tutorial_simple", None),
        ("lportal_boxrooms", None),
        ("panda3d_culling", Some("panda3d")),
    ] {
        let a = load(&fixture(&format!("{stem}.glb")), preset);
        let b = load(&fixture(&format!("{stem}.obj")), preset);
        assert_eq!(room_names(&a), room_names(&b), "{stem}");
        assert_eq!(portal_links(&a), portal_links(&b), "{stem}");
        assert_eq!(a.scene.triangle_count(), b.scene.triangle_count(), "{stem}");
    }
}

#[test]
fn samples_agree_across_formats() {
    let a = load(&sample("two_rooms.gltf"), None);
    let b = load(&sample("two_rooms.obj"), None);
    for t in [&a, &b] {
        assert_eq!(
            room_names(t),
            BTreeSet::from(["kitchen".to_string(), "lounge".to_string()])
        );
        assert_eq!(
            portal_links(t),
            BTreeSet::from([(
                "kitchen".to_string(),
                "lounge".to_string(),
                "lounge-portal".to_string()
            )])
        );
        assert_eq!(t.scene.triangle_count(), 46);
        let kitchen = &t.tagging.rooms[0];
        assert_eq!(kitchen.detail.len(), 1, "the table is a prop");
        assert_eq!(kitchen.structure.len(), 3);
        assert!(t.diagnostics.is_empty(), "{:?}", t.diagnostics);
    }
}

#[test]
fn near_misses_are_warned_with_the_fix() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(
        dir.path(),
        "near.gltf",
        &gltf(&[
            n("Level", None, false),
            n("Kitchen_Room ", Some(0), false),
            n("Floor", Some(1), true),
            n("Room-kitchen.001", Some(0), false),
            n("lounge-room", Some(0), false),
        ]),
    );
    let t = load(&p, None);
    let misses: Vec<_> = t
        .diagnostics
        .iter()
        .filter(|d| d.code == Code::TAG_NEAR_MISS)
        .collect();
    assert_eq!(misses.len(), 2, "{:?}", t.diagnostics);
    assert!(misses[0].message.contains("`Kitchen_Room `"));
    assert_eq!(
        misses[0].location.node.as_deref(),
        Some("Level/Kitchen_Room ")
    );
    assert!(misses[0]
        .hint
        .as_deref()
        .unwrap()
        .contains("`Kitchen-Room`"));
    assert!(misses[1]
        .hint
        .as_deref()
        .unwrap()
        .contains("`Room_kitchen`"));
    assert_eq!(room_names(&t), BTreeSet::from(["lounge".to_string()]));
    // The near-miss room's floor is in no room.
    assert_eq!(t.tagging.unassigned.len(), 1);
}

#[test]
fn godot_conventions_wildcards_groups_bounds() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(
        dir.path(),
        "godot.gltf",
        &gltf(&[
            n("RoomList", None, false),
            n("outside-roomgroup", Some(0), false),
            n("garden-room", Some(1), false),
            n("Grass", Some(2), true),
            n("KITCHEN-ROOM", Some(0), false),
            n("Walls", Some(4), true),
            n("garden*1-portal", Some(4), true),
            n("garden*2-portal", Some(4), true),
            n("-portal", Some(4), true),
            n("Kitchen-bound", Some(4), true),
            n("Chair-detail", Some(4), true),
            n("Collision-ignore", Some(4), true),
        ]),
    );
    for preset in [None, Some("godot")] {
        let t = load(&p, preset);
        assert_eq!(
            room_names(&t),
            BTreeSet::from(["garden".to_string(), "KITCHEN".to_string()])
        );
        assert_eq!(t.tagging.room_groups.len(), 1);
        assert_eq!(t.tagging.room_groups[0].name, "outside");
        assert_eq!(t.tagging.room_groups[0].rooms, vec![0]);
        assert_eq!(t.tagging.portals.len(), 3);
        let garden = t.tagging.room_by_name(&t.rules, "garden").unwrap();
        let kitchen = t.tagging.room_by_name(&t.rules, "kitchen").unwrap();
        assert_eq!(t.tagging.portals[0].target_room, Some(garden));
        assert_eq!(t.tagging.portals[1].target_room, Some(garden));
        assert_eq!(t.tagging.portals[0].source_room, Some(kitchen));
        // A bare `-portal` is auto-linked later by position.
        assert_eq!(t.tagging.portals[2].target_name, None);
        assert_eq!(t.tagging.bounds.len(), 1);
        assert_eq!(t.tagging.bounds[0].room, Some(kitchen));
        assert_eq!(t.tagging.rooms[kitchen].volume, VolumeHint::Bound);
        assert_eq!(t.tagging.ignored.len(), 1);
        if preset.is_none() {
            assert_eq!(t.tagging.rooms[kitchen].structure.len(), 1);
            assert_eq!(t.tagging.rooms[kitchen].detail.len(), 1);
        } else {
            // The godot preset has no -detail rule: the chair is structure.
            assert_eq!(t.tagging.rooms[kitchen].structure.len(), 2);
        }
        assert!(!t.diagnostics.has_errors(), "{:?}", t.diagnostics);
    }
}

#[test]
fn extras_win_over_names_and_carry_portal_flags() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(
        dir.path(),
        "extras.gltf",
        &gltf(&[
            n("A", None, false).extras(json!({"room": "attic"})),
            n("floor", Some(0), true),
            n("room_decoy", None, false).extras(json!({"room": "cellar"})),
            n("hatch", Some(0), true)
                .extras(json!({"portal": "cellar", "one_way": true, "closed": "yes"})),
            n("mirror", Some(0), true)
                .extras(json!({"portcullis": {"portal": true, "portal_kind": "mirror"}})),
            n("tp_in", Some(0), true).extras(
                json!({"portal": "cellar", "portal_kind": "teleporter", "teleport_exit": "tp_out"}),
            ),
            n("tp_out", Some(2), true).extras(
                json!({"portal": "attic", "portal_kind": "teleporter", "teleport_exit": "nowhere"}),
            ),
            n("lamp", Some(0), true).extras(json!({"detail": 1})),
            n("gizmo", Some(0), true).extras(json!({"ignore": true, "room": ["bad"]})),
            n("window", Some(0), true).material("visportal"),
        ]),
    );
    let t = load(&p, None);
    assert_eq!(
        room_names(&t),
        BTreeSet::from(["attic".to_string(), "cellar".to_string()])
    );
    let by = |name: &str| {
        t.tagging
            .portals
            .iter()
            .find(|p| t.scene.node_label(p.node) == name)
            .unwrap()
    };
    let hatch = by("hatch");
    assert!(hatch.one_way && hatch.closed);
    assert_eq!(
        hatch.target_room,
        t.tagging.room_by_name(&t.rules, "cellar")
    );
    assert_eq!(by("mirror").kind, PortalKind::Mirror);
    let tp = by("tp_in");
    assert_eq!(tp.kind, PortalKind::Teleporter);
    assert_eq!(
        tp.teleport_exit.map(|n| t.scene.node_label(n)),
        Some("tp_out".to_string())
    );
    assert!(t.diagnostics.has(Code::TAG_TELEPORT_EXIT_UNKNOWN));
    assert!(t.diagnostics.has(Code::TAG_EXTRAS_INVALID));
    assert_eq!(t.tagging.ignored.len(), 1);
    assert!(by("window").rule.starts_with("material."));
    let attic = &t.tagging.rooms[t.tagging.room_by_name(&t.rules, "attic").unwrap()];
    assert_eq!(attic.detail.len(), 1);
    assert_eq!(attic.structure.len(), 1);
}

#[test]
fn unknown_targets_are_errors_with_a_suggestion() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(
        dir.path(),
        "unknown.gltf",
        &gltf(&[
            n("room_kitchen", None, false),
            n("portal_lounges", Some(0), true),
            n("room_lounge", None, false),
            n("room_kitchen", None, false),
            n("bound_x", None, true),
            n("portal_nowhere", None, true),
        ]),
    );
    let t = load(&p, None);
    let d = t
        .diagnostics
        .iter()
        .find(|d| d.code == Code::TAG_UNKNOWN_TARGET)
        .unwrap();
    assert!(d.message.contains("`lounges`"));
    assert!(d.hint.as_deref().unwrap().contains("`lounge`"));
    assert!(t.diagnostics.has(Code::TAG_DUPLICATE_ROOM));
    assert!(t.diagnostics.has(Code::TAG_BOUND_NO_ROOM));
    assert!(t.diagnostics.has(Code::TAG_PORTAL_NO_SOURCE));
    assert!(t.diagnostics.has_errors());
}

#[test]
fn config_next_to_the_input_adds_rules() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(
        dir.path(),
        "studio.gltf",
        &gltf(&[n("RM_office", None, false), n("desk", Some(0), true)]),
    );
    let t = load(&p, None);
    assert!(t.tagging.rooms.is_empty());
    assert!(t.diagnostics.has(Code::TAG_NO_ROOMS));
    write(
        dir.path(),
        "portcullis.toml",
        "[tags]\n[[tags.rule]]\nid = \"studio.room\"\nkind = \"room\"\npattern = '^RM_(?P<name>.+)$'\nexample = \"RM_kitchen\"\n",
    );
    let t = load(&p, None);
    assert_eq!(room_names(&t), BTreeSet::from(["office".to_string()]));
    assert_eq!(t.tagging.rooms[0].rule, "studio.room");
    assert_eq!(
        t.config.path.as_deref(),
        Some(dir.path().join("portcullis.toml").as_path())
    );
}

/// Issue 29, item 5: a misspelt tag word is a near miss, found by edit distance against every
/// rule's affix, case-insensitively; a word that merely contains one is not.
#[test]
fn misspelt_tag_words_are_near_misses() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(
        dir.path(),
        "typos.gltf",
        &gltf(&[
            n("Level", None, false),
            n("lounge-rooom", Some(0), true),
            n("Kitchen_rom", Some(0), true),
            n("Broom_cupboard", Some(0), true),
        ]),
    );
    let t = load(&p, None);
    let hints: Vec<String> = t
        .diagnostics
        .iter()
        .filter(|d| d.code == Code::TAG_NEAR_MISS)
        .map(|d| d.hint.clone().unwrap_or_default())
        .collect();
    assert_eq!(hints.len(), 2, "{:?}", t.diagnostics);
    assert!(hints[0].contains("`lounge-room`"), "{hints:?}");
    assert!(hints[1].contains("`Kitchen-room`"), "{hints:?}");
}

/// Issue 29, item 3: the anchors' portal materials (id Tech 4's `textures/editor/visportal`,
/// Quake 3's `textures/common/areaportal`) and a DCC's numbered duplicates (`portal.001`,
/// `lounge-portal.001`) are tags under the default preset.
#[test]
fn anchor_portal_materials_and_numbered_duplicates_are_tags() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(
        dir.path(),
        "materials.gltf",
        &gltf(&[
            n("kitchen-room", None, false),
            n("Floor", Some(0), true),
            n("door", Some(0), true).material("textures/editor/visportal"),
            n("hatch", Some(0), true).material("textures/common/areaportal"),
            n("window", Some(0), true).material("portal.001"),
            n("lounge-portal.001", Some(0), true),
            n("lounge-room.001", None, false),
            n("Floor2", Some(6), true),
            n("caulked", Some(0), true).material("textures/common/caulk"),
        ]),
    );
    let t = load(&p, None);
    let portals: BTreeSet<String> = t
        .tagging
        .portals
        .iter()
        .map(|p| t.scene.node_label(p.node))
        .collect();
    assert_eq!(
        portals,
        BTreeSet::from(["door", "hatch", "window", "lounge-portal.001"].map(str::to_string)),
        "{:?}",
        t.diagnostics
    );
    assert_eq!(
        room_names(&t),
        BTreeSet::from(["kitchen".to_string(), "lounge".to_string()])
    );
    assert_eq!(t.tagging.ignored.len(), 1);
    assert!(
        !t.diagnostics.has(Code::TAG_NEAR_MISS),
        "{:?}",
        t.diagnostics
    );
}

/// Tags a copy of `t`'s scene after `edit`, with `preset`.
fn retag(
    t: &Tagged,
    preset: Option<&str>,
    edit: impl FnOnce(&mut portcullis::scene::Scene),
) -> Tagged {
    let mut scene = t.scene.clone();
    edit(&mut scene);
    common::tagged_with(scene, Default::default(), preset)
}

/// Issue 29, item 7: extras say what the schema documents, or are reported. A footprint's
/// `footprint_height` sets its cells' height (on the footprint, or on its room's node); a
/// number where a name or flag belongs, a priority that is not a whole number or a height
/// that is not positive is `TAG_EXTRAS_INVALID`; names lose stray spaces.
#[test]
fn extras_are_honoured_or_reported_and_names_trimmed() {
    use portcullis::pipeline::build_cells;
    let base = load(&fixture("panda3d_culling.glb"), Some("panda3d"));
    let node = |t: &Tagged, name: &str| {
        t.scene
            .nodes
            .iter()
            .position(|n| n.name.as_deref() == Some(name))
            .unwrap()
    };
    // A footprint piece raised by h everywhere (a ramp's too) is a cell of volume h times its
    // plan area: the mean height is volume over the area of the vertices' plan hull.
    let heights = |t: &mut Tagged, room: &str| -> Vec<f64> {
        let c = build_cells(t);
        let r = t.tagging.room_by_name(&t.rules, room).unwrap();
        c.room_cells[r]
            .iter()
            .map(|&i| {
                let plan: Vec<(f64, f64)> = c.cells[i]
                    .poly
                    .vertices(1e-9)
                    .iter()
                    .map(|v| (v.x, v.z))
                    .collect();
                c.cells[i].volume / hull_area(plan)
            })
            .collect()
    };
    let before = heights(&mut base.clone(), "cell4");
    assert!(before.iter().all(|h| (h - 1.25).abs() > 1e-6), "{before:?}");
    let cell4 = node(&base, "cell4");
    let mut set = retag(&base, Some("panda3d"), |s| {
        s.nodes[cell4].extras = Some(json!({"footprint_height": 1.25}));
    });
    let after = heights(&mut set, "cell4");
    assert!(!after.is_empty());
    for h in after {
        assert!((h - 1.25).abs() < 1e-6, "{h}");
    }

    let bad = retag(&base, Some("panda3d"), |s| {
        s.nodes[cell4].extras = Some(json!({"footprint_height": -1, "priority": 1.5}));
    });
    let invalid: Vec<&str> = bad
        .diagnostics
        .iter()
        .filter(|d| d.code == Code::TAG_EXTRAS_INVALID)
        .map(|d| d.message.as_str())
        .collect();
    assert_eq!(invalid.len(), 2, "{invalid:?}");
    assert!(invalid[0].contains("priority") && invalid[1].contains("footprint_height"));

    let dir = tempfile::tempdir().unwrap();
    let p = write(
        dir.path(),
        "typed.gltf",
        &gltf(&[
            n(" kitchen-room", None, false),
            n("Floor", Some(0), true),
            n("Shelf", Some(0), true).extras(json!({"room": 5})),
            n("Lamp", Some(0), true).extras(json!({"detail": 1})),
        ]),
    );
    let t = load(&p, None);
    assert_eq!(room_names(&t), BTreeSet::from(["kitchen".to_string()]));
    let invalid: Vec<_> = t
        .diagnostics
        .iter()
        .filter(|d| d.code == Code::TAG_EXTRAS_INVALID)
        .collect();
    assert_eq!(invalid.len(), 1, "{:?}", t.diagnostics);
    assert!(
        invalid[0].message.contains("`room`"),
        "{}",
        invalid[0].message
    );
    assert_eq!(t.tagging.rooms[0].detail.len(), 1);
}

/// The area of the convex hull of plan points (monotone chain, shoelace).
fn hull_area(mut pts: Vec<(f64, f64)>) -> f64 {
    pts.sort_by(|a, b| a.partial_cmp(b).unwrap());
    pts.dedup();
    let cross = |o: (f64, f64), a: (f64, f64), b: (f64, f64)| {
        (a.0 - o.0) * (b.1 - o.1) - (a.1 - o.1) * (b.0 - o.0)
    };
    let mut hull: Vec<(f64, f64)> = Vec::new();
    for pass in 0..2 {
        let start = hull.len();
        let it: Box<dyn Iterator<Item = &(f64, f64)>> = if pass == 0 {
            Box::new(pts.iter())
        } else {
            Box::new(pts.iter().rev())
        };
        for &p in it {
            while hull.len() >= start + 2
                && cross(hull[hull.len() - 2], hull[hull.len() - 1], p) <= 0.0
            {
                hull.pop();
            }
            hull.push(p);
        }
        hull.pop();
    }
    let n = hull.len();
    (0..n)
        .map(|i| {
            let (a, b) = (hull[i], hull[(i + 1) % n]);
            a.0 * b.1 - b.0 * a.1
        })
        .sum::<f64>()
        .abs()
        / 2.0
}
