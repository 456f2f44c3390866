//! A grid of N rooms joined by open jamb-and-lintel doorways (issue 52), written twice: as one
//! brush map (every brush in worldspawn, one room, as every map is) and as glTF with one tagged
//! room node per room (each room lists its floor, ceiling, its west and south walls and, on
//! the grid's edge, its east and north walls). The same boxes either way, so the two readings
//! can be held to each other: cells, portals, time and memory.
//!
//! Rooms are 256 x 256 x 128 units (Quake's inch: 6.5 x 6.5 x 3.25 m) on a 272 unit pitch
//! (16 unit walls), `ceil(sqrt(N))` to a row; a doorway is 64 x 96 units in the middle of each
//! wall between two rooms. With `doors`, a `func_door` brush (glTF: a block tagged `door`)
//! fills every doorway.

use serde_json::{json, Value};

use super::blocks::box_brush;

const SIZE: f64 = 256.0;
const WALL: f64 = 16.0;
const HEIGHT: f64 = 128.0;
const PITCH: f64 = SIZE + WALL;
const DOOR_W: f64 = 64.0;
const DOOR_H: f64 = 96.0;
/// Metres per unit, as the brush-map importer reads units.
const INCH: f64 = 0.0254;

/// A box in map units (Z up), min and max corners.
pub type Box3 = ([f64; 3], [f64; 3]);

/// The grid: each room's blocks and doors (boxes in map units).
pub struct Grid {
    pub rooms: Vec<Vec<Box3>>,
    /// Each doorway's box and the room whose wall it is in.
    pub doors: Vec<(usize, Box3)>,
    /// Where the player starts (map units): room 0's middle.
    pub start: [f64; 3],
}

/// The blocks of a wall along `axis` (0: x, 1: y) at `at` (its low side), spanning `from`..`to`
/// along the other axis, with a doorway in the middle when `door`; the doorway's box.
fn wall(axis: usize, at: f64, from: f64, to: f64, door: bool) -> (Vec<Box3>, Option<Box3>) {
    let bx = |a0: f64, a1: f64, b0: f64, b1: f64, z0: f64, z1: f64| -> Box3 {
        // `a` across the wall (thickness), `b` along it.
        if axis == 0 {
            ([a0, b0, z0], [a1, b1, z1])
        } else {
            ([b0, a0, z0], [b1, a1, z1])
        }
    };
    let (a0, a1) = (at, at + WALL);
    if !door {
        return (vec![bx(a0, a1, from, to, 0.0, HEIGHT)], None);
    }
    let mid = (from + to) / 2.0;
    let (d0, d1) = (mid - DOOR_W / 2.0, mid + DOOR_W / 2.0);
    let blocks = vec![
        bx(a0, a1, from, d0, 0.0, HEIGHT),
        bx(a0, a1, d1, to, 0.0, HEIGHT),
        bx(a0, a1, d0, d1, DOOR_H, HEIGHT),
    ];
    (blocks, Some(bx(a0, a1, d0, d1, 0.0, DOOR_H)))
}

impl Grid {
    pub fn new(n: usize) -> Grid {
        let cols = (n as f64).sqrt().ceil() as usize;
        let exists = |c: usize, r: usize| c < cols && r * cols + c < n;
        let mut rooms = Vec::with_capacity(n);
        let mut doors = Vec::new();
        for i in 0..n {
            let (c, r) = (i % cols, i / cols);
            let (x0, y0) = (c as f64 * PITCH, r as f64 * PITCH);
            let (x1, y1) = (x0 + PITCH + WALL, y0 + PITCH + WALL);
            let mut blocks = vec![
                ([x0, y0, -WALL], [x1, y1, 0.0]),
                ([x0, y0, HEIGHT], [x1, y1, HEIGHT + WALL]),
            ];
            // West and south walls, with a doorway to the room beyond; east and north only on
            // the grid's edge.
            for (axis, at, from, to, listed, door) in [
                (0, x0, y0, y1, true, c > 0),
                (1, y0, x0, x1, true, r > 0),
                (0, x0 + PITCH, y0, y1, !exists(c + 1, r), false),
                (1, y0 + PITCH, x0, x1, !exists(c, r + 1), false),
            ] {
                if listed {
                    let (b, d) = wall(axis, at, from, to, door);
                    blocks.extend(b);
                    doors.extend(d.map(|d| (i, d)));
                }
            }
            rooms.push(blocks);
        }
        Grid {
            rooms,
            doors,
            start: [PITCH / 2.0 + WALL / 2.0, PITCH / 2.0 + WALL / 2.0, 32.0],
        }
    }

    /// The grid as one brush map: worldspawn, a `func_door` per doorway when `doors`, and an
    /// `info_player_start`.
    pub fn to_map(&self, doors: bool) -> String {
        let mut out = String::from("{\n\"classname\" \"worldspawn\"\n");
        for (lo, hi) in self.rooms.iter().flatten() {
            out += &box_brush(*lo, *hi);
        }
        out += "}\n";
        if doors {
            for (_, (lo, hi)) in &self.doors {
                out += "{\n\"classname\" \"func_door\"\n";
                out += &box_brush(*lo, *hi);
                out += "}\n";
            }
        }
        let [x, y, z] = self.start;
        out +=
            &format!("{{\n\"classname\" \"info_player_start\"\n\"origin\" \"{x} {y} {z}\"\n}}\n");
        out
    }

    /// The grid as glTF (metres, Y up, as the importer reads the map): one room node per room,
    /// every block a node placing one unit cube by translation and scale, door blocks (when
    /// `doors`) in the room whose wall they stand in, and a player start.
    pub fn to_gltf(&self, doors: bool) -> String {
        // Map (x, y, z) units to glTF (x, z, -y) metres: a box's corners swap along y.
        let place = |(lo, hi): &Box3| -> (Value, Value) {
            let min = [lo[0] * INCH, lo[2] * INCH, -hi[1] * INCH];
            let max = [hi[0] * INCH, hi[2] * INCH, -lo[1] * INCH];
            let size: Vec<f64> = (0..3).map(|k| max[k] - min[k]).collect();
            (json!(min), json!(size))
        };
        let mut nodes = vec![json!({"name": "Level", "children": []})];
        let add = |nodes: &mut Vec<Value>, parent: usize, node: Value| {
            nodes.push(node);
            let k = nodes.len() - 1;
            nodes[parent]["children"]
                .as_array_mut()
                .unwrap()
                .push(json!(k));
            k
        };
        let mut door_rooms = vec![Vec::new(); self.rooms.len()];
        if doors {
            for (room, d) in &self.doors {
                door_rooms[*room].push(*d);
            }
        }
        for (i, blocks) in self.rooms.iter().enumerate() {
            let name = format!("r{i}");
            let room = add(
                &mut nodes,
                0,
                json!({"name": name, "extras": {"room": name}, "children": []}),
            );
            for (k, b) in blocks.iter().enumerate() {
                let (t, s) = place(b);
                let node =
                    json!({"name": format!("r{i}_b{k}"), "mesh": 0, "translation": t, "scale": s});
                add(&mut nodes, room, node);
            }
            for (k, d) in door_rooms[i].iter().enumerate() {
                let (t, s) = place(d);
                let node = json!({"name": format!("r{i}_door{k}"), "mesh": 0, "translation": t,
                    "scale": s, "extras": {"door": true}});
                add(&mut nodes, room, node);
            }
        }
        let [x, y, z] = self.start;
        let start = json!({"name": "start", "translation": [x * INCH, z * INCH, -y * INCH],
            "extras": {"player_start": true}});
        add(&mut nodes, 0, start);
        json!({
            "asset": {"version": "2.0", "generator": "portcullis tests/common/grid.rs"},
            "scene": 0,
            "scenes": [{"nodes": [0]}],
            "nodes": nodes,
            "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
            "accessors": [
                {"bufferView": 0, "componentType": 5126, "count": 8, "type": "VEC3",
                 "min": [0.0, 0.0, 0.0], "max": [1.0, 1.0, 1.0]},
                {"bufferView": 1, "componentType": 5123, "count": 36, "type": "SCALAR"}
            ],
            "bufferViews": [
                {"buffer": 0, "byteOffset": 0, "byteLength": 96},
                {"buffer": 0, "byteOffset": 96, "byteLength": 72}
            ],
            "buffers": [{"byteLength": 168, "uri": unit_cube_uri()}]
        })
        .to_string()
    }
}

/// The unit cube 0..1, 8 corners and 12 outward triangles, as a data URI.
fn unit_cube_uri() -> String {
    let mut bytes = Vec::new();
    for i in 0..8u32 {
        for k in 0..3 {
            bytes.extend_from_slice(&(((i >> k) & 1) as f32).to_le_bytes());
        }
    }
    for q in super::blocks::BOX_QUADS {
        for i in [q[0], q[1], q[2], q[0], q[2], q[3]] {
            bytes.extend_from_slice(&(i as u16).to_le_bytes());
        }
    }
    use base64::Engine;
    let data = base64::engine::general_purpose::STANDARD.encode(&bytes);
    format!("data:application/octet-stream;base64,{data}")
}
