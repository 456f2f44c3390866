//! The runtime (issue 27) against oracles that share no code with it: per-pixel rays cast by
//! brute force through the level's own triangles (parry's BVH), carried on through mirrors and
//! teleporters by the portal's transform, and cells found by clipping each ray to the planes as
//! the test reads them from the JSON; the camera's cell against ray parity on its room's
//! triangles. Then the metamorphic properties: a closed door or a narrower view only removes
//! cells, moving level and camera together changes nothing, and without transformed portals a
//! trace stays inside the camera cell's stored PVS.

mod common;

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use common::rng::SplitMix64 as Rng;
use glam::{DMat4, DVec3};
use parry3d_f64::query::{Ray, RayCast};
use parry3d_f64::shape::TriMesh;
use portcullis::runtime::{Doors, Level, Location, Trace, TraceOptions, View};
use serde_json::Value;

/// The extension as this test reads it (its own parsing).
struct Ext {
    tol: f64,
    cells: Vec<CellJ>,
    portals: Vec<PortalJ>,
    lo: DVec3,
    hi: DVec3,
}

struct CellJ {
    room: String,
    planes: Vec<(DVec3, f64)>,
    min: DVec3,
    max: DVec3,
}

struct PortalJ {
    poly: Vec<DVec3>,
    centre: DVec3,
    /// Unit normal from the source cell into the target.
    n: DVec3,
    from: usize,
    to: Option<usize>,
    transform: Option<DMat4>,
    one_way: bool,
    closed: bool,
}

fn v3(v: &Value) -> DVec3 {
    DVec3::new(
        v[0].as_f64().unwrap(),
        v[1].as_f64().unwrap(),
        v[2].as_f64().unwrap(),
    )
}

fn margin(c: &CellJ, p: DVec3) -> f64 {
    c.planes
        .iter()
        .map(|(n, d)| d - n.dot(p))
        .fold(f64::INFINITY, f64::min)
}

fn read_ext(path: &Path) -> Ext {
    let (doc, _) = common::read_gltf(&std::fs::read(path).unwrap());
    let e = &doc["extensions"]["PORTCULLIS_portals"];
    let tol = e["tolerance"].as_f64().unwrap();
    let cells: Vec<CellJ> = e["cells"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| CellJ {
            room: c["room"].as_str().unwrap().to_string(),
            planes: c["planes"]
                .as_array()
                .unwrap()
                .iter()
                .map(|p| (v3(p), p[3].as_f64().unwrap()))
                .collect(),
            min: v3(&c["bounds"]["min"]),
            max: v3(&c["bounds"]["max"]),
        })
        .collect();
    let empty = Vec::new();
    let portals = e["portals"]
        .as_array()
        .unwrap_or(&empty)
        .iter()
        .map(|p| {
            let poly: Vec<DVec3> = p["polygon"].as_array().unwrap().iter().map(v3).collect();
            let centre = poly.iter().copied().sum::<DVec3>() / poly.len() as f64;
            let mut n = DVec3::ZERO;
            for i in 0..poly.len() {
                n += (poly[i] - centre).cross(poly[(i + 1) % poly.len()] - centre);
            }
            let mut n = n.normalize();
            let from = p["cells"][0].as_u64().unwrap() as usize;
            let size = poly.iter().map(|v| v.distance(centre)).fold(0.0, f64::max);
            // The side of the source cell: step back a little from the centre.
            if margin(&cells[from], centre - n * size * 1e-3)
                < margin(&cells[from], centre + n * size * 1e-3)
            {
                n = -n;
            }
            PortalJ {
                poly,
                centre,
                n,
                from,
                to: p["cells"]
                    .get(1)
                    .and_then(Value::as_u64)
                    .map(|t| t as usize),
                transform: p["transform"].as_array().map(|m| {
                    let a: Vec<f64> = m.iter().map(|x| x.as_f64().unwrap()).collect();
                    DMat4::from_cols_slice(&a)
                }),
                one_way: p["oneWay"] == Value::Bool(true),
                closed: p["closed"] == Value::Bool(true),
            }
        })
        .collect();
    let lo = cells
        .iter()
        .fold(DVec3::splat(f64::INFINITY), |a, c| a.min(c.min));
    let hi = cells
        .iter()
        .fold(DVec3::splat(f64::NEG_INFINITY), |a, c| a.max(c.max));
    Ext {
        tol,
        cells,
        portals,
        lo,
        hi,
    }
}

fn in_polygon(poly: &[DVec3], n: DVec3, p: DVec3) -> bool {
    let mut sign = 0.0;
    for i in 0..poly.len() {
        let s = (poly[(i + 1) % poly.len()] - poly[i])
            .cross(p - poly[i])
            .dot(n);
        if s != 0.0 {
            if sign != 0.0 && s.signum() != sign {
                return false;
            }
            sign = s.signum();
        }
    }
    true
}

/// The parameter interval of `o + t d` inside cell `c`, within `t0..t1`.
fn interval(c: &CellJ, o: DVec3, d: DVec3, t0: f64, t1: f64) -> Option<(f64, f64)> {
    let (mut a, mut b) = (t0, t1);
    for (n, off) in &c.planes {
        let (nd, no) = (n.dot(d), n.dot(o));
        if nd.abs() < 1e-300 {
            if no > *off {
                return None;
            }
            continue;
        }
        let t = (off - no) / nd;
        if nd > 0.0 {
            b = b.min(t);
        } else {
            a = a.max(t);
        }
        if a >= b {
            return None;
        }
    }
    Some((a, b))
}

fn slab_hit(c: &CellJ, o: DVec3, d: DVec3, t0: f64, t1: f64) -> bool {
    let inv = d.recip();
    let ta = (c.min - o) * inv;
    let tb = (c.max - o) * inv;
    let lo = ta.min(tb).max_element().max(t0);
    let hi = ta.max(tb).min_element().min(t1);
    lo <= hi + 1e-9
}

/// One region a pixel's ray reaches: the cell (`None` the outside) and the draw transform of
/// the space it is reached in.
type Reached = (Option<usize>, DMat4);

/// Every region the ray from `eye` along `dir` passes through for more than `min_len`
/// beyond the near plane, until the level's triangles stop it.
fn ray_regions(
    ext: &Ext,
    mesh: &TriMesh,
    eye: DVec3,
    dir: DVec3,
    near_t: f64,
    max_transforms: usize,
    min_len: f64,
) -> Vec<Reached> {
    let far = (ext.hi - ext.lo).length() * 4.0 + 1.0;
    let (mut o, mut d) = (eye, dir);
    let mut draw = DMat4::IDENTITY;
    let mut travelled = 0.0;
    let mut transforms = 0;
    let mut out: Vec<Reached> = Vec::new();
    loop {
        let t_hit = mesh
            .cast_local_ray(&Ray::new(o, d), far, false)
            .unwrap_or(far);
        // The first portal that stops or redirects the ray before the triangles do.
        let mut stop: Option<(f64, usize, bool)> = None;
        for (i, p) in ext.portals.iter().enumerate() {
            let nd = p.n.dot(d);
            if nd.abs() < 1e-12 {
                continue;
            }
            let t = p.n.dot(p.centre - o) / nd;
            if t <= 1e-9 || t >= t_hit || stop.is_some_and(|(s, _, _)| t >= s) {
                continue;
            }
            if !in_polygon(&p.poly, p.n, o + d * t) {
                continue;
            }
            let onward = nd > 0.0;
            if p.closed || (p.one_way && !onward) {
                stop = Some((t, i, false));
            } else if p.transform.is_some() && onward {
                stop = Some((t, i, true));
            }
        }
        let end = stop.map_or(t_hit, |(t, _, _)| t);
        let start = (near_t - travelled).max(0.0);
        if end - start > min_len {
            let mut covered: Vec<(f64, f64)> = Vec::new();
            for (c, cell) in ext.cells.iter().enumerate() {
                if !slab_hit(cell, o, d, start, end) {
                    continue;
                }
                if let Some((a, b)) = interval(cell, o, d, start, end) {
                    covered.push((a, b));
                    if b - a > min_len {
                        out.push((Some(c), draw));
                    }
                }
            }
            // The outside: a stretch in no cell that the ray entered through an opening to
            // the exterior. A stretch entered through a portal between cells is the depth of
            // a thick wall's doorway, and one at the ray's start an eye in no cell: neither is
            // claimed to be the outside.
            covered.sort_by(|x, y| x.0.total_cmp(&y.0));
            let mut at = start;
            let mut gaps = Vec::new();
            for (a, b) in covered {
                if a - at > min_len {
                    gaps.push((at, a));
                }
                at = at.max(b);
            }
            if end - at > min_len {
                gaps.push((at, end));
            }
            let exterior = |t: f64| {
                let p = o + d * t;
                ext.portals.iter().any(|q| {
                    q.to.is_none()
                        && q.n.dot(p - q.centre).abs() <= min_len
                        && in_polygon(&q.poly, q.n, p - q.n * q.n.dot(p - q.centre))
                })
            };
            if gaps.iter().any(|&(a, _)| a > start && exterior(a)) {
                out.push((None, draw));
            }
        }
        match stop {
            Some((t, i, true)) if transforms < max_transforms => {
                let m = ext.portals[i].transform.unwrap();
                o = m.transform_point3(o + d * t);
                d = m.transform_vector3(d).normalize();
                draw *= m.inverse();
                travelled += t;
                transforms += 1;
            }
            _ => return out,
        }
    }
}

fn same_transform(a: &DMat4, b: &DMat4) -> bool {
    a.abs_diff_eq(*b, 1e-6 * (1.0 + a.w_axis.abs().max_element()))
}

/// Converts `level` (with its preset) into `dir`, returning the .glb.
fn convert(level: &Path, preset: Option<&str>, dir: &Path) -> PathBuf {
    let out = dir.join(format!(
        "{}.glb",
        level.file_name().unwrap().to_string_lossy()
    ));
    let mut cmd = assert_cmd::Command::cargo_bin("portcullis").unwrap();
    cmd.arg("convert").arg(level).arg("-o").arg(&out);
    if let Some(p) = preset {
        cmd.args(["--tags", p]);
    }
    // Levels with warnings still convert (exit 0 or 1 with the output written).
    let o = cmd.output().unwrap();
    assert!(out.exists(), "{}", String::from_utf8_lossy(&o.stderr));
    out
}

fn levels() -> Vec<(PathBuf, Option<&'static str>)> {
    let mut v = common::levels_and_samples();
    v.push((common::fixture("MAP01_godot.glb"), None));
    v.push((common::fixture("E1M2_godot.glb"), None));
    v
}

/// Every level of [`levels`], converted into `dir` and loaded both ways: by the runtime, and
/// by this test's own reading of the extension.
fn converted(dir: &Path) -> impl Iterator<Item = (PathBuf, Level, Ext)> + '_ {
    levels().into_iter().map(move |(path, preset)| {
        let glb = convert(&path, preset, dir);
        (path, Level::load(&glb).unwrap(), read_ext(&glb))
    })
}

/// A random point at least `keep` inside cell `c`, if one is found.
fn point_in(ext: &Ext, c: usize, keep: f64, rng: &mut Rng) -> Option<DVec3> {
    let cell = &ext.cells[c];
    for _ in 0..200 {
        let p = cell.min + (cell.max - cell.min) * DVec3::new(rng.unit(), rng.unit(), rng.unit());
        if margin(cell, p) > keep {
            return Some(p);
        }
    }
    None
}

fn random_dir(rng: &mut Rng) -> DVec3 {
    loop {
        let v = DVec3::new(
            rng.unit() * 2.0 - 1.0,
            rng.unit() * 2.0 - 1.0,
            rng.unit() * 2.0 - 1.0,
        );
        let l = v.length();
        if l > 0.1 && l <= 1.0 && (v.y / l).abs() < 0.95 {
            return v / l;
        }
    }
}

struct Camera {
    eye: DVec3,
    look: DVec3,
    fov: f64,
    aspect: f64,
    near: f64,
}

impl Camera {
    fn view(&self) -> View {
        View::new(
            self.eye.to_array(),
            self.look.to_array(),
            [0.0, 1.0, 0.0],
            self.fov,
            self.aspect,
            self.near,
        )
        .unwrap()
    }

    /// The unit ray through NDC (x, y), and the distance along it to the near plane.
    fn ray(&self, x: f64, y: f64) -> (DVec3, f64) {
        let f = self.look.normalize();
        let r = f.cross(DVec3::Y).normalize();
        let u = r.cross(f);
        let ty = (self.fov.to_radians() / 2.0).tan();
        let d = (f + r * (x * ty * self.aspect) + u * (y * ty)).normalize();
        (d, self.near / d.dot(f))
    }
}

/// Random cameras inside random cells, and cameras on the axis of random portals at the
/// distances the anchors' trackers report trouble at: -1e-3, 0, +1e-3, near/2, 2 near.
fn cameras(ext: &Ext, count: usize, rng: &mut Rng) -> Vec<Camera> {
    let scale = (ext.hi - ext.lo).length();
    let near = (scale * 1e-3).clamp(0.01, 0.1);
    let mut out = Vec::new();
    for _ in 0..count {
        let c = (rng.unit() * ext.cells.len() as f64) as usize % ext.cells.len();
        if let Some(eye) = point_in(ext, c, near * 2.0, rng) {
            out.push(Camera {
                eye,
                look: random_dir(rng),
                fov: 40.0 + rng.unit() * 60.0,
                aspect: 1.0 + rng.unit(),
                near,
            });
        }
    }
    // Mirrors and teleporters, looked at from random points of the room they are in.
    for p in ext.portals.iter().filter(|p| p.transform.is_some()) {
        for _ in 0..3 {
            let c = p.from;
            if let Some(eye) = point_in(ext, c, near * 2.0, rng) {
                if (p.centre - eye).dot(p.n) > near * 4.0 {
                    out.push(Camera {
                        eye,
                        look: (p.centre - eye).normalize(),
                        fov: 50.0 + rng.unit() * 40.0,
                        aspect: 16.0 / 9.0,
                        near,
                    });
                }
            }
        }
    }
    let plain: Vec<&PortalJ> = ext
        .portals
        .iter()
        .filter(|p| p.transform.is_none() && p.n.y.abs() < 0.9)
        .collect();
    for k in 0..(count / 4).min(plain.len()) {
        let p = plain[(rng.unit() * plain.len() as f64) as usize % plain.len()];
        let s = [-1e-3, 0.0, 1e-3, near / 2.0, 2.0 * near][k % 5];
        out.push(Camera {
            eye: p.centre - p.n * s,
            look: (p.n + random_dir(rng) * 0.3).normalize(),
            fov: 70.0,
            aspect: 16.0 / 9.0,
            near,
        });
    }
    out
}

#[test]
fn every_pixel_ray_lands_in_a_traced_cell_and_its_rectangle() {
    let dir = tempfile::tempdir().unwrap();
    let mut rng = Rng::new(27);
    let (mut rays, mut checked, mut outside_checked) = (0usize, 0usize, 0usize);
    let mut transformed_checked = 0usize;
    let mut report = Vec::new();
    for (path, preset) in levels() {
        let glb = convert(&path, preset, dir.path());
        let level = Level::load(&glb).unwrap();
        let ext = read_ext(&glb);
        let (t, _, _) = common::load_level(&path, preset);
        let mesh = common::opaque_mesh(&t);
        let min_len = (ext.hi - ext.lo).length() * 1e-4;
        let opts = TraceOptions {
            max_depth: 10_000,
            ..Default::default()
        };
        let doors = Doors::new(&level);
        let mut trace = Trace::default();
        let (w, h) = (24, 14);
        let mut failures = Vec::new();
        for cam in cameras(&ext, 16, &mut rng) {
            level.trace(&cam.view(), &doors, &opts, &mut trace);
            for j in 0..h {
                for i in 0..w {
                    let x = (i as f64 + 0.5) / w as f64 * 2.0 - 1.0;
                    let y = (j as f64 + 0.5) / h as f64 * 2.0 - 1.0;
                    let (d, near_t) = cam.ray(x, y);
                    rays += 1;
                    let reached = ray_regions(
                        &ext,
                        &mesh,
                        cam.eye,
                        d,
                        near_t,
                        opts.max_transform_depth,
                        min_len,
                    );
                    for (cell, draw) in reached {
                        let identity = same_transform(&draw, &DMat4::IDENTITY);
                        let entry = trace.visible().iter().find(|v| {
                            v.cell == cell
                                && match &v.transform {
                                    None => identity,
                                    Some(m) => same_transform(m, &draw),
                                }
                        });
                        checked += 1;
                        if cell.is_none() {
                            outside_checked += 1;
                        }
                        if !identity {
                            transformed_checked += 1;
                        }
                        let e = 1e-6;
                        let ok = entry.is_some_and(|v| {
                            v.rect[0] - e <= x
                                && x <= v.rect[2] + e
                                && v.rect[1] - e <= y
                                && y <= v.rect[3] + e
                        });
                        if !ok {
                            // A ray that slips between two triangles' shared edge is not a
                            // sightline: it counts only if rays a hair beside it agree.
                            let robust = [(1e-6, 0.0), (-1e-6, 0.0), (0.0, 1e-6), (0.0, -1e-6)]
                                .iter()
                                .all(|(dx, dy)| {
                                    let (d2, n2) = cam.ray(x + dx, y + dy);
                                    ray_regions(
                                        &ext,
                                        &mesh,
                                        cam.eye,
                                        d2,
                                        n2,
                                        opts.max_transform_depth,
                                        min_len,
                                    )
                                    .iter()
                                    .any(|(c2, m2)| *c2 == cell && same_transform(m2, &draw))
                                });
                            if robust {
                                failures.push(format!(
                                    "eye {:?} look {:?} pixel ({x:.3}, {y:.3}): ray reaches {:?} ({}), trace {}",
                                    cam.eye,
                                    cam.look,
                                    cell,
                                    if identity { "direct" } else { "transformed" },
                                    match entry {
                                        None => "lacks it".to_string(),
                                        Some(v) => format!("has rect {:?}", v.rect),
                                    }
                                ));
                            }
                        }
                    }
                }
            }
        }
        if !failures.is_empty() {
            report.push(format!(
                "{}: {} misses, first: {}",
                path.display(),
                failures.len(),
                failures[..failures.len().min(3)].join("\n  ")
            ));
        }
    }
    assert!(report.is_empty(), "{}", report.join("\n"));
    assert!(rays > 50_000, "{rays} rays");
    assert!(checked > rays / 2, "{checked} region hits of {rays} rays");
    assert!(outside_checked > 0, "some rays reach the outside");
    assert!(
        transformed_checked > 0,
        "some rays pass mirrors or teleporters"
    );
    eprintln!("{rays} rays, {checked} regions reached ({outside_checked} outside, {transformed_checked} through transforms)");
}

#[test]
fn the_camera_cell_agrees_with_ray_parity_on_its_room() {
    use common::rays::{
        bounds, classify, is_closed, open_edges, room_triangles, segment_distance, signed_volume,
    };
    let dir = tempfile::tempdir().unwrap();
    let mut rng = Rng::new(2701);
    let (mut inside_judged, mut outside_judged) = (0, 0);
    for (path, preset) in levels() {
        let glb = convert(&path, preset, dir.path());
        let level = Level::load(&glb).unwrap();
        let ext = read_ext(&glb);
        let (t, c, _) = common::load_level(&path, preset);
        for (r, room) in t.tagging.rooms.iter().enumerate() {
            let cells: Vec<usize> = (0..ext.cells.len())
                .filter(|&i| ext.cells[i].room == room.name)
                .collect();
            let from_surface = c.room_cells[r].iter().all(|&i| {
                !matches!(
                    c.cells[i].source,
                    portcullis::cells::CellSource::Bound | portcullis::cells::CellSource::Footprint
                )
            });
            if cells.is_empty() || !from_surface {
                continue;
            }
            let tris = room_triangles(&t, &c, r);
            if tris.is_empty() {
                continue;
            }
            // Parity reads a closed shell that faces in; other rooms by the nearest hit's side.
            let closed = is_closed(&tris) && signed_volume(&tris) < 0.0;
            let (lo, hi) = bounds(&tris);
            let size = hi - lo;
            let edge = 1e-6 * size.max_element() + 10.0 * ext.tol;
            let rims = if closed {
                Vec::new()
            } else {
                open_edges(&tris)
            };
            let away = 0.05 * size.max_element();
            for _ in 0..60 {
                let p = lo + size * DVec3::new(rng.unit(), rng.unit(), rng.unit());
                if rims.iter().any(|&(a, b)| segment_distance(p, a, b) < away) {
                    continue;
                }
                // Within the margin of a cell's boundary the answer is the tolerance's.
                if ext.cells.iter().any(|x| margin(x, p).abs() <= edge) {
                    continue;
                }
                let Some(inside) = classify(&tris, closed, p) else {
                    continue;
                };
                let found = level.locate(p, None);
                if inside {
                    inside_judged += 1;
                    let ok = found.cell().is_some_and(|f| cells.contains(&f));
                    // A nested room's cell may hold a point of the room around it.
                    let nested = found.cell().is_some_and(|f| {
                        ext.cells[f].room != room.name && margin(&ext.cells[f], p) > 0.0
                    });
                    assert!(
                        ok || nested,
                        "{}: {p:?} is inside room {} by ray parity, located {found:?}",
                        path.display(),
                        room.name
                    );
                } else {
                    outside_judged += 1;
                    let Some(f) = found.cell() else { continue };
                    assert!(
                        !cells.contains(&f),
                        "{}: {p:?} is outside room {} by ray parity, located in its cell {f}",
                        path.display(),
                        room.name
                    );
                }
            }
        }
    }
    assert!(inside_judged > 200, "{inside_judged} inside points judged");
    assert!(
        outside_judged > 20,
        "{outside_judged} outside points judged"
    );
}

/// The visible (cell, transformed?) set of a trace.
fn seen(t: &Trace) -> BTreeSet<(Option<usize>, bool)> {
    t.visible()
        .iter()
        .map(|v| (v.cell, v.transform.is_some()))
        .collect()
}

#[test]
fn closing_a_door_or_narrowing_the_view_only_removes_cells() {
    let dir = tempfile::tempdir().unwrap();
    let mut rng = Rng::new(99);
    let mut shrank = 0;
    for (path, level, ext) in converted(dir.path()) {
        let opts = TraceOptions::default();
        let open = Doors::new(&level);
        let (mut a, mut b) = (Trace::default(), Trace::default());
        for cam in cameras(&ext, 12, &mut rng) {
            level.trace(&cam.view(), &open, &opts, &mut a);
            let wide = seen(&a);
            let narrow = Camera {
                fov: cam.fov * 0.6,
                ..cam
            };
            level.trace(&narrow.view(), &open, &opts, &mut b);
            assert!(
                seen(&b).is_subset(&wide),
                "{}: narrower view saw more",
                path.display()
            );
            shrank += usize::from(seen(&b).len() < wide.len());
            if level.portals() == 0 {
                continue;
            }
            let p = (rng.unit() * level.portals() as f64) as usize % level.portals();
            let mut doors = open.clone();
            doors.set(&level, p, true);
            level.trace(&cam.view(), &doors, &opts, &mut b);
            assert!(
                seen(&b).is_subset(&wide),
                "{}: closing portal {p} saw more",
                path.display()
            );
        }
    }
    assert!(
        shrank > 0,
        "no narrower view ever saw less: the test proves nothing"
    );
}

/// Trace options without the PVS prefilter and with no depth limit to speak of.
fn unfiltered() -> TraceOptions {
    TraceOptions {
        use_pvs: false,
        max_depth: 10_000,
        ..Default::default()
    }
}

#[test]
fn without_transformed_portals_a_trace_stays_in_the_camera_cells_pvs() {
    let dir = tempfile::tempdir().unwrap();
    let mut rng = Rng::new(5);
    let mut compared = 0;
    for (path, level, ext) in converted(dir.path()) {
        if ext.portals.iter().any(|p| p.transform.is_some()) {
            continue;
        }
        let opts = unfiltered();
        let doors = Doors::new(&level);
        let mut t = Trace::default();
        for cam in cameras(&ext, 12, &mut rng) {
            level.trace(&cam.view(), &doors, &opts, &mut t);
            let Location::Inside(c) = t.location else {
                continue;
            };
            for v in t.visible() {
                if let Some(x) = v.cell {
                    compared += 1;
                    assert!(
                        level.pvs_sees(c, x),
                        "{}: from cell {c} the trace reaches cell {x}, which its stored PVS lacks",
                        path.display()
                    );
                }
            }
        }
    }
    assert!(compared > 100, "{compared}");
}

/// Distance from `p` to the convex planar polygon `poly` (this test's own: the runtime has one).
fn to_polygon(p: DVec3, poly: &[DVec3], n: DVec3) -> f64 {
    let h = n.dot(p - poly[0]);
    let q = p - n * h;
    if in_polygon(poly, n, q) {
        return h.abs();
    }
    (0..poly.len())
        .map(|i| {
            let (a, b) = (poly[i], poly[(i + 1) % poly.len()]);
            let t = ((p - a).dot(b - a) / (b - a).length_squared()).clamp(0.0, 1.0);
            p.distance(a + (b - a) * t)
        })
        .fold(f64::INFINITY, f64::min)
}

/// Issue 43, item 4: cameras at the middle of every cell's box (which lies on the planes that
/// aligned portal edges span, as a Doom map's grid makes them), looking 12 ways. Without
/// the prefilter, a trace stays inside the stored PVS: an eye on such a plane saw a view
/// pinched to a line through 11 portals on Freedoom E1M2, kept alive by the clipping's
/// slack. Cameras whose near plane can reach through a portal are passed over: they see
/// through it with the whole view, which is what the near plane shows, not a sightline.
#[test]
fn a_trace_from_a_cells_middle_stays_in_its_pvs() {
    let dir = tempfile::tempdir().unwrap();
    let (mut traced, mut compared) = (0, 0);
    for level_file in ["E1M2_godot.glb", "MAP01_godot.glb", "E3M3_godot.glb"] {
        let glb = convert(&common::fixture(level_file), None, dir.path());
        let level = Level::load(&glb).unwrap();
        let ext = read_ext(&glb);
        let opts = unfiltered();
        let doors = Doors::new(&level);
        let mut t = Trace::default();
        let (fov, aspect, near) = (90.0f64, 16.0 / 9.0, 0.05);
        let half = (fov.to_radians() / 2.0).tan();
        let reach = near * (1.0 + half * half * (1.0 + aspect * aspect)).sqrt() + ext.tol;
        let mut looks = Vec::new();
        for k in 0..8 {
            let a = k as f64 * std::f64::consts::FRAC_PI_4;
            looks.push(DVec3::new(a.cos(), 0.0, a.sin()));
            if k % 2 == 0 {
                looks.push(DVec3::new(a.cos(), 0.7, a.sin()).normalize());
            }
        }
        for (c, cell) in ext.cells.iter().enumerate() {
            let eye = (cell.min + cell.max) * 0.5;
            if margin(cell, eye) <= reach
                || ext
                    .portals
                    .iter()
                    .any(|p| to_polygon(eye, &p.poly, p.n) <= reach)
            {
                continue;
            }
            for &look in &looks {
                let view = View::new(
                    eye.to_array(),
                    look.to_array(),
                    [0.0, 1.0, 0.0],
                    fov,
                    aspect,
                    near,
                )
                .unwrap();
                level.trace(&view, &doors, &opts, &mut t);
                assert_eq!(t.location, Location::Inside(c), "{level_file}: eye {eye}");
                traced += 1;
                for x in t.visible().iter().filter_map(|v| v.cell) {
                    compared += 1;
                    assert!(
                        level.pvs_sees(c, x),
                        "{level_file}: from {eye} looking {look} in cell {c} the trace reaches cell {x}, which its stored PVS lacks"
                    );
                }
            }
        }
    }
    assert!(traced > 10_000 && compared > 100_000, "{traced} {compared}");
}

/// Issue 43: a camera in samples/wedge_room.gltf's wedge, 4 cm at its widest (the eye 1.3 cm
/// from its walls, the near plane 2 mm away), sees what rays cast from its eye through the
/// level's triangles see: both wide cells beside it, every pixel inside the traced rectangle.
#[test]
fn a_camera_in_a_four_centimetre_wedge_sees_what_rays_from_its_eye_see() {
    let dir = tempfile::tempdir().unwrap();
    let path = common::sample("wedge_room.gltf");
    let glb = convert(&path, None, dir.path());
    let level = Level::load(&glb).unwrap();
    let ext = read_ext(&glb);
    let (t, _, _) = common::load_level(&path, None);
    let mesh = common::opaque_mesh(&t);
    let eye = DVec3::new(5.0, 1.5, 4.0 + 0.04 * 2.0 / 3.0 / 2.0);
    let wedge = (0..ext.cells.len())
        .find(|&c| margin(&ext.cells[c], eye) > 0.0)
        .unwrap();
    assert!(
        ext.cells[wedge].max.z - ext.cells[wedge].min.z < 0.05,
        "the eye is in the wedge"
    );
    let doors = Doors::new(&level);
    let opts = TraceOptions::default();
    let mut trace = Trace::default();
    let mut reached_all = BTreeSet::new();
    for look in [
        DVec3::new(-1.0, 0.0, -0.3),
        DVec3::new(1.0, 0.0, -0.3),
        DVec3::new(0.0, 0.0, -1.0),
        DVec3::new(-0.5, -0.2, -1.0),
        DVec3::new(0.7, 0.3, -1.0),
    ] {
        let cam = Camera {
            eye,
            look: look.normalize(),
            fov: 80.0,
            aspect: 16.0 / 9.0,
            near: 0.002,
        };
        level.trace(&cam.view(), &doors, &opts, &mut trace);
        assert_eq!(trace.location, Location::Inside(wedge));
        let (w, h) = (64, 36);
        for j in 0..h {
            for i in 0..w {
                let x = (i as f64 + 0.5) / w as f64 * 2.0 - 1.0;
                let y = (j as f64 + 0.5) / h as f64 * 2.0 - 1.0;
                let (d, near_t) = cam.ray(x, y);
                for (cell, _) in ray_regions(&ext, &mesh, eye, d, near_t, 0, 1e-4) {
                    reached_all.insert(cell);
                    let entry = trace.visible().iter().find(|v| v.cell == cell);
                    let e = 1e-6;
                    assert!(
                        entry.is_some_and(|v| v.rect[0] - e <= x
                            && x <= v.rect[2] + e
                            && v.rect[1] - e <= y
                            && y <= v.rect[3] + e),
                        "look {look}, pixel ({x:.3}, {y:.3}): the ray reaches {cell:?}, the trace {:?}",
                        entry.map(|v| v.rect)
                    );
                }
            }
        }
    }
    let wide: BTreeSet<Option<usize>> = (0..ext.cells.len())
        .filter(|&c| c != wedge)
        .map(Some)
        .collect();
    assert!(
        wide.is_subset(&reached_all),
        "rays from the wedge reach {reached_all:?}"
    );
}

/// The extension moved by `m` (a rigid motion), as JSON.
fn moved(doc: &Value, m: DMat4) -> Value {
    let mut e = doc.clone();
    let pt = |v: &Value| -> Value {
        let p = m.transform_point3(v3(v));
        serde_json::json!([p.x, p.y, p.z])
    };
    for c in e["cells"].as_array_mut().unwrap() {
        for p in c["planes"].as_array_mut().unwrap() {
            let n = v3(p);
            let on = n * p[3].as_f64().unwrap();
            let (n2, on2) = (m.transform_vector3(n), m.transform_point3(on));
            *p = serde_json::json!([n2.x, n2.y, n2.z, n2.dot(on2)]);
        }
        let (lo, hi) = (v3(&c["bounds"]["min"]), v3(&c["bounds"]["max"]));
        let mut a = DVec3::splat(f64::INFINITY);
        let mut b = DVec3::splat(f64::NEG_INFINITY);
        for i in 0..8 {
            let corner =
                DVec3::select(glam::BVec3::new(i & 1 != 0, i & 2 != 0, i & 4 != 0), hi, lo);
            let q = m.transform_point3(corner);
            a = a.min(q);
            b = b.max(q);
        }
        c["bounds"] = serde_json::json!({"min": [a.x, a.y, a.z], "max": [b.x, b.y, b.z]});
    }
    if let Some(ps) = e.get_mut("portals").and_then(Value::as_array_mut) {
        for p in ps {
            let poly: Vec<Value> = p["polygon"].as_array().unwrap().iter().map(pt).collect();
            p["polygon"] = Value::Array(poly);
            if let Some(t) = p["transform"].as_array() {
                let a: Vec<f64> = t.iter().map(|x| x.as_f64().unwrap()).collect();
                let conj = m * DMat4::from_cols_slice(&a) * m.inverse();
                p["transform"] = serde_json::json!(conj.to_cols_array());
            }
        }
    }
    e
}

/// A converted level loaded as it is and moved by rigid motions, for invariance tests.
struct Movable {
    ext_json: Value,
    pvs: Option<portcullis::format::Pvs>,
    level: Level,
}

impl Movable {
    fn load(glb: &Path) -> Movable {
        let (doc, bin) = common::read_gltf(&std::fs::read(glb).unwrap());
        let ext_json = doc["extensions"]["PORTCULLIS_portals"].clone();
        let base: portcullis::format::Annotated = serde_json::from_value(ext_json.clone()).unwrap();
        let bufs: Vec<Vec<u8>> = bin.into_iter().collect();
        let pvs = portcullis::format::read::visibility(&base, &doc, &bufs).map(|r| r.unwrap());
        let level = Level::from_annotation(&base, pvs.clone()).unwrap();
        Movable {
            ext_json,
            pvs,
            level,
        }
    }

    fn moved(&self, m: DMat4) -> Level {
        let a: portcullis::format::Annotated =
            serde_json::from_value(moved(&self.ext_json, m)).unwrap();
        Level::from_annotation(&a, self.pvs.clone()).unwrap()
    }
}

/// Asserts that `cam` in `level` and the camera moved by `m` in `there` (the level moved by
/// `m`) find the same location, cells and rectangles.
fn same_answer_moved(level: &Level, there: &Level, cam: &Camera, m: DMat4, what: &str) {
    let opts = TraceOptions::default();
    let v1 = View::new(
        m.transform_point3(cam.eye).to_array(),
        m.transform_vector3(cam.look).to_array(),
        m.transform_vector3(DVec3::Y).to_array(),
        cam.fov,
        cam.aspect,
        cam.near,
    )
    .unwrap();
    let (mut t0, mut t1) = (Trace::default(), Trace::default());
    level.trace(&cam.view(), &Doors::new(level), &opts, &mut t0);
    there.trace(&v1, &Doors::new(there), &opts, &mut t1);
    let at = format!(
        "{what}: eye {:?} look {:?} moved by {m:?}",
        cam.eye, cam.look
    );
    assert_eq!(t0.location, t1.location, "{at}");
    assert_eq!(seen(&t0), seen(&t1), "{at}");
    for v in t0.visible() {
        let w = t1
            .visible()
            .iter()
            .find(|w| w.cell == v.cell && w.transform.is_some() == v.transform.is_some())
            .unwrap();
        for k in 0..4 {
            assert!(
                (v.rect[k] - w.rect[k]).abs() < 1e-6,
                "{at}: rect {:?} became {:?}",
                v.rect,
                w.rect
            );
        }
    }
}

/// At least 240 cameras drawn in every level (random cells, mirrors, portals at the distances
/// trackers report trouble at), each traced as it is and with the level moved, turned about
/// Y and about an oblique axis, and both. Three levels or more keep 200 cameras.
#[test]
fn moving_the_level_and_the_camera_together_changes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let motions = [
        DMat4::from_translation(DVec3::new(1e5, -3e4, 2e5)),
        DMat4::from_translation(DVec3::new(1048576.0, 0.0, 0.0)),
        DMat4::from_rotation_y(30f64.to_radians()),
        DMat4::from_rotation_y(137f64.to_radians())
            * DMat4::from_translation(DVec3::new(3.0, 0.0, -7.0)),
        DMat4::from_translation(DVec3::new(1e5, 1e5, -1e5))
            * DMat4::from_axis_angle(DVec3::new(1.0, 2.0, 3.0).normalize(), 37f64.to_radians()),
    ];
    let (mut traces, mut many) = (0, 0);
    for (path, preset) in levels() {
        let glb = convert(&path, preset, dir.path());
        let movable = Movable::load(&glb);
        let ext = read_ext(&glb);
        // Each level's cameras from a seed of its own, so adding a level moves no other's.
        let name = path.file_name().unwrap().to_string_lossy();
        let mut rng = Rng::new(
            name.bytes()
                .fold(11u64, |h, b| h.wrapping_mul(31) ^ b as u64),
        );
        let cams = cameras(&ext, 240, &mut rng);
        if cams.len() >= 200 {
            many += 1;
        }
        for m in motions {
            let there = movable.moved(m);
            for cam in &cams {
                same_answer_moved(&movable.level, &there, cam, m, &path.display().to_string());
                traces += 1;
            }
        }
    }
    eprintln!("{many} levels with 200 cameras or more, {traces} traces compared");
    assert!(many >= 3, "only {many} levels kept 200 cameras");
    assert!(traces > 3000, "{traces} traces");
}

/// Issue 53: in Freedoom MAP01 an eye at (42, -1, 28) lies on the plane through a chain of
/// aligned portal edges, and sees cells 234 and 235 through a view pinched to a sliver a few
/// hairs wide. Whether rounding kept that sliver changed when the level and the camera were
/// turned 30 degrees about Y. Every look around that eye, turned and moved, gives one answer.
#[test]
fn an_eye_on_a_plane_of_aligned_portal_edges_sees_the_same_turned() {
    let dir = tempfile::tempdir().unwrap();
    let glb = convert(&common::fixture("MAP01_godot.glb"), None, dir.path());
    let movable = Movable::load(&glb);
    for m in [
        DMat4::from_rotation_y(30f64.to_radians()),
        DMat4::from_translation(DVec3::new(1e5, 1e5, -1e5))
            * DMat4::from_axis_angle(DVec3::new(1.0, 2.0, 3.0).normalize(), 37f64.to_radians()),
    ] {
        let there = movable.moved(m);
        for az in 0..72 {
            for el in [-30.0f64, 0.0, 30.0] {
                for (fov, aspect) in [(60.0, 1.0), (90.0, 16.0 / 9.0), (70.0, 1.5)] {
                    let (t, e) = ((az as f64 * 5.0).to_radians(), el.to_radians());
                    let cam = Camera {
                        eye: DVec3::new(42.0, -1.0, 28.0),
                        look: DVec3::new(t.cos() * e.cos(), e.sin(), t.sin() * e.cos()),
                        fov,
                        aspect,
                        near: 0.05,
                    };
                    same_answer_moved(&movable.level, &there, &cam, m, "MAP01");
                }
            }
        }
    }
}

fn cull_cmd() -> assert_cmd::Command {
    assert_cmd::Command::cargo_bin("portcullis").unwrap()
}

#[test]
fn cull_reports_each_camera_as_json_and_as_text() {
    let dir = tempfile::tempdir().unwrap();
    let glb = convert(&common::sample("teleporter.gltf"), None, dir.path());
    let cams = dir.path().join("cams.jsonl");
    std::fs::write(
        &cams,
        concat!(
            "{\"eye\":[2,1.5,2],\"look\":[1,0,0],\"up\":[0,1,0],\"fov_y\":70,\"aspect\":1.78,\"near\":0.05}\n",
            "\n",
            "{\"eye\":[2,1.5,2],\"look\":[-1,0,0]}\n",
            "{\"eye\":[50,50,50],\"look\":[1,0,0]}\n",
        ),
    )
    .unwrap();
    // `cull LEVEL --cameras CAMS EXTRA...`, which must succeed: its stdout.
    let cull = |extra: &[&str]| {
        common::succeeds(
            cull_cmd()
                .arg("cull")
                .arg(&glb)
                .arg("--cameras")
                .arg(&cams)
                .args(extra),
        )
        .stdout
    };
    let r: Value = serde_json::from_slice(&cull(&["--format", "json"])).unwrap();
    let r = r.as_array().unwrap();
    assert_eq!(r.len(), 3, "one result per camera, blank lines skipped");
    assert_eq!(r[0]["cell"], 0);
    assert_eq!(r[0]["location"], "inside");
    let vis = r[0]["visible"].as_array().unwrap();
    assert_eq!(vis.len(), 2, "{vis:?}");
    assert_eq!(vis[0]["cell"], 0);
    assert_eq!(vis[0]["depth"], 0);
    assert!(vis[0].get("transform").is_none());
    assert_eq!(vis[1]["cell"], 1);
    assert_eq!(vis[1]["via"], serde_json::json!([0]));
    assert_eq!(vis[1]["mirrored"], false);
    // Cell b (x 10..14) drawn where the teleporter shows it: 6 m back towards the camera.
    assert_eq!(vis[1]["transform"][12], -6.0);
    let rect: Vec<f64> = vis[1]["rect"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    assert!(
        rect[0] < 0.0 && rect[2] > 0.0 && rect[0] > -1.0 && rect[2] < 1.0,
        "{rect:?}"
    );
    assert_eq!(r[1]["visible"].as_array().unwrap().len(), 1, "looking away");
    assert_eq!(r[2]["cell"], Value::Null);
    assert_eq!(r[2]["location"], "outside");
    assert!(r[2]["nearest"].is_u64());
    assert!(r[0]["stats"]["portals_tested"].as_u64().unwrap() >= 1);
    // Closing the teleporter (and its partner) leaves the camera's own cell.
    let r: Value = serde_json::from_slice(&cull(&["--format", "json", "--closed", "1"])).unwrap();
    assert_eq!(r[0]["visible"].as_array().unwrap().len(), 1);
    let text = String::from_utf8(cull(&[])).unwrap();
    assert!(
        text.contains("camera 1: inside of cell 0 (a); 2 visible"),
        "{text}"
    );
    assert!(
        text.contains("cell 1 (b)  depth 1") && text.contains("via 0  (transformed)"),
        "{text}"
    );
    assert!(
        text.contains("camera 3: outside every cell (nearest: cell"),
        "{text}"
    );
}

/// `cull --stats` prices each view three ways; on pillar_room (Floor, Walls and Ceiling one
/// node each, in all four cells) the draw lists submit less than the whole nodes, which
/// submit no more than frustum culling alone.
/// A cameras file in `dir`: every cell's centre, looking along +x, +z, -x and -z.
fn centre_cameras(level: &Level, fov_y: f64, dir: &Path) -> PathBuf {
    let cams = dir.join("cams.jsonl");
    let mut lines = String::new();
    for c in 0..level.cells() {
        let (lo, hi) = level.bounds(c);
        let eye: Vec<f64> = (0..3).map(|i| (lo[i] + hi[i]) / 2.0).collect();
        for look in ["[1,0,0]", "[0,0,1]", "[-1,0,0]", "[0,0,-1]"] {
            lines += &format!("{{\"eye\":{eye:?},\"look\":{look},\"fov_y\":{fov_y}}}\n");
        }
    }
    std::fs::write(&cams, lines).unwrap();
    cams
}

#[test]
fn cull_stats_price_each_view_by_draw_lists_whole_nodes_and_frustum() {
    let dir = tempfile::tempdir().unwrap();
    let glb = convert(&common::sample("pillar_room.gltf"), None, dir.path());
    let level = Level::load(&glb).unwrap();
    let cams = centre_cameras(&level, 75.0, dir.path());
    let cull = |extra: &[&str]| {
        let mut c = cull_cmd();
        c.arg("cull")
            .arg(&glb)
            .arg("--cameras")
            .arg(&cams)
            .arg("--stats")
            .args(extra);
        common::succeeds(&mut c).stdout
    };
    let r: Value = serde_json::from_slice(&cull(&["--format", "json"])).unwrap();
    let r = r.as_array().unwrap();
    assert_eq!(r.len(), 4 * level.cells());
    let tri = |v: &Value, k: &str| v["submitted"][k]["triangles"].as_u64().unwrap();
    let mut fewer = 0;
    for v in r {
        let (lists, nodes, frustum) = (tri(v, "lists"), tri(v, "nodes"), tri(v, "frustum"));
        assert!(
            0 < lists && lists <= nodes && nodes <= frustum && frustum <= 64,
            "{v}"
        );
        fewer += usize::from(lists < nodes);
        let own: u64 = (v["visible"].as_array().unwrap().iter())
            .map(|c| c["triangles"].as_u64().unwrap())
            .sum();
        assert!(
            own >= lists,
            "the visible cells' own triangles hold what is drawn: {v}"
        );
    }
    assert!(
        fewer * 2 >= r.len(),
        "draw lists drew less in only {fewer} views"
    );
    let text = String::from_utf8(cull(&[])).unwrap();
    assert!(text.contains("  submitted: draw lists "), "{text}");
    assert!(
        text.contains(&format!("{} views of a level of 64 triangles", r.len())),
        "{text}"
    );
}

/// What the cells `cells` draw, computed from the file's `cells[].nodes`, `cells[].draws` and
/// `split` alone: the nodes not split, and each split primitive's indices as a set, cut into
/// runs of consecutive indices (`[node, primitive, first, count]`).
fn draw_of_cells(ext: &Value, cells: &[u64]) -> Value {
    let prims = ext["split"]["primitives"]
        .as_array()
        .cloned()
        .unwrap_or_default();
    let split: BTreeSet<u64> = prims.iter().map(|p| p["node"].as_u64().unwrap()).collect();
    let mut nodes = BTreeSet::new();
    let mut indices: BTreeSet<(u64, u64)> = BTreeSet::new();
    for &c in cells {
        let cell = &ext["cells"][c as usize];
        for n in cell["nodes"].as_array().unwrap() {
            let n = n.as_u64().unwrap();
            if !split.contains(&n) {
                nodes.insert(n);
            }
        }
        for d in cell["draws"].as_array().into_iter().flatten() {
            let [k, first, count] = [0, 1, 2].map(|i| d[i].as_u64().unwrap());
            let p = &prims[k as usize];
            let (pf, pc) = (p["first"].as_u64().unwrap(), p["count"].as_u64().unwrap());
            assert!(pf <= first && first + count <= pf + pc, "{d} outside {p}");
            indices.extend((first..first + count).map(|i| (k, i)));
        }
    }
    let mut runs: Vec<[u64; 3]> = Vec::new();
    for (k, i) in indices {
        match runs.last_mut() {
            Some(r) if r[0] == k && r[1] + r[2] == i => r[2] += 1,
            _ => runs.push([k, i, 1]),
        }
    }
    let ranges: Vec<Value> = (runs.iter())
        .map(|&[k, first, count]| {
            let p = &prims[k as usize];
            serde_json::json!([p["node"], p["primitive"], first, count])
        })
        .collect();
    serde_json::json!({"nodes": nodes, "ranges": ranges})
}

/// `cull --draw-lists`: each view's draw list is the union of the file's lists of the cells it
/// sees without a transform, and each entry seen through a mirror or teleporter carries its
/// own cell's; without the flag the output is the same less the lists.
#[test]
fn cull_draw_lists_are_the_files_lists_of_the_visible_cells() {
    let dir = tempfile::tempdir().unwrap();
    let mut joined = 0;
    let mut moved = 0;
    for name in [
        "pillar_room.gltf",
        "brush_doors.map",
        "mirror.gltf",
        "block_door.gltf",
    ] {
        let glb = convert(&common::sample(name), None, dir.path());
        let (doc, _) = common::read_gltf(&std::fs::read(&glb).unwrap());
        let ext = &doc["extensions"]["PORTCULLIS_portals"];
        let level = Level::load(&glb).unwrap();
        let cams = centre_cameras(&level, 90.0, dir.path());
        let cull = |extra: &[&str]| {
            let mut c = cull_cmd();
            c.arg("cull")
                .arg(&glb)
                .arg("--cameras")
                .arg(&cams)
                .args(extra);
            common::succeeds(&mut c).stdout
        };
        let with = cull(&["--format", "jsonl", "--draw-lists"]);
        let without = cull(&["--format", "jsonl"]);
        let text = String::from_utf8(cull(&["--draw-lists"])).unwrap();
        let with = String::from_utf8(with).unwrap();
        let without = String::from_utf8(without).unwrap();
        assert_eq!(with.lines().count(), 4 * level.cells(), "{name}");
        let mut human = Vec::new();
        for (a, b) in with.lines().zip(without.lines()) {
            let mut r: Value = serde_json::from_str(a).unwrap();
            let direct: Vec<u64> = (r["visible"].as_array().unwrap().iter())
                .filter(|v| v.get("transform").is_none())
                .filter_map(|v| v["cell"].as_u64())
                .collect();
            assert_eq!(r["draw"], draw_of_cells(ext, &direct), "{name}: {a}");
            let own: usize = (direct.iter())
                .map(|&c| {
                    ext["cells"][c as usize]["draws"]
                        .as_array()
                        .map_or(0, Vec::len)
                })
                .sum();
            joined += usize::from(r["draw"]["ranges"].as_array().unwrap().len() < own);
            for v in r["visible"].as_array_mut().unwrap() {
                match (v.get("transform"), v["cell"].as_u64()) {
                    (Some(_), Some(c)) => {
                        assert_eq!(v["draw"], draw_of_cells(ext, &[c]), "{name}: {a}");
                        moved += 1;
                    }
                    (Some(_), None) => assert_eq!(v["draw"], draw_of_cells(ext, &[]), "{a}"),
                    (None, _) => assert!(v.get("draw").is_none(), "{name}: {a}"),
                }
                v.as_object_mut().unwrap().shift_remove("draw");
            }
            let counts = format!(
                "  draw: {} nodes, {} ranges",
                r["draw"]["nodes"].as_array().unwrap().len(),
                r["draw"]["ranges"].as_array().unwrap().len()
            );
            r.as_object_mut().unwrap().shift_remove("draw");
            assert_eq!(r.to_string(), b, "{name}: the flag adds the lists alone");
            human.push(counts);
        }
        let said: Vec<&str> = (text.lines())
            .filter(|l| l.starts_with("  draw: "))
            .collect();
        assert_eq!(said.len(), human.len(), "{name}: {text}");
        for (line, counts) in said.iter().zip(&human) {
            assert!(
                line.starts_with(counts.as_str()),
                "{name}: {line} for {counts}"
            );
        }
    }
    assert!(joined > 0, "no view joined ranges of two cells");
    assert!(moved > 0, "no view through the mirror");
}

#[test]
fn cull_refuses_bad_input_with_what_where_and_how() {
    let dir = tempfile::tempdir().unwrap();
    let glb = convert(&common::sample("two_rooms.gltf"), None, dir.path());
    let unconverted = common::sample("two_rooms.gltf");
    let missing = dir.path().join("missing.glb");
    // A converted .glb cut short, and one cut inside its header: the shared GLB reader names
    // what is wrong with the container.
    let cut = dir.path().join("cut.glb");
    std::fs::write(&cut, &std::fs::read(&glb).unwrap()[..300]).unwrap();
    let stub = dir.path().join("stub.glb");
    std::fs::write(&stub, b"glTF\x02\x00\x00\x00").unwrap();
    let cams = dir.path().join("cams.jsonl");
    let good = "{\"eye\":[1,1,1],\"look\":[1,0,0]}\n";
    // (level, cameras, extra arguments, what the report must say); each run exits 2 and
    // prints nothing on stdout.
    let cases: [(&Path, String, &[&str], &[&str]); 11] = [
        (
            &glb,
            format!("{good}{{\"eye\":[1,1],\"look\":[1,0,0]}}\n"),
            &[],
            &["error[CULL_CAMERA_INVALID]", "cams.jsonl:2", "hint:"],
        ),
        (
            &glb,
            "{\"eye\":[1,1,1],\"look\":[0,1,0],\"up\":[0,2,0]}\n".into(),
            &[],
            &["error[CULL_CAMERA_INVALID]", "cams.jsonl:1", "up"],
        ),
        // Unknown fields are typos.
        (
            &glb,
            "{\"eye\":[1,1,1],\"look\":[1,0,0],\"fov\":60}\n".into(),
            &[],
            &["error[CULL_CAMERA_INVALID]"],
        ),
        (
            &glb,
            good.into(),
            &["--closed", "7"],
            &[
                "error[CULL_PORTAL_UNKNOWN]",
                "portal 7 does not exist",
                "2 portals",
                "#/extensions/PORTCULLIS_portals/portals",
            ],
        ),
        // Door options that contradict each other or repeat (portals 0 and 1 are one door).
        (
            &glb,
            good.into(),
            &["--closed", "0", "--open", "0"],
            &["error: portal 0 is given with both --closed and --open"],
        ),
        (
            &glb,
            good.into(),
            &["--closed", "0", "--closed", "0"],
            &["error: portal 0 is given twice (--closed 0)"],
        ),
        (
            &glb,
            good.into(),
            &["--closed", "0", "--open", "1"],
            &[
                "portals 0 and 1 are the two sides of one door",
                "give one of them",
            ],
        ),
        (
            &unconverted,
            good.into(),
            &[],
            &[
                "error[CULL_NOT_CONVERTED]",
                "no PORTCULLIS_portals extension",
                "portcullis convert",
            ],
        ),
        (
            &missing,
            good.into(),
            &[],
            &["error[IO_READ_FAILED]", "cannot be read"],
        ),
        (
            &cut,
            good.into(),
            &[],
            &[
                "error[CULL_NOT_CONVERTED]",
                "not a readable .glb: truncated GLB: the header says",
                "but the file has 300",
            ],
        ),
        (
            &stub,
            good.into(),
            &[],
            &[
                "error[CULL_NOT_CONVERTED]",
                "8 bytes, shorter than the 12-byte header",
            ],
        ),
    ];
    for (level, cams_text, extra, says) in cases {
        std::fs::write(&cams, &cams_text).unwrap();
        let o = cull_cmd()
            .arg("cull")
            .arg(level)
            .arg("--cameras")
            .arg(&cams)
            .args(extra)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{cams_text} {extra:?}: {err}");
        for s in says {
            assert!(err.contains(s), "{cams_text} {extra:?}: no `{s}` in {err}");
        }
        assert!(o.stdout.is_empty(), "{cams_text} {extra:?}");
    }
}

#[test]
fn a_level_without_rooms_loads_and_everything_is_outside() {
    let dir = tempfile::tempdir().unwrap();
    for name in ["occlusion_room.glb", "gi_zdm2.glb", "living_room.glb"] {
        let glb = convert(&common::fixture(name), None, dir.path());
        let level = Level::load(&glb).unwrap();
        assert_eq!((level.cells(), level.portals()), (0, 0), "{name}");
        let v = View::new(
            [0.0, 1.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            60.0,
            1.5,
            0.05,
        )
        .unwrap();
        let mut t = Trace::default();
        level.trace(&v, &Doors::new(&level), &TraceOptions::default(), &mut t);
        assert_eq!(t.location, Location::Outside { nearest: None }, "{name}");
        assert_eq!(seen(&t), BTreeSet::from([(None, false)]), "{name}");
        let mut touching = vec![7];
        level.cells_touching(DVec3::splat(-1.0), DVec3::splat(1.0), &mut touching);
        assert!(touching.is_empty());
    }
}

#[test]
fn a_gltf_and_a_glb_of_one_level_give_the_same_traces() {
    let dir = tempfile::tempdir().unwrap();
    let input = common::fixture("MAP01_godot.glb");
    let glb = convert(&input, None, dir.path());
    let gltf = dir.path().join("map01.gltf");
    let o = cull_cmd()
        .arg("convert")
        .arg(&input)
        .arg("-o")
        .arg(&gltf)
        .output()
        .unwrap();
    assert!(gltf.exists(), "{}", String::from_utf8_lossy(&o.stderr));
    let (doc, _) = common::read_gltf(&std::fs::read(&gltf).unwrap());
    let vis = &doc["extensions"]["PORTCULLIS_portals"]["visibility"];
    assert!(
        vis.get("bufferView").is_some(),
        "the PVS lies in a buffer: {vis}"
    );
    let (a, b) = (Level::load(&glb).unwrap(), Level::load(&gltf).unwrap());
    let ext = read_ext(&glb);
    let mut rng = Rng::new(8);
    let (mut ta, mut tb) = (Trace::default(), Trace::default());
    for cam in cameras(&ext, 40, &mut rng) {
        a.trace(
            &cam.view(),
            &Doors::new(&a),
            &TraceOptions::default(),
            &mut ta,
        );
        b.trace(
            &cam.view(),
            &Doors::new(&b),
            &TraceOptions::default(),
            &mut tb,
        );
        assert_eq!(ta.visible(), tb.visible());
        assert_eq!(ta.stats, tb.stats, "the same PVS prefiltered both");
    }
}
