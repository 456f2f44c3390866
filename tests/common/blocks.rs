//! Block levels built in code, node by node, as a glTF exporter writes them: every block a
//! closed box mesh local to its corner, placed by the node's transform (so a level moved far
//! away keeps f64 positions, as a glTF node's translation does).

use glam::{DMat4, DVec3};
use portcullis::scene::{Format, Mesh, Node, Primitive, Scene, SourceRef};
use serde_json::{json, Value};

/// A box's faces by corner (corner i has x from bit 0, y from bit 1, z from bit 2), each
/// counter-clockwise seen from outside.
pub const BOX_QUADS: [[usize; 4]; 6] = [
    [0, 4, 6, 2],
    [1, 3, 7, 5],
    [0, 1, 5, 4],
    [2, 6, 7, 3],
    [0, 2, 3, 1],
    [4, 5, 7, 6],
];

/// The outward triangles of a box, min and max corners.
pub fn box_tris(lo: DVec3, hi: DVec3) -> Vec<[DVec3; 3]> {
    let c = |i: usize| {
        DVec3::new(
            if i & 1 == 0 { lo.x } else { hi.x },
            if i & 2 == 0 { lo.y } else { hi.y },
            if i & 4 == 0 { lo.z } else { hi.z },
        )
    };
    BOX_QUADS
        .iter()
        .flat_map(|q| [[c(q[0]), c(q[1]), c(q[2])], [c(q[0]), c(q[2]), c(q[3])]])
        .collect()
}

/// A scene under construction; every node is placed by `world` after its own offset. Its path
/// says OBJ, so positions count as exact decimal input, not f32.
pub struct Builder {
    pub scene: Scene,
    world: DMat4,
}

impl Builder {
    pub fn new(world: DMat4) -> Builder {
        Builder {
            scene: Scene::new("built.obj".into(), Format::Obj),
            world,
        }
    }

    /// A node at `at` (before `world`) with mesh-local triangles, if any.
    pub fn node(
        &mut self,
        name: &str,
        parent: Option<usize>,
        tris: Vec<[DVec3; 3]>,
        extras: Option<Value>,
        at: DVec3,
    ) -> usize {
        let scene = &mut self.scene;
        let mesh = (!tris.is_empty()).then(|| {
            scene.meshes.push(Mesh {
                name: Some(name.into()),
                positions: tris.iter().flatten().copied().collect(),
                triangles: (0..tris.len() as u32)
                    .map(|i| [3 * i, 3 * i + 1, 3 * i + 2])
                    .collect(),
                primitives: vec![Primitive {
                    material: None,
                    first_triangle: 0,
                    triangle_count: tris.len(),
                    source: SourceRef::default(),
                    file: None,
                }],
                extras: None,
                source: SourceRef::default(),
            });
            scene.meshes.len() - 1
        });
        scene.add_node(Node {
            name: Some(name.into()),
            parent,
            children: vec![],
            world: self.world * DMat4::from_translation(at),
            mesh,
            extras,
            source: SourceRef::default(),
        })
    }

    /// A room node (tagged by extras) to hang blocks under.
    pub fn room(&mut self, name: &str) -> usize {
        self.node(
            name,
            None,
            vec![],
            Some(json!({ "room": name })),
            DVec3::ZERO,
        )
    }

    /// A box block in `room`, its mesh local to its min corner.
    pub fn block(&mut self, room: usize, name: &str, lo: DVec3, hi: DVec3) -> usize {
        self.node(name, Some(room), box_tris(DVec3::ZERO, hi - lo), None, lo)
    }

    /// An upward quad at height `y` over x in `x`, z in `z` (a ground plane).
    pub fn ground(&mut self, room: usize, name: &str, x: [f64; 2], z: [f64; 2], y: f64) {
        let (a, b, c, d) = (
            DVec3::new(x[0], y, z[0]),
            DVec3::new(x[0], y, z[1]),
            DVec3::new(x[1], y, z[1]),
            DVec3::new(x[1], y, z[0]),
        );
        self.node(
            name,
            Some(room),
            vec![[a, b, c], [a, c, d]],
            None,
            DVec3::ZERO,
        );
    }

    /// A player start (`player`) or another occupant, by extras.
    pub fn occupant(&mut self, name: &str, player: bool, at: DVec3) -> usize {
        let key = if player { "player_start" } else { "occupant" };
        self.node(name, None, vec![], Some(json!({ key: true })), at)
    }
}

/// A box brush in the Quake format (three points a face, the normal out of the brush).
pub fn box_brush(lo: [f64; 3], hi: [f64; 3]) -> String {
    let mut out = String::from("{\n");
    let axes = [DVec3::X, DVec3::Y, DVec3::Z];
    for k in 0..3 {
        for (sign, at) in [(1.0, hi), (-1.0, lo)] {
            let n = axes[k] * sign;
            let (a, b) = (axes[(k + 1) % 3], axes[(k + 2) % 3]);
            // a × b = axes[k]: swap for the negative face so the cross points out.
            let (a, b) = if sign > 0.0 { (a, b) } else { (b, a) };
            let q =
                DVec3::from_array(lo) * (DVec3::ONE - axes[k]) + DVec3::from_array(at) * axes[k];
            let (p0, p1, p2) = (q + a * 16.0, q, q + b * 16.0);
            debug_assert!((p0 - p1).cross(p2 - p1).dot(n) > 0.0);
            out += &format!(
                "( {} {} {} ) ( {} {} {} ) ( {} {} {} ) stone 0 0 0 1 1\n",
                p0.x, p0.y, p0.z, p1.x, p1.y, p1.z, p2.x, p2.y, p2.z
            );
        }
    }
    out + "}\n"
}
