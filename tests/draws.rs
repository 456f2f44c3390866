//! Triangles drawn per view, judged as an engine programmer would: the converted file read by
//! a glTF reader of this test's own (node transforms, accessors, the split indices), cameras
//! at the cells' centres (four looks, 75° field of view, 16:9), the runtime's visible cells
//! and their draw lists, frustum culling by each node's box on top. A triangle *lies in* a
//! cell when one of the points of a barycentric grid over it, clear of its edges, is inside the
//! cell's planes (the file's tolerance), and, drawn from its front only, the cell does not lie
//! wholly behind it: code that shares nothing with the split. What the draw lists submit must hold
//! every triangle lying in a visible cell and be at most 1.1 times as many.
//!
//! The shared levels take minutes in a debug build: `cargo test --release --test draws --
//! --ignored --nocapture`.

mod common;

use std::collections::{HashMap, HashSet};
use std::path::Path;

use common::plain::{accessor, triangles};
use glam::{DMat4, DVec3};
use portcullis::runtime::{Doors, DrawList, Level, Meshes, Trace, TraceOptions, View, ViewCost};
use serde_json::Value;

/// A triangle of the file: node, primitive, its three indices into the primitive's vertices.
type TriId = (usize, usize, [u32; 3]);

/// A primitive's world positions, its triangles, and whether only their fronts are drawn
/// (glTF's rule: a material without `doubleSided`, or none), and whether the node's transform
/// mirrors, turning the front from counter-clockwise to clockwise.
struct Prim {
    pos: Vec<DVec3>,
    tris: Vec<[u32; 3]>,
    one_sided: bool,
    mirrored: bool,
}

/// The file as a plain reader sees it.
struct Plain {
    /// Per (node, primitive): world positions of its vertices and its triangles.
    prims: HashMap<(usize, usize), Prim>,
    /// Per node with a mesh: its world box.
    boxes: HashMap<usize, (DVec3, DVec3)>,
    /// The split indices accessor's values.
    split: Vec<u32>,
    doc: Value,
}

fn read_plain(path: &Path) -> Plain {
    let (doc, bin) = common::read_gltf(&std::fs::read(path).unwrap());
    let bin = bin.unwrap_or_default();
    let world: HashMap<usize, DMat4> = common::plain::world(&doc).into_iter().collect();
    let parts: HashSet<usize> = (doc["nodes"].as_array().into_iter().flatten())
        .flat_map(|n| {
            let p = n["extensions"]["PORTCULLIS_portals"]["parts"].as_array();
            p.into_iter()
                .flatten()
                .map(|i| i.as_u64().unwrap() as usize)
        })
        .collect();
    let mut prims = HashMap::new();
    let mut boxes = HashMap::new();
    for (&n, m) in &world {
        let Some(mesh) = doc["nodes"][n]["mesh"].as_u64() else {
            continue;
        };
        // What no cell renders (a portal's or a bound's mesh) an engine following the
        // extension draws for no view: the node carries no `cell` or `cells`. A part of a
        // node split by cell is judged all the same (one that lies in no cell has none).
        if doc["nodes"][n]["extensions"]["PORTCULLIS_portals"].is_null() && !parts.contains(&n) {
            continue;
        }
        let mut b = (DVec3::splat(f64::MAX), DVec3::splat(f64::MIN));
        for (k, p) in doc["meshes"][mesh as usize]["primitives"]
            .as_array()
            .unwrap()
            .iter()
            .enumerate()
        {
            let mode = p["mode"].as_u64().unwrap_or(4);
            let pos: Vec<DVec3> = accessor(
                &doc,
                &bin,
                p["attributes"]["POSITION"].as_u64().unwrap() as usize,
            )
            .into_iter()
            .map(|v| m.transform_point3(DVec3::new(v[0], v[1], v[2])))
            .collect();
            let idx = common::plain::indices(&doc, &bin, p, pos.len());
            let tris = triangles(mode, &idx);
            // An engine bounds a mesh by its vertices, not by the triangles it indexes: a
            // part of a node split by cell shares its node's vertices, and its box.
            for &v in &pos {
                b.0 = b.0.min(v);
                b.1 = b.1.max(v);
            }
            let one_sided = !p["material"]
                .as_u64()
                .is_some_and(|i| doc["materials"][i as usize]["doubleSided"] == true);
            prims.insert(
                (n, k),
                Prim {
                    pos,
                    tris,
                    one_sided,
                    mirrored: m.determinant() < 0.0,
                },
            );
        }
        if b.0.x <= b.1.x {
            boxes.insert(n, b);
        }
    }
    let ext = &doc["extensions"]["PORTCULLIS_portals"];
    let split = match ext["split"]["indices"].as_u64() {
        Some(a) => accessor(&doc, &bin, a as usize)
            .into_iter()
            .map(|v| v[0] as u32)
            .collect(),
        None => Vec::new(),
    };
    Plain {
        prims,
        boxes,
        split,
        doc,
    }
}

/// A cell's planes `[n, d]` (`n · p <= d` inside).
fn planes(doc: &Value) -> Vec<Vec<(DVec3, f64)>> {
    doc["extensions"]["PORTCULLIS_portals"]["cells"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| {
            c["planes"]
                .as_array()
                .unwrap()
                .iter()
                .map(|p| {
                    let p: Vec<f64> = p
                        .as_array()
                        .unwrap()
                        .iter()
                        .map(|x| x.as_f64().unwrap())
                        .collect();
                    (DVec3::new(p[0], p[1], p[2]), p[3])
                })
                .collect()
        })
        .collect()
}

/// The centre of a cell: the mean of its corners, found plane triple by plane triple.
fn centre(planes: &[(DVec3, f64)], tol: f64) -> Option<DVec3> {
    let corners = common::corners(planes, tol);
    (!corners.is_empty()).then(|| corners.iter().sum::<DVec3>() / corners.len() as f64)
}

/// Points of a triangle that say which cells it lies in: those of the barycentric eighth grid
/// and the centroid at least `margin` from every edge's line, or all of them when none is (a
/// triangle too thin or too small to have such a point).
fn samples(t: [DVec3; 3], margin: f64) -> Vec<DVec3> {
    let grid = (0..=8).flat_map(move |i| (0..=8 - i).map(move |j| (i, j)));
    let all: Vec<DVec3> = grid
        .map(move |(i, j)| {
            let (a, b) = (i as f64 / 8.0, j as f64 / 8.0);
            t[0] * a + t[1] * b + t[2] * (1.0 - a - b)
        })
        .chain(std::iter::once((t[0] + t[1] + t[2]) / 3.0))
        .collect();
    let normal = (t[1] - t[0]).cross(t[2] - t[0]);
    let far = |p: &DVec3| {
        (0..3).all(|k| {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            let along = (b - a).normalize_or_zero();
            let off = (*p - a) - along * (*p - a).dot(along);
            off.length() >= margin
        })
    };
    let inner: Vec<DVec3> = all.iter().copied().filter(far).collect();
    if normal.length() > 0.0 && !inner.is_empty() {
        inner
    } else {
        all
    }
}

/// The frustum's side planes (inward normals through the eye) and the near plane.
fn frustum(eye: DVec3, look: DVec3, fov_y: f64, aspect: f64) -> Vec<(DVec3, f64)> {
    let f = look.normalize();
    let r = f.cross(DVec3::Y).normalize();
    let u = r.cross(f);
    let ty = (fov_y.to_radians() / 2.0).tan();
    let tx = ty * aspect;
    let mut out = Vec::new();
    for (side, t) in [(r, tx), (-r, tx), (u, ty), (-u, ty)] {
        // Inward: a point p is inside when n · (p - eye) >= 0.
        let n = (f * t - side).normalize();
        out.push((n, n.dot(eye)));
    }
    out.push((f, f.dot(eye) + 0.05));
    out
}

fn box_in(fr: &[(DVec3, f64)], b: (DVec3, DVec3)) -> bool {
    fr.iter().all(|&(n, d)| {
        let p = DVec3::new(
            if n.x >= 0.0 { b.1.x } else { b.0.x },
            if n.y >= 0.0 { b.1.y } else { b.0.y },
            if n.z >= 0.0 { b.1.z } else { b.0.z },
        );
        n.dot(p) >= d - 1e-9
    })
}

/// What the views judged.
#[derive(Debug, Default)]
struct Judged {
    views: usize,
    /// Triangles lying in the visible cells, summed over the views.
    inside: usize,
    /// Triangles the draw lists submit.
    submitted: usize,
    /// Triangles the nodes of the visible cells hold (today's whole-node drawing).
    whole: usize,
    /// Triangles of the level in the frustum (frustum culling alone).
    frustum: usize,
    /// Draw calls submitted.
    calls: usize,
    /// Triangles lying in a visible cell the draw lists left out.
    missed: usize,
    /// Views that see exactly two cells, and of them those whose draw lists (no frustum
    /// culling) hold more triangles than lie in the two cells.
    two_cells: usize,
    two_cells_over: usize,
    /// Submitted triangles lying in no cell at all.
    no_cell: usize,
    /// Submitted triangles lying in cells, none of them visible.
    elsewhere: usize,
    triangles: usize,
    /// The runtime's own pricing of the same views (`Level::cost`).
    runtime: ViewCost,
}

fn convert(input: &Path, preset: Option<&str>, out: &Path) {
    convert_as(input, preset, out, &[]);
}

fn convert_as(input: &Path, preset: Option<&str>, out: &Path, args: &[&str]) {
    let mut cmd = assert_cmd::Command::cargo_bin("portcullis").unwrap();
    cmd.arg("convert").arg(input).arg("-o").arg(out).args(args);
    if let Some(p) = preset {
        cmd.args(["--tags", p]);
    }
    common::succeeds(&mut cmd);
}

/// How far in front of a single-sided triangle's plane, in tolerances, a cell must reach to
/// see it (see `judge`).
const FACING: f64 = 64.0;

fn judge(path: &Path) -> Judged {
    let plain = read_plain(path);
    let level = Level::load(path).unwrap();
    let cells = planes(&plain.doc);
    let tol = level.tolerance();
    let mut keys: Vec<&(usize, usize)> = plain.prims.keys().collect();
    keys.sort();
    let corners: Vec<Vec<DVec3>> = cells.iter().map(|c| common::corners(c, tol)).collect();
    // Every triangle with its cells by the sample points.
    let mut tris: Vec<(TriId, Vec<usize>)> = Vec::new();
    for &&(n, k) in &keys {
        let prim = &plain.prims[&(n, k)];
        let (pos, ts) = (&prim.pos, &prim.tris);
        for t in ts {
            if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] {
                continue;
            }
            let w = t.map(|i| pos[i as usize]);
            // A triangle lies in a cell by its points clear of its own edges (the extension's
            // rule: a wall whose top edge meets the floor of the cell above is not that cell's).
            let inner = samples(w, 2.5 * tol);
            let (lo, hi) = (w[0].min(w[1]).min(w[2]), w[0].max(w[1]).max(w[2]));
            let inside: Vec<usize> = (0..level.cells())
                .filter(|&c| {
                    let (cmin, cmax) = level.bounds(c);
                    let (cmin, cmax) = (DVec3::from(cmin), DVec3::from(cmax));
                    (lo - tol).cmple(cmax).all() && (hi + tol).cmpge(cmin).all()
                })
                .filter(|&c| {
                    inner
                        .iter()
                        .any(|&p| cells[c].iter().all(|(n, d)| n.dot(p) - d <= 0.5 * tol))
                })
                // A triangle seen from its front only is not the cell's that lies wholly
                // behind it (a ceiling on the floor of the cell above). Corners found again
                // from the written planes carry rounding of several tolerances (up to 7.5 on
                // e3m4), so a cell reaching less than `FACING` tolerances in front is behind.
                .filter(|&c| {
                    let front = (w[1] - w[0]).cross(w[2] - w[0]);
                    let front = if prim.mirrored { -front } else { front }.normalize_or_zero();
                    !prim.one_sided
                        || front == DVec3::ZERO
                        || corners[c]
                            .iter()
                            .any(|&p| front.dot(p - w[0]) > FACING * tol)
                })
                .collect();
            tris.push(((n, k, *t), inside));
        }
    }
    let split: HashMap<(usize, usize), ()> = plain.doc["extensions"]["PORTCULLIS_portals"]["split"]
        ["primitives"]
        .as_array()
        .into_iter()
        .flatten()
        .map(|p| {
            (
                (
                    p["node"].as_u64().unwrap() as usize,
                    p["primitive"].as_u64().unwrap() as usize,
                ),
                (),
            )
        })
        .collect();
    let doors = Doors::new(&level);
    let (meshes, mut scratch) = (Meshes::load(path).unwrap(), DrawList::default());
    let (opts, mut trace, mut list) = (
        TraceOptions::default(),
        Trace::default(),
        DrawList::default(),
    );
    let mut j = Judged {
        triangles: tris.len(),
        ..Default::default()
    };
    let node_tris: HashMap<usize, usize> = keys.iter().fold(HashMap::new(), |mut m, &&(n, k)| {
        *m.entry(n).or_default() += plain.prims[&(n, k)].tris.len();
        m
    });
    for cell in &cells {
        let Some(eye) = centre(cell, tol) else {
            continue;
        };
        for look in [DVec3::X, DVec3::Z, -DVec3::X, -DVec3::Z] {
            let view = View::new(
                eye.to_array(),
                look.to_array(),
                [0.0, 1.0, 0.0],
                75.0,
                16.0 / 9.0,
                0.05,
            )
            .unwrap();
            level.trace(&view, &doors, &opts, &mut trace);
            if trace.location.cell().is_none() {
                continue;
            }
            j.views += 1;
            let fr = frustum(eye, look, 75.0, 16.0 / 9.0);
            let in_view = |n: usize| plain.boxes.get(&n).is_some_and(|&b| box_in(&fr, b));
            let visible: Vec<usize> = trace.visible().iter().filter_map(|v| v.cell).collect();
            let seen: HashSet<usize> = visible.iter().copied().collect();
            j.runtime += level.cost(&meshes, &view, &trace, &mut scratch);
            level.draw_list(visible.iter().copied(), &mut list);
            if seen.len() == 2 {
                j.two_cells += 1;
                let listed = list.ranges.iter().map(|r| r.count / 3).sum::<usize>()
                    + list
                        .nodes
                        .iter()
                        .map(|n| node_tris.get(n).copied().unwrap_or(0))
                        .sum::<usize>();
                let lying = (tris.iter())
                    .filter(|(_, inside)| inside.iter().any(|c| seen.contains(c)))
                    .count();
                if listed > lying {
                    j.two_cells_over += 1;
                }
            }
            let mut drawn: HashSet<TriId> = HashSet::new();
            for &n in &list.nodes {
                if in_view(n) {
                    for &(nn, k) in keys.iter().copied() {
                        if nn == n {
                            j.calls += 1;
                            drawn.extend(plain.prims[&(n, k)].tris.iter().map(|t| (n, k, *t)));
                            j.submitted += plain.prims[&(n, k)].tris.len();
                        }
                    }
                }
            }
            for r in &list.ranges {
                assert!(split.contains_key(&(r.node, r.primitive)));
                if in_view(r.node) {
                    j.calls += 1;
                    j.submitted += r.count / 3;
                    for t in plain.split[r.first..r.first + r.count].chunks_exact(3) {
                        drawn.insert((r.node, r.primitive, [t[0], t[1], t[2]]));
                    }
                }
            }
            let mut whole: HashSet<usize> = HashSet::new();
            for &c in &visible {
                let nodes =
                    plain.doc["extensions"]["PORTCULLIS_portals"]["cells"][c]["nodes"].as_array();
                whole.extend(
                    nodes
                        .into_iter()
                        .flatten()
                        .map(|n| n.as_u64().unwrap() as usize),
                );
            }
            j.whole += whole
                .iter()
                .filter(|&&n| in_view(n))
                .map(|n| node_tris.get(n).copied().unwrap_or(0))
                .sum::<usize>();
            j.frustum += node_tris
                .iter()
                .filter(|(&n, _)| in_view(n))
                .map(|(_, &t)| t)
                .sum::<usize>();
            for (id, inside) in &tris {
                if !in_view(id.0) {
                    continue;
                }
                if inside.iter().any(|c| seen.contains(c)) {
                    j.inside += 1;
                    if !drawn.contains(id) {
                        j.missed += 1;
                    }
                } else if drawn.contains(id) {
                    if inside.is_empty() {
                        j.no_cell += 1;
                    } else {
                        j.elsewhere += 1;
                    }
                }
            }
        }
    }
    j
}

/// The output passes the Khronos glTF-Validator with no error and the extension's schema.
fn valid(out: &Path, name: &str) {
    if let Some(report) = common::khronos_validate(out) {
        let errors = report["issues"]["numErrors"].as_u64().unwrap();
        assert_eq!(errors, 0, "{name}: {}", report["issues"]["messages"]);
    }
    let (doc, _) = common::read_gltf(&std::fs::read(out).unwrap());
    let errs = portcullis::schema::validate(
        portcullis::schema::Schema::Portals,
        &doc["extensions"]["PORTCULLIS_portals"],
    );
    assert!(errs.is_empty(), "{name}: {errs:?}");
}

fn judged(name: &str, input: &Path, preset: Option<&str>) -> Judged {
    let j = judged_as(name, input, preset, &[]);
    let parts = judged_as(
        &format!("{name}, split by cell"),
        input,
        preset,
        &["--split-by-cell"],
    );
    // The parts hold the split nodes' triangles as the draw lists do, in boxes of their own
    // (so frustum culling takes more of them): the same views, no more submitted.
    assert_eq!(parts.views, j.views, "{name}");
    assert!(
        parts.submitted <= j.submitted,
        "{name}: {parts:?} against {j:?}"
    );
    j
}

fn judged_as(name: &str, input: &Path, preset: Option<&str>, args: &[&str]) -> Judged {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out.glb");
    convert_as(input, preset, &out, args);
    valid(&out, name);
    let j = judge(&out);
    eprintln!(
        "{name}: {} views, {} triangles; per view: frustum only {:.1}, whole nodes {:.1}, draw lists {:.1} in {:.1} calls, lying in the visible cells {:.1}; ratio {:.3}; missed {}; submitted in no cell {:.1}, in cells not visible {:.1}",
        j.views,
        j.triangles,
        j.frustum as f64 / j.views as f64,
        j.whole as f64 / j.views as f64,
        j.submitted as f64 / j.views as f64,
        j.calls as f64 / j.views as f64,
        j.inside as f64 / j.views as f64,
        j.submitted as f64 / j.inside as f64,
        j.missed,
        j.no_cell as f64 / j.views as f64,
        j.elsewhere as f64 / j.views as f64,
    );
    // The runtime prices the same views from the file's JSON alone (accessor bounds and
    // counts, which the validator holds to the data): the same figures as read here, but for
    // boxes that only touch a side of the frustum (each side decides them by its own
    // rounding): within 0.1%.
    let r = j.runtime;
    let ours = [
        r.frustum.triangles,
        r.nodes.triangles,
        r.lists.triangles,
        r.lists.calls,
    ];
    let theirs = [j.frustum, j.whole, j.submitted, j.calls].map(|x| x as u64);
    for ((a, b), what) in ours
        .iter()
        .zip(theirs)
        .zip(["frustum", "nodes", "lists", "list calls"])
    {
        assert!(
            a.abs_diff(b) as f64 <= 1e-3 * b as f64,
            "{name}: Level::cost's {what} {a} against the test's own count {b}"
        );
    }
    assert!(j.views > 0 && j.inside > 0, "{name}: nothing judged");
    assert_eq!(j.missed, 0, "{name}: triangles in visible cells left out");
    assert!(
        j.submitted as f64 <= 1.1 * j.inside as f64,
        "{name}: {} submitted > 1.1 × {} in the visible cells",
        j.submitted,
        j.inside
    );
    j
}

/// `pillar_room`'s `Floor`, `Walls` and `Ceiling` are one node each, in all four cells: drawn
/// whole, culling saved nothing. A view from a corner cell that sees two cells draws no more
/// than the triangles lying in those two.
#[test]
fn pillar_room_and_a_generated_building_draw_what_their_visible_cells_hold() {
    let j = judged("pillar_room", &common::sample("pillar_room.gltf"), None);
    assert!(j.views >= 16, "{j:?}");
    assert!(j.whole > j.submitted, "{j:?}");
    assert!(j.two_cells > 0, "no view sees just two cells: {j:?}");
    assert_eq!(j.two_cells_over, 0, "{j:?}");
    let dir = tempfile::tempdir().unwrap();
    let g = common::generated_building(dir.path(), 40, 1);
    let j = judged("building of 40 rooms", &g, None);
    assert!(j.views > 100, "{j:?}");
}

#[test]
#[ignore = "minutes: run with --release --ignored"]
fn shared_levels_draw_what_their_visible_cells_hold() {
    let dir = tempfile::tempdir().unwrap();
    let g = common::generated_building(dir.path(), 300, 1);
    let j = judged("building of 300 rooms", &g, None);
    assert!(j.views > 1000, "{j:?}");
    for (rel, preset) in [
        ("ericw-tools/testmaps/E1M1-edited-ents.map", None),
        (
            "ericw-tools/testmaps/LibreQuake/lq1/maps/src/e3/e3m4.map",
            None,
        ),
        ("ericw-tools/testmaps/retrojam1_ericw.map", None),
        // E1M1's brushes as a plain exporter writes them: solid blocks, read as the .map is.
        ("ericw-tools/gltf/E1M1-edited-ents.gltf", None),
        ("freedoom/freedoom2_MAP01.glb", Some("doom")),
        ("freedoom/freedoom1_E1M2.glb", Some("doom")),
        ("freedoom/freedoom1_E3M3.glb", Some("doom")),
    ] {
        if let Some(p) = common::shared(rel) {
            judged(rel, &p, preset);
        }
    }
}

/// The PVS rows carry the outside: both of the courtyard's cells may see the sky, neither of
/// two closed rooms does.
#[test]
fn pvs_rows_say_which_cells_see_the_outside() {
    let dir = tempfile::tempdir().unwrap();
    for (sample, sees) in [("courtyard.gltf", true), ("two_rooms.gltf", false)] {
        let out = dir.path().join(format!("{sample}.glb"));
        convert(&common::sample(sample), None, &out);
        let level = Level::load(&out).unwrap();
        assert_eq!(level.cells(), 2, "{sample}");
        let (doc, _) = common::read_gltf(&std::fs::read(&out).unwrap());
        let listed = doc["extensions"]["PORTCULLIS_portals"]["visibility"]["outside"]
            .as_array()
            .map(Vec::len);
        assert_eq!(listed, sees.then_some(2), "{sample}");
        for c in 0..level.cells() {
            assert_eq!(level.sees_outside(c), sees, "{sample}: cell {c}");
        }
    }
}
