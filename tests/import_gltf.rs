//! glTF importer: third-party levels, generated edge cases and a malformed set.

use std::path::{Path, PathBuf};

use base64::Engine as _;
use glam::DVec3;
use portcullis::diag::{Code, Diagnostic, Severity};
use portcullis::import::{import_bytes, import_path, ImportOptions, Imported};
use portcullis::scene::{Format, NodeId, Scene};
use serde_json::{json, Value};

fn fixture(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures")
        .join(rel)
}

fn load(rel: &str) -> Imported {
    let path = fixture(rel);
    import_path(&path, &ImportOptions::default()).unwrap_or_else(|d| panic!("{rel}: {d}"))
}

fn import_json(doc: &Value) -> Result<Imported, Diagnostic> {
    let bytes = serde_json::to_vec(doc).unwrap();
    import_bytes(
        &bytes,
        Path::new("test.gltf"),
        Format::Gltf,
        Path::new("."),
        &ImportOptions::default(),
    )
}

fn ok(doc: &Value) -> Imported {
    import_json(doc).unwrap_or_else(|d| panic!("{d}"))
}

fn err(doc: &Value) -> Diagnostic {
    match import_json(doc) {
        Ok(_) => panic!("expected the import to fail"),
        Err(d) => d,
    }
}

fn node_by_name(scene: &Scene, name: &str) -> NodeId {
    (0..scene.nodes.len())
        .find(|&i| scene.nodes[i].name.as_deref() == Some(name))
        .unwrap_or_else(|| panic!("no node {name}"))
}

fn assert_close(a: DVec3, b: DVec3) {
    assert!((a - b).length() < 1e-9, "{a} != {b}");
}

// ---------------------------------------------------------------------------------------------
// A tiny glTF writer: one buffer as a data: URI, views and accessors appended as needed.

#[derive(Default)]
struct Doc {
    buf: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
}

impl Doc {
    fn view(&mut self, bytes: &[u8]) -> usize {
        while self.buf.len() % 4 != 0 {
            self.buf.push(0);
        }
        self.views
            .push(json!({"buffer": 0, "byteOffset": self.buf.len(), "byteLength": bytes.len()}));
        self.buf.extend_from_slice(bytes);
        self.views.len() - 1
    }

    fn accessor(&mut self, mut acc: Value) -> usize {
        if acc.get("byteOffset").is_none() {
            acc["byteOffset"] = json!(0);
        }
        self.accessors.push(acc);
        self.accessors.len() - 1
    }

    fn positions(&mut self, p: &[[f32; 3]]) -> usize {
        let bytes: Vec<u8> = p.iter().flatten().flat_map(|f| f.to_le_bytes()).collect();
        let v = self.view(&bytes);
        self.accessor(
            json!({"bufferView": v, "componentType": 5126, "count": p.len(), "type": "VEC3"}),
        )
    }

    fn indices_u16(&mut self, i: &[u16]) -> usize {
        let bytes: Vec<u8> = i.iter().flat_map(|x| x.to_le_bytes()).collect();
        let v = self.view(&bytes);
        self.accessor(
            json!({"bufferView": v, "componentType": 5123, "count": i.len(), "type": "SCALAR"}),
        )
    }

    /// The finished document; `rest` supplies nodes, meshes, scenes and so on.
    fn finish(&self, rest: Value) -> Value {
        let mut d = json!({
            "asset": {"version": "2.0"},
            "accessors": self.accessors,
            "bufferViews": self.views,
            "buffers": [{
                "byteLength": self.buf.len(),
                "uri": format!("data:application/octet-stream;base64,{}",
                    base64::engine::general_purpose::STANDARD.encode(&self.buf)),
            }],
        });
        for (k, v) in rest.as_object().unwrap() {
            d[k] = v.clone();
        }
        d
    }
}

const QUAD: [[f32; 3]; 4] = [[0., 0., 0.], [1., 0., 0.], [1., 0., 1.], [0., 0., 1.]];

/// One node with one mesh whose single primitive is `prim`.
fn single(doc: &Doc, prim: Value) -> Value {
    doc.finish(json!({
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"name": "n", "mesh": 0}],
        "meshes": [{"name": "m", "primitives": [prim]}],
    }))
}

// ---------------------------------------------------------------------------------------------
// Third-party levels

#[test]
fn third_party_triangle_counts() {
    for (file, tris) in [
        ("lportal_tutorial_simple.glb", 158),
        ("lportal_boxrooms.glb", 3352),
        ("panda3d_culling.glb", 385),
        ("occlusion_room.glb", 63720),
        ("living_room.glb", 5088),
        ("gi_zdm2.glb", 58772),
    ] {
        let im = load(&format!("third_party/{file}"));
        assert_eq!(im.scene.triangle_count(), tris, "{file}");
        assert_eq!(im.scene.format, Format::Glb);
        assert!(!im.diagnostics.has_errors(), "{file}: {:?}", im.diagnostics);
        let src = im.scene.gltf.as_ref().expect("glTF source kept");
        assert_eq!(src.buffers.len(), 1, "{file}");
        assert!(src.document().unwrap().get("asset").is_some());
        for m in &im.scene.meshes {
            let n = m.positions.len() as u32;
            assert!(m.triangles.iter().flatten().all(|&i| i < n), "{file}");
            assert!(m.positions.iter().all(|p| p.is_finite()), "{file}");
        }
    }
}

#[test]
fn boxrooms_instancing() {
    let im = load("third_party/lportal_boxrooms.glb");
    let s = &im.scene;
    assert_eq!(s.nodes.len(), 132);
    let mesh_nodes = s.nodes.iter().filter(|n| n.mesh.is_some()).count();
    assert_eq!(mesh_nodes, 110);
    assert_eq!(s.meshes.len(), 7);
    assert!(s.meshes.len() < mesh_nodes);
    assert_eq!(s.materials.len(), 6);
    // Every node's source pointer names its glTF node, and parents come before children.
    for (i, n) in s.nodes.iter().enumerate() {
        assert!(n.source.pointer.as_deref().unwrap().starts_with("/nodes/"));
        if let Some(p) = n.parent {
            assert!(p < i && s.nodes[p].children.contains(&i));
        }
    }
}

#[test]
fn tutorial_simple_wall_aabb() {
    let im = load("third_party/lportal_tutorial_simple.glb");
    let s = &im.scene;
    let wall = (0..s.nodes.len())
        .find(|&i| s.node_path(i) == "Root/RoomList/room_kitchen/Wall3")
        .expect("Wall3 node");
    let pts = s.world_positions(wall);
    assert!(!pts.is_empty());
    let min = pts
        .iter()
        .fold(DVec3::splat(f64::INFINITY), |a, p| a.min(*p));
    let max = pts
        .iter()
        .fold(DVec3::splat(f64::NEG_INFINITY), |a, p| a.max(*p));
    assert!(
        (min - DVec3::new(2.8, 0.0, 1.0)).abs().max_element() < 1e-5,
        "{min}"
    );
    assert!(
        (max - DVec3::new(3.0, 2.0, 3.0)).abs().max_element() < 1e-5,
        "{max}"
    );
    assert_eq!(s.meshes.len(), 4);
    assert_eq!(s.nodes.len(), 21);
}

#[test]
fn panda3d_extras_kept() {
    let im = load("third_party/panda3d_culling.glb");
    let s = &im.scene;
    let portals = s
        .nodes
        .iter()
        .filter(|n| {
            n.extras
                .as_ref()
                .and_then(|e| e.pointer("/egg_scalars/portal"))
                .is_some()
        })
        .count();
    assert!(portals > 0);
}

// ---------------------------------------------------------------------------------------------
// Transforms

#[test]
fn trs_and_matrix_agree() {
    let mut d = Doc::default();
    let p = d.positions(&QUAD);
    let (t, s) = ([10.0, 2.0, -3.0], [2.0, 1.0, 0.5]);
    // 90 degrees about +Y: (x, y, z) -> (z, y, -x).
    let h = std::f64::consts::FRAC_1_SQRT_2;
    let r = [0.0, h, 0.0, h];
    let m = glam::DMat4::from_scale_rotation_translation(
        DVec3::from(s),
        glam::DQuat::from_xyzw(r[0], r[1], r[2], r[3]),
        DVec3::from(t),
    );
    let doc = d.finish(json!({
        "scenes": [{"nodes": [0, 1]}],
        "nodes": [
            {"name": "trs", "mesh": 0, "translation": t, "rotation": r, "scale": s},
            {"name": "mat", "mesh": 0, "matrix": m.to_cols_array()},
        ],
        "meshes": [{"primitives": [{"attributes": {"POSITION": p}}]}],
    }));
    let im = ok(&doc);
    let s = &im.scene;
    let a = s.world_positions(node_by_name(s, "trs"));
    let b = s.world_positions(node_by_name(s, "mat"));
    assert_eq!(a.len(), 4);
    for (x, y) in a.iter().zip(&b) {
        assert_close(*x, *y);
    }
    // (1, 0, 0) scaled (2, 1, 0.5) -> (2, 0, 0), rotated -> (0, 0, -2), translated.
    assert_close(a[1], DVec3::new(10.0, 2.0, -5.0));
}

#[test]
fn nested_transforms_compose_in_f64() {
    let mut d = Doc::default();
    let p = d.positions(&[[0., 0., 0.], [1., 0., 0.], [0., 1., 0.]]);
    let doc = d.finish(json!({
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [
            {"name": "outer", "children": [1], "translation": [1000000.123456789, 0, 0], "scale": [2, 2, 2]},
            {"name": "mid", "children": [2], "translation": [0.001, 0, 0]},
            {"name": "leaf", "mesh": 0, "translation": [0, 0, 5]},
        ],
        "meshes": [{"primitives": [{"attributes": {"POSITION": p}}]}],
    }));
    let im = ok(&doc);
    let s = &im.scene;
    let leaf = node_by_name(s, "leaf");
    assert_eq!(s.node_path(leaf), "outer/mid/leaf");
    let w = s.world_positions(leaf);
    // outer * mid * leaf: x = 1000000.123456789 + 2 * (0.001 + px), z = 2 * 5.
    assert_close(w[0], DVec3::new(1000000.125456789, 0.0, 10.0));
    assert_close(w[1], DVec3::new(1000002.125456789, 0.0, 10.0));
    assert_eq!(s.roots.len(), 1);
}

#[test]
fn non_finite_transform_is_refused() {
    let mut d = Doc::default();
    let p = d.positions(&QUAD);
    let doc = d.finish(json!({
        "scenes": [{"nodes": [0]}],
        "nodes": [
            {"children": [1], "scale": [1e200, 1e200, 1e200]},
            {"mesh": 0, "scale": [1e200, 1e200, 1e200]},
        ],
        "meshes": [{"primitives": [{"attributes": {"POSITION": p}}]}],
    }));
    let e = err(&doc);
    assert_eq!(e.code, Code::GLTF_TRANSFORM_INVALID);
    assert_eq!(e.location.source.pointer.as_deref(), Some("/nodes/1"));
}

// ---------------------------------------------------------------------------------------------
// Primitive modes and index types

fn mode_triangles(mode: u32, indices: Option<&[u16]>, n: usize) -> Vec<[u32; 3]> {
    let mut d = Doc::default();
    let pts: Vec<[f32; 3]> = (0..n).map(|i| [i as f32, (i % 2) as f32, 0.0]).collect();
    let p = d.positions(&pts);
    let mut prim = json!({"attributes": {"POSITION": p}, "mode": mode});
    if let Some(i) = indices {
        prim["indices"] = json!(d.indices_u16(i));
    }
    let im = ok(&single(&d, prim));
    let m = &im.scene.meshes[0];
    assert_eq!(m.primitives.len(), 1);
    assert_eq!(m.primitives[0].triangle_count, m.triangles.len());
    m.triangles.clone()
}

#[test]
fn triangle_strip_alternates_winding() {
    assert_eq!(
        mode_triangles(5, None, 5),
        vec![[0, 1, 2], [1, 3, 2], [2, 3, 4]]
    );
    assert_eq!(
        mode_triangles(5, Some(&[4, 3, 2, 1]), 5),
        vec![[4, 3, 2], [3, 1, 2]]
    );
}

#[test]
fn triangle_fan() {
    assert_eq!(
        mode_triangles(6, None, 5),
        vec![[1, 2, 0], [2, 3, 0], [3, 4, 0]]
    );
    assert_eq!(
        mode_triangles(6, Some(&[2, 0, 1, 3]), 4),
        vec![[0, 1, 2], [1, 3, 2]]
    );
}

#[test]
fn non_indexed_triangles() {
    assert_eq!(mode_triangles(4, None, 6), vec![[0, 1, 2], [3, 4, 5]]);
}

#[test]
fn index_component_types() {
    let idx = [0u32, 1, 2, 0, 2, 3];
    for (ct, size) in [(5121, 1), (5123, 2), (5125, 4)] {
        let mut d = Doc::default();
        let p = d.positions(&QUAD);
        let bytes: Vec<u8> = idx
            .iter()
            .flat_map(|&i| i.to_le_bytes()[..size].to_vec())
            .collect();
        let v = d.view(&bytes);
        let i =
            d.accessor(json!({"bufferView": v, "componentType": ct, "count": 6, "type": "SCALAR"}));
        let im = ok(&single(
            &d,
            json!({"attributes": {"POSITION": p}, "indices": i}),
        ));
        assert_eq!(
            im.scene.meshes[0].triangles,
            vec![[0, 1, 2], [0, 2, 3]],
            "{ct}"
        );
    }
}

#[test]
fn degenerate_triangles_dropped_and_counted() {
    let mut d = Doc::default();
    let p = d.positions(&QUAD);
    let i = d.indices_u16(&[0, 1, 2, 0, 0, 1, 2, 3, 3, 0, 2, 3]);
    let im = ok(&single(
        &d,
        json!({"attributes": {"POSITION": p}, "indices": i}),
    ));
    assert_eq!(im.scene.meshes[0].triangles, vec![[0, 1, 2], [0, 2, 3]]);
    let degen: Vec<_> = im
        .diagnostics
        .iter()
        .filter(|d| d.code == Code::GEOM_DEGENERATE_TRIANGLES)
        .collect();
    assert_eq!(degen.len(), 1);
    assert_eq!(degen[0].severity, Severity::Info);
    assert!(degen[0].message.contains('2'), "{}", degen[0].message);
}

#[test]
fn points_and_lines_skipped_once() {
    let mut d = Doc::default();
    let p = d.positions(&QUAD);
    let doc = d.finish(json!({
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [
            {"attributes": {"POSITION": p}, "mode": 0},
            {"attributes": {"POSITION": p}, "mode": 1},
            {"attributes": {"POSITION": p}, "mode": 4, "material": 0},
        ]}],
        "materials": [{"name": "stone", "extras": {"k": 1}}],
    }));
    let im = ok(&doc);
    let skipped: Vec<_> = im
        .diagnostics
        .iter()
        .filter(|d| d.code == Code::GLTF_NON_TRIANGLES_SKIPPED)
        .collect();
    assert_eq!(skipped.len(), 1);
    assert_eq!(skipped[0].severity, Severity::Info);
    let m = &im.scene.meshes[0];
    assert_eq!(m.primitives.len(), 1);
    assert_eq!(m.primitives[0].material, Some(0));
    assert_eq!(
        m.primitives[0].source.pointer.as_deref(),
        Some("/meshes/0/primitives/2")
    );
    assert_eq!(m.positions.len(), 4);
    assert_eq!(m.triangles.len(), 1);
    let mat = &im.scene.materials[0];
    assert_eq!(mat.name.as_deref(), Some("stone"));
    assert_eq!(mat.extras, Some(json!({"k": 1})));
    assert_eq!(mat.source.pointer.as_deref(), Some("/materials/0"));
}

#[test]
fn primitives_concatenate_positions() {
    let mut d = Doc::default();
    let a = d.positions(&QUAD);
    let b = d.positions(&[[5., 0., 0.], [6., 0., 0.], [6., 1., 0.]]);
    let doc = d.finish(json!({
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"name": "two", "extras": {"x": true}, "primitives": [
            {"attributes": {"POSITION": a}, "mode": 6},
            {"attributes": {"POSITION": b}, "material": 1},
        ]}],
        "materials": [{"name": "a"}, {"name": "b"}],
    }));
    let im = ok(&doc);
    let m = &im.scene.meshes[0];
    assert_eq!(m.name.as_deref(), Some("two"));
    assert_eq!(m.extras, Some(json!({"x": true})));
    assert_eq!(m.positions.len(), 7);
    assert_eq!(m.triangles, vec![[1, 2, 0], [2, 3, 0], [4, 5, 6]]);
    assert_eq!(m.primitives[1].first_triangle, 2);
    assert_eq!(m.primitives[1].triangle_count, 1);
    assert_eq!(m.primitives[1].material, Some(1));
}

#[test]
fn shared_position_accessor_stored_once() {
    let mut d = Doc::default();
    let p = d.positions(&QUAD);
    let a = d.indices_u16(&[0, 1, 2]);
    let b = d.indices_u16(&[0, 2, 3]);
    let doc = d.finish(json!({
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [
            {"attributes": {"POSITION": p}, "indices": a, "material": 0},
            {"attributes": {"POSITION": p}, "indices": b, "material": 1},
        ]}],
        "materials": [{"name": "floor"}, {"name": "wall"}],
    }));
    let im = ok(&doc);
    let m = &im.scene.meshes[0];
    assert_eq!(m.positions.len(), 4);
    assert_eq!(m.triangles, vec![[0, 1, 2], [0, 2, 3]]);
    assert_eq!(
        im.scene.mesh_material_names(0),
        vec![Some("floor"), Some("wall")]
    );
}

// ---------------------------------------------------------------------------------------------
// Accessors

#[test]
fn quantized_positions() {
    let mut d = Doc::default();
    // i16 normalized: 32767 -> 1, -32767 -> -1, -32768 -> -1 (clamped), 16384 -> 0.50002.
    let shorts: [[i16; 3]; 3] = [[32767, 0, -32767], [-32768, 16384, 0], [0, 0, 32767]];
    let mut bytes = Vec::new();
    for p in shorts {
        for c in p {
            bytes.extend_from_slice(&c.to_le_bytes());
        }
        bytes.extend_from_slice(&[0, 0]); // VEC3 of i16 padded to 8 bytes
    }
    let v = d.view(&bytes);
    d.views[v]["byteStride"] = json!(8);
    let a = d.accessor(json!({"bufferView": v, "componentType": 5122, "normalized": true, "count": 3, "type": "VEC3"}));
    // u16 not normalized: integer values.
    let ushorts: [[u16; 3]; 3] = [[0, 0, 0], [65535, 7, 0], [3, 0, 40000]];
    let bytes: Vec<u8> = ushorts
        .iter()
        .flat_map(|p| {
            let mut v: Vec<u8> = p.iter().flat_map(|c| c.to_le_bytes()).collect();
            v.extend_from_slice(&[0, 0]);
            v
        })
        .collect();
    let v = d.view(&bytes);
    d.views[v]["byteStride"] = json!(8);
    let b = d.accessor(json!({"bufferView": v, "componentType": 5123, "count": 3, "type": "VEC3"}));
    let doc = d.finish(json!({
        "extensionsUsed": ["KHR_mesh_quantization"],
        "extensionsRequired": ["KHR_mesh_quantization"],
        "scenes": [{"nodes": [0, 1]}],
        "nodes": [{"mesh": 0}, {"mesh": 1}],
        "meshes": [
            {"primitives": [{"attributes": {"POSITION": a}}]},
            {"primitives": [{"attributes": {"POSITION": b}}]},
        ],
    }));
    let im = ok(&doc);
    let p = &im.scene.meshes[0].positions;
    assert_close(p[0], DVec3::new(1.0, 0.0, -1.0));
    assert_close(p[1], DVec3::new(-1.0, 16384.0 / 32767.0, 0.0));
    assert_close(p[2], DVec3::new(0.0, 0.0, 1.0));
    let q = &im.scene.meshes[1].positions;
    assert_close(q[1], DVec3::new(65535.0, 7.0, 0.0));
    assert_close(q[2], DVec3::new(3.0, 0.0, 40000.0));
    assert_eq!(im.scene.triangle_count(), 2);
}

#[test]
fn sparse_positions() {
    let mut d = Doc::default();
    let base = d.positions(&QUAD);
    let bv = d.accessors[base]["bufferView"].clone();
    let idx: Vec<u8> = [1u16, 3].iter().flat_map(|i| i.to_le_bytes()).collect();
    let iv = d.view(&idx);
    let vals: Vec<u8> = [[9f32, 8., 7.], [6., 5., 4.]]
        .iter()
        .flatten()
        .flat_map(|f| f.to_le_bytes())
        .collect();
    let vv = d.view(&vals);
    let sparse = json!({"count": 2,
        "indices": {"bufferView": iv, "componentType": 5123},
        "values": {"bufferView": vv}});
    let on_view = d.accessor(json!({"bufferView": bv, "componentType": 5126, "count": 4, "type": "VEC3", "sparse": sparse}));
    let on_zeros =
        d.accessor(json!({"componentType": 5126, "count": 4, "type": "VEC3", "sparse": sparse}));
    let doc = d.finish(json!({
        "scenes": [{"nodes": [0, 1]}],
        "nodes": [{"mesh": 0}, {"mesh": 1}],
        "meshes": [
            {"primitives": [{"attributes": {"POSITION": on_view}}]},
            {"primitives": [{"attributes": {"POSITION": on_zeros}, "mode": 0}, {"attributes": {"POSITION": on_zeros}, "mode": 6}]},
        ],
    }));
    let im = ok(&doc);
    let p = &im.scene.meshes[0].positions;
    assert_eq!(
        p,
        &vec![
            DVec3::ZERO,
            DVec3::new(9., 8., 7.),
            DVec3::new(1., 0., 1.),
            DVec3::new(6., 5., 4.)
        ]
    );
    let z = &im.scene.meshes[1].positions;
    assert_eq!(z[0], DVec3::ZERO);
    assert_eq!(z[1], DVec3::new(9., 8., 7.));
    assert_eq!(z[2], DVec3::ZERO);
    assert_eq!(z[3], DVec3::new(6., 5., 4.));
}

#[test]
fn sparse_index_out_of_range_is_refused() {
    let mut d = Doc::default();
    let idx: Vec<u8> = [9u16, 0].iter().flat_map(|i| i.to_le_bytes()).collect();
    let iv = d.view(&idx);
    let vv = d.view(&[0u8; 24]);
    let a = d.accessor(
        json!({"componentType": 5126, "count": 3, "type": "VEC3", "sparse": {"count": 1,
        "indices": {"bufferView": iv, "componentType": 5123}, "values": {"bufferView": vv}}}),
    );
    let e = err(&single(&d, json!({"attributes": {"POSITION": a}})));
    assert_eq!(e.code, Code::GLTF_ACCESSOR_OUT_OF_BOUNDS);
    assert!(e
        .location
        .source
        .pointer
        .as_deref()
        .unwrap()
        .starts_with("/accessors/0/sparse"));
}

#[test]
fn position_must_be_vec3() {
    let mut d = Doc::default();
    let p = d.positions(&QUAD);
    d.accessors[p]["type"] = json!("VEC2");
    let e = err(&single(&d, json!({"attributes": {"POSITION": p}})));
    assert_eq!(e.code, Code::GLTF_ACCESSOR_INVALID);
    assert_eq!(e.location.source.pointer.as_deref(), Some("/accessors/0"));
}

#[test]
fn interleaved_stride_and_offsets() {
    let mut d = Doc::default();
    // Position + a 4-byte attribute, stride 16, accessor starting 16 bytes into the view.
    let mut bytes = vec![0xAAu8; 16];
    for p in QUAD {
        for c in p {
            bytes.extend_from_slice(&c.to_le_bytes());
        }
        bytes.extend_from_slice(&[0xFF; 4]);
    }
    let v = d.view(&bytes);
    d.views[v]["byteStride"] = json!(16);
    let a = d.accessor(json!({"bufferView": v, "byteOffset": 16, "componentType": 5126, "count": 4, "type": "VEC3"}));
    let im = ok(&single(
        &d,
        json!({"attributes": {"POSITION": a}, "mode": 6}),
    ));
    let p = &im.scene.meshes[0].positions;
    assert_eq!(p[2], DVec3::new(1.0, 0.0, 1.0));
    assert_eq!(p[3], DVec3::new(0.0, 0.0, 1.0));
    // One more element would read past the view.
    let mut d2 = Doc::default();
    let v = d2.view(&bytes);
    d2.views[v]["byteStride"] = json!(16);
    let a = d2.accessor(json!({"bufferView": v, "byteOffset": 16, "componentType": 5126, "count": 5, "type": "VEC3"}));
    let e = err(&single(&d2, json!({"attributes": {"POSITION": a}})));
    assert_eq!(e.code, Code::GLTF_ACCESSOR_OUT_OF_BOUNDS);
    assert_eq!(e.location.source.pointer.as_deref(), Some("/accessors/0"));
}

#[test]
fn hostile_unbacked_count_is_refused() {
    let d = Doc::default();
    let mut doc = single(&d, json!({"attributes": {"POSITION": 0}}));
    doc["accessors"] = json!([{"componentType": 5126, "count": 2000000000u64, "type": "VEC3"}]);
    let e = err(&doc);
    assert_eq!(e.code, Code::GLTF_ACCESSOR_OUT_OF_BOUNDS);
}

// ---------------------------------------------------------------------------------------------
// Scene graph

#[test]
fn instanced_mesh_is_stored_once() {
    let mut d = Doc::default();
    let p = d.positions(&QUAD);
    let doc = d.finish(json!({
        "scenes": [{"nodes": [0, 1]}],
        "nodes": [
            {"name": "a", "mesh": 1, "extras": {"tag": "room"}},
            {"name": "b", "mesh": 1, "translation": [5, 0, 0]},
        ],
        "meshes": [
            {"name": "unused", "primitives": [{"attributes": {"POSITION": p}}]},
            {"name": "used", "primitives": [{"attributes": {"POSITION": p}, "mode": 6}]},
        ],
    }));
    let im = ok(&doc);
    let s = &im.scene;
    assert_eq!(s.meshes.len(), 1);
    assert_eq!(s.meshes[0].name.as_deref(), Some("used"));
    assert_eq!(s.meshes[0].source.pointer.as_deref(), Some("/meshes/1"));
    let (a, b) = (node_by_name(s, "a"), node_by_name(s, "b"));
    assert_eq!(s.nodes[a].mesh, Some(0));
    assert_eq!(s.nodes[b].mesh, Some(0));
    assert_eq!(s.nodes[a].extras, Some(json!({"tag": "room"})));
    assert_eq!(s.nodes[b].source.pointer.as_deref(), Some("/nodes/1"));
    assert_eq!(s.triangle_count(), 4);
    assert_close(s.world_positions(b)[1], DVec3::new(6.0, 0.0, 0.0));
}

#[test]
fn default_scene_is_used_and_other_scenes_ignored() {
    let mut d = Doc::default();
    let p = d.positions(&QUAD);
    let doc = d.finish(json!({
        "scene": 1,
        "scenes": [{"nodes": [0]}, {"nodes": [1]}],
        "nodes": [{"name": "zero", "mesh": 0}, {"name": "one"}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": p}}]}],
    }));
    let im = ok(&doc);
    assert_eq!(im.scene.nodes.len(), 1);
    assert_eq!(im.scene.nodes[0].name.as_deref(), Some("one"));
    assert!(im.scene.meshes.is_empty());
}

#[test]
fn no_scene_uses_root_nodes_with_warning() {
    let mut d = Doc::default();
    let p = d.positions(&QUAD);
    let doc = d.finish(json!({
        "nodes": [{"name": "child", "mesh": 0}, {"name": "root", "children": [0]}, {"name": "lone"}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": p}, "mode": 6}]}],
    }));
    let im = ok(&doc);
    let s = &im.scene;
    assert!(im.diagnostics.has(Code::GLTF_NO_SCENE));
    assert_eq!(s.nodes.len(), 3);
    assert_eq!(s.roots.len(), 2);
    assert_eq!(s.node_path(node_by_name(s, "child")), "root/child");
}

/// Meshes are built while the nodes are walked; a broken mesh is still blamed exactly when a
/// node-by-node walk would have reached it before the node that stops the walk.
#[test]
fn a_broken_mesh_is_blamed_only_if_the_walk_reached_it() {
    let mut d = Doc::default();
    let good = d.positions(&QUAD);
    // 100 vertices claimed over the 48 bytes of a quad.
    let v = d.view(&[0u8; 48]);
    let broken =
        d.accessor(json!({"bufferView": v, "componentType": 5126, "count": 100, "type": "VEC3"}));
    let meshes = json!([
        {"primitives": [{"attributes": {"POSITION": good}}]},
        {"primitives": [{"attributes": {"POSITION": broken}}]},
    ]);
    let zero_rotation = json!({"rotation": [0.0, 0.0, 0.0, 0.0]});
    let level = |nodes: Value| {
        let n = nodes.as_array().unwrap().len();
        d.finish(json!({
            "scenes": [{"nodes": (0..n).collect::<Vec<_>>()}],
            "nodes": nodes,
            "meshes": meshes,
        }))
    };
    // The broken mesh comes first: it is the error.
    let e = err(&level(json!([{"mesh": 0}, {"mesh": 1}, zero_rotation])));
    assert_eq!(e.code, Code::GLTF_ACCESSOR_OUT_OF_BOUNDS, "{e:?}");
    assert_eq!(
        e.location.source.pointer.as_deref(),
        Some(format!("/accessors/{broken}").as_str())
    );
    // The walk stops first: the broken mesh after it is never read.
    let e = err(&level(json!([{"mesh": 0}, zero_rotation, {"mesh": 1}])));
    assert_eq!(e.code, Code::GLTF_TRANSFORM_INVALID, "{e:?}");
    assert_eq!(
        e.location.source.pointer.as_deref(),
        Some("/nodes/1/rotation")
    );
}

#[test]
fn node_mesh_out_of_range_names_pointer() {
    let mut d = Doc::default();
    let p = d.positions(&QUAD);
    let doc = d.finish(json!({
        "scenes": [{"nodes": [0, 1, 2, 3]}],
        "nodes": [{}, {}, {}, {"mesh": 4}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": p}}]}],
    }));
    let e = err(&doc);
    assert_eq!(e.code, Code::GLTF_BAD_INDEX);
    assert_eq!(e.location.source.pointer.as_deref(), Some("/nodes/3/mesh"));
}

#[test]
fn unreachable_cycle_and_two_parents_detected() {
    let d = Doc::default();
    let cycle = d.finish(json!({
        "scenes": [{"nodes": [0]}],
        "nodes": [{}, {"children": [2]}, {"children": [1]}],
    }));
    assert_eq!(err(&cycle).code, Code::GLTF_NODE_CYCLE);
    let selfref = d.finish(json!({"nodes": [{"children": [0]}]}));
    assert_eq!(err(&selfref).code, Code::GLTF_NODE_CYCLE);
    let two = d.finish(json!({
        "scenes": [{"nodes": [0, 1]}],
        "nodes": [{"children": [2]}, {"children": [2]}, {}],
    }));
    let e = err(&two);
    assert_eq!(e.code, Code::GLTF_NODE_CYCLE);
    assert_eq!(
        e.location.source.pointer.as_deref(),
        Some("/nodes/1/children/0")
    );
}

#[test]
fn deep_hierarchy_does_not_overflow_the_stack() {
    let n = 100_000;
    let nodes: Vec<Value> = (0..n)
        .map(|i| {
            if i + 1 < n {
                json!({"children": [i + 1]})
            } else {
                json!({})
            }
        })
        .collect();
    let doc = Doc::default().finish(json!({"scenes": [{"nodes": [0]}], "nodes": nodes}));
    let im = ok(&doc);
    assert_eq!(im.scene.nodes.len(), n);
}

#[test]
fn gpu_instancing_optional_is_noted_required_is_refused() {
    let mut d = Doc::default();
    let p = d.positions(&QUAD);
    let mut doc = d.finish(json!({
        "extensionsUsed": ["EXT_mesh_gpu_instancing"],
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0, "extensions": {"EXT_mesh_gpu_instancing": {"attributes": {}}}}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": p}}]}],
    }));
    let im = ok(&doc);
    assert!(im.diagnostics.has(Code::GLTF_EXTENSION_IGNORED));
    assert_eq!(im.scene.triangle_count(), 1);
    doc["extensionsRequired"] = json!(["EXT_mesh_gpu_instancing"]);
    let e = err(&doc);
    assert_eq!(e.code, Code::GLTF_REQUIRED_EXTENSION_UNSUPPORTED);
    assert!(e.message.contains("EXT_mesh_gpu_instancing"));
}

// ---------------------------------------------------------------------------------------------
// Extensions, versions, containers, buffers

#[test]
fn draco_required_is_refused_with_hint() {
    let mut d = Doc::default();
    let p = d.positions(&QUAD);
    let mut doc = single(&d, json!({"attributes": {"POSITION": p}}));
    doc["extensionsUsed"] = json!(["KHR_materials_unlit", "KHR_draco_mesh_compression"]);
    doc["extensionsRequired"] = json!(["KHR_materials_unlit", "KHR_draco_mesh_compression"]);
    let e = err(&doc);
    assert_eq!(e.code, Code::GLTF_REQUIRED_EXTENSION_UNSUPPORTED);
    assert!(
        e.message.contains("KHR_draco_mesh_compression"),
        "{}",
        e.message
    );
    assert_eq!(
        e.location.source.pointer.as_deref(),
        Some("/extensionsRequired/1")
    );
    assert!(e.hint.as_deref().unwrap().contains("Draco"));
    // Unknown required extensions are refused too; known non-geometric ones are read.
    doc["extensionsRequired"] = json!(["VENDOR_mystery"]);
    assert_eq!(err(&doc).code, Code::GLTF_REQUIRED_EXTENSION_UNSUPPORTED);
    doc["extensionsRequired"] = json!([
        "KHR_texture_transform",
        "KHR_lights_punctual",
        "EXT_texture_webp"
    ]);
    assert!(import_json(&doc).is_ok());
}

#[test]
fn unsupported_versions() {
    let d = Doc::default();
    for v in ["1.0", "3.0", ""] {
        let mut doc = d.finish(json!({}));
        doc["asset"]["version"] = json!(v);
        assert_eq!(err(&doc).code, Code::GLTF_UNSUPPORTED_VERSION, "{v}");
    }
    let mut doc = d.finish(json!({}));
    doc["asset"]["version"] = json!("2.1");
    assert!(import_json(&doc).is_ok());
}

#[test]
fn external_bin_next_to_gltf() {
    let dir = tempfile::tempdir().unwrap();
    let mut d = Doc::default();
    let p = d.positions(&QUAD);
    let i = d.indices_u16(&[0, 1, 2, 0, 2, 3]);
    let mut doc = single(&d, json!({"attributes": {"POSITION": p}, "indices": i}));
    doc["buffers"][0]["uri"] = json!("level%20data.bin");
    std::fs::write(dir.path().join("level data.bin"), &d.buf).unwrap();
    let gltf = dir.path().join("level.gltf");
    std::fs::write(&gltf, serde_json::to_vec_pretty(&doc).unwrap()).unwrap();
    let im = import_path(&gltf, &ImportOptions::default()).unwrap();
    assert_eq!(im.scene.triangle_count(), 2);
    assert_eq!(im.scene.format, Format::Gltf);
    let src = im.scene.gltf.as_ref().unwrap();
    assert_eq!(src.buffers[0], d.buf);
    assert_eq!(src.document().unwrap(), doc);
    assert_eq!(src.base_dir, dir.path());

    // A stale (short) .bin.
    std::fs::write(dir.path().join("level data.bin"), &d.buf[..10]).unwrap();
    let e = import_path(&gltf, &ImportOptions::default()).unwrap_err();
    assert_eq!(e.code, Code::GLTF_BUFFER_TOO_SHORT);
    assert_eq!(e.location.source.pointer.as_deref(), Some("/buffers/0"));
}

fn make_glb(json: &Value, bin: &[u8]) -> Vec<u8> {
    let mut j = serde_json::to_vec(json).unwrap();
    while j.len() % 4 != 0 {
        j.push(b' ');
    }
    let mut b = bin.to_vec();
    while b.len() % 4 != 0 {
        b.push(0);
    }
    let total = 12 + 8 + j.len() + 8 + b.len();
    let mut out = Vec::new();
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(j.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&j);
    out.extend_from_slice(&(b.len() as u32).to_le_bytes());
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(&b);
    out
}

#[test]
fn glb_built_in_test() {
    let mut d = Doc::default();
    let p = d.positions(&QUAD);
    let i = d.indices_u16(&[0, 1, 2, 0, 2, 3, 1]);
    d.accessors[i]["count"] = json!(6);
    let mut doc = single(&d, json!({"attributes": {"POSITION": p}, "indices": i}));
    doc["buffers"] = json!([{"byteLength": d.buf.len()}]);
    let glb = make_glb(&doc, &d.buf);
    // Detected by content even when the name says .gltf.
    let im = import_bytes(
        &glb,
        Path::new("level.gltf"),
        Format::Gltf,
        Path::new("."),
        &ImportOptions::default(),
    )
    .unwrap();
    assert_eq!(im.scene.format, Format::Glb);
    assert_eq!(im.scene.triangle_count(), 2);
    let src = im.scene.gltf.as_ref().unwrap();
    assert_eq!(src.document().unwrap(), doc);
    assert!(src.buffers[0].starts_with(&d.buf));

    // Every truncation and a damaged header fail cleanly, never panic.
    for len in 0..glb.len() {
        let r = import_bytes(
            &glb[..len],
            Path::new("cut.glb"),
            Format::Glb,
            Path::new("."),
            &ImportOptions::default(),
        );
        assert!(r.is_err(), "prefix of {len} bytes accepted");
    }
    let mut bad = glb.clone();
    bad[8..12].copy_from_slice(&3u32.to_le_bytes());
    let e = import_bytes(
        &bad,
        Path::new("bad.glb"),
        Format::Glb,
        Path::new("."),
        &ImportOptions::default(),
    )
    .unwrap_err();
    assert_eq!(e.code, Code::GLB_INVALID);
}

#[test]
fn glb_without_bin_chunk() {
    let d = Doc::default();
    let mut doc = d.finish(json!({}));
    doc["buffers"] = json!([{"byteLength": 12}]);
    let j = serde_json::to_vec(&doc).unwrap();
    let mut glb = make_glb(&doc, &[]);
    // Drop the empty BIN chunk header.
    glb.truncate(glb.len() - 8);
    let total = glb.len() as u32;
    glb[8..12].copy_from_slice(&total.to_le_bytes());
    assert!(glb.len() >= 20 + j.len());
    let e = import_bytes(
        &glb,
        Path::new("x.glb"),
        Format::Glb,
        Path::new("."),
        &ImportOptions::default(),
    )
    .unwrap_err();
    assert_eq!(e.code, Code::GLTF_BUFFER_MISSING);
}

#[test]
fn bad_data_uri_and_non_file_uri() {
    let mut d = Doc::default();
    let p = d.positions(&QUAD);
    let mut doc = single(&d, json!({"attributes": {"POSITION": p}}));
    doc["buffers"][0]["uri"] = json!("data:application/octet-stream;base64,@@@@");
    let e = err(&doc);
    assert_eq!(e.code, Code::GLTF_BUFFER_MISSING);
    assert_eq!(e.location.source.pointer.as_deref(), Some("/buffers/0"));
    doc["buffers"][0]["uri"] = json!("https://example.com/level.bin");
    assert_eq!(err(&doc).code, Code::GLTF_BUFFER_MISSING);
    // application/gltf-buffer is the other registered media type.
    doc["buffers"][0]["uri"] = json!(format!(
        "data:application/gltf-buffer;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(&d.buf)
    ));
    assert!(import_json(&doc).is_ok());
}

#[test]
fn missing_texture_does_not_fail() {
    let mut d = Doc::default();
    let p = d.positions(&QUAD);
    let mut doc = single(&d, json!({"attributes": {"POSITION": p}}));
    doc["images"] = json!([{"uri": "nowhere/texture.png"}]);
    doc["textures"] = json!([{"source": 0}]);
    assert!(import_json(&doc).is_ok());
}

#[test]
fn schema_errors_name_the_item() {
    let mut d = Doc::default();
    let p = d.positions(&QUAD);
    let mut doc = single(&d, json!({"attributes": {"POSITION": p}}));
    doc["nodes"][0]["mesh"] = json!("zero");
    let e = err(&doc);
    assert_eq!(e.code, Code::GLTF_INVALID_JSON);
    assert_eq!(e.location.source.pointer.as_deref(), Some("/nodes/0"));
    let mut doc = single(&d, json!({"attributes": {"POSITION": p}}));
    doc["accessors"][0].as_object_mut().unwrap().remove("count");
    let e = err(&doc);
    assert_eq!(e.code, Code::GLTF_INVALID_JSON);
    assert_eq!(
        e.location.source.pointer.as_deref(),
        Some("/accessors/0/count")
    );
}

// ---------------------------------------------------------------------------------------------
// The checked-in malformed set

#[test]
fn malformed_set() {
    let cases: &[(&str, Code, bool)] = &[
        ("empty.gltf", Code::INPUT_EMPTY, true),
        ("truncated.glb", Code::GLB_INVALID, true),
        ("invalid_json.gltf", Code::GLTF_INVALID_JSON, true),
        ("missing_bin.gltf", Code::GLTF_BUFFER_MISSING, true),
        ("accessor_oob.gltf", Code::GLTF_ACCESSOR_OUT_OF_BOUNDS, true),
        ("huge_count.gltf", Code::GLTF_ACCESSOR_OUT_OF_BOUNDS, true),
        ("nan_position.gltf", Code::GEOM_NON_FINITE, false),
        ("inf_position.gltf", Code::GEOM_NON_FINITE, false),
        (
            "index_out_of_range.gltf",
            Code::MESH_INDEX_OUT_OF_RANGE,
            true,
        ),
        ("node_cycle.gltf", Code::GLTF_NODE_CYCLE, true),
        ("wrong_version.gltf", Code::GLTF_UNSUPPORTED_VERSION, true),
    ];
    for &(file, code, fatal) in cases {
        let path = fixture(&format!("malformed/gltf/{file}"));
        let r = std::panic::catch_unwind(|| import_path(&path, &ImportOptions::default()));
        let r = r.unwrap_or_else(|_| panic!("{file}: the importer panicked"));
        let d = match (r, fatal) {
            (Err(d), true) => d,
            (Ok(im), false) => {
                assert_eq!(im.scene.triangle_count(), 2, "{file}");
                assert!(im
                    .scene
                    .meshes
                    .iter()
                    .all(|m| m.positions.iter().all(|p| p.is_finite())));
                im.diagnostics
                    .iter()
                    .find(|d| d.code == code)
                    .unwrap_or_else(|| panic!("{file}: no {code}"))
                    .clone()
            }
            (Err(d), false) => panic!("{file}: unexpected fatal {d}"),
            (Ok(_), true) => panic!("{file}: expected {code}, import succeeded"),
        };
        assert_eq!(d.code, code, "{file}: {d}");
        assert_eq!(d.severity, Severity::Error, "{file}");
        assert!(
            d.message.contains(file),
            "{file}: message does not name the file: {d}"
        );
        assert_eq!(d.location.file.as_deref(), Some(path.as_path()), "{file}");
        assert!(d.hint.is_some(), "{file}: no hint");
        match file {
            "invalid_json.gltf" => assert_eq!(d.location.source.line, Some(4)),
            "accessor_oob.gltf" | "huge_count.gltf" => {
                assert_eq!(d.location.source.pointer.as_deref(), Some("/accessors/0"))
            }
            "nan_position.gltf" | "inf_position.gltf" => {
                assert_eq!(d.location.source.pointer.as_deref(), Some("/accessors/0"))
            }
            "missing_bin.gltf" => {
                assert_eq!(d.location.source.pointer.as_deref(), Some("/buffers/0"));
                assert!(d.message.contains("missing.bin"));
            }
            "index_out_of_range.gltf" => assert_eq!(
                d.location.source.pointer.as_deref(),
                Some("/meshes/0/primitives/0")
            ),
            _ => {}
        }
    }
}

/// Byte-level damage to a real level: every outcome is a clean result, never a panic.
#[test]
fn corrupted_bytes_never_panic() {
    let glb = std::fs::read(fixture("third_party/lportal_tutorial_simple.glb")).unwrap();
    let mut seed = 0x2545_F491_4F6C_DD1Du64;
    for round in 0..1500 {
        let mut bytes = glb.clone();
        for _ in 0..1 + round % 4 {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            let at = (seed % bytes.len() as u64) as usize;
            bytes[at] = (seed >> 32) as u8;
        }
        let r = std::panic::catch_unwind(|| {
            import_bytes(
                &bytes,
                Path::new("fuzz.glb"),
                Format::Glb,
                Path::new("."),
                &ImportOptions::default(),
            )
        });
        assert!(r.is_ok(), "panic in round {round}");
    }
}
