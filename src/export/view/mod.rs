//! `portcullis view` and `check --html`: one self-contained HTML page that shows a converted
//! level in 3D (geometry, cells by room, portals by kind, leaks, sightline rays and the PVS of a
//! picked cell), for designers who would rather look than read.
//!
//! The page is data plus a fixed viewer: [`payload`] turns the level's stages into one JSON
//! object, and [`page`] wraps it with three.js and the viewer script, both embedded in the
//! binary, so the file opens offline from disk. Nothing here decides anything about the level;
//! it draws what the stages found.
//!
//! `page.rs` inlines the payload (coordinates rounded to 0.1 mm) with `assets/three.min.js`
//! (three.js r158, vendored unmodified with its licence: the last release with a classic-script
//! build that a page opened from disk can inline) and `assets/viewer.js` (drawing, picking, the PVS
//! of a cell, the camera's cell and what its PVS draws in view). It decides nothing about the
//! level. Invariant: the page makes no network request and exposes `window.portcullis = {ready,
//! cells, portals, select(cell)}`, which `tests/viewer.rs` drives in headless Chromium.

mod page;

pub use page::page;

use crate::level::Level;
use glam::DVec3;
use serde_json::{json, Value};

use crate::diag::{Diagnostic, Severity};
use crate::export::debug::{room_rgb, PortalStyle};
use crate::scene::Scene;
use crate::tags::Tagging;
use crate::vis::Pvs;

/// What the page shows besides the level itself.
#[derive(Debug, Default)]
pub struct Extras<'a> {
    /// Leak paths (polylines), from `check --sealed`.
    pub leaks: &'a [Vec<DVec3>],
    /// Rays that joined cells the PVS keeps apart (`PVS_MISSES_SIGHTLINE`).
    pub sightlines: &'a [Vec<DVec3>],
    /// Listed beside the view by `check --html`; each with a position can be flown to.
    pub diagnostics: &'a [Diagnostic],
}

/// Coordinates to 0.1 mm: the page draws, it does not measure, and full f64 digits tripled its
/// size.
fn r(x: f64) -> Value {
    let v = (x * 1e4).round() / 1e4;
    json!(if v == 0.0 { 0.0 } else { v })
}

fn point(p: DVec3) -> [Value; 3] {
    [r(p.x), r(p.y), r(p.z)]
}

fn flat(points: &[DVec3]) -> Vec<Value> {
    points.iter().flat_map(|p| point(*p)).collect()
}

fn hex(rgb: [f64; 3]) -> String {
    let c = |x: f64| (x.clamp(0.0, 1.0) * 255.0).round() as u8;
    format!("#{:02x}{:02x}{:02x}", c(rgb[0]), c(rgb[1]), c(rgb[2]))
}

/// The level's drawn geometry in world space, as one indexed triangle list: every mesh node
/// of the scene except authored portals, bound volumes and ignored nodes, which no renderer
/// draws.
fn geometry(scene: &Scene, tagging: &Tagging) -> Value {
    let hidden: std::collections::HashSet<usize> = tagging
        .portals
        .iter()
        .map(|p| p.node)
        .chain(tagging.bounds.iter().map(|b| b.node))
        .chain(tagging.ignored.iter().map(|i| i.node))
        .collect();
    let mut positions = Vec::new();
    let mut indices: Vec<u32> = Vec::new();
    for n in scene.walk() {
        if hidden.contains(&n) {
            continue;
        }
        let node = &scene.nodes[n];
        let Some(m) = node.mesh else { continue };
        let mesh = &scene.meshes[m];
        let base = (positions.len() / 3) as u32;
        positions.extend(
            mesh.positions
                .iter()
                .flat_map(|p| point(node.world.transform_point3(*p))),
        );
        let winding = scene.winding(n);
        for &t in &mesh.triangles {
            if t.iter().all(|&i| (i as usize) < mesh.positions.len()) {
                indices.extend(winding.order(t).map(|i| base + i));
            }
        }
    }
    json!({"positions": positions, "indices": indices})
}

/// The page's data: counts, rooms, geometry, cells (faces and planes), portals (outline,
/// cells, style), each cell's PVS row, leaks, sightline rays and diagnostics.
pub fn payload(title: &str, level: &Level, pvs: &Pvs, extras: &Extras) -> Value {
    let (scene, tagging, cells, portals) =
        (level.scene(), level.tagging(), &level.cells, &level.portals);
    let rooms: Vec<Value> = tagging
        .rooms
        .iter()
        .enumerate()
        .map(|(i, r)| json!({"name": r.name, "colour": hex(room_rgb(i))}))
        .collect();
    let cell_list: Vec<Value> = cells
        .cells
        .iter()
        .map(|c| {
            json!({
                "room": c.room,
                "faces": c.poly.faces.iter().map(|f| flat(&f.points)).collect::<Vec<_>>(),
                "planes": c.poly.faces.iter().map(|f| {
                    let (n, d) = (f.plane.normal, f.plane.d);
                    [r(n.x), r(n.y), r(n.z), r(d)]
                }).collect::<Vec<_>>(),
                "min": point(c.bounds.min),
                "max": point(c.bounds.max),
            })
        })
        .collect();
    let portal_list: Vec<Value> = portals
        .portals
        .iter()
        .map(|p| {
            let style = PortalStyle::of(p);
            json!({
                "polygon": flat(&p.polygon),
                "from": p.from,
                "to": p.to,
                "style": style.label(),
                "colour": hex(style.rgb()),
            })
        })
        .collect();
    let legend: Vec<Value> = PortalStyle::ALL
        .iter()
        .map(|s| json!({"label": s.label(), "colour": hex(s.rgb())}))
        .collect();
    let rows: Vec<Vec<usize>> = (0..pvs.cells()).map(|c| pvs.visible(c).collect()).collect();
    let lines = |ls: &[Vec<DVec3>]| -> Vec<Vec<Value>> { ls.iter().map(|l| flat(l)).collect() };
    // Errors first, then warnings, then infos, each in the order found: on a Doom map the
    // first error came after 48 notes and warnings.
    let mut listed: Vec<&Diagnostic> = extras.diagnostics.iter().collect();
    listed.sort_by_key(|d| match d.severity {
        Severity::Error => 0,
        Severity::Warning => 1,
        Severity::Info => 2,
    });
    let diagnostics: Vec<Value> = listed
        .into_iter()
        .map(|d| {
            json!({
                "severity": match d.severity {
                    Severity::Error => "error",
                    Severity::Warning => "warning",
                    Severity::Info => "info",
                },
                "code": d.code.as_str(),
                "message": d.message,
                "where": d.location.to_string(),
                "position": d.location.position,
                "hint": d.hint,
            })
        })
        .collect();
    json!({
        "title": title,
        "rooms": rooms,
        "geometry": geometry(scene, tagging),
        "cells": cell_list,
        "portals": portal_list,
        "legend": legend,
        "pvs": rows,
        "leaks": lines(extras.leaks),
        "sightlines": lines(extras.sightlines),
        "diagnostics": diagnostics,
    })
}
