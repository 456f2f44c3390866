//! The angle tolerance on a level (issue 71): normals within `geom::tolerance::ANGLE` (1e-5
//! rad) are parallel, normals further apart are not, whatever the distances. Two rooms share a
//! wall with a door in it; the east room is turned about the vertical line through the door's
//! centre, at the origin, so the two walls' planes both pass through it and no point of the
//! turned wall moves further than the distance tolerance. Turned by half the angle tolerance,
//! the walls face each other and the door is one pair of portals; turned by twice it, they do
//! not, and there is no door. Each turn is a fixed number, so a tolerance ten times finer
//! loses the first door and one ten times coarser finds the second.

mod common;
#[path = "stiff/levels.rs"]
mod stiff;

use glam::DVec3;
use portcullis::cells::CellSet;
use portcullis::pipeline::{build_cells, build_portals, load_tagged, LoadOptions, Tagged};
use portcullis::portals::PortalSet;
use stiff::{box_room, hole, Face, ObjLevel};

/// The documented angle tolerance (radians), which the turns below straddle.
const ANGLE: f64 = 1e-5;

/// Half the room's width (m) along the wall: the furthest a point of the wall is from the
/// line it is turned about.
const HALF_WIDTH: f64 = 2.0;

/// Decimals the level is written with, every coordinate to the last one (as `%g` writes six
/// significant digits): the file is then good to 1e-5 m, and its distance tolerance several
/// times the furthest a point of the turned wall moves, `HALF_WIDTH` times twice [`ANGLE`].
const DECIMALS: usize = 5;

fn v(x: f64, y: f64, z: f64) -> DVec3 {
    DVec3::new(x, y, z)
}

/// `p` turned by `angle` about the vertical line through the origin, to [`DECIMALS`].
fn turned(p: DVec3, angle: f64) -> DVec3 {
    let (s, c) = angle.sin_cos();
    let q = v(c * p.x + s * p.z, p.y, c * p.z - s * p.x);
    let k = 10f64.powi(DECIMALS as i32);
    (q * k).round() / k
}

/// The level as OBJ text, every coordinate written to [`DECIMALS`] places.
fn obj_text(level: &ObjLevel) -> String {
    use std::fmt::Write;
    let mut s = String::new();
    let mut next = 1usize;
    for (name, tris) in &level.objects {
        writeln!(s, "o {name}").unwrap();
        for t in tris {
            for p in t {
                writeln!(s, "v {:.d$} {:.d$} {:.d$}", p.x, p.y, p.z, d = DECIMALS).unwrap();
            }
            writeln!(s, "f {} {} {}", next, next + 1, next + 2).unwrap();
            next += 3;
        }
    }
    s
}

struct Built {
    t: Tagged,
    c: CellSet,
    p: PortalSet,
}

impl Built {
    /// Portals from a cell of room `a` into a cell of room `b`: (portal, its area).
    fn between(&self, a: &str, b: &str) -> Vec<f64> {
        let room = |c: usize| self.t.tagging.rooms[self.c.cells[c].room].name.as_str();
        self.p
            .portals
            .iter()
            .filter(|p| room(p.from) == a && p.to.is_some_and(|t| room(t) == b))
            .map(|p| p.area)
            .collect()
    }
}

/// Two 4 x 3 x 4 m rooms either side of x = 0, z from -2 to 2, with a door z -0.5 .. 0.5,
/// y 0 .. 2.2 in the wall they share; the east room turned by `angle`.
fn two_rooms(angle: f64) -> Built {
    let door = |f| hole(f, -0.5, 0.5, 0.0, 2.2);
    let mut level = ObjLevel::default();
    level.room(
        "west",
        box_room(v(-4.0, 0.0, -2.0), v(0.0, 3.0, 2.0), &[door(Face::X1)], &[]),
    );
    let east = box_room(v(0.0, 0.0, -2.0), v(4.0, 3.0, 2.0), &[door(Face::X0)], &[]);
    let east = east.into_iter().map(|t| t.map(|p| turned(p, angle)));
    level.room("east", east.collect());
    let dir = tempfile::tempdir().unwrap();
    let path = common::write(dir.path(), "level.obj", &obj_text(&level));
    let mut t = load_tagged(&path, &LoadOptions::default()).unwrap();
    let c = build_cells(&mut t);
    let p = build_portals(&mut t, &c);
    // Only the angle decides: the turned wall is within the distance tolerance of the other.
    let moved = HALF_WIDTH * 2.0 * ANGLE;
    assert!(
        c.tolerance.distance > moved,
        "the distance tolerance {} should exceed {moved} m",
        c.tolerance.distance
    );
    Built { t, c, p }
}

#[test]
fn walls_half_the_angle_tolerance_apart_share_their_door() {
    let b = two_rooms(0.5 * ANGLE);
    assert_eq!(b.c.cells.len(), 2);
    let (there, back) = (b.between("west", "east"), b.between("east", "west"));
    assert_eq!(there.len(), 1, "{:#?}", b.t.diagnostics);
    assert_eq!(back.len(), 1);
    assert!((there[0] - 2.2).abs() < 1e-3, "door area {}", there[0]);
}

#[test]
fn walls_twice_the_angle_tolerance_apart_do_not_face_each_other() {
    let b = two_rooms(2.0 * ANGLE);
    assert_eq!(b.c.cells.len(), 2);
    assert_eq!(b.between("west", "east"), Vec::<f64>::new());
    assert_eq!(b.between("east", "west"), Vec::<f64>::new());
}
