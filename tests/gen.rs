//! The level generator: its buildings pass `check` with no warning, and the portal graph
//! portcullis derives joins exactly the rooms the generator put doors and stairs between.

mod common;

use std::collections::BTreeSet;

use portcullis::buildings::{self, GenOptions, Layout};

#[test]
fn generated_buildings_give_the_rooms_and_doors_they_were_built_with() {
    for (rooms, seed) in [(1, 1), (12, 3), (40, 9)] {
        let dir = tempfile::tempdir().unwrap();
        let path = common::generated_building(dir.path(), rooms, seed);
        // Clean: every authored portal matched, every room reachable, no stray geometry.
        assert_cmd::Command::cargo_bin("portcullis")
            .unwrap()
            .args(["check", "--deny", "warnings"])
            .arg(&path)
            .assert()
            .success();
        let (t, cells, portals) = common::load_level(&path, None);
        let layout = Layout::new(rooms, seed);
        assert_eq!(t.tagging.rooms.len(), rooms);
        // An L room is split into two cells; every other room is one.
        let ls = layout.rooms.iter().filter(|r| r.cells.len() == 3).count();
        assert_eq!(
            cells.cells.len(),
            rooms + ls,
            "{rooms} rooms, {ls} L shapes"
        );
        // Room pairs joined by portals = doors + one stair link per storey above the first.
        let name = |c: usize| t.tagging.rooms[cells.cells[c].room].name.clone();
        let mut joined: BTreeSet<(String, String)> = BTreeSet::new();
        for p in &portals.portals {
            if let Some(to) = p.to {
                let (a, b) = (name(p.from), name(to));
                if a != b {
                    joined.insert((a.clone().min(b.clone()), a.max(b)));
                }
            }
        }
        let mut expected: BTreeSet<(String, String)> = BTreeSet::new();
        for d in &layout.doors {
            let (a, b) = (layout.name(d.a), layout.name(d.b));
            expected.insert((a.clone().min(b.clone()), a.max(b)));
        }
        for s in 1..layout.storeys {
            let (a, b) = (format!("s{}_stair", s - 1), format!("s{s}_stair"));
            expected.insert((a.clone().min(b.clone()), a.max(b)));
        }
        assert_eq!(joined, expected, "{rooms} rooms");
    }
}

#[test]
fn the_same_seed_gives_the_same_bytes() {
    let a = buildings::generate(&GenOptions {
        rooms: 25,
        seed: 4,
        props: true,
    });
    let b = buildings::generate(&GenOptions {
        rooms: 25,
        seed: 4,
        props: true,
    });
    let fmt = portcullis::export::target::OutFormat::Glb;
    assert_eq!(
        portcullis::export::gltf_out::write_plain(&a, fmt),
        portcullis::export::gltf_out::write_plain(&b, fmt)
    );
    let c = buildings::generate(&GenOptions {
        rooms: 25,
        seed: 5,
        props: true,
    });
    assert_ne!(
        portcullis::export::gltf_out::write_plain(&a, fmt),
        portcullis::export::gltf_out::write_plain(&c, fmt)
    );
}

#[test]
fn generated_levels_pass_the_khronos_validator() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("g.glb");
    let scene = buildings::generate(&GenOptions {
        rooms: 8,
        seed: 2,
        props: true,
    });
    std::fs::write(
        &path,
        portcullis::export::gltf_out::write_plain(
            &scene,
            portcullis::export::target::OutFormat::Glb,
        ),
    )
    .unwrap();
    if let Some(report) = common::khronos_validate(&path) {
        assert_eq!(report["issues"]["numErrors"], 0, "{report:#}");
    }
}
