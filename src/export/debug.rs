//! A debug view of cells and portals as a self-contained GLB, so a level's partition can be
//! inspected in any glTF viewer next to the level itself (same world coordinates, no
//! recentring: the two files overlay exactly).
//!
//! The container is written by hand rather than through a glTF library: the gltf crate only
//! reads, and the document is small and fixed in shape. Every choice below serves two goals:
//! the Khronos validator reports no errors (accessor bounds are taken from the f32 values
//! actually written, views are 4-byte aligned, empty arrays are left out), and the same input
//! gives the same bytes (no maps with random order, no timestamps), so outputs can be diffed.

use crate::level::Level;
use glam::DVec3;
use serde_json::{json, Map, Value};

use crate::geom::polyhedron::ConvexPolyhedron;
use crate::portals::Portal;
use crate::tags::rules::PortalKind;

/// Findings from later checks to draw over the cells: they are only useful in context.
#[derive(Debug, Clone, Default)]
pub struct DebugExtras {
    /// Paths by which the exterior reaches inside (each a polyline, world coordinates).
    pub leaks: Vec<Vec<DVec3>>,
    /// Regions where cells overlap.
    pub overlaps: Vec<ConvexPolyhedron>,
    /// Rays that joined two cells the PVS keeps apart (`[check] sightlines`), each a polyline.
    pub sightlines: Vec<Vec<DVec3>>,
}

/// How a portal is shown. The GLB and the SVG map share it so a colour means the same thing in
/// both; the order of the checks in [`PortalStyle::of`] decides which property wins when a
/// portal has several (a closed mirror is shown as closed, because it passes nothing).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PortalStyle {
    /// Two-way and open.
    Plain,
    /// Passes sight one way only.
    OneWay,
    /// Opens onto the outside (no target cell).
    Exterior,
    /// Reflects back into its own cell.
    Mirror,
    /// Leads to its exit elsewhere in the level.
    Teleporter,
    /// A closed door: passes nothing until opened.
    Closed,
}

impl PortalStyle {
    /// Every style, in legend order.
    pub const ALL: [PortalStyle; 6] = [
        PortalStyle::Plain,
        PortalStyle::OneWay,
        PortalStyle::Exterior,
        PortalStyle::Mirror,
        PortalStyle::Teleporter,
        PortalStyle::Closed,
    ];

    /// The style `p` is drawn in; the first matching property wins (closed first).
    pub fn of(p: &Portal) -> PortalStyle {
        if p.closed {
            PortalStyle::Closed
        } else if p.kind == PortalKind::Mirror {
            PortalStyle::Mirror
        } else if p.kind == PortalKind::Teleporter {
            PortalStyle::Teleporter
        } else if p.to.is_none() {
            PortalStyle::Exterior
        } else if p.one_way {
            PortalStyle::OneWay
        } else {
            PortalStyle::Plain
        }
    }

    /// sRGB, 0..1.
    pub(crate) fn rgb(self) -> [f64; 3] {
        match self {
            PortalStyle::Plain => [0.18, 0.8, 0.25],
            PortalStyle::OneWay => [1.0, 0.55, 0.0],
            PortalStyle::Exterior => [0.9, 0.1, 0.1],
            PortalStyle::Mirror => [0.55, 0.8, 1.0],
            PortalStyle::Teleporter => [0.6, 0.25, 0.85],
            PortalStyle::Closed => [0.55, 0.55, 0.55],
        }
    }

    /// The legend's word for the style.
    pub(crate) fn label(self) -> &'static str {
        match self {
            PortalStyle::Plain => "plain two-way",
            PortalStyle::OneWay => "one-way",
            PortalStyle::Exterior => "exterior",
            PortalStyle::Mirror => "mirror",
            PortalStyle::Teleporter => "teleporter",
            PortalStyle::Closed => "closed",
        }
    }
}

/// A distinct sRGB colour per room: hues a golden angle apart, so neighbouring room indices
/// (often neighbouring rooms) never look alike, however many rooms there are.
pub(crate) fn room_rgb(room: usize) -> [f64; 3] {
    let h = (room as f64 * 0.618_033_988_749_895).fract();
    hsv(h, 0.55, 0.95)
}

fn hsv(h: f64, s: f64, v: f64) -> [f64; 3] {
    let h6 = h * 6.0;
    let i = h6.floor();
    let f = h6 - i;
    let (p, q, t) = (v * (1.0 - s), v * (1.0 - s * f), v * (1.0 - s * (1.0 - f)));
    match i as i32 % 6 {
        0 => [v, t, p],
        1 => [q, v, p],
        2 => [p, v, t],
        3 => [p, q, v],
        4 => [t, p, v],
        _ => [v, p, q],
    }
}

/// glTF colour factors are linear; converting keeps the GLB and the SVG looking alike.
fn linear(c: [f64; 3], alpha: f64) -> Value {
    let l = |x: f64| {
        let v = if x <= 0.04045 {
            x / 12.92
        } else {
            ((x + 0.055) / 1.055).powf(2.4)
        };
        // Rounded so the JSON stays short and independent of the last bits of `powf`.
        (v * 1e4).round() / 1e4
    };
    json!([l(c[0]), l(c[1]), l(c[2]), alpha])
}

/// Offset of a portal along its direction of travel, so the two portals of a pair (same
/// polygon, opposite directions) do not z-fight and both can be picked in a viewer.
const PORTAL_OFFSET: f64 = 0.01;

const ARRAY_BUFFER: u32 = 34962;
const ELEMENT_ARRAY_BUFFER: u32 = 34963;
const MODE_LINE_STRIP: u32 = 3;
const MODE_TRIANGLES: u32 = 4;

#[derive(Default)]
struct Doc {
    bin: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
    materials: Vec<Value>,
    material_keys: Vec<String>,
    meshes: Vec<Value>,
    nodes: Vec<Value>,
}

impl Doc {
    fn view(&mut self, bytes: &[u8], target: u32) -> usize {
        // Every element is 4 bytes, so views stay 4-aligned; the pad is for robustness only.
        while self.bin.len() % 4 != 0 {
            self.bin.push(0);
        }
        self.views.push(json!({
            "buffer": 0,
            "byteOffset": self.bin.len(),
            "byteLength": bytes.len(),
            "target": target,
        }));
        self.bin.extend_from_slice(bytes);
        self.views.len() - 1
    }

    fn positions(&mut self, pts: &[DVec3]) -> usize {
        let mut bytes = Vec::with_capacity(pts.len() * 12);
        let mut lo = [f32::INFINITY; 3];
        let mut hi = [f32::NEG_INFINITY; 3];
        for p in pts {
            for (k, c) in p.to_array().into_iter().enumerate() {
                let f = c as f32;
                lo[k] = lo[k].min(f);
                hi[k] = hi[k].max(f);
                bytes.extend_from_slice(&f.to_le_bytes());
            }
        }
        let view = self.view(&bytes, ARRAY_BUFFER);
        // Written as the f64 of the f32, whose decimal form is exact: readers that compare in
        // double and readers that round to f32 both find the values equal.
        let f = |a: [f32; 3]| json!([a[0] as f64, a[1] as f64, a[2] as f64]);
        self.accessors.push(json!({
            "bufferView": view,
            "componentType": 5126,
            "count": pts.len(),
            "type": "VEC3",
            "min": f(lo),
            "max": f(hi),
        }));
        self.accessors.len() - 1
    }

    fn indices(&mut self, idx: &[u32]) -> usize {
        let bytes: Vec<u8> = idx.iter().flat_map(|i| i.to_le_bytes()).collect();
        let view = self.view(&bytes, ELEMENT_ARRAY_BUFFER);
        self.accessors.push(json!({
            "bufferView": view,
            "componentType": 5125,
            "count": idx.len(),
            "type": "SCALAR",
        }));
        self.accessors.len() - 1
    }

    /// Materials are made on first use so the file holds none that nothing references.
    fn material(&mut self, key: &str, name: &str, rgb: [f64; 3], alpha: f64) -> usize {
        if let Some(i) = self.material_keys.iter().position(|k| k == key) {
            return i;
        }
        let mut m = json!({
            "name": name,
            "pbrMetallicRoughness": {
                "baseColorFactor": linear(rgb, alpha),
                "metallicFactor": 0.0,
                "roughnessFactor": 1.0,
            },
            "doubleSided": true,
        });
        if alpha < 1.0 {
            m["alphaMode"] = json!("BLEND");
        }
        self.materials.push(m);
        self.material_keys.push(key.to_string());
        self.materials.len() - 1
    }

    /// One node; a mesh only when there is something to draw, because glTF forbids empty
    /// accessors but the node still stands for its cell or portal.
    fn node(&mut self, name: String, prim: Option<Value>, extras: Value) {
        let mut node = json!({ "name": name });
        if let Some(prim) = prim {
            self.meshes
                .push(json!({ "name": name, "primitives": [prim] }));
            node["mesh"] = json!(self.meshes.len() - 1);
        }
        node["extras"] = extras;
        self.nodes.push(node);
    }

    /// Triangle fans over convex polygons (outward CCW stays front-facing).
    fn polygons<'a>(
        &mut self,
        polys: impl IntoIterator<Item = &'a [DVec3]>,
        offset: DVec3,
        material: usize,
    ) -> Option<Value> {
        let mut pts = Vec::new();
        let mut idx = Vec::new();
        for poly in polys {
            if poly.len() < 3 {
                continue;
            }
            let base = pts.len() as u32;
            pts.extend(poly.iter().map(|p| *p + offset));
            for i in 1..poly.len() as u32 - 1 {
                idx.extend_from_slice(&[base, base + i, base + i + 1]);
            }
        }
        if idx.is_empty() {
            return None;
        }
        let pos = self.positions(&pts);
        let ind = self.indices(&idx);
        Some(json!({
            "attributes": { "POSITION": pos },
            "indices": ind,
            "material": material,
            "mode": MODE_TRIANGLES,
        }))
    }

    fn into_glb(self) -> Vec<u8> {
        let mut doc = Map::new();
        doc.insert(
            "asset".into(),
            json!({ "version": "2.0", "generator": "portcullis" }),
        );
        let node_ids: Vec<usize> = (0..self.nodes.len()).collect();
        let mut scene = json!({ "name": "portcullis debug" });
        if !node_ids.is_empty() {
            scene["nodes"] = json!(node_ids);
        }
        doc.insert("scene".into(), json!(0));
        doc.insert("scenes".into(), json!([scene]));
        let arrays = [
            ("nodes", self.nodes),
            ("meshes", self.meshes),
            ("materials", self.materials),
            ("accessors", self.accessors),
            ("bufferViews", self.views),
        ];
        for (key, v) in arrays {
            if !v.is_empty() {
                doc.insert(key.into(), Value::Array(v));
            }
        }
        let bin = self.bin;
        if !bin.is_empty() {
            doc.insert("buffers".into(), json!([{ "byteLength": bin.len() }]));
        }
        let json = serde_json::to_vec(&Value::Object(doc)).expect("JSON values serialise");
        crate::format::glb::frame(&json, (!bin.is_empty()).then_some(&bin[..]))
    }
}

/// The debug GLB: one node per cell (`cell N (room NAME)`, translucent, a colour per room), one
/// per portal (`portal I: cell A -> cell B` or `-> exterior`, coloured by [`PortalStyle`],
/// moved 1 cm along its direction of travel), then `leak K` line strips (red) and `overlap K`
/// meshes (translucent magenta). Nodes come in that order, so node `N` is cell `N` and node
/// `cells + I` is portal `I`; each node's extras repeat the indices for scripts.
pub fn debug_glb(level: &Level, extra: &DebugExtras) -> Vec<u8> {
    let (tagging, cells, portals) = (level.tagging(), &level.cells, &level.portals);
    let mut doc = Doc::default();
    let room_name = |r: usize| tagging.rooms.get(r).map_or("?", |room| room.name.as_str());
    for (i, cell) in cells.cells.iter().enumerate() {
        let name = room_name(cell.room);
        let mat = doc.material(
            &format!("room {}", cell.room),
            &format!("room {name}"),
            room_rgb(cell.room),
            0.25,
        );
        let prim = doc.polygons(
            cell.poly.faces.iter().map(|f| f.points.as_slice()),
            DVec3::ZERO,
            mat,
        );
        doc.node(
            format!("cell {i} (room {name})"),
            prim,
            json!({ "cell": i, "room": name }),
        );
    }
    for (i, p) in portals.portals.iter().enumerate() {
        let style = PortalStyle::of(p);
        let mat = doc.material(
            &format!("portal {style:?}"),
            &format!("portal: {}", style.label()),
            style.rgb(),
            0.6,
        );
        let prim = doc.polygons([p.polygon.as_slice()], p.normal * PORTAL_OFFSET, mat);
        let to = p.to.map_or("exterior".to_string(), |t| format!("cell {t}"));
        doc.node(
            format!("portal {i}: cell {} -> {to}", p.from),
            prim,
            json!({
                "portal": i,
                "from": p.from,
                "to": p.to,
                "style": style.label(),
                "partner": p.partner,
            }),
        );
    }
    for (k, line) in extra.leaks.iter().enumerate() {
        let prim = (line.len() >= 2).then(|| {
            let mat = doc.material("leak", "leak", [1.0, 0.0, 0.0], 1.0);
            let pos = doc.positions(line);
            json!({ "attributes": { "POSITION": pos }, "material": mat, "mode": MODE_LINE_STRIP })
        });
        doc.node(format!("leak {k}"), prim, json!({ "leak": k }));
    }
    for (k, line) in extra.sightlines.iter().enumerate() {
        let prim = (line.len() >= 2).then(|| {
            let mat = doc.material("sightline", "sightline", [1.0, 0.8, 0.0], 1.0);
            let pos = doc.positions(line);
            json!({ "attributes": { "POSITION": pos }, "material": mat, "mode": MODE_LINE_STRIP })
        });
        doc.node(
            format!("missed sightline {k}"),
            prim,
            json!({ "sightline": k }),
        );
    }
    for (k, poly) in extra.overlaps.iter().enumerate() {
        let mat = doc.material("overlap", "overlap", [1.0, 0.0, 1.0], 0.4);
        let prim = doc.polygons(
            poly.faces.iter().map(|f| f.points.as_slice()),
            DVec3::ZERO,
            mat,
        );
        doc.node(format!("overlap {k}"), prim, json!({ "overlap": k }));
    }
    doc.into_glb()
}
