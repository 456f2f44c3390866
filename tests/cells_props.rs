//! Property tests of the cells stage on generated rooms: convexity, disjointness, volume
//! conservation, and invariance under translation, rotation and scale.

mod common;

use glam::{DMat4, DQuat, DVec2, DVec3};
use portcullis::cells::{build, CellSet};
use portcullis::config::CellsConfig;
use portcullis::scene::Scene;
use portcullis::tags::{presets, recognise};
use proptest::prelude::*;

/// A prism room over a rectilinear outline (counter-clockwise in (x, z)), as an inward-facing
/// shell split into Floor / Walls / Ceiling meshes under a `hall-room` node.
fn prism_room(outline: &[DVec2], floor_rects: &[[f64; 4]], height: f64, world: DMat4) -> Scene {
    let p3 = |q: DVec2, y: f64| DVec3::new(q.x, y, q.y);
    let quad = |a: DVec3, b: DVec3, c: DVec3, d: DVec3, inward: DVec3| -> Vec<[DVec3; 3]> {
        let n = (b - a).cross(c - a);
        if n.dot(inward) >= 0.0 {
            vec![[a, b, c], [a, c, d]]
        } else {
            vec![[a, c, b], [a, d, c]]
        }
    };
    let mut floor = Vec::new();
    let mut ceiling = Vec::new();
    for r in floor_rects {
        let [x0, z0, x1, z1] = *r;
        let (a, b, c, d) = (
            DVec2::new(x0, z0),
            DVec2::new(x1, z0),
            DVec2::new(x1, z1),
            DVec2::new(x0, z1),
        );
        floor.extend(quad(
            p3(a, 0.0),
            p3(b, 0.0),
            p3(c, 0.0),
            p3(d, 0.0),
            DVec3::Y,
        ));
        ceiling.extend(quad(
            p3(a, height),
            p3(b, height),
            p3(c, height),
            p3(d, height),
            -DVec3::Y,
        ));
    }
    let mut walls = Vec::new();
    for i in 0..outline.len() {
        let (a, b) = (outline[i], outline[(i + 1) % outline.len()]);
        let e = b - a;
        // Counter-clockwise outline: the inside is to the left.
        let inward = DVec3::new(-e.y, 0.0, e.x);
        walls.extend(quad(
            p3(a, 0.0),
            p3(b, 0.0),
            p3(b, height),
            p3(a, height),
            inward,
        ));
    }
    common::scene_of(
        vec![
            ("hall-room", None, vec![], None),
            ("Floor", Some(0), floor, None),
            ("Walls", Some(0), walls, None),
            ("Ceiling", Some(0), ceiling, None),
        ],
        world,
    )
}

fn cells_of(scene: &Scene, up: DVec3) -> CellSet {
    let rules = presets::load("default").unwrap();
    let tagging = recognise(scene, &rules);
    let cfg = CellsConfig {
        up: up.to_array(),
        ..Default::default()
    };
    build(scene, &tagging, &cfg)
}

/// An L: [0,a]x[0,d] minus [b,a]x[c,d].
fn l_room(a: f64, b: f64, c: f64, d: f64, h: f64, world: DMat4) -> (Scene, f64) {
    let outline = [
        DVec2::new(0.0, 0.0),
        DVec2::new(a, 0.0),
        DVec2::new(a, c),
        DVec2::new(b, c),
        DVec2::new(b, d),
        DVec2::new(0.0, d),
    ];
    let rects = [[0.0, 0.0, a, c], [0.0, c, b, d]];
    let volume = (a * c + b * (d - c)) * h;
    (prism_room(&outline, &rects, h, world), volume)
}

/// `rel`: the relative volume error allowed (1e-9, plus what f64 rounding of the input
/// coordinates themselves costs when a small room sits far from the origin).
fn check_invariants(c: &CellSet, volume: f64, scale: f64, rel: f64) {
    let eps = c.tolerance.distance * 10.0;
    let sum: f64 = c.cells.iter().map(|x| x.volume).sum();
    // Cells are defined up to the distance tolerance: each face may sit anywhere within it,
    // so the volume is right within the tolerance times the surface area.
    let area: f64 = c
        .cells
        .iter()
        .flat_map(|x| x.poly.faces.iter())
        .map(|f| portcullis::geom::polyhedron::polygon_area(&f.points, f.plane.normal))
        .sum();
    assert!(
        (sum - volume).abs() <= rel * volume || (sum - volume).abs() <= c.tolerance.distance * area,
        "cells sum to {sum}, room {volume} (tolerance {}, area {area})",
        c.tolerance.distance
    );
    for cell in &c.cells {
        for v in cell.poly.vertices(eps) {
            for f in &cell.poly.faces {
                assert!(f.plane.distance(v) <= eps, "not convex");
            }
        }
    }
    for (i, a) in c.cells.iter().enumerate() {
        for b in &c.cells[i + 1..] {
            let v = a
                .poly
                .intersection(&b.poly, c.tolerance.distance)
                .map(|x| x.volume())
                .unwrap_or(0.0);
            assert!(v <= 1e-9 * volume.max(scale.powi(3)), "overlap {v}");
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]

    #[test]
    fn l_rooms_split_in_two_and_conserve_volume(
        a in 2.0f64..20.0, bf in 0.2f64..0.8, d in 2.0f64..20.0, cf in 0.2f64..0.8, h in 1.0f64..8.0,
    ) {
        let (b, c) = (a * bf, d * cf);
        let (scene, volume) = l_room(a, b, c, d, h, DMat4::IDENTITY);
        let cells = cells_of(&scene, DVec3::Y);
        prop_assert_eq!(cells.cells.len(), 2);
        check_invariants(&cells, volume, 1.0, 1e-9);
    }

    #[test]
    fn the_same_cells_after_moving_turning_and_scaling(
        a in 2.0f64..20.0, d in 2.0f64..20.0, h in 1.0f64..8.0,
        tx in -1e5f64..1e5, ty in -3e4f64..3e4, tz in -2e5f64..2e5,
        rx in -3.2f64..3.2, ry in -3.2f64..3.2, rz in -3.2f64..3.2,
        log_scale in -3.0f64..3.0,
    ) {
        let (b, c) = (a * 0.5, d * 0.4);
        let (base, volume) = l_room(a, b, c, d, h, DMat4::IDENTITY);
        let reference = cells_of(&base, DVec3::Y);
        let scale = 10f64.powf(log_scale);
        let m = DMat4::from_translation(DVec3::new(tx, ty, tz))
            * DMat4::from_quat(DQuat::from_euler(glam::EulerRot::XYZ, rx, ry, rz))
            * DMat4::from_scale(DVec3::splat(scale));
        let (moved, _) = l_room(a, b, c, d, h, m);
        let cells = cells_of(&moved, m.transform_vector3(DVec3::Y).normalize());
        prop_assert_eq!(cells.cells.len(), reference.cells.len());
        let far = tx.abs().max(ty.abs()).max(tz.abs()) / (scale * a.min(d));
        check_invariants(&cells, volume * scale.powi(3), scale, 1e-9 + 1e3 * f64::EPSILON * far);
        // Up to the transform: every reference vertex maps onto a vertex of the same cell.
        let tol = (cells.tolerance.distance * 10.0).max(1e-9 * scale);
        for (r, x) in reference.cells.iter().zip(&cells.cells) {
            // Cells are defined up to the distance tolerance: a face may sit anywhere within it,
            // so volumes agree within the tolerance times the surface area.
            let area: f64 = x
                .poly
                .faces
                .iter()
                .map(|f| portcullis::geom::polyhedron::polygon_area(&f.points, f.plane.normal))
                .sum();
            let dv = (r.volume * scale.powi(3) - x.volume).abs();
            prop_assert!(
                dv <= (1e-9 + 1e3 * f64::EPSILON * far) * x.volume
                    || dv <= cells.tolerance.distance * area,
                "volume differs by {} m³ (tolerance {} m, area {} m²)", dv, cells.tolerance.distance, area
            );
            let vx = x.poly.vertices(tol);
            for v in r.poly.vertices(1e-12) {
                let w = m.transform_point3(v);
                prop_assert!(vx.iter().any(|u| u.distance(w) <= tol), "vertex {} missing", w);
            }
        }
    }
}
