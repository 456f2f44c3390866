//! Brush maps (`.map`: TrenchBroom, J.A.C.K., Radiant; Quake, Valve 220, Quake 2, Quake 3,
//! id Tech 4) as a level of solid blocks, tagged by the conventions of the formats as qbsp
//! reads them:
//!
//! - the world's brushes (`worldspawn`, `func_group`) are closed solids of one room, `world`
//!   (a `_portcullis_room` key on a `func_group` puts its brushes in a room of that name);
//!   every other brush entity goes in the room it stands in (`rooms.rs`);
//!   extras `solid` on each, so that even a map of one brush is read as solid, and
//!   `structure`, so that no loose brush is taken for a prop (qbsp has none);
//! - `func_detail*` brushes, liquids (a `*` texture, or Quake 2 liquid, mist or window
//!   contents), Quake 2 detail contents and other brush
//!   entities (`func_door`, `func_plat`, `func_wall`, ...) are detail: rendered, in a cell,
//!   neither sealing nor shaping cells;
//! - tool brushes (every face `clip`, `hint`, `hintskip` or `origin`; in Quake 2, contents of
//!   clip or origin and not solid) and `trigger_*` entities are ignored; a `skip`
//!   face is solid, as qbsp reads it;
//! - doors (`func_door*`, `func_plat*` brushes) are detail flagged `door`, area portals (a
//!   Quake 2 `func_areaportal` or area portal contents, a brush with an id Tech 4 `visportal`
//!   or Quake 3 `areaportal` face) are ignored geometry flagged `area_portal`: both are gates
//!   (`cells::Gate`), volumes whose air gets cells of its own so that the portals where they
//!   fill an opening are theirs (a door's start open and close with it);
//! - point entities are nodes at their `origin`, turned by `angle`, with every key/value in
//!   their extras; `info_player_start` (`_deathmatch`, `_coop`, `2`) are player starts;
//! - every entity with a place (a point entity, a brush entity with an `origin` key or an
//!   origin brush) is an **occupant**, as qbsp's outside fill takes them (`qbsp/outside.cc`):
//!   it marks the air it stands in, and a leak is the void reaching it. Exempt, as there:
//!   entities at (0 0 0), and those with `_nofill` or `_lightgrid_hint` set; one inside a
//!   brush is skipped by the cells stage.
//!
//! Units: map units are inches with Z up; the scene is metres with glTF's +Y up, `(x, y, z)`
//! -> `(x, z, -y) * 0.0254` (`[import] map_scale` sets another number of metres per unit). Each brush is one node and one mesh, a material per texture name
//! (liquids and skies keep theirs). A brush that is not a closed solid (collinear face points,
//! fewer than four planes, open, flat) stops the import with its entity, brush and line, as
//! does text that is not a map, since a level with a hole where a wall was meant would leak.

use std::collections::HashMap;
use std::path::Path;

use glam::{DMat4, DVec3};
use serde_json::{json, Map, Value};

use super::Imported;
use crate::diag::{Code, Diagnostic, Diagnostics, Location};
use crate::scene::{Format, Material, Mesh, Node, NodeId, Primitive, Scene, SourceRef};

mod brush;
mod parse;
mod rooms;

use rooms::Rooms;

/// Map coordinates reach ±32768 in every engine of the family; a brush is clipped out of a box
/// well beyond that, and one beyond it is refused.
const WORLD: f64 = 1_048_576.0;

/// Metres per map unit (Quake's inch).
pub(crate) const METRES_PER_UNIT: f64 = 0.0254;

/// qbsp drops a portal with fewer than three edges longer than this many units
/// (`WindingIsTiny`): narrower gaps between brushes are no leak to it, nor to us.
const TINY_EDGE: f64 = 0.2;

/// What a brush is to the level.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Role {
    Structure,
    Detail,
    Ignored,
    /// A door's or lift's brush: detail whose volume is a gate (`cells::Gate`).
    Door,
    /// An area portal's brush: no wall, a gate between areas.
    AreaPortal,
}

/// Reads a brush map; `scale` is metres per map unit (`None`: Quake's inch).
pub fn import(bytes: &[u8], path: &Path, scale: Option<f64>) -> Result<Imported, Diagnostic> {
    let scale = scale
        .filter(|s| s.is_finite() && *s > 0.0)
        .unwrap_or(METRES_PER_UNIT);
    let text = std::str::from_utf8(bytes).map_err(|e| {
        let line = bytes[..e.valid_up_to()]
            .iter()
            .filter(|&&b| b == b'\n')
            .count()
            + 1;
        Diagnostic::new(
            Code::MAP_SYNTAX,
            "the brush map is not UTF-8 text",
            Location::file(path).with_line(line),
        )
        .hint("save the map as text from its editor (TrenchBroom, J.A.C.K., Radiant)")
    })?;
    let (entities, skipped) = parse::parse(text).map_err(|e| {
        let code = if e.brush {
            Code::MAP_BRUSH_INVALID
        } else {
            Code::MAP_SYNTAX
        };
        Diagnostic::new(code, e.message, Location::file(path).with_line(e.line)).hint(
            if e.brush {
                "fix or delete the brush in the editor (the three points of a face must lie within the map and not on one line)"
            } else {
                "the file is not a brush map the Quake-family editors write; open and save it again in the editor"
            },
        )
    })?;
    let mut b = Builder::new(path, scale);
    let rooms = Rooms::read(&entities);
    for (ei, e) in entities.iter().enumerate() {
        b.entity(ei, e, &rooms)?;
    }
    if skipped > 0 {
        b.diags.push(
            Diagnostic::new(
                Code::MAP_PATCHES_SKIPPED,
                format!("{skipped} patch(es) or other non-brush primitive(s) were skipped"),
                Location::file(path),
            )
            .hint("patches are curved surfaces that seal nothing in qbsp or dmap either; brushes behind them close the level"),
        );
    }
    Ok(Imported {
        scene: b.scene,
        diagnostics: b.diags,
    })
}

/// Map units (Z up) to metres, glTF's Y up.
fn to_scene(p: DVec3, scale: f64) -> DVec3 {
    DVec3::new(p.x, p.z, -p.y) * scale
}

struct Builder<'a> {
    path: &'a Path,
    /// Metres per map unit.
    scale: f64,
    scene: Scene,
    diags: Diagnostics,
    root: NodeId,
    rooms: HashMap<String, NodeId>,
    materials: HashMap<String, usize>,
}

impl<'a> Builder<'a> {
    fn new(path: &'a Path, scale: f64) -> Self {
        let mut scene = Scene::new(path.to_path_buf(), Format::Map);
        scene.crack_width = Some(TINY_EDGE * scale);
        // The inverse of `to_scene`: x = x / s, y = -z / s, z = y / s.
        scene.to_file = Some(DMat4::from_cols(
            glam::DVec4::new(1.0 / scale, 0.0, 0.0, 0.0),
            glam::DVec4::new(0.0, 0.0, 1.0 / scale, 0.0),
            glam::DVec4::new(0.0, -1.0 / scale, 0.0, 0.0),
            glam::DVec4::W,
        ));
        // The root is `map`, not the file's name: a name like `e1m1_rooms` would read as a tag.
        let root = scene.add_node(node(Some("map".into()), None, None, DMat4::IDENTITY, 1));
        Builder {
            path,
            scale,
            scene,
            diags: Diagnostics::default(),
            root,
            rooms: HashMap::new(),
            materials: HashMap::new(),
        }
    }

    /// The node of room `name`, made on first use.
    fn room(&mut self, name: &str, line: usize) -> NodeId {
        if let Some(&n) = self.rooms.get(name) {
            return n;
        }
        let extras = json!({ "room": name });
        let n = self.scene.add_node(node(
            Some(name.to_string()),
            Some(self.root),
            Some(extras),
            DMat4::IDENTITY,
            line,
        ));
        self.rooms.insert(name.to_string(), n);
        n
    }

    fn entity(&mut self, ei: usize, e: &parse::Entity, rooms: &Rooms) -> Result<(), Diagnostic> {
        let class = e.classname().to_string();
        if e.brushes.is_empty() {
            self.point_entity(e);
            return Ok(());
        }
        if class != "worldspawn" {
            self.brush_entity_occupant(e);
        }
        let mut built = Vec::with_capacity(e.brushes.len());
        for (bi, b) in e.brushes.iter().enumerate() {
            let b = rooms::placed(e, b);
            if b.faces.len() > brush::MAX_BRUSH_FACES {
                return Err(Diagnostic::new(
                    Code::MAP_BRUSH_INVALID,
                    format!(
                        "brush {bi} of entity {ei} (`{class}`) has {} faces, more than the {} a brush may have",
                        b.faces.len(),
                        brush::MAX_BRUSH_FACES
                    ),
                    Location::file(self.path).with_line(b.line),
                )
                .hint("split it into brushes of fewer faces (a round shape of many sides is usually several brushes)"));
            }
            let rings = brush::polygons(&b.faces).map_err(|why| {
                let hint = match why {
                    brush::NotSolid::Beyond => "move the brush into the map, or delete it",
                    _ => "fix or delete the brush in the editor",
                };
                Diagnostic::new(
                    Code::MAP_BRUSH_INVALID,
                    format!("brush {bi} of entity {ei} (`{class}`) {}", why.message()),
                    Location::file(self.path).with_line(b.line),
                )
                .hint(hint)
            })?;
            built.push((b, rings));
        }
        let room_name = match rooms::made_by(e) {
            Some(n) => n.to_string(),
            None => {
                let boxes = built.iter().filter_map(|(_, r)| rooms::bounds(r));
                let at = boxes.reduce(|(a, b), (c, d)| (a.min(c), b.max(d)));
                rooms.of(e, at)
            }
        };
        let parent = self.room(&room_name, e.line);
        for (bi, (b, rings)) in built.iter().enumerate() {
            let role = role(&class, b);
            let mesh = self.mesh(&b.faces, rings, b.line);
            let mut extras = Map::new();
            match role {
                // A world brush is structure, however loose it stands: qbsp has no props,
                // every world brush carves its BSP and the map says what is detail
                // (`func_detail`), so no cell may reach into one (a box on a floor or in a
                // window slot read as a prop left cells up to 81 cm into it). `solid` keeps
                // even a one-brush map solid.
                Role::Structure => {
                    extras.insert("structure".into(), Value::Bool(true));
                    extras.insert("solid".into(), Value::Bool(true))
                }
                Role::Detail => extras.insert("detail".into(), Value::Bool(true)),
                Role::Ignored => extras.insert("ignore".into(), Value::Bool(true)),
                // A door's brushes are one door (its entity number says which): the cell
                // stage makes them one gate.
                Role::Door => {
                    extras.insert("door".into(), Value::Bool(true));
                    extras.insert("entity".into(), Value::from(ei));
                    extras.insert("detail".into(), Value::Bool(true))
                }
                Role::AreaPortal => {
                    extras.insert("area_portal".into(), Value::Bool(true));
                    extras.insert("entity".into(), Value::from(ei));
                    extras.insert("ignore".into(), Value::Bool(true))
                }
            };
            extras.insert("classname".into(), Value::String(class.clone()));
            let name = format!("{class} {ei} brush {bi}");
            let mut n = node(
                Some(name),
                Some(parent),
                Some(Value::Object(extras)),
                DMat4::IDENTITY,
                b.line,
            );
            n.mesh = Some(mesh);
            self.scene.add_node(n);
        }
        Ok(())
    }

    /// A brush's mesh: its faces as fans, a primitive per texture.
    fn mesh(&mut self, faces: &[parse::Face], rings: &[(Vec<DVec3>, usize)], line: usize) -> usize {
        let mut positions: Vec<DVec3> = Vec::new();
        let mut index: HashMap<[u64; 3], u32> = HashMap::new();
        let mut by_texture: Vec<(usize, Vec<[u32; 3]>)> = Vec::new();
        for (ring, k) in rings {
            let ids: Vec<u32> = ring
                .iter()
                .map(|p| {
                    let q = to_scene(*p, self.scale);
                    let key = [q.x.to_bits(), q.y.to_bits(), q.z.to_bits()];
                    *index.entry(key).or_insert_with(|| {
                        positions.push(q);
                        positions.len() as u32 - 1
                    })
                })
                .collect();
            let m = self.material(&faces[*k].texture);
            let tris = match by_texture.iter_mut().find(|(mm, _)| *mm == m) {
                Some((_, t)) => t,
                None => {
                    by_texture.push((m, Vec::new()));
                    &mut by_texture.last_mut().expect("pushed").1
                }
            };
            for w in ids[1..].windows(2) {
                tris.push([ids[0], w[0], w[1]]);
            }
        }
        let mut triangles = Vec::new();
        let mut primitives = Vec::new();
        for (m, tris) in by_texture {
            primitives.push(Primitive {
                material: Some(m),
                first_triangle: triangles.len(),
                triangle_count: tris.len(),
                source: SourceRef::line(line),
                file: None,
            });
            triangles.extend(tris);
        }
        self.scene.meshes.push(Mesh {
            name: None,
            positions,
            triangles,
            primitives,
            extras: None,
            source: SourceRef::line(line),
        });
        self.scene.meshes.len() - 1
    }

    fn material(&mut self, texture: &str) -> usize {
        if let Some(&m) = self.materials.get(texture) {
            return m;
        }
        self.scene.materials.push(Material {
            name: Some(texture.to_string()),
            extras: None,
            // A liquid's surface is seen from under it too; every other face from its front.
            double_sided: texture.starts_with('*'),
            source: SourceRef::default(),
        });
        let m = self.scene.materials.len() - 1;
        self.materials.insert(texture.to_string(), m);
        m
    }

    /// A brush entity with a place (an `origin` key, else its origin brush's centre) is an
    /// occupant there, as qbsp takes it.
    fn brush_entity_occupant(&mut self, e: &parse::Entity) {
        let origin = e.get("origin").and_then(parse_vec3).or_else(|| {
            e.brushes
                .iter()
                .find(|b| b.faces.iter().all(|f| texture_name(&f.texture) == "origin"))
                .and_then(|b| brush::polygons(&b.faces).ok())
                .and_then(|rings| rooms::bounds(&rings))
                .map(|(lo, hi)| (lo + hi) * 0.5)
        });
        let Some(origin) = origin.filter(|o| occupies(e, *o)) else {
            return;
        };
        let extras = json!({ "occupant": true, "classname": e.classname() });
        let n = node(
            Some(format!("{} origin", e.classname())),
            Some(self.root),
            Some(extras),
            DMat4::from_translation(to_scene(origin, self.scale)),
            e.line,
        );
        self.scene.add_node(n);
    }

    fn point_entity(&mut self, e: &parse::Entity) {
        let class = e.classname();
        let origin = e.get("origin").and_then(parse_vec3);
        // An entity with no place (worldspawn, a target list, a light style): nothing to stand.
        let Some(origin) = origin else {
            return;
        };
        let yaw = e
            .get("angle")
            .and_then(|a| a.trim().parse::<f64>().ok())
            .filter(|a| a.is_finite() && *a >= 0.0)
            .unwrap_or(0.0);
        let world = DMat4::from_translation(to_scene(origin, self.scale))
            * DMat4::from_rotation_y(yaw.to_radians());
        let mut extras: Map<String, Value> = e
            .keys
            .iter()
            .map(|(k, v)| (k.clone(), Value::String(v.clone())))
            .collect();
        if matches!(
            class,
            "info_player_start"
                | "info_player_start2"
                | "info_player_deathmatch"
                | "info_player_coop"
        ) {
            extras.insert("player_start".into(), Value::Bool(true));
        } else if occupies(e, origin) {
            extras.insert("occupant".into(), Value::Bool(true));
        }
        let n = node(
            Some(class.to_string()),
            Some(self.root),
            Some(Value::Object(extras)),
            world,
            e.line,
        );
        self.scene.add_node(n);
    }
}

/// Whether an entity at `origin` is an occupant (qbsp's `MarkOccupiedLeafs`): not at the map's
/// origin (where brush models without one sit), and not `_nofill` or `_lightgrid_hint`.
fn occupies(e: &parse::Entity, origin: DVec3) -> bool {
    let set = |k: &str| {
        e.get(k)
            .and_then(|v| v.trim().parse::<f64>().ok())
            .is_some_and(|v| v as i64 != 0)
    };
    origin.abs().max_element() > 1e-4 && !set("_nofill") && !set("_lightgrid_hint")
}

/// A texture's name without its folder, in lower case (`textures/common/Origin` -> `origin`).
fn texture_name(t: &str) -> String {
    let t = t.to_ascii_lowercase();
    t.rsplit('/').next().unwrap_or(&t).to_string()
}

/// Three finite numbers (an `origin`).
fn parse_vec3(s: &str) -> Option<DVec3> {
    let v: Vec<f64> = s
        .split_whitespace()
        .map(|s| s.parse::<f64>().ok().filter(|x| x.is_finite()))
        .collect::<Option<_>>()?;
    (v.len() == 3).then(|| DVec3::new(v[0], v[1], v[2]))
}

fn node(
    name: Option<String>,
    parent: Option<NodeId>,
    extras: Option<Value>,
    world: DMat4,
    line: usize,
) -> Node {
    Node {
        name,
        parent,
        children: Vec::new(),
        world,
        mesh: None,
        extras,
        source: SourceRef::line(line),
    }
}

/// What qbsp makes of a brush: by its entity, then its contents. Quake 1 tells contents by
/// texture name, and only a few names are special (ericw-tools' `face_get_contents`): `origin`,
/// `hint`/`hintskip` and `clip` are no walls, `*` names are liquids, `sky` seals; any other
/// name, `skip` included, is solid. Quake 2 writes the contents bits on each face.
fn role(class: &str, b: &parse::Brush) -> Role {
    const SOLID: i64 = 1;
    const WINDOW: i64 = 2;
    const LIQUID: i64 = 8 | 16 | 32;
    const MIST: i64 = 64;
    const AREAPORTAL: i64 = 0x8000;
    const CLIP: i64 = 0x10000 | 0x20000;
    const ORIGIN: i64 = 0x100_0000;
    const DETAIL: i64 = 0x800_0000;
    if class.starts_with("trigger_") {
        return Role::Ignored;
    }
    let name = |f: &parse::Face| {
        let t = f.texture.to_ascii_lowercase();
        t.rsplit('/').next().unwrap_or(&t).to_string()
    };
    let quake2 = b.faces.iter().any(|f| f.contents.is_some());
    let (tool, liquid, detail) = if quake2 {
        let c = b
            .faces
            .iter()
            .filter_map(|f| f.contents)
            .fold(0, |a, c| a | c);
        let tool = c & SOLID == 0 && c & (AREAPORTAL | CLIP | ORIGIN) != 0;
        let liquid = c & SOLID == 0 && c & (LIQUID | MIST | WINDOW) != 0;
        (tool, liquid, c & DETAIL != 0)
    } else {
        let tool = b
            .faces
            .iter()
            .all(|f| ["origin", "hint", "hintskip", "clip"].contains(&name(f).as_str()));
        (
            tool,
            b.faces.iter().any(|f| name(f).starts_with('*')),
            false,
        )
    };
    let portal_face = b
        .faces
        .iter()
        .any(|f| matches!(name(f).as_str(), "visportal" | "areaportal"));
    let areaportal = quake2
        && b.faces
            .iter()
            .filter_map(|f| f.contents)
            .any(|c| c & AREAPORTAL != 0);
    if class == "func_areaportal" || portal_face || areaportal {
        return Role::AreaPortal;
    }
    if tool {
        return Role::Ignored;
    }
    if class.starts_with("func_door") || class.starts_with("func_plat") {
        return Role::Door;
    }
    if liquid || detail {
        return Role::Detail;
    }
    match class {
        "worldspawn" | "func_group" => Role::Structure,
        _ => Role::Detail,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_room_of_brushes_is_solids_of_one_room_with_a_start() {
        // A box brush: three points a face, (p0 - p1) x (p2 - p1) out of the brush.
        let brush = |lo: [i32; 3], hi: [i32; 3]| {
            let mut out = String::from("{\n");
            let tex = ["a", "b", "c"];
            for k in 0..3 {
                for (sign, at) in [(1, hi), (-1, lo)] {
                    let (mut a, mut b) = ([0; 3], [0; 3]);
                    a[(k + 1) % 3] = 16;
                    b[(k + 2) % 3] = 16;
                    if sign < 0 {
                        std::mem::swap(&mut a, &mut b);
                    }
                    let mut q = lo;
                    q[k] = at[k];
                    let p = |d: [i32; 3]| {
                        format!("( {} {} {} )", q[0] + d[0], q[1] + d[1], q[2] + d[2])
                    };
                    out += &format!("{} {} {} {} 0 0 0 1 1\n", p(a), p([0; 3]), p(b), tex[k]);
                }
            }
            out + "}\n"
        };
        let text = format!(
            "{{\n\"classname\" \"worldspawn\"\n{}}}\n{{\n\"classname\" \"info_player_start\"\n\"origin\" \"0 0 32\"\n}}\n",
            brush([0, 0, 0], [64, 32, 16])
        );
        let im = import(text.as_bytes(), Path::new("t.map"), None).unwrap();
        let s = &im.scene;
        assert_eq!(s.meshes.len(), 1);
        let m = &s.meshes[0];
        assert_eq!(m.triangles.len(), 12);
        assert_eq!(m.positions.len(), 8);
        // Outward, in metres: the divergence theorem gives the brush's volume.
        let v: f64 = m
            .triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| m.positions[i as usize]);
                a.dot(b.cross(c)) / 6.0
            })
            .sum();
        let want = 64.0 * 32.0 * 16.0 * METRES_PER_UNIT.powi(3);
        assert!((v - want).abs() < 1e-9 * want, "{v} vs {want}");
        assert_eq!(s.materials.len(), 3);
        let start = s
            .nodes
            .iter()
            .find(|n| n.name.as_deref() == Some("info_player_start"))
            .unwrap();
        assert!(
            (start.world.w_axis.truncate() - DVec3::new(0.0, 32.0, 0.0) * METRES_PER_UNIT).length()
                < 1e-12
        );
    }

    #[test]
    fn a_brush_of_three_planes_is_an_error_with_its_line() {
        let text = "{\n\"classname\" \"worldspawn\"\n{\n( 0 0 0 ) ( 0 1 0 ) ( 0 0 1 ) a 0 0 0 1 1\n( 0 0 0 ) ( 0 0 1 ) ( 1 0 0 ) a 0 0 0 1 1\n( 0 0 0 ) ( 1 0 0 ) ( 0 1 0 ) a 0 0 0 1 1\n}\n}\n";
        let e = import(text.as_bytes(), Path::new("t.map"), None).unwrap_err();
        assert_eq!(e.code, Code::MAP_BRUSH_INVALID);
        assert_eq!(e.location.source.line, Some(3));
    }
}
