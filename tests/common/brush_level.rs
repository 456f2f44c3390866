//! A brush map as a level of one room (issue 41), for the tests and the benchmark: every
//! world brush a closed mesh tagged `solid` (as a brush map's importer tags them),
//! `func_detail` brushes detail, liquids and tool brushes (clip, hint, skip, trigger, origin)
//! and other brush entities left out, as qbsp leaves them out of the hull that seals; point
//! entities as nodes at their origins, `info_player_start` a player start. Props are not
//! looked for: every world brush is structure, as in qbsp.

use glam::{DMat4, DVec3};
use portcullis::pipeline::Tagged;

use super::map::{self, Entity};

/// What qbsp makes of a brush, by its entity and textures.
#[derive(PartialEq)]
pub enum Use {
    Structure,
    Detail,
    Skip,
}

pub fn brush_use(e: &Entity, b: &map::Brush) -> Use {
    let class = e.classname();
    let tex = |f: &map::Face| f.texture.to_ascii_lowercase();
    // Liquids do not seal in Quake; clip, hint, skip, trigger and origin brushes are no walls.
    let liquid = b.faces.iter().any(|f| tex(f).starts_with('*'));
    let tool = b.faces.iter().all(|f| {
        let t = tex(f);
        ["clip", "hint", "hintskip", "skip", "trigger", "origin"]
            .iter()
            .any(|k| t == *k || t.ends_with(&format!("/{k}")))
    });
    if liquid || tool || b.triangles.is_empty() {
        return Use::Skip;
    }
    match class {
        "worldspawn" | "func_group" => Use::Structure,
        c if c.starts_with("func_detail") => Use::Detail,
        _ => Use::Skip,
    }
}

/// A map as a tagged level: one room of its world brushes, its point entities as nodes.
pub fn level(entities: &[Entity]) -> (Tagged, Vec<(String, DVec3)>) {
    let mut parts: Vec<super::Part> = vec![("world-room", None, Vec::new(), None)];
    let mut points = Vec::new();
    let mut names: Vec<String> = Vec::new();
    for (ei, e) in entities.iter().enumerate() {
        for (bi, b) in e.brushes.iter().enumerate() {
            let extras = match brush_use(e, b) {
                Use::Structure => serde_json::json!({ "solid": true }),
                Use::Detail => serde_json::json!({ "solid": true, "detail": true }),
                Use::Skip => continue,
            };
            let tris = b
                .triangles
                .iter()
                .map(|t| t.map(map::to_y_up_metres))
                .collect();
            names.push(format!("e{ei}_b{bi}"));
            parts.push(("brush", Some(0), tris, Some(extras)));
        }
        if let (Some(o), true) = (e.origin(), e.brushes.is_empty()) {
            points.push((e.classname().to_string(), map::to_y_up_metres(o)));
        }
    }
    let starts: Vec<DVec3> = points
        .iter()
        .filter(|(c, _)| c.starts_with("info_player_start") || c == "info_player_deathmatch")
        .map(|(_, p)| *p)
        .collect();
    for _ in &starts {
        parts.push((
            "player_start",
            None,
            Vec::new(),
            Some(serde_json::json!({ "player_start": true })),
        ));
    }
    let mut scene = super::scene_of(parts, DMat4::IDENTITY);
    let first = scene.nodes.len() - starts.len();
    for (k, p) in starts.iter().enumerate() {
        scene.nodes[first + k].world = DMat4::from_translation(*p);
    }
    let mut config = portcullis::config::Config::default();
    // qbsp: every world brush is structure, however loose it stands.
    config.cells.detect_props = false;
    (super::tagged_with(scene, config, None), points)
}
