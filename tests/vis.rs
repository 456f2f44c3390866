//! Visibility: the methods nest (sampled ⊆ full ⊆ fast ⊆ flood) on every sample and
//! third-party level; known answers on small graphs built by hand; transformed portals;
//! the same result for any thread count; and a ray-cast oracle that does not use the vis
//! code: a clear segment between two cells means the second is in the first's full PVS.

mod common;

use common::sample;
use glam::DVec3;
use parry3d_f64::query::{Ray, RayCast};
use portcullis::geom::plane::Plane;
use portcullis::vis::{self, Method, Pvs, VisGraph, VisOptions, VisPortal};

fn run(g: &VisGraph, method: Method) -> Pvs {
    vis::compute(
        g,
        &VisOptions {
            method,
            samples: 300,
            ..Default::default()
        },
    )
}

/// sampled ⊆ full ⊆ fast ⊆ flood, with the pairs that break it named.
pub fn assert_nested(name: &str, g: &VisGraph) -> [Pvs; 4] {
    let [flood, fast, full, sampled] = Method::ALL.map(|m| run(g, m));
    for (small, big, what) in [
        (&sampled, &full, "sampled ⊆ full"),
        (&full, &fast, "full ⊆ fast"),
        (&fast, &flood, "fast ⊆ flood"),
    ] {
        let extra = small.missing_from(big);
        assert!(
            extra.is_empty(),
            "{name}: {what} fails for {:?}",
            &extra[..extra.len().min(10)]
        );
    }
    [flood, fast, full, sampled]
}

fn graph_of(path: &std::path::Path, preset: Option<&str>) -> VisGraph {
    let (_, c, p) = common::load_level(path, preset);
    VisGraph::from_portal_set(c.cells.len(), &p, c.tolerance.distance)
}

#[test]
fn methods_nest_on_every_level() {
    for (f, preset) in common::levels_with_rooms() {
        let g = graph_of(&f, preset);
        let [flood, _, full, sampled] = assert_nested(&f.display().to_string(), &g);
        assert!(sampled.pairs() <= full.pairs() && full.pairs() <= flood.pairs());
    }
}

/// The level with its openings to the exterior walled up: the PVS without the outside.
fn walled(p: &portcullis::portals::PortalSet) -> portcullis::portals::PortalSet {
    let mut w = p.clone();
    for q in w.portals.iter_mut().filter(|q| q.to.is_none()) {
        q.closed = true;
    }
    w
}

/// The outside only ever adds sightlines: on every level the PVS with it holds the PVS with
/// the openings to the exterior walled up, and a level with no such opening (closed), or with
/// only openings on the hull of its portals (where nothing comes back), gets exactly the same
/// PVS, with no outside cell in its graph.
#[test]
fn the_outside_only_adds_sightlines() {
    let mut opened = 0;
    for (f, preset) in common::levels_with_rooms() {
        let (_, c, p) = common::load_level(&f, preset);
        let opts = VisOptions::default();
        let eps = c.tolerance.distance;
        let with = vis::of_level(c.cells.len(), &p, eps, &opts);
        let without = vis::of_level(c.cells.len(), &walled(&p), eps, &opts);
        assert_eq!(with.cells(), c.cells.len(), "{}", f.display());
        let extra = without.missing_from(&with);
        assert!(extra.is_empty(), "{}: lost {extra:?}", f.display());
        let exterior = p.portals.iter().any(|q| q.to.is_none() && !q.closed);
        let g = VisGraph::from_portal_set(c.cells.len(), &p, eps);
        assert!(exterior || g.outside.is_none(), "{}", f.display());
        if g.outside.is_some() {
            opened += usize::from(with != without);
        } else {
            assert_eq!(with, without, "{}", f.display());
        }
    }
    assert!(
        opened >= 2,
        "only {opened} levels see more through the outside"
    );
}

/// A two-cell sample whose cells no portal joins but each sees the other through the
/// outside, in every conservative method and not with the exterior walled up (`sampled`, a
/// lower bound, does not walk the outside); and the segment `a` → `b`, from one cell into the
/// other, that the ray caster finds clear. Returns the portals.
fn seen_only_through_the_outside(name: &str, a: DVec3, b: DVec3) -> portcullis::portals::PortalSet {
    let (t, c, p) = common::load_level(&sample(name), None);
    assert_eq!(c.cells.len(), 2, "{name}");
    assert!(
        p.portals.iter().all(|q| q.to.is_none()),
        "{name}: a portal joins the cells"
    );
    let eps = c.tolerance.distance;
    for method in Method::ALL {
        let opts = VisOptions {
            method,
            samples: 300,
            ..Default::default()
        };
        let pvs = vis::of_level(2, &p, eps, &opts);
        let sees = method != Method::Sampled;
        assert_eq!(
            pvs.sees(0, 1) && pvs.sees(1, 0),
            sees,
            "{name}: {}",
            method.name()
        );
        assert!(!vis::of_level(2, &walled(&p), eps, &opts).sees(0, 1));
    }
    let cell_of = |q: DVec3| (0..2).find(|&k| c.cells[k].poly.contains_strictly(q, 1e-6));
    let (ca, cb) = (cell_of(a), cell_of(b));
    assert!(
        ca.is_some() && cb.is_some() && ca != cb,
        "{name}: {ca:?} {cb:?}"
    );
    let d = b - a;
    let mesh = common::opaque_mesh(&t);
    assert!(
        !mesh.intersects_local_ray(&Ray::new(a, d / d.length()), d.length()),
        "{name}"
    );
    p
}

/// Two roofless courts side by side (x 0..4 and 6..10), each walled 3 m high towards the
/// other and 6 m at its back, no door: each sees the other over the walls, through the sky
/// (from high at one back wall to high at the other, over both 3 m front walls).
#[test]
fn courts_see_each_other_over_the_top() {
    let p = seen_only_through_the_outside(
        "courtyard.gltf",
        DVec3::new(0.5, 5.5, 2.0),
        DVec3::new(9.5, 5.5, 2.0),
    );
    assert_eq!(p.portals.len(), 2, "each court's top opens to the sky");
}

/// Two rooms 0.3 m apart whose walls each have a door, the doors not facing each other (z
/// 0.5..1.5 in x = 4, z 2.5..3.5 in x = 4.3): no portal bridges the wall, each door is a 2.2 m²
/// hole into the hollow between the walls, and through it each room sees the other (a
/// segment through both doors).
#[test]
fn offset_doors_see_through_the_hollow_wall() {
    let p = seen_only_through_the_outside(
        "offset_holes.gltf",
        DVec3::new(3.88, 1.0, 0.2),
        DVec3::new(4.42, 1.0, 3.8),
    );
    let areas: Vec<f64> = p.portals.iter().map(|q| q.area).collect();
    assert_eq!(areas.len(), 2);
    assert!(areas.iter().all(|a| (a - 2.2).abs() < 1e-6), "{areas:?}");
}

/// A quad on the plane `axis = at` spanning `(a0..a1)` on the other horizontal axis and
/// height 0..3, leading from `from` to `to` in the direction `dir` (±1 along `axis`).
fn door(from: usize, to: usize, axis: usize, at: f64, dir: f64, a0: f64, a1: f64) -> VisPortal {
    let p = |u: f64, h: f64| {
        if axis == 0 {
            DVec3::new(at, h, u)
        } else {
            DVec3::new(u, h, at)
        }
    };
    let winding = vec![p(a0, 0.0), p(a1, 0.0), p(a1, 3.0), p(a0, 3.0)];
    let mut n = DVec3::ZERO;
    n[if axis == 0 { 0 } else { 2 }] = dir;
    VisPortal {
        from,
        to,
        plane: Plane::from_point_normal(winding[0], n).unwrap(),
        winding,
        transform: None,
        origin: 0,
    }
}

fn both(a: usize, b: usize, axis: usize, at: f64, a0: f64, a1: f64) -> [VisPortal; 2] {
    [
        door(a, b, axis, at, 1.0, a0, a1),
        door(b, a, axis, at, -1.0, a0, a1),
    ]
}

/// Four 4 x 4 rooms around a square: A (x 0..4, z 0..4), B (x 4..8, z 0..4), C (x 4..8,
/// z 4..8), D (x 0..4, z 4..8); doors A|B at x = 4, z 0..1; B|C at z = 4, x 7..8; C|D at x = 4,
/// z 7..8. A straight line through all three doors would have to turn back, so A and D do not
/// see each other; every other pair has a sightline (A→C e.g. (3.5, 0.5) → (4, 1) → (7, 4);
/// B→D e.g. (8, 3) → (7, 4) → (4, 7)).
#[test]
fn known_answer_corridor_around_a_corner() {
    let mut portals = Vec::new();
    portals.extend(both(0, 1, 0, 4.0, 0.0, 1.0));
    portals.extend(both(1, 2, 2, 4.0, 7.0, 8.0));
    // C → D travels towards -x.
    portals.push(door(2, 3, 0, 4.0, -1.0, 7.0, 8.0));
    portals.push(door(3, 2, 0, 4.0, 1.0, 7.0, 8.0));
    let g = VisGraph::new(4, portals, 1e-9);
    let [flood, fast, full, sampled] = assert_nested("corridor", &g);
    assert_eq!(flood.pairs(), 16);
    let want = "0: 0 1 2\n1: 0 1 2 3\n2: 0 1 2 3\n3: 1 2 3\n";
    assert_eq!(full.to_text(), want);
    assert_eq!(
        sampled.to_text(),
        want,
        "the sampler finds every real pair here"
    );
    assert!(fast.pairs() >= full.pairs());
}

/// Three rooms in a row, A (x 0..4), B (x 4..8), C (x 8..12), all z 0..8: a two-way door A|B
/// at x = 4, z 0..1, and a one-way portal C → B at x = 8, z 7..8. Were it two-way, A would see
/// C ((3.5, 0.25) → (4, 1) → (8, 7)); one-way, nothing in A or B sees C, and C sees both.
#[test]
fn known_answer_one_way() {
    let mut portals = Vec::new();
    portals.extend(both(0, 1, 0, 4.0, 0.0, 1.0));
    portals.push(door(2, 1, 0, 8.0, -1.0, 7.0, 8.0));
    let g = VisGraph::new(3, portals, 1e-9);
    let [_, _, full, _] = assert_nested("one-way", &g);
    assert_eq!(full.to_text(), "0: 0 1\n1: 0 1\n2: 0 1 2\n");
}

#[test]
fn mirror_and_teleporter_follow_transforms() {
    // The teleporter joins two rooms that do not touch: a sees b only through it.
    let g = graph_of(&sample("teleporter.gltf"), None);
    assert_eq!(g.cells, 2);
    for depth in [0, 1] {
        let opts = VisOptions {
            transform_depth: depth,
            ..Default::default()
        };
        let full = vis::compute(&g, &opts);
        assert_eq!(full.sees(0, 1), depth > 0, "depth {depth}");
        let sampled = vis::compute(
            &g,
            &VisOptions {
                method: Method::Sampled,
                samples: 500,
                ..opts.clone()
            },
        );
        assert!(sampled.is_subset_of(&full));
        assert_eq!(sampled.sees(0, 1), depth > 0);
    }
    // The mirror leads back into its own room.
    let g = graph_of(&sample("mirror.gltf"), None);
    assert!(g.has_transforms());
    assert_eq!(run(&g, Method::Full).pairs(), 1);
}

/// The full PVS does not depend on how the portals are listed: which chain reaches a portal
/// first, and which wave a portal falls in, change only the work, never the answer.
#[test]
fn the_same_result_for_any_listing_of_the_portals() {
    for name in [
        "stair_hall.gltf",
        "offset_holes.gltf",
        "courtyard.gltf",
        "mirror.gltf",
    ] {
        let g = graph_of(&sample(name), None);
        let full = run(&g, Method::Full);
        // Reversed, and every third portal moved to the front.
        let mut by: Vec<usize> = (0..g.portals.len()).rev().collect();
        by.sort_by_key(|&k| k % 3 != 0);
        let portals = by.iter().map(|&k| g.portals[k].clone()).collect();
        let mut h = VisGraph::new(g.cells, portals, g.epsilon);
        h.outside = g.outside;
        assert_eq!(run(&h, Method::Full), full, "{name}");
    }
}

#[test]
fn the_same_result_for_any_thread_count() {
    let (file, _) =
        portcullis::prt::read(&common::root().join("tests/fixtures/prt/light_general.prt"))
            .unwrap();
    let g = file.graph(None);
    for m in [Method::Full, Method::Sampled, Method::Fast] {
        let one = vis::compute(
            &g,
            &VisOptions {
                method: m,
                samples: 200,
                threads: Some(1),
                ..Default::default()
            },
        );
        let four = vis::compute(
            &g,
            &VisOptions {
                method: m,
                samples: 200,
                threads: Some(4),
                ..Default::default()
            },
        );
        assert_eq!(one, four, "{m:?}");
    }
}

/// The oracle: random segments between points of two different cells that hit none of the
/// level's triangles are sightlines, so the second cell must be in the first's full PVS.
#[test]
fn clear_segments_are_in_the_full_pvs() {
    let mut total = 0;
    for (file, preset) in common::levels_with_rooms() {
        let (t, c, p) = common::load_level(&file, preset);
        if c.cells.len() < 2 {
            continue;
        }
        let full = vis::of_level(
            c.cells.len(),
            &p,
            c.tolerance.distance,
            &VisOptions::default(),
        );
        let mesh = common::opaque_mesh(&t);
        let mut seed = 0x2545f4914f6cdd1du64;
        let mut rnd = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        for _ in 0..300 {
            let a = (rnd() * c.cells.len() as f64) as usize % c.cells.len();
            let b = (rnd() * c.cells.len() as f64) as usize % c.cells.len();
            if a == b {
                continue;
            }
            let mut pick = |cell: usize| loop {
                let bb = c.cells[cell].bounds;
                let q = bb.min + (bb.max - bb.min) * DVec3::new(rnd(), rnd(), rnd());
                if c.cells[cell].poly.contains_strictly(q, 1e-6) {
                    return q;
                }
            };
            let (pa, pb) = (pick(a), pick(b));
            let d = pb - pa;
            if mesh.intersects_local_ray(&Ray::new(pa, d / d.length()), d.length()) {
                continue;
            }
            assert!(
                full.sees(a, b),
                "{}: a clear segment {pa} → {pb} joins cell {a} to cell {b}, not in the full PVS",
                file.display()
            );
            total += 1;
        }
    }
    assert!(total > 100, "only {total} clear segments were judged");
}

/// Four rooms in a row (x 0..4, 4..8, 8..12, 12..16, all z 0..8) with wide doors: A|B and
/// C|D two-way, B → C one-way. A sees straight through to D, though nothing in D can see back
/// past C: the flow's symmetry filter (a finished reverse that never saw A rules its portal
/// out for A) must not apply when a portal has no reverse.
#[test]
fn known_answer_one_way_in_the_middle() {
    let mut portals = Vec::new();
    portals.extend(both(0, 1, 0, 4.0, 1.0, 7.0));
    portals.push(door(1, 2, 0, 8.0, 1.0, 1.0, 7.0));
    portals.extend(both(2, 3, 0, 12.0, 1.0, 7.0));
    let g = VisGraph::new(4, portals, 1e-9);
    let [_, _, full, _] = assert_nested("one-way in the middle", &g);
    assert_eq!(
        full.to_text(),
        "0: 0 1 2 3
1: 0 1 2 3
2: 2 3
3: 2 3
"
    );
}

/// A reader that stops early (`portcullis vis big.prt | head`) ends the command quietly: no
/// panic, no error message about the pipe.
#[cfg(unix)]
#[test]
fn a_closed_pipe_ends_vis_quietly() {
    use std::io::Read;
    use std::process::{Command, Stdio};
    // A straight corridor of 300 cells sees end to end: 90 000 pairs, far more text than a
    // pipe buffers.
    let cells = 300;
    let mut prt = format!("PRT1\n{cells}\n{}\n", cells - 1);
    for i in 0..cells - 1 {
        let x = (i + 1) as f64;
        prt += &format!("4 {i} {} ({x} 0 0) ({x} 0 1) ({x} 1 1) ({x} 1 0)\n", i + 1);
    }
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("corridor.prt");
    std::fs::write(&path, prt).unwrap();
    let mut child = Command::new(env!("CARGO_BIN_EXE_portcullis"))
        .args(["vis", "--method", "flood"])
        .arg(&path)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut first = [0u8; 16];
    let mut out = child.stdout.take().unwrap();
    out.read_exact(&mut first).unwrap();
    assert!(first.starts_with(b"0: 0 1 2"));
    drop(out);
    let done = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&done.stderr);
    assert!(
        !stderr.contains("panicked") && !stderr.contains("Broken pipe"),
        "{stderr}"
    );
    assert_ne!(done.status.code(), Some(101), "{stderr}");
}

/// A roofless hall's openings are its top, on the hull of its portals: nothing can come back
/// through them, so its graph has no outside, and its PVS is the walled-up level's.
#[test]
fn openings_on_the_hull_lead_nowhere() {
    let f = common::sample("block_roofless.gltf");
    let (_, c, p) = common::load_level(&f, None);
    let eps = c.tolerance.distance;
    assert!(
        p.portals.iter().any(|q| q.to.is_none() && !q.closed),
        "the hall has no opening to the exterior"
    );
    let g = VisGraph::from_portal_set(c.cells.len(), &p, eps);
    assert!(g.outside.is_none(), "the sky over the hall leads somewhere");
    let opts = VisOptions::default();
    let with = vis::of_level(c.cells.len(), &p, eps, &opts);
    let without = vis::of_level(c.cells.len(), &walled(&p), eps, &opts);
    assert_eq!(with, without);
}

/// The flow's work budget: cut short at any size, the full PVS stays conservative (it holds
/// the unbounded flow's result) and no looser than `fast`; the count of portals cut short is
/// reported; and the result is the same for any thread count, since the bounds are fixed by
/// work counted at wave ends.
#[test]
fn a_flow_cut_short_by_its_budget_stays_between_full_and_fast() {
    // A generated building of 60 rooms: big enough that the flow is tighter than `fast`.
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("b.glb");
    let scene = portcullis::buildings::generate(&portcullis::buildings::GenOptions {
        rooms: 60,
        seed: 3,
        props: false,
    });
    let fmt = portcullis::export::target::OutFormat::Glb;
    std::fs::write(
        &path,
        portcullis::export::gltf_out::write_plain(&scene, fmt),
    )
    .unwrap();
    let g = graph_of(&path, None);
    let with = |method, budget, threads| {
        vis::computed(
            &g,
            &VisOptions {
                method,
                threads: Some(threads),
                flow_budget: budget,
                ..Default::default()
            },
        )
    };
    let exact = with(Method::Full, vis::DEFAULT_FLOW_BUDGET, 2);
    assert_eq!(exact.cut_short, 0, "a small level fits the default budget");
    // The largest budget `--flow-budget` takes: no overflow, the same exact flow, also on a
    // level of one wave (a few portals), where a source's bound is the whole half budget.
    let most = with(Method::Full, u64::MAX, 2);
    assert_eq!((most.pvs, most.cut_short), (exact.pvs.clone(), 0));
    let small = graph_of(&sample("stair_hall.gltf"), None);
    let huge = VisOptions {
        flow_budget: u64::MAX,
        ..Default::default()
    };
    let c = vis::computed(&small, &huge);
    assert_eq!(c.cut_short, 0);
    assert_eq!(c.pvs, run(&small, Method::Full));
    let fast = with(Method::Fast, 1, 2).pvs;
    assert!(
        exact.pvs.pairs() < fast.pairs(),
        "the flow is tighter than fast here"
    );
    let mut cut_any = false;
    for budget in [1, 100, 1_000, 5_000, 20_000] {
        let one = with(Method::Full, budget, 1);
        let two = with(Method::Full, budget, 2);
        assert_eq!(
            one.pvs, two.pvs,
            "budget {budget}: threads change the result"
        );
        assert_eq!(one.cut_short, two.cut_short);
        let lost = exact.pvs.missing_from(&one.pvs);
        assert!(
            lost.is_empty(),
            "budget {budget} lost {:?}",
            &lost[..lost.len().min(5)]
        );
        let over = one.pvs.missing_from(&fast);
        assert!(
            over.is_empty(),
            "budget {budget}: looser than fast at {over:?}"
        );
        cut_any |= one.cut_short > 0;
    }
    assert!(cut_any, "the small budgets cut some flow short");
    assert!(with(Method::Full, 1, 2).pvs.pairs() > exact.pvs.pairs());
}
