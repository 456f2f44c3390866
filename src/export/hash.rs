//! The input hash: what a stored annotation was made from, so a consumer can tell it is
//! stale. One definition, named in the hash itself, so hashes written by earlier builds are
//! recomputed by their own definition rather than reported stale.

use crate::scene::Scene;
use crate::tags::Tagging;

/// The hash of every input of the result, so a consumer can tell the annotation is stale:
/// each node's world transform, name and extras, its mesh's positions, triangles and
/// materials (names and extras), in walk order, then the settings that shape the cells and
/// portals ([`Tagging::settings`]). XXH3-64, written `xxh3v2:` + 16 hex digits.
pub fn input_hash(scene: &Scene, tagging: &Tagging) -> String {
    let mut h = xxhash_rust::xxh3::Xxh3::new();
    hashed_bytes(scene, tagging, Coverage::Everything, |b| h.update(b));
    format!("xxh3v2:{:016x}", h.digest())
}

/// [`input_hash`] by the definition a stored hash names: `xxh3v2:`, or, as earlier builds
/// wrote them, `xxh3:` (XXH3-64) and `fnv1a64:` (FNV-1a 64) over the geometry and the names of
/// the recognised rooms and portal nodes only. `None` for a name it does not know.
pub fn input_hash_like(stored: &str, scene: &Scene, tagging: &Tagging) -> Option<String> {
    match stored.split_once(':')?.0 {
        "xxh3v2" => Some(input_hash(scene, tagging)),
        "xxh3" => {
            let mut h = xxhash_rust::xxh3::Xxh3::new();
            hashed_bytes(scene, tagging, Coverage::GeometryAndTags, |b| h.update(b));
            Some(format!("xxh3:{:016x}", h.digest()))
        }
        "fnv1a64" => {
            let mut h: u64 = 0xcbf29ce484222325;
            hashed_bytes(scene, tagging, Coverage::GeometryAndTags, |bytes| {
                for b in bytes {
                    h ^= *b as u64;
                    h = h.wrapping_mul(0x100000001b3);
                }
            });
            Some(format!("fnv1a64:{h:016x}"))
        }
        _ => None,
    }
}

/// What a hash definition covers.
#[derive(Clone, Copy, PartialEq)]
enum Coverage {
    /// Earlier builds': geometry, room names and portal nodes.
    GeometryAndTags,
    /// Also names, extras, materials and the settings.
    Everything,
}

/// Feeds `eat` the bytes an input hash is over. Positions and triangles go a mesh at a time
/// (XXH3 is fast on long runs, slow on many short ones). Text is followed by a 0 byte, and an
/// absent name or extras by 0xff, so no two inputs run together into the same bytes.
fn hashed_bytes(scene: &Scene, tagging: &Tagging, what: Coverage, mut eat: impl FnMut(&[u8])) {
    let everything = what == Coverage::Everything;
    let text = |t: Option<&str>, eat: &mut dyn FnMut(&[u8])| match t {
        Some(t) => {
            eat(t.as_bytes());
            eat(&[0]);
        }
        None => eat(&[0xff]),
    };
    let json = |v: Option<&serde_json::Value>| v.map(|v| v.to_string());
    // In memory the bytes are the little-endian ones the hash is defined over only on a
    // little-endian machine; elsewhere they are converted one number at a time.
    let little = cfg!(target_endian = "little");
    for n in scene.walk() {
        let node = &scene.nodes[n];
        for x in node.world.to_cols_array() {
            eat(&x.to_bits().to_le_bytes());
        }
        if everything {
            text(node.name.as_deref(), &mut eat);
            text(json(node.extras.as_ref()).as_deref(), &mut eat);
        }
        if let Some(m) = node.mesh {
            let mesh = &scene.meshes[m];
            if everything {
                text(json(mesh.extras.as_ref()).as_deref(), &mut eat);
                for p in &mesh.primitives {
                    let material = p.material.map(|i| &scene.materials[i]);
                    text(material.and_then(|m| m.name.as_deref()), &mut eat);
                    text(
                        json(material.and_then(|m| m.extras.as_ref())).as_deref(),
                        &mut eat,
                    );
                    eat(&(p.first_triangle as u64).to_le_bytes());
                    eat(&(p.triangle_count as u64).to_le_bytes());
                }
            }
            if little {
                eat(bytemuck::cast_slice(&mesh.positions));
                eat(bytemuck::cast_slice(&mesh.triangles));
                continue;
            }
            for p in &mesh.positions {
                for x in p.to_array() {
                    eat(&x.to_bits().to_le_bytes());
                }
            }
            for t in &mesh.triangles {
                for i in t {
                    eat(&i.to_le_bytes());
                }
            }
        }
    }
    // Areas are made from the geometry (hashed above), not declared.
    for r in tagging.rooms.iter().filter(|r| r.area_of.is_none()) {
        eat(r.name.as_bytes());
        eat(&[0]);
    }
    for p in &tagging.portals {
        eat(&(p.node as u64).to_le_bytes());
    }
    if everything {
        eat(&tagging.settings);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::format::NAME;
    use serde_json::Value;
    use std::path::Path;

    fn level(name: &str) -> crate::pipeline::Tagged {
        let path = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("samples")
            .join(name);
        crate::pipeline::load_tagged(&path, &Default::default()).expect("a bundled sample")
    }

    /// The bytes hashed are the documented ones, number by number in little-endian order,
    /// whichever way they are fed (a mesh's positions go as one slice of memory).
    #[test]
    fn hashed_bytes_are_the_little_endian_numbers() {
        let t = level("door_window.gltf");
        let mut want = Vec::new();
        for n in t.scene.walk() {
            let node = &t.scene.nodes[n];
            for x in node.world.to_cols_array() {
                want.extend(x.to_le_bytes());
            }
            if let Some(m) = node.mesh {
                let mesh = &t.scene.meshes[m];
                for p in &mesh.positions {
                    want.extend(p.x.to_le_bytes());
                    want.extend(p.y.to_le_bytes());
                    want.extend(p.z.to_le_bytes());
                }
                for tri in &mesh.triangles {
                    for i in tri {
                        want.extend(i.to_le_bytes());
                    }
                }
            }
        }
        for r in &t.tagging.rooms {
            want.extend(r.name.as_bytes());
            want.push(0);
        }
        for p in &t.tagging.portals {
            want.extend((p.node as u64).to_le_bytes());
        }
        let mut got = Vec::new();
        hashed_bytes(&t.scene, &t.tagging, Coverage::GeometryAndTags, |b| {
            got.extend_from_slice(b)
        });
        assert!(want.len() > 1000);
        assert_eq!(got, want);
        let legacy = format!("xxh3:{:016x}", xxhash_rust::xxh3::xxh3_64(&want));
        assert_eq!(input_hash_like(&legacy, &t.scene, &t.tagging), Some(legacy));
    }

    /// Issue 29, item 12: the hash covers every input of the result. A tag set in extras, a
    /// renamed node, a material renamed, a `[cells]` setting or a tag rule changes it; the
    /// same level loaded twice does not.
    #[test]
    fn the_input_hash_covers_extras_names_materials_and_settings() {
        let t = level("two_rooms.gltf");
        let hash = |t: &crate::pipeline::Tagged| input_hash(&t.scene, &t.tagging);
        let base = hash(&t);
        assert!(base.starts_with("xxh3v2:"), "{base}");
        assert_eq!(base, hash(&level("two_rooms.gltf")));
        let retag = |scene: Scene, config: crate::config::Config| {
            let rules = crate::config::rule_set(&config, None).unwrap();
            let imported = crate::import::Imported {
                scene,
                diagnostics: Default::default(),
            };
            crate::pipeline::tag(imported, config, rules)
        };
        let table = t
            .scene
            .nodes
            .iter()
            .position(|n| n.name.as_deref() == Some("Table-detail"))
            .unwrap();
        let floor = t
            .scene
            .nodes
            .iter()
            .position(|n| n.name.as_deref() == Some("Floor"))
            .unwrap();
        let mut changed = Vec::new();
        let mut s = t.scene.clone();
        s.nodes[table].extras = Some(serde_json::json!({"ignore": true}));
        changed.push(("extras ignore", retag(s, Default::default())));
        let mut s = t.scene.clone();
        s.nodes[floor].extras = Some(serde_json::json!({"bound": true}));
        changed.push(("extras bound", retag(s, Default::default())));
        let mut s = t.scene.clone();
        s.nodes[floor].name = Some("Floor2".into());
        changed.push(("a node renamed", retag(s, Default::default())));
        let mut s = t.scene.clone();
        s.materials[0].name = Some("nodraw".into());
        changed.push(("a material renamed", retag(s, Default::default())));
        let mut config = crate::config::Config::default();
        config.cells.max_planes = 7;
        changed.push(("[cells] max_planes", retag(t.scene.clone(), config)));
        let mut config = crate::config::Config::default();
        config.tags.preset = Some("godot".into());
        changed.push(("the godot preset", retag(t.scene.clone(), config)));
        for (what, c) in &changed {
            assert_ne!(hash(c), base, "{what}");
        }
        // Unchanged tags and settings give the same hash through the same path.
        assert_eq!(hash(&retag(t.scene.clone(), Default::default())), base);
    }

    /// A hash stored by an earlier build (FNV-1a) is recomputed as FNV-1a: the sample's
    /// annotation, written by such a build from the same level, still matches; a different
    /// level's does not, and an unknown algorithm matches nothing.
    #[test]
    fn an_earlier_builds_fnv_hash_is_recomputed_as_fnv() {
        let stored = |name: &str| {
            let path = Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("samples/broken")
                .join(name);
            let v: Value = serde_json::from_slice(&std::fs::read(path).unwrap()).unwrap();
            v["extensions"][NAME]["inputHash"]
                .as_str()
                .unwrap()
                .to_string()
        };
        let fresh = stored("PORTAL_UNPAIRED.gltf");
        assert!(fresh.starts_with("fnv1a64:"), "{fresh}");
        let t = crate::pipeline::load_tagged(
            &Path::new(env!("CARGO_MANIFEST_DIR")).join("samples/broken/PORTAL_UNPAIRED.gltf"),
            &Default::default(),
        )
        .unwrap();
        assert_eq!(
            input_hash_like(&fresh, &t.scene, &t.tagging),
            Some(fresh.clone())
        );
        let other = level("door_window.gltf");
        assert_ne!(
            input_hash_like(&fresh, &other.scene, &other.tagging),
            Some(fresh)
        );
        assert_eq!(input_hash_like("md5:00", &t.scene, &t.tagging), None);
    }
}
