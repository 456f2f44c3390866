//! A stored `PORTCULLIS_portals` annotation as a check subject: validated against its schema
//! and its own references first (a broken annotation is reported and not checked further,
//! since its indices cannot be trusted), compared with the level for staleness, then turned
//! into cells and portals the geometric checks read like freshly built ones.

use glam::{DMat4, DVec3};

use super::{CellInfo, Subject};
use crate::diag::{Code, Diagnostic, Location};
use crate::export as extension;
use crate::format::NAME;
use crate::format::{read, Annotated};
use crate::geom::aabb::Aabb;
use crate::geom::plane::Plane;
use crate::geom::polyhedron::{polygon_area, ConvexPolyhedron};
use crate::level::Tagged;
use crate::portals::{Portal, PortalSet};
use crate::tags::rules::PortalKind;

/// What a file's stored annotation holds and what is wrong with it.
#[derive(Debug, Clone)]
pub struct Stored {
    /// Parsed, when it parses.
    pub annotated: Option<Annotated>,
    /// ANNOTATION_INVALID (with `validate`) and ANNOTATION_STALE findings.
    pub diagnostics: Vec<Diagnostic>,
    /// The annotation's input hash no longer matches the level: rebuilt since, or edited.
    pub stale: bool,
    /// Parsed and free of schema and reference problems: safe to check geometrically.
    pub sound: bool,
}

impl Stored {
    /// What is known when the level's text cannot be read again to look for an annotation.
    fn unreadable(path: &std::path::Path, e: std::io::Error) -> Stored {
        Stored {
            annotated: None,
            diagnostics: vec![Diagnostic::new(
                Code::IO_READ_FAILED,
                format!("cannot read the stored annotation: {e}"),
                Location::file(path),
            )
            .hint("check the file again once nothing else is writing it")],
            stale: false,
            sound: false,
        }
    }
}

fn pointer(rest: &str) -> String {
    format!("/extensions/{NAME}{rest}")
}

/// The annotation of a tagged glTF level, if it has one. With `validate`, schema and
/// reference problems are reported.
pub fn read(t: &Tagged, validate: bool) -> Option<Stored> {
    let src = t.scene.gltf.as_ref()?;
    // Only the root's extensions are parsed: the rest of a big level's document is not needed.
    let doc = &match src.subset(&["extensions"]) {
        Ok(doc) => doc,
        Err(e) => return Some(Stored::unreadable(&t.scene.path, e)),
    };
    let raw = doc.get("extensions")?.get(NAME)?;
    let at = || Location::file(&t.scene.path).with_pointer(pointer(""));
    let parsed = read::annotation(doc);
    let mut problems: Vec<String> = Vec::new();
    if validate {
        problems.extend(crate::schema::validate(crate::schema::Schema::Portals, raw));
    }
    let annotated = match parsed {
        Some(Ok(a)) => {
            if validate {
                let nodes = src
                    .members()
                    .ok()
                    .flatten()
                    .and_then(|m| m.into_iter().find(|(k, _)| k == "nodes"))
                    .and_then(|(_, v)| crate::scene::json_text::array_len(v))
                    .unwrap_or(0);
                problems.extend(read::consistency(&a, nodes).iter().map(ToString::to_string));
            }
            Some(a)
        }
        Some(Err(e)) => {
            if validate && problems.is_empty() {
                problems.push(e.to_string());
            }
            None
        }
        None => None,
    };
    let mut diagnostics: Vec<Diagnostic> = problems
        .iter()
        .map(|p| {
            Diagnostic::new(
                Code::ANNOTATION_INVALID,
                format!("the stored annotation is invalid: {p}"),
                at(),
            )
            .hint("convert the level again to rewrite the annotation")
        })
        .collect();
    let stale = annotated.as_ref().is_some_and(|a| {
        extension::input_hash_like(&a.input_hash, &t.scene, &t.tagging).as_ref()
            != Some(&a.input_hash)
    });
    if stale {
        diagnostics.push(
            Diagnostic::new(
                Code::ANNOTATION_STALE,
                "the stored annotation was computed from a different level or settings (geometry, names, extras, materials, tag rules, [cells] or [portals])",
                at(),
            )
            .hint("convert the level again"),
        );
    }
    let sound = annotated.is_some() && problems.is_empty();
    Some(Stored {
        annotated,
        diagnostics,
        stale,
        sound,
    })
}

/// The stored portals as a [`PortalSet`]. Directions come from the polygons' winding
/// (counter-clockwise seen from the source cell).
pub(crate) fn portal_set(a: &Annotated) -> PortalSet {
    let portals = a
        .portals
        .iter()
        .map(|r| {
            let polygon: Vec<DVec3> = r.polygon.iter().map(|v| DVec3::from_array(*v)).collect();
            let facing = Plane::from_polygon(&polygon).map_or(DVec3::ZERO, |p| p.normal);
            Portal {
                from: r.from(),
                to: r.to(),
                area: polygon_area(&polygon, facing),
                polygon,
                normal: -facing,
                kind: match r.kind.as_deref() {
                    Some("mirror") => PortalKind::Mirror,
                    Some("teleporter") => PortalKind::Teleporter,
                    _ => PortalKind::Plain,
                },
                one_way: r.one_way,
                closed: r.closed,
                door: r.door,
                internal: r.internal,
                transform: r.transform.map(|m| DMat4::from_cols_array(&m)),
                authored: None,
                partner: r.partner,
            }
        })
        .collect();
    PortalSet {
        portals,
        ..Default::default()
    }
}

/// The scene nodes of the occupants the annotation says stand inside a solid block.
fn buried(t: &Tagged, a: &Annotated) -> Vec<crate::scene::NodeId> {
    (0..t.scene.nodes.len())
        .filter(|&n| {
            crate::export::gltf_out::node_index(&t.scene, n)
                .is_some_and(|i| a.buried_occupants.contains(&i))
        })
        .collect()
}

/// The check subject for a sound stored annotation of `t`.
pub fn subject<'a>(t: &Tagged, a: &Annotated, portals: &'a PortalSet) -> Subject<'a> {
    let eps = a.tolerance.max(1e-12);
    let names = t
        .scene
        .gltf
        .as_ref()
        .map(crate::scene::json_text::node_names)
        .unwrap_or_default();
    let node_name = |n: usize| {
        names
            .get(n)
            .and_then(Option::as_deref)
            .map_or(format!("#{n}"), str::to_string)
    };
    let mut bounds = Aabb::EMPTY;
    let cells = a
        .cells
        .iter()
        .enumerate()
        .map(|(i, c)| {
            let b = Aabb {
                min: DVec3::from_array(c.bounds.min),
                max: DVec3::from_array(c.bounds.max),
            };
            bounds = bounds.union(&b);
            let planes: Vec<Plane> = c
                .planes
                .iter()
                .filter_map(|[x, y, z, d]| {
                    let n = DVec3::new(*x, *y, *z);
                    let len = n.length();
                    (len > 0.0 && len.is_finite()).then(|| Plane {
                        normal: n / len,
                        d: d / len,
                    })
                })
                .collect();
            CellInfo {
                poly: ConvexPolyhedron::from_planes(&planes, &b, eps),
                label: format!("cell {i} (room `{}`)", c.room),
                at: Location::file(&t.scene.path).with_pointer(pointer(&format!("/cells/{i}"))),
            }
        })
        .collect();
    let file = t.scene.path.clone();
    let portal_at = a
        .portals
        .iter()
        .enumerate()
        .map(|(i, r)| {
            let loc = Location::file(&file).with_pointer(pointer(&format!("/portals/{i}")));
            match r.node {
                Some(n) => loc.with_node(node_name(n)),
                None => loc,
            }
        })
        .collect();
    let room = |c: usize| a.cells.get(c).map_or("?", |c| c.room.as_str());
    let portal_label = a
        .portals
        .iter()
        .enumerate()
        .map(|(i, r)| {
            let name = r.node.map(node_name);
            super::portal_label(i, name.as_deref(), room(r.from()), r.to().map(room))
        })
        .collect();
    Subject {
        file,
        cells,
        portals,
        portal_at,
        portal_label,
        eps,
        extent: if bounds.is_empty() {
            1.0
        } else {
            bounds.size().length()
        },
        max_wall_thickness: t.config.portals.max_wall_thickness,
        crack: crate::cells::crack_width(&t.config.cells, &t.scene),
        starts: super::starts(t, &buried(t, a)),
        overlaps: Vec::new(),
    }
}
