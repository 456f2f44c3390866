//! `--tags auto` on real levels nobody tagged, judged by an oracle that shares no code with the
//! cells, portals or PVS: rays cast from random eyes in the generated cells against the
//! level's own triangles (parry's ray cast), each hit's cell looked up by its planes; the
//! hit's cell must be in the eye's cell's full PVS. The Freedoom maps are merged into one
//! untagged node here, so no sector structure is left.
//!
//! living_room runs in the suite; the bigger levels are marked for explicit runs
//! (`cargo test --release --test auto_oracle -- --ignored`), as they take minutes.

mod common;

use std::path::Path;

use glam::{DMat4, DVec3};
use parry3d_f64::query::{Ray, RayCast};
use portcullis::import::Imported;
use portcullis::pipeline;
use portcullis::vis::{self, VisOptions};

/// Every mesh node's triangles in world space, wound as rendered.
fn world_triangles(s: &portcullis::scene::Scene) -> Vec<[DVec3; 3]> {
    let mut tris = Vec::new();
    for n in s.walk() {
        let Some(m) = s.nodes[n].mesh else { continue };
        let w = s.world_positions(n);
        let flip = s.nodes[n].world.determinant() < 0.0;
        for t in &s.meshes[m].triangles {
            let [a, b, c] = t.map(|i| w[i as usize]);
            tris.push(if flip { [a, c, b] } else { [a, b, c] });
        }
    }
    tris
}

/// The level's mesh nodes as one untagged node of world triangles.
fn merged(path: &Path) -> portcullis::scene::Scene {
    let imported = portcullis::import::import_path(path, &Default::default()).expect("imports");
    let tris = world_triangles(&imported.scene);
    common::scene_of(vec![("level", None, tris, None)], DMat4::IDENTITY)
}

/// Eyes, rays per eye, and the misses and hits in no cell the oracle found.
struct Verdict {
    rays: usize,
    misses: Vec<String>,
    nowhere: usize,
    /// Hits in no cell whose node no cell the eye's cell sees renders.
    undrawn: Vec<String>,
}

fn audit(scene: portcullis::scene::Scene, eyes: usize, per_eye: usize) -> Verdict {
    let config = portcullis::config::Config::default();
    let rules = portcullis::config::rule_set(&config, Some("auto")).unwrap();
    let imported = Imported {
        scene,
        diagnostics: Default::default(),
    };
    let tagged = pipeline::tag(imported, config, rules);
    let mesh = common::opaque_mesh(&tagged);
    // The node of each of the mesh's triangles, in `opaque_mesh`'s order.
    let owner: Vec<usize> = tagged
        .scene
        .walk()
        .into_iter()
        .filter(|&n| !tagged.tagging.portals.iter().any(|q| q.node == n))
        .filter(|&n| !tagged.tagging.footprints.iter().any(|f| f.node == n))
        .filter(|&n| !tagged.tagging.bounds.iter().any(|b| b.node == n))
        .flat_map(|n| {
            let k = tagged.scene.nodes[n]
                .mesh
                .map_or(0, |m| tagged.scene.meshes[m].triangles.len());
            std::iter::repeat_n(n, k)
        })
        .collect();
    assert_eq!(owner.len(), mesh.indices().len(), "triangle owners");
    let level = pipeline::build(tagged);
    let c = &level.cells;
    assert!(!c.cells.is_empty(), "no cells");
    let full = vis::of_level(
        c.cells.len(),
        &level.portals,
        c.tolerance.distance,
        &VisOptions::default(),
    );
    let mut rng = common::rng::SplitMix64::new(0x5eed_a070);
    let total: f64 = c.cells.iter().map(|x| x.volume).sum();
    let inside = |cell: usize, q: DVec3| {
        (c.cells[cell].poly.faces.iter()).all(|f| f.plane.normal.dot(q) - f.plane.d <= 1e-9)
    };
    let in_box = |k: usize, q: DVec3| {
        let b = &c.cells[k].bounds;
        (b.min - 1e-9).cmple(q).all() && (b.max + 1e-9).cmpge(q).all()
    };
    let cell_at = |q: DVec3| (0..c.cells.len()).find(|&k| in_box(k, q) && inside(k, q));
    let mut v = Verdict {
        rays: 0,
        misses: Vec::new(),
        nowhere: 0,
        undrawn: Vec::new(),
    };
    for _ in 0..eyes {
        // An eye in a cell picked by volume: the air a camera stands in.
        let mut pick = rng.unit() * total;
        let eye_cell = (c.cells.iter().position(|x| {
            pick -= x.volume;
            pick <= 0.0
        }))
        .unwrap_or(c.cells.len() - 1);
        let bb = c.cells[eye_cell].bounds;
        let eye = loop {
            let q = bb.min + (bb.max - bb.min) * DVec3::new(rng.unit(), rng.unit(), rng.unit());
            if inside(eye_cell, q) {
                break q;
            }
        };
        for _ in 0..per_eye {
            let d = loop {
                let d = DVec3::new(rng.unit(), rng.unit(), rng.unit()) * 2.0 - 1.0;
                let l = d.length();
                if l > 1e-3 && l <= 1.0 {
                    break d / l;
                }
            };
            let Some(hit) = mesh.cast_local_ray_and_get_normal(&Ray::new(eye, d), f64::MAX, true)
            else {
                continue;
            };
            let toi = hit.time_of_impact;
            v.rays += 1;
            // Just before the hit: the air the hit surface faces, in some cell. Two
            // tolerances off the surface, along the ray: a wall within the tolerance of a
            // cell's face is on that face, and a hit a hair past it is no sighting of the
            // cell behind (gi_zdm2: a ray met a wall 0.39 m away, 4e-7 m short of which
            // the cell beyond began).
            let across = d.dot(hit.normal).abs().max(1e-3);
            let back = (1e-6 * toi).max(2.0 * c.tolerance.distance / across);
            let Some(hit_cell) = cell_at(eye + d * (toi - back).max(0.0)) else {
                // Air in no cell (past an opening to the exterior): the hit is still seen,
                // so a cell the eye's cell sees must render its node.
                v.nowhere += 1;
                let node = owner[hit.subshape as usize];
                let drawn = (0..c.cells.len())
                    .filter(|&k| k == eye_cell || full.sees(eye_cell, k))
                    .any(|k| c.cells[k].nodes.contains(&node));
                if !drawn {
                    v.undrawn
                        .push(format!("{eye} along {d}: node {node} at {toi}"));
                }
                continue;
            };
            if hit_cell != eye_cell && !full.sees(eye_cell, hit_cell) {
                v.misses.push(format!(
                    "{eye} along {d}: cell {eye_cell} sees cell {hit_cell} at {toi}"
                ));
            }
        }
    }
    v
}

fn judge(name: &str, v: Verdict) {
    eprintln!(
        "{name}: {} rays hit, {} misses, {} hits in no cell",
        v.rays,
        v.misses.len(),
        v.nowhere
    );
    assert!(v.rays > 100, "{name}: only {} rays hit", v.rays);
    assert!(
        v.misses.is_empty(),
        "{name}: {} misses, first {:?}",
        v.misses.len(),
        v.misses.first()
    );
    assert!(
        v.undrawn.is_empty(),
        "{name}: {} hits in no cell drawn by no cell the eye's cell sees, first {:?}",
        v.undrawn.len(),
        v.undrawn.first()
    );
}

#[test]
fn living_room_rays_find_no_cell_the_pvs_misses() {
    let Some(p) = common::shared("godot/living_room.glb") else {
        return;
    };
    let scene = portcullis::import::import_path(&p, &Default::default())
        .unwrap()
        .scene;
    judge("living_room", audit(scene, 200, 50));
}

#[test]
#[ignore = "minutes: run with --ignored"]
fn shared_levels_rays_find_no_cell_the_pvs_misses() {
    for rel in [
        "freedoom/freedoom2_MAP01.glb",
        "freedoom/freedoom1_E1M2.glb",
        "freedoom/freedoom1_E3M3.glb",
    ] {
        let Some(p) = common::shared(rel) else {
            continue;
        };
        judge(rel, audit(merged(&p), 200, 50));
    }
    // gi_zdm2 and pandora reach the flow's work budget: their PVS is conservative, looser.
    for rel in [
        "godot/occlusion_room.glb",
        "godot/gi_zdm2.glb",
        "sauerbraten/pandora.obj",
    ] {
        let Some(p) = common::shared(rel) else {
            continue;
        };
        let scene = portcullis::import::import_path(&p, &Default::default())
            .unwrap()
            .scene;
        judge(rel, audit(scene, 200, 50));
    }
}

fn convert(input: &Path, preset: Option<&str>, out: &Path) -> portcullis::runtime::Level {
    let mut cmd = assert_cmd::Command::cargo_bin("portcullis").unwrap();
    cmd.arg("convert").arg(input).arg("-o").arg(out);
    if let Some(p) = preset {
        cmd.args(["--tags", p]);
    }
    let o = cmd.output().unwrap();
    assert!(out.exists(), "{}", String::from_utf8_lossy(&o.stderr));
    portcullis::runtime::Level::load(out).unwrap()
}

/// The share of a level's cell volume the runtime returns in each view (`None` where the eye
/// lies in no cell). Each eye looks along ±x and ±z with y up, every direction and the eye
/// moved by `m` (the level's own motion).
fn drawn_shares(
    level: &portcullis::runtime::Level,
    volumes: &[f64],
    eyes: &[DVec3],
    m: DMat4,
) -> Vec<Option<f64>> {
    use portcullis::runtime::{Doors, Trace, TraceOptions, View};
    assert_eq!(level.cells(), volumes.len(), "runtime and library cells");
    let total: f64 = volumes.iter().sum();
    let (doors, opts, mut t) = (Doors::new(level), TraceOptions::default(), Trace::default());
    let mut shares = Vec::new();
    let up = m.transform_vector3(DVec3::Y);
    for eye in eyes {
        for look in [DVec3::X, DVec3::Z, -DVec3::X, -DVec3::Z] {
            let view = View::new(
                m.transform_point3(*eye).to_array(),
                m.transform_vector3(look).to_array(),
                up.to_array(),
                90.0,
                16.0 / 9.0,
                0.05,
            )
            .unwrap();
            level.trace(&view, &doors, &opts, &mut t);
            if t.location.cell().is_none() {
                shares.push(None);
                continue;
            }
            let seen: std::collections::BTreeSet<usize> =
                t.visible().iter().filter_map(|v| v.cell).collect();
            shares.push(Some(seen.iter().map(|&c| volumes[c]).sum::<f64>() / total));
        }
    }
    shares
}

/// The mean of the views' shares where `with` places the eye too, and the views left out.
fn mean_share(shares: &[Option<f64>], with: &[Option<f64>]) -> (f64, usize) {
    let kept: Vec<f64> = (shares.iter().zip(with))
        .filter_map(|(s, w)| w.and(*s))
        .collect();
    let mean = kept.iter().sum::<f64>() / kept.len().max(1) as f64;
    (mean, shares.len() - kept.len())
}

/// The level's world triangles, its mesh nodes taken in the order `seed` shuffles them
/// (`None`: as they come), every point moved by `m`.
fn merged_triangles(path: &Path, seed: Option<u64>, m: DMat4) -> Vec<[DVec3; 3]> {
    let scene = portcullis::import::import_path(path, &Default::default())
        .expect("imports")
        .scene;
    let mut nodes: Vec<usize> = (scene.walk().into_iter())
        .filter(|&n| scene.nodes[n].mesh.is_some())
        .collect();
    if let Some(seed) = seed {
        common::rng::SplitMix64::new(seed).shuffle(&mut nodes);
    }
    let mut tris = Vec::new();
    for n in nodes {
        let m_n = scene.nodes[n].mesh.unwrap();
        let w = scene.world_positions(n);
        let flip = scene.nodes[n].world.determinant() < 0.0;
        for t in &scene.meshes[m_n].triangles {
            let [a, b, c] = t.map(|i| m.transform_point3(w[i as usize]));
            tris.push(if flip { [a, c, b] } else { [a, b, c] });
        }
    }
    tris
}

/// Triangles written as an OBJ of one object (shortest round-trip decimals: exact f64).
fn write_triangles(tris: &[[DVec3; 3]], path: &Path) {
    use std::fmt::Write;
    let (mut v, mut f) = (String::from("o level\n"), String::new());
    for (k, t) in tris.iter().enumerate() {
        for p in t {
            writeln!(v, "v {} {} {}", p.x, p.y, p.z).unwrap();
        }
        writeln!(f, "f {} {} {}", 3 * k + 1, 3 * k + 2, 3 * k + 3).unwrap();
    }
    std::fs::write(path, v + &f).unwrap();
}

/// The acceptance's drawn share: from the designer's own cell centres, four views each, the
/// share of the level's cell volume the runtime returns with generated cells is at most 1.3
/// times the share it returns with the designer's, on each map merged into one untagged mesh
/// three ways: as its meshes come, in a shuffled order, and turned 37° about (1, 2, 3) and
/// moved 1e5 m (the eyes and views moved along). A view whose eye lies in no generated cell
/// (a designer's outdoor cell reaching up into the void over the merged mesh's roofs) is left
/// out of the generated mean; the ratio is also judged over only the views both readings
/// place, so leaving views out cannot pass it.
#[test]
#[ignore = "minutes: run with --ignored"]
fn doom_maps_drawn_share_is_within_1_3_times_the_designers_merged_shuffled_and_turned() {
    let dir = tempfile::tempdir().unwrap();
    let turned = DMat4::from_rotation_translation(
        glam::DQuat::from_axis_angle(DVec3::new(1.0, 2.0, 3.0).normalize(), 37f64.to_radians()),
        DVec3::splat(1e5),
    );
    let variants = [
        ("merged", None, DMat4::IDENTITY),
        ("shuffled", Some(0x5eed_0066), DMat4::IDENTITY),
        ("turned and moved", None, turned),
    ];
    let mut over = Vec::new();
    for (designer, plain) in [
        ("freedoom/MAP01_godot.glb", "freedoom/freedoom2_MAP01.glb"),
        ("freedoom/E1M2_godot.glb", "freedoom/freedoom1_E1M2.glb"),
        ("freedoom/E3M3_godot.glb", "freedoom/freedoom1_E3M3.glb"),
    ] {
        let (Some(d), Some(p)) = (common::shared(designer), common::shared(plain)) else {
            continue;
        };
        let built = common::built(&d, None);
        let eyes: Vec<DVec3> = (built.cells.cells.iter())
            .map(|c| {
                let v = c.poly.vertices(1e-9);
                v.iter().sum::<DVec3>() / v.len() as f64
            })
            .collect();
        assert!(eyes.len() > 50, "{designer}: only {} eyes", eyes.len());
        let dv: Vec<f64> = built.cells.cells.iter().map(|c| c.volume).collect();
        let tagged = convert(&d, None, &dir.path().join("designer.glb"));
        let d_shares = drawn_shares(&tagged, &dv, &eyes, DMat4::IDENTITY);
        let (ds, dout) = mean_share(&d_shares, &d_shares);
        for (variant, seed, m) in variants {
            let obj = dir.path().join("merged.obj");
            write_triangles(&merged_triangles(&p, seed, m), &obj);
            let auto = common::built(&obj, Some("auto"));
            let av: Vec<f64> = auto.cells.cells.iter().map(|c| c.volume).collect();
            let generated = convert(&obj, Some("auto"), &dir.path().join("auto.glb"));
            let g_shares = drawn_shares(&generated, &av, &eyes, m);
            let (gs, gout) = mean_share(&g_shares, &g_shares);
            // The same views on both sides: those the generated cells place.
            let (ds_same, _) = mean_share(&d_shares, &g_shares);
            let (ratio, same) = (gs / ds, gs / ds_same);
            eprintln!(
                "{designer}, {variant}: designer share {ds:.3} ({} cells, {dout} views outside), generated {gs:.3} ({} cells, {gout} views of {} outside), ratio {ratio:.2} ({same:.2} over the same views)",
                dv.len(),
                av.len(),
                g_shares.len(),
            );
            if ratio.max(same) > 1.3 {
                over.push(format!("{designer}, {variant}: {ratio:.2} ({same:.2})"));
            }
        }
    }
    assert!(
        over.is_empty(),
        "generated share over 1.3 × the designer's: {over:?}"
    );
}

/// Rooms, cells and PVS pairs of a level under `--tags auto`, every node moved by `m`.
fn reading(mut scene: portcullis::scene::Scene, m: DMat4) -> (usize, usize, usize) {
    for n in scene.nodes.iter_mut() {
        n.world = m * n.world;
    }
    let config = portcullis::config::Config::default();
    let rules = portcullis::config::rule_set(&config, Some("auto")).unwrap();
    let imported = Imported {
        scene,
        diagnostics: Default::default(),
    };
    let level = pipeline::build(pipeline::tag(imported, config, rules));
    let cells = level.cells.cells.len();
    let pvs = pipeline::pvs(&level, vis::Method::Full);
    let pairs = (0..cells).map(|c| pvs.visible(c).count()).sum();
    (level.tagging().rooms.len(), cells, pairs)
}

#[test]
#[ignore = "a minute: run with --ignored"]
fn turned_and_moved_the_same_rooms_and_pvs_within_one_percent() {
    // 37° about (1, 2, 3), then 1e5 m away (the acceptance's motion).
    let m = DMat4::from_rotation_translation(
        glam::DQuat::from_axis_angle(DVec3::new(1.0, 2.0, 3.0).normalize(), 37f64.to_radians()),
        DVec3::splat(1e5),
    );
    for rel in [
        "freedoom/freedoom2_MAP01.glb",
        "freedoom/freedoom1_E1M2.glb",
        "freedoom/freedoom1_E3M3.glb",
    ] {
        let Some(p) = common::shared(rel) else {
            continue;
        };
        let scene = merged(&p);
        let (rooms, cells, pairs) = reading(scene.clone(), DMat4::IDENTITY);
        let (t_rooms, t_cells, t_pairs) = reading(scene, m);
        let change = (t_pairs as f64 - pairs as f64) / pairs as f64;
        eprintln!(
            "{rel}: rooms {rooms} / {t_rooms}, cells {cells} / {t_cells}, PVS pairs {pairs} / {t_pairs} ({:+.2}%)",
            100.0 * change
        );
        // Something was judged: rooms found, and cells that see more than themselves.
        assert!(
            rooms > 1 && pairs > 2 * cells,
            "{rel}: {rooms} rooms, {pairs} pairs"
        );
        assert_eq!(rooms, t_rooms, "{rel}: the same rooms turned");
        assert!(
            change.abs() <= 0.01,
            "{rel}: PVS pairs changed {:+.2}%",
            100.0 * change
        );
    }
}
