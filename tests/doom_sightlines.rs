//! Sightlines among the Doom maps' overlapping sectors, judged as an engine programmer's
//! oracle judges them, sharing no code with the cells, portals or PVS: rays from random eyes
//! cast against the level's triangles (parry), the point 5 mm in front of the wall hit (along
//! the wall's normal, towards the eye) looked up in the cells by their planes; a cell holding it
//! must be in the eye's cell's PVS. Eyes stand in every cell whose box overlaps a cell of
//! another room (E3M3 draws sectors over one another), where a cut, or a cell with no air of
//! its own, could leave a face no portal opens.

mod common;

use common::fixture;
use glam::DVec3;
use parry3d_f64::query::{Ray, RayCast};
use portcullis::pipeline;
use portcullis::vis::Method;

/// The cells holding `p` (within a tenth of a millimetre).
fn cells_at(level: &pipeline::Level, p: DVec3) -> Vec<usize> {
    (level.cells.cells.iter().enumerate())
        .filter(|(_, c)| c.poly.faces.iter().all(|f| f.plane.distance(p) <= 1e-4))
        .map(|(i, _)| i)
        .collect()
}

/// Rays from eyes in the cells whose boxes overlap another room's: (rays that hit, misses).
fn audit(
    level: &pipeline::Level,
    eyes_per_cell: usize,
    rays_per_eye: usize,
) -> (usize, Vec<String>) {
    let pvs = pipeline::pvs(level, Method::Full);
    let mesh = common::opaque_mesh(&level.tagged);
    let cells = &level.cells.cells;
    let overlapping: Vec<usize> = (0..cells.len())
        .filter(|&a| {
            (0..cells.len()).any(|b| {
                cells[a].room != cells[b].room && {
                    let (x, y) = (&cells[a].bounds, &cells[b].bounds);
                    (0..3).all(|k| x.min[k] < y.max[k] - 1e-3 && y.min[k] < x.max[k] - 1e-3)
                }
            })
        })
        .collect();
    assert!(!overlapping.is_empty(), "no overlapping boxes to judge");
    let mut rng = common::rng::SplitMix64::new(66);
    let (mut hits, mut misses) = (0, Vec::new());
    for &c in &overlapping {
        let b = &cells[c].bounds;
        let mut eyes = 0;
        for _ in 0..200 * eyes_per_cell {
            if eyes == eyes_per_cell {
                break;
            }
            let u = DVec3::new(rng.unit(), rng.unit(), rng.unit());
            let eye = b.min + (b.max - b.min) * u;
            if cells_at(level, eye) != vec![c] {
                continue;
            }
            eyes += 1;
            for _ in 0..rays_per_eye {
                let d = loop {
                    let v = DVec3::new(rng.unit(), rng.unit(), rng.unit()) * 2.0 - 1.0;
                    if v.length_squared() > 1e-6 && v.length_squared() <= 1.0 {
                        break v.normalize();
                    }
                };
                let ray = Ray::new(eye, d);
                let Some(h) = mesh.cast_local_ray_and_get_normal(&ray, 1e4, false) else {
                    continue;
                };
                hits += 1;
                let mut n = h.normal;
                if n.dot(d) > 0.0 {
                    n = -n;
                }
                let q = eye + d * h.time_of_impact + n * 0.005;
                let holding = cells_at(level, q);
                if !holding.is_empty() && !holding.iter().any(|&k| pvs.visible(c).any(|v| v == k)) {
                    misses.push(format!(
                        "eye {eye} in cell {c}, ray {d}: {q} in cells {holding:?}"
                    ));
                }
            }
        }
    }
    (hits, misses)
}

#[test]
fn no_sightline_is_lost_among_overlapping_sectors() {
    for (map, rays) in [
        ("E3M3_godot.glb", 128),
        ("MAP01_godot.glb", 16),
        ("E1M2_godot.glb", 16),
    ] {
        let level = common::built(&fixture(map), None);
        let (hits, misses) = audit(&level, 4, rays);
        eprintln!("{map}: {hits} rays hit, {} misses", misses.len());
        assert!(hits > 1000, "{map}: only {hits} rays judged");
        assert!(misses.is_empty(), "{map}: {}", misses.join("\n"));
    }
}

/// The ray issue 66 reported on E3M3: from sector 83, it meets a slanted wall 1.8 mm from the
/// corner where the wall meets sector 91's side, and the point 5 mm in front of the wall lies
/// across that side, where sector 91, a closed door (floor and ceiling at one height), stood as
/// a 6 m column of air extruded from its floor, in no cell of the eye's PVS. A closed door has
/// no air: the point is in no cell.
#[test]
fn the_reported_e3m3_ray_lands_in_no_cell_the_eye_cannot_see() {
    let level = common::built(&fixture("E3M3_godot.glb"), None);
    let pvs = pipeline::pvs(&level, Method::Full);
    let eye = DVec3::new(-3.25, 1.375, -14.25);
    let d = DVec3::new(0.96518, -0.20560, -0.16170).normalize();
    let mesh = common::opaque_mesh(&level.tagged);
    let h = mesh
        .cast_local_ray_and_get_normal(&Ray::new(eye, d), 1e4, false)
        .expect("the ray meets the wall");
    assert!(
        (h.time_of_impact - 1.552).abs() < 0.01,
        "{}",
        h.time_of_impact
    );
    let mut n = h.normal;
    if n.dot(d) > 0.0 {
        n = -n;
    }
    let q = eye + d * h.time_of_impact + n * 0.005;
    let from = cells_at(&level, eye);
    assert_eq!(from.len(), 1, "{from:?}");
    let room = |c: usize| {
        level.tagged.tagging.rooms[level.cells.cells[c].room]
            .name
            .clone()
    };
    assert_eq!(room(from[0]), "sector_83");
    for k in cells_at(&level, q) {
        assert!(
            pvs.visible(from[0]).any(|v| v == k),
            "{q} lies in cell {k} (room `{}`), which the eye's cell does not see",
            room(k)
        );
    }
    assert!(
        !(0..level.cells.cells.len()).any(|c| room(c) == "sector_91"),
        "the closed door sector_91 has no cell"
    );
    // Where the ray lands, approached along it (5 mm short of the wall), is the eye's own cell.
    let landing = eye + d * (h.time_of_impact - 0.005);
    assert_eq!(cells_at(&level, landing), from, "{landing}");
}
