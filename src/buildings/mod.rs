//! A procedural level generator, for benchmarks and scale tests: a building of N rooms on
//! several storeys, tagged the way a designer would tag it (Godot-style `-room`, `-portal`,
//! `-detail` names and a `player_start`), with doors between rooms (a spanning tree plus some
//! loops), windows in the outer walls, L-shaped rooms (three cells of a 2x2 block), a
//! stairwell joining each storey to the next through an opening in the slab, and furniture.
//!
//! The same options give the same level, byte for byte (a seeded generator, no hash-map
//! order). Walls have no thickness: two rooms sharing a wall each have their own surface on
//! the same plane, facing into the room, as in many exported levels; storeys stack the same way.
//!
//! `layout.rs` plans a building: the same grid on every storey (cell sizes from a seeded
//! SplitMix64), rooms of one cell or an L of three, a stairwell in the first cell of each storey,
//! doors from a random spanning tree of neighbouring rooms plus extra loops, windows in outer
//! walls. `surfaces.rs` turns one room into inward floor, ceiling and walls with rectangular holes
//! (split along every hole edge so pieces meet edge to edge), the authored portal quads of its
//! doors (facing out of the room, the Godot convention), stairs, a bound box for a stairwell, and
//! furniture. Invariants: every room is reachable; the portals portcullis derives join exactly the
//! rooms the layout put doors and stairs between (tests/gen.rs checks it against the layout).

use glam::DVec3;

use crate::scene::{Format, Material, Mesh, Node, Primitive, Scene, SourceRef};

mod layout;
mod surfaces;

pub use layout::Layout;

/// What to generate.
#[derive(Debug, Clone)]
pub struct GenOptions {
    /// Rooms in the building (at least 1).
    pub rooms: usize,
    /// Seed of the layout's choices (sizes, doors, windows, L shapes).
    pub seed: u64,
    /// Furniture in every room (two boxes of a table and chair set), tagged `-detail`.
    pub props: bool,
}

impl Default for GenOptions {
    fn default() -> Self {
        GenOptions {
            rooms: 10,
            seed: 1,
            props: true,
        }
    }
}

/// Storey height (m): floor to the floor above.
pub(crate) const STOREY: f64 = 3.0;
/// Door size (m).
pub(crate) const DOOR_WIDTH: f64 = 1.0;
/// Door height (m).
pub(crate) const DOOR_HEIGHT: f64 = 2.1;

pub(crate) use crate::rng::SplitMix64 as Rng;

/// Builds the level as a scene (world-space meshes, identity transforms), ready for
/// [`crate::export::gltf_out::write_plain`].
pub fn generate(opts: &GenOptions) -> Scene {
    let layout = Layout::new(opts.rooms.max(1), opts.seed);
    let mut b = Builder::new();
    let level = b.node("Level", None, None, None);
    let mut storey_nodes = Vec::new();
    for s in 0..layout.storeys {
        storey_nodes.push(b.node(&format!("storey{s}"), Some(level), None, None));
    }
    for (r, room) in layout.rooms.iter().enumerate() {
        let name = layout.name(r);
        let node = b.node(
            &format!("{name}-room"),
            Some(storey_nodes[room.storey]),
            None,
            None,
        );
        let s = surfaces::room(&layout, r);
        b.mesh_node("Floor", node, s.floor, Mat::Floor);
        b.mesh_node("Ceiling", node, s.ceiling, Mat::Wall);
        b.mesh_node("Walls", node, s.walls, Mat::Wall);
        for (target, quad) in s.portals {
            b.mesh_node(
                &format!("{}-portal", layout.name(target)),
                node,
                quad,
                Mat::Portal,
            );
        }
        if !s.bound.is_empty() {
            let m = b.mesh(s.bound);
            b.node(
                "Volume",
                Some(node),
                Some(m),
                Some(serde_json::json!({"bound": true})),
            );
        }
        if !s.stairs.is_empty() {
            b.mesh_node("Stairs-detail", node, s.stairs, Mat::Wood);
        }
        if opts.props {
            let mut rng = Rng::new(opts.seed.wrapping_mul(31).wrapping_add(r as u64));
            let furniture = surfaces::furniture(&layout, r, &mut rng);
            if !furniture.is_empty() {
                b.mesh_node("Furniture-detail", node, furniture, Mat::Wood);
            }
        }
        if r == 0 {
            let c = layout.cell_centre(room.cells[0], room.storey);
            let start = b.node(
                "PlayerStart",
                Some(node),
                None,
                Some(serde_json::json!({"player_start": true})),
            );
            b.scene.nodes[start].world = glam::DMat4::from_translation(c + DVec3::Y * 1.0);
        }
    }
    b.scene
}

/// One room of at least `planes` distinct planes (`3 × steps + 3`), for timing the 3D cell
/// decomposition: a stair hall whose floor and ceiling rise together, steps of 0.3 m tread
/// and 0.15 m rise, 2.575 m clear height (not a whole number of rises, so no tread shares a
/// plane with a ceiling), 4 m wide. Each step is one convex cell, so the answer is known:
/// as many cells as steps. Planes: a tread, a ceiling and a riser per step (the first step has
/// no riser) and the two end walls and two side walls.
pub fn stair_hall(planes: usize) -> Scene {
    let steps = planes.saturating_sub(3).div_ceil(3).max(1);
    let (tread, rise, clear, width) = (0.3, 0.15, 2.575, 4.0);
    let floor = |i: usize| i as f64 * rise;
    let x = |i: usize| i as f64 * tread;
    let mut tris: Vec<[DVec3; 3]> = Vec::new();
    // A rectangle as two triangles, wound to face `inward`.
    let mut quad = |a: DVec3, b: DVec3, c: DVec3, d: DVec3, inward: DVec3| {
        let n = (b - a).cross(c - a);
        if n.dot(inward) > 0.0 {
            tris.push([a, b, c]);
            tris.push([a, c, d]);
        } else {
            tris.push([a, c, b]);
            tris.push([a, d, c]);
        }
    };
    let p = DVec3::new;
    // A face across the hall (z from 0 to width) between two corners given in (x, y).
    let mut across = |a: (f64, f64), b: (f64, f64), inward: DVec3| {
        quad(
            p(a.0, a.1, 0.0),
            p(b.0, b.1, 0.0),
            p(b.0, b.1, width),
            p(a.0, a.1, width),
            inward,
        )
    };
    let mut sides: Vec<(f64, f64, f64, f64)> = Vec::new();
    for i in 0..steps {
        let (x0, x1, f, c) = (x(i), x(i + 1), floor(i), floor(i) + clear);
        across((x0, f), (x1, f), DVec3::Y);
        across((x0, c), (x1, c), -DVec3::Y);
        sides.push((x0, x1, f, c));
        if i > 0 {
            // The riser below this tread and the one above the previous ceiling.
            let (pf, pc) = (floor(i - 1), floor(i - 1) + clear);
            across((x0, pf), (x0, f), -DVec3::X);
            across((x0, pc), (x0, c), DVec3::X);
        }
    }
    let (lx, lf) = (x(steps), floor(steps - 1));
    across((0.0, 0.0), (0.0, clear), DVec3::X);
    across((lx, lf), (lx, lf + clear), -DVec3::X);
    for (x0, x1, f, c) in sides {
        for (z, inward) in [(0.0, DVec3::Z), (width, -DVec3::Z)] {
            quad(p(x0, f, z), p(x1, f, z), p(x1, c, z), p(x0, c, z), inward);
        }
    }
    let mut b = Builder::new();
    let level = b.node("Level", None, None, None);
    let room = b.node("stair-room", Some(level), None, None);
    b.mesh_node("Shell", room, tris, Mat::Wall);
    b.scene
}

#[derive(Clone, Copy)]
enum Mat {
    Floor,
    Wall,
    Wood,
    Portal,
}

struct Builder {
    scene: Scene,
}

impl Builder {
    fn new() -> Builder {
        let mut scene = Scene::new("generated.glb".into(), Format::Glb);
        for name in ["floor", "wall", "wood", "portal"] {
            scene.materials.push(Material {
                name: Some(name.into()),
                extras: None,
                double_sided: false,
                source: SourceRef::default(),
            });
        }
        Builder { scene }
    }

    fn node(
        &mut self,
        name: &str,
        parent: Option<usize>,
        mesh: Option<usize>,
        extras: Option<serde_json::Value>,
    ) -> usize {
        self.scene.add_node(Node {
            name: Some(name.into()),
            parent,
            children: Vec::new(),
            world: glam::DMat4::IDENTITY,
            mesh,
            extras,
            source: SourceRef::default(),
        })
    }

    /// A node with a mesh of `tris`.
    fn mesh_node(&mut self, name: &str, parent: usize, tris: Vec<[DVec3; 3]>, mat: Mat) {
        let m = self.mesh_with(name, tris, Some(mat));
        self.node(name, Some(parent), Some(m), None);
    }

    /// A mesh without material (bound volumes).
    fn mesh(&mut self, tris: Vec<[DVec3; 3]>) -> usize {
        self.mesh_with("Volume", tris, None)
    }

    /// A mesh of `tris`, vertices shared within it.
    fn mesh_with(&mut self, name: &str, tris: Vec<[DVec3; 3]>, mat: Option<Mat>) -> usize {
        let mut positions: Vec<DVec3> = Vec::new();
        let mut index: std::collections::BTreeMap<[u64; 3], u32> = Default::default();
        let mut triangles = Vec::with_capacity(tris.len());
        for t in &tris {
            let mut ids = [0u32; 3];
            for (k, p) in t.iter().enumerate() {
                let key = [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()];
                ids[k] = *index.entry(key).or_insert_with(|| {
                    positions.push(*p);
                    (positions.len() - 1) as u32
                });
            }
            triangles.push(ids);
        }
        let mesh = self.scene.meshes.len();
        self.scene.meshes.push(Mesh {
            name: Some(name.into()),
            positions,
            primitives: vec![Primitive {
                material: mat.map(|m| m as usize),
                first_triangle: 0,
                triangle_count: triangles.len(),
                source: SourceRef::default(),
                file: None,
            }],
            triangles,
            extras: None,
            source: SourceRef::default(),
        });
        mesh
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_same_options_give_the_same_level() {
        let a = generate(&GenOptions::default());
        let b = generate(&GenOptions::default());
        assert_eq!(a.nodes.len(), b.nodes.len());
        for (x, y) in a.meshes.iter().zip(&b.meshes) {
            assert_eq!(x.positions, y.positions);
            assert_eq!(x.triangles, y.triangles);
        }
    }
}
