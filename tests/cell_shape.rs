//! Cells shaped by the openings (issue 52): where every block of a level is in one room node
//! (as every brush map is), a doorway still gets its reveal cell and a portal the size of the
//! hole, as it does with one room node per room.

mod common;

use common::blocks::Builder;
use glam::{DMat4, DQuat, DVec3};
use portcullis::pipeline::Level;

fn v(x: f64, y: f64, z: f64) -> DVec3 {
    DVec3::new(x, y, z)
}

/// 37° about (1, 2, 3), then 1e5 m away.
fn turned() -> DMat4 {
    let q = DQuat::from_axis_angle(v(1.0, 2.0, 3.0).normalize(), 37f64.to_radians());
    DMat4::from_translation(v(1e5, -3e4, 7e4)) * DMat4::from_quat(q)
}

fn build(b: Builder) -> Level {
    let mut t = common::tagged(b.scene);
    let c = portcullis::pipeline::build_cells(&mut t);
    let p = portcullis::pipeline::build_portals(&mut t, &c);
    Level::new(t, c, p)
}

/// Two 4 x 3 x 4 m rooms through a 0.3 m wall with a 1 x 2.1 m door between two jambs under a
/// lintel, every block in one room node.
fn jamb_door(world: DMat4) -> Builder {
    let (h, t) = (3.0, 0.3);
    let mut b = Builder::new(world);
    let r = b.room("level");
    let x1 = 8.0 + t;
    for (n, lo, hi) in [
        ("floor", v(-t, -t, -t), v(x1 + t, 0.0, 4.0 + t)),
        ("ceiling", v(-t, h, -t), v(x1 + t, h + t, 4.0 + t)),
        ("south", v(-t, 0.0, -t), v(x1 + t, h, 0.0)),
        ("north", v(-t, 0.0, 4.0), v(x1 + t, h, 4.0 + t)),
        ("west", v(-t, 0.0, 0.0), v(0.0, h, 4.0)),
        ("east", v(x1, 0.0, 0.0), v(x1 + t, h, 4.0)),
        ("jamb_south", v(4.0, 0.0, 0.0), v(4.0 + t, h, 1.5)),
        ("jamb_north", v(4.0, 0.0, 2.5), v(4.0 + t, h, 4.0)),
        ("lintel", v(4.0, 2.1, 1.5), v(4.0 + t, h, 2.5)),
    ] {
        b.block(r, n, lo, hi);
    }
    b.occupant("start", true, v(1.0, 1.0, 1.0));
    b
}

#[test]
fn a_doorway_in_one_room_node_gets_its_reveal_and_a_door_sized_portal() {
    for (way, world) in [("as built", DMat4::IDENTITY), ("turned", turned())] {
        let level = build(jamb_door(world));
        let cells = &level.cells.cells;
        let vols: Vec<f64> = cells.iter().map(|c| c.volume).collect();
        assert!(
            (3..=4).contains(&cells.len()),
            "{way}: 3 or 4 cells, got {} ({vols:?})",
            cells.len()
        );
        let reveal = cells.iter().position(|c| (c.volume - 0.63).abs() < 1e-3);
        assert!(reveal.is_some(), "{way}: a 0.63 m³ reveal cell ({vols:?})");
        let r = reveal.unwrap();
        let door: Vec<f64> = (level.portals.portals.iter())
            .filter(|p| p.from == r)
            .map(|p| p.area)
            .collect();
        assert!(
            door.len() == 2 && door.iter().all(|a| (a - 2.1).abs() < 1e-3),
            "{way}: the reveal opens 2.1 m² each way ({door:?})"
        );
    }
}

/// Cells and directed portals of a level file.
fn counts(path: &std::path::Path) -> (usize, usize) {
    let level = common::built(path, None);
    (level.cells.cells.len(), level.portals.portals.len())
}

/// A grid of rooms through open doorways, as one brush map (one room) and as glTF with one
/// room node per room (tests/common/grid.rs): the map's cells and portals are the grid's,
/// within the bounds, and a door brush in every doorway adds at most half again.
#[test]
fn a_grid_as_one_brush_map_is_cut_as_its_rooms() {
    let dir = tempfile::tempdir().unwrap();
    let g = common::grid::Grid::new(12);
    let write = |name: &str, text: String| {
        let p = dir.path().join(name);
        std::fs::write(&p, text).unwrap();
        p
    };
    let (mc, mp) = counts(&write("open.map", g.to_map(false)));
    let (gc, gp) = counts(&write("open.gltf", g.to_gltf(false)));
    let (dc, _) = counts(&write("doors.map", g.to_map(true)));
    let (gdc, _) = counts(&write("doors.gltf", g.to_gltf(true)));
    // 12 rooms on 4 x 3 with 17 doorways: a cell per room and per reveal at the least.
    assert!(gc >= 12 + 17, "{gc} glTF cells");
    assert!(mc * 10 <= gc * 12, "{mc} cells as a map, {gc} as glTF");
    assert!(mp * 10 <= gp * 13, "{mp} portals as a map, {gp} as glTF");
    assert!(dc * 2 <= mc * 3, "{dc} cells with doors, {mc} open");
    assert_eq!(dc, gdc, "doors: the map's cells and the glTF's");
}

/// A block tagged `door` (extras) in `room`.
fn door_block(b: &mut Builder, room: usize, name: &str, lo: DVec3, hi: DVec3) -> usize {
    b.node(
        name,
        Some(room),
        common::blocks::box_tris(DVec3::ZERO, hi - lo),
        Some(serde_json::json!({ "door": true })),
        lo,
    )
}

/// A door block that fills its doorway is cells of its own whose portals the door closes; door
/// blocks that leave the air around them joined (bars with gaps, a block standing in a room)
/// close nothing and cut no cell, however their planes run through the room.
#[test]
fn a_door_cuts_only_where_it_closes_an_opening() {
    for (way, world) in [("as built", DMat4::IDENTITY), ("turned", turned())] {
        let open = build(jamb_door(world));
        let mut b = jamb_door(world);
        let r = 0;
        door_block(&mut b, r, "door", v(4.05, 0.0, 1.5), v(4.25, 2.1, 2.5));
        let level = build(b);
        let doors: Vec<f64> = (level.portals.portals.iter())
            .filter(|p| p.door)
            .map(|p| p.area)
            .collect();
        assert!(
            doors.len() >= 2 && doors.iter().all(|a| (a - 2.1).abs() < 1e-3),
            "{way}: the door closes the 2.1 m² opening both ways ({doors:?})"
        );
        assert!(
            level.cells.cells.len() <= open.cells.cells.len() + 2,
            "{way}: the door adds at most its own cell and the reveal's other half"
        );
        // Two bars 0.1 m square in the doorway (0.4 m gaps), and a block standing in a room.
        let mut b = jamb_door(world);
        door_block(&mut b, r, "bar1", v(4.1, 0.0, 1.8), v(4.2, 2.1, 1.9));
        door_block(&mut b, r, "bar2", v(4.1, 0.0, 2.1), v(4.2, 2.1, 2.2));
        door_block(&mut b, r, "lift", v(1.5, 0.0, 1.5), v(2.5, 0.5, 2.5));
        let level = build(b);
        assert!(
            level.portals.portals.iter().all(|p| !p.door),
            "{way}: bars with gaps and a lift in a room close nothing"
        );
        assert_eq!(
            level.cells.cells.len(),
            open.cells.cells.len(),
            "{way}: and cut no cell"
        );
    }
}

/// Two 40 x 3 x 6 m halls through a doorway: with `[cells] max_cell_width` at its 16 m default
/// some hall cells are halved (each half 20 m long, no longer), never more than half as many
/// cells again; with the width raised past the halls, none is.
#[test]
fn wide_cells_are_halved_within_a_budget() {
    let dir = tempfile::tempdir().unwrap();
    let mut map = String::from("{\n\"classname\" \"worldspawn\"\n");
    // Units: 40 m = 1575 units; two halls side by side along y, a 64-unit doorway between.
    let (l, w, h, t) = (1575.0, 236.0, 118.0, 16.0);
    let boxes = [
        ([-t, -t, -t], [l + t, 2.0 * w + 2.0 * t, 0.0]),
        ([-t, -t, h], [l + t, 2.0 * w + 2.0 * t, h + t]),
        ([-t, -t, 0.0], [0.0, 2.0 * w + 2.0 * t, h]),
        ([l, -t, 0.0], [l + t, 2.0 * w + 2.0 * t, h]),
        ([0.0, -t, 0.0], [l, 0.0, h]),
        ([0.0, 2.0 * w + t, 0.0], [l, 2.0 * w + 2.0 * t, h]),
        ([0.0, w, 0.0], [l / 2.0 - 32.0, w + t, h]),
        ([l / 2.0 + 32.0, w, 0.0], [l, w + t, h]),
        ([l / 2.0 - 32.0, w, 96.0], [l / 2.0 + 32.0, w + t, h]),
    ];
    for (lo, hi) in boxes {
        map += &common::blocks::box_brush(lo, hi);
    }
    map += "}\n{\n\"classname\" \"info_player_start\"\n\"origin\" \"64 64 24\"\n}\n";
    let path = dir.path().join("halls.map");
    std::fs::write(&path, &map).unwrap();
    let level = common::built(&path, None);
    let widths: Vec<f64> = level
        .cells
        .cells
        .iter()
        .map(|c| {
            let b = c.bounds;
            (b.max - b.min).max_element()
        })
        .collect();
    std::fs::write(
        dir.path().join("portcullis.toml"),
        "[cells]\nmax_cell_width = 100.0\n",
    )
    .unwrap();
    let whole = common::built(&path, None).cells.cells.len();
    let n = widths.len();
    assert!(n > whole, "{n} cells halved, {whole} whole");
    assert!(
        2 * n <= 3 * whole + 1,
        "{n} cells, at most half again of {whole}"
    );
    assert!(
        widths.iter().all(|w| *w <= 20.01 || *w >= 39.0),
        "halves are 20 m long: {widths:?}"
    );
}
