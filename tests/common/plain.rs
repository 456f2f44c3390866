//! A glTF reader of the tests' own, as a plain engine reads a file: the default scene's nodes
//! with their transforms, each primitive's positions and triangles, nothing of the extension.
//! It shares no code with the importer or the writer.

use std::path::Path;

use base64::Engine;
use glam::{DMat4, DQuat, DVec3};
use serde_json::Value;

/// The document and its one buffer: a .glb's BIN chunk, or a .gltf's data: URI.
pub fn read(path: &Path) -> (Value, Vec<u8>) {
    let bytes = std::fs::read(path).unwrap();
    let (doc, bin) = super::read_gltf(&bytes);
    let bin = bin.unwrap_or_else(|| {
        let uri = doc["buffers"][0]["uri"].as_str().unwrap_or("");
        let data = uri.split_once(";base64,").map_or("", |(_, d)| d);
        base64::engine::general_purpose::STANDARD
            .decode(data)
            .unwrap_or_default()
    });
    (doc, bin)
}

/// Accessor `i`'s elements as numbers (no sparse accessors, one buffer).
pub fn accessor(doc: &Value, bin: &[u8], i: usize) -> Vec<Vec<f64>> {
    let a = &doc["accessors"][i];
    let count = a["count"].as_u64().unwrap() as usize;
    let comps = match a["type"].as_str().unwrap() {
        "SCALAR" => 1,
        "VEC2" => 2,
        "VEC3" => 3,
        "VEC4" => 4,
        t => panic!("accessor type {t}"),
    };
    let ct = a["componentType"].as_u64().unwrap();
    let size = match ct {
        5120 | 5121 => 1,
        5122 | 5123 => 2,
        5125 | 5126 => 4,
        _ => panic!("component type {ct}"),
    };
    let v = &doc["bufferViews"][a["bufferView"].as_u64().unwrap() as usize];
    assert_eq!(v["buffer"].as_u64().unwrap_or(0), 0, "one buffer");
    let base = v["byteOffset"].as_u64().unwrap_or(0) as usize
        + a["byteOffset"].as_u64().unwrap_or(0) as usize;
    let stride = v["byteStride"]
        .as_u64()
        .map_or(comps * size, |s| s as usize);
    (0..count)
        .map(|k| {
            (0..comps)
                .map(|c| {
                    let o = base + k * stride + c * size;
                    let b = &bin[o..o + size];
                    match ct {
                        5121 => b[0] as f64,
                        5123 => u16::from_le_bytes([b[0], b[1]]) as f64,
                        5125 => u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
                        5126 => f32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
                        _ => panic!("component type {ct} for positions or indices"),
                    }
                })
                .collect()
        })
        .collect()
}

/// A node's local transform.
pub fn local(n: &Value) -> DMat4 {
    if let Some(m) = n["matrix"].as_array() {
        let m: Vec<f64> = m.iter().map(|x| x.as_f64().unwrap()).collect();
        return DMat4::from_cols_slice(&m);
    }
    let v = |k: &str, d: &[f64]| -> Vec<f64> {
        n[k].as_array()
            .map(|a| a.iter().map(|x| x.as_f64().unwrap()).collect())
            .unwrap_or(d.to_vec())
    };
    let (t, r, s) = (
        v("translation", &[0.0; 3]),
        v("rotation", &[0.0, 0.0, 0.0, 1.0]),
        v("scale", &[1.0; 3]),
    );
    DMat4::from_scale_rotation_translation(
        DVec3::new(s[0], s[1], s[2]),
        DQuat::from_xyzw(r[0], r[1], r[2], r[3]),
        DVec3::new(t[0], t[1], t[2]),
    )
}

/// Every node of the default scene with its world transform, in walk order.
pub fn world(doc: &Value) -> Vec<(usize, DMat4)> {
    let roots = doc["scenes"][doc["scene"].as_u64().unwrap_or(0) as usize]["nodes"]
        .as_array()
        .cloned()
        .unwrap_or_default();
    let mut stack: Vec<(usize, DMat4)> = (roots.iter().rev())
        .map(|n| (n.as_u64().unwrap() as usize, DMat4::IDENTITY))
        .collect();
    let mut out = Vec::new();
    while let Some((n, up)) = stack.pop() {
        let node = &doc["nodes"][n];
        let m = up * local(node);
        out.push((n, m));
        for c in node["children"].as_array().into_iter().flatten().rev() {
            stack.push((c.as_u64().unwrap() as usize, m));
        }
    }
    out
}

/// The triangles an index list makes in `mode` (4 list, 5 strip, 6 fan; others none).
pub fn triangles(mode: u64, idx: &[u32]) -> Vec<[u32; 3]> {
    match mode {
        4 => idx.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect(),
        5 => (0..idx.len().saturating_sub(2))
            .map(|i| {
                if i % 2 == 0 {
                    [idx[i], idx[i + 1], idx[i + 2]]
                } else {
                    [idx[i + 1], idx[i], idx[i + 2]]
                }
            })
            .collect(),
        6 => (1..idx.len().saturating_sub(1))
            .map(|i| [idx[i], idx[i + 1], idx[0]])
            .collect(),
        _ => Vec::new(),
    }
}

/// A primitive's indices (0, 1, 2, … without an index accessor).
pub fn indices(doc: &Value, bin: &[u8], p: &Value, vertices: usize) -> Vec<u32> {
    match p["indices"].as_u64() {
        Some(a) => (accessor(doc, bin, a as usize).into_iter())
            .map(|v| v[0] as u32)
            .collect(),
        None => (0..vertices as u32).collect(),
    }
}

/// What a plain reader draws: every triangle of every mesh in the scene, its world corners
/// in order (so the winding counts) to a micrometre, with its material, sorted.
pub fn drawn(path: &Path) -> Vec<([i64; 9], Option<u64>)> {
    let (doc, bin) = read(path);
    let mut out = Vec::new();
    for (n, m) in world(&doc) {
        let Some(mesh) = doc["nodes"][n]["mesh"].as_u64() else {
            continue;
        };
        for p in doc["meshes"][mesh as usize]["primitives"]
            .as_array()
            .into_iter()
            .flatten()
        {
            let Some(pa) = p["attributes"]["POSITION"].as_u64() else {
                continue;
            };
            let pos: Vec<DVec3> = (accessor(&doc, &bin, pa as usize).into_iter())
                .map(|v| m.transform_point3(DVec3::new(v[0], v[1], v[2])))
                .collect();
            let idx = indices(&doc, &bin, p, pos.len());
            for t in triangles(p["mode"].as_u64().unwrap_or(4), &idx) {
                let mut k = [0i64; 9];
                for (j, &i) in t.iter().enumerate() {
                    let q = pos[i as usize];
                    for (c, x) in [q.x, q.y, q.z].into_iter().enumerate() {
                        k[3 * j + c] = (x * 1e6).round() as i64;
                    }
                }
                out.push((k, p["material"].as_u64()));
            }
        }
    }
    out.sort_unstable();
    out
}
