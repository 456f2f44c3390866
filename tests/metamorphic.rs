//! Metamorphic tests (issue 25, DESIGN.md Numerics): moving, turning, scaling or re-ordering a
//! level must not change its cells, portals, pairing, room adjacency, PVS or diagnostics.
//!
//! Every sample, every third-party level and a generated 100-room building are imported once;
//! each change is applied to the `Scene` (every node's world matrix, or the mesh data for the
//! re-orderings), and tags, cells, portals, checks and the full PVS are rerun from the changed
//! scene. Cells are matched by room and by their centroid (computed here from the faces, by
//! the divergence theorem) moved by the change; portals by their matched cells and moved
//! centroid. Then, strictly: the same cells per room (count and volumes), the same portals
//! (count, cell pairs, kinds, partners, areas within 1e-6 relative or the tolerance along the
//! perimeter), the same room adjacency,
//! the same PVS pairs of matched cells and the same diagnostics.
//!
//! Lengths in the configuration (`max_tolerance`, `max_wall_thickness`, heights, the crack and
//! widest-cell widths, the overlap volume) are scaled with the level: a level modelled in
//! millimetres is configured in millimetres. The up axis is turned with the level.

mod common;

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use common::{fixture, sample};
use glam::{DMat4, DVec3};
use portcullis::cells::CellSet;
use portcullis::diag::Code;
use portcullis::geom::polyhedron::polygon_area;
use portcullis::pipeline::{build_cells, build_portals, load_tagged, Tagged};
use portcullis::portals::PortalSet;
use portcullis::scene::Scene;

/// A fixed-seed generator, so every run shuffles the same way.
use common::rng::SplitMix64 as Rng;

#[derive(Clone, Copy, Debug)]
enum Change {
    /// A rigid or similarity transform of the whole level.
    Move(DMat4),
    /// Node indices, root order and children order shuffled.
    ShuffleNodes,
    /// Triangles shuffled within each primitive, each triangle's vertices rotated (winding
    /// kept).
    ShuffleTriangles,
    /// The winding of every prop and detail mesh reversed.
    FlipProps,
}

impl Change {
    fn matrix(self) -> DMat4 {
        match self {
            Change::Move(m) => m,
            _ => DMat4::IDENTITY,
        }
    }
}

fn changes(up: DVec3) -> Vec<(&'static str, Change)> {
    let turn = |deg: f64| Change::Move(DMat4::from_axis_angle(up, deg.to_radians()));
    let oblique = DVec3::new(1.0, 2.0, 3.0).normalize();
    vec![
        (
            "translate (1e5, -3e4, 2e5)",
            Change::Move(DMat4::from_translation(DVec3::new(1e5, -3e4, 2e5))),
        ),
        (
            "translate (2^20, 0, 0)",
            Change::Move(DMat4::from_translation(DVec3::new(1048576.0, 0.0, 0.0))),
        ),
        ("turn 30 degrees about up", turn(30.0)),
        ("turn 90 degrees about up", turn(90.0)),
        ("turn 137 degrees about up", turn(137.0)),
        (
            "turn 90 degrees about x",
            Change::Move(DMat4::from_rotation_x(std::f64::consts::FRAC_PI_2)),
        ),
        (
            "turn 37 degrees about (1, 2, 3)",
            Change::Move(DMat4::from_axis_angle(oblique, 37f64.to_radians())),
        ),
        (
            "scale 1e-3",
            Change::Move(DMat4::from_scale(DVec3::splat(1e-3))),
        ),
        (
            "scale 1e3",
            Change::Move(DMat4::from_scale(DVec3::splat(1e3))),
        ),
        // A mirrored instance (scale -1 on one axis, as DCC tools mirror): the mirror image of
        // every cell and portal (issue 29, item 2).
        (
            "mirror x",
            Change::Move(DMat4::from_scale(DVec3::new(-1.0, 1.0, 1.0))),
        ),
        ("shuffle nodes", Change::ShuffleNodes),
        ("shuffle triangles", Change::ShuffleTriangles),
        ("flip prop winding", Change::FlipProps),
    ]
}

/// One level's result, in names and world coordinates.
struct Outcome {
    tagged: Tagged,
    cells: CellSet,
    portals: PortalSet,
    /// The full PVS as (cell, cell) pairs, a cell seeing itself left out.
    pvs: BTreeSet<(usize, usize)>,
}

impl Outcome {
    fn room_name(&self, c: usize) -> &str {
        &self.tagged.tagging.rooms[self.cells.cells[c].room].name
    }
    fn codes(&self) -> BTreeMap<Code, usize> {
        let mut out = BTreeMap::new();
        for d in self.tagged.diagnostics.iter() {
            *out.entry(d.code).or_default() += 1;
        }
        out
    }
    /// Room pairs joined by a portal, by name.
    fn adjacency(&self) -> BTreeSet<(String, Option<String>)> {
        self.portals
            .portals
            .iter()
            .map(|p| {
                (
                    self.room_name(p.from).to_string(),
                    p.to.map(|t| self.room_name(t).to_string()),
                )
            })
            .collect()
    }
}

/// The centroid of a convex cell from its faces (the divergence theorem over a fan of
/// tetrahedra from a point inside): written here, so the comparison shares no code with the
/// cell stage.
fn cell_centroid(c: &portcullis::cells::Cell) -> DVec3 {
    let faces = &c.poly.faces;
    let n: usize = faces.iter().map(|f| f.points.len()).sum();
    let inner = faces
        .iter()
        .flat_map(|f| f.points.iter().copied())
        .sum::<DVec3>()
        / n.max(1) as f64;
    let (mut vol, mut acc) = (0.0, DVec3::ZERO);
    for f in faces {
        for i in 1..f.points.len().saturating_sub(1) {
            let (p, q, r) = (f.points[0], f.points[i], f.points[i + 1]);
            let v = (p - inner).dot((q - inner).cross(r - inner)).abs() / 6.0;
            vol += v;
            acc += v * (inner + p + q + r) / 4.0;
        }
    }
    if vol > 0.0 {
        acc / vol
    } else {
        inner
    }
}

fn run(scene: Scene, base: &Tagged, m: DMat4) -> Outcome {
    run_with(scene, base, m, 1.0)
}

/// `run`, with the tolerance the policy's times `factor`.
fn run_with(scene: Scene, base: &Tagged, m: DMat4, factor: f64) -> Outcome {
    let s = m.transform_vector3(DVec3::X).length();
    let mut config = base.config.clone();
    config.cells.tolerance_factor = factor;
    config.cells.up = m
        .transform_vector3(DVec3::from_array(base.config.cells.up))
        .normalize()
        .to_array();
    config.cells.max_tolerance *= s;
    config.cells.overlap_volume *= s * s * s;
    config.cells.max_cell_width *= s;
    config.cells.default_height = config.cells.default_height.map(|h| h * s);
    config.cells.footprint_height = config.cells.footprint_height.map(|h| h * s);
    config.portals.max_wall_thickness *= s;
    config.portals.min_opening_width = config.portals.min_opening_width.map(|w| w * s);
    // The crack width is a length too: the format's (a brush map's 0.2 units) or the default.
    let crack = config
        .cells
        .crack_width
        .or(scene.crack_width)
        .unwrap_or(portcullis::config::DEFAULT_CRACK_WIDTH);
    config.cells.crack_width = Some(crack * s);
    let tagging = portcullis::tags::recognise(&scene, &base.rules);
    let diagnostics = tagging.diagnostics.clone();
    let mut tagged = Tagged {
        scene,
        config,
        rules: base.rules.clone(),
        tagging,
        diagnostics,
    };
    let cells = build_cells(&mut tagged);
    let portals = build_portals(&mut tagged, &cells);
    common::check_parts(&mut tagged, &cells, &portals, false);
    let full = portcullis::vis::of_level(
        cells.cells.len(),
        &portals,
        cells.tolerance.distance,
        &portcullis::vis::VisOptions::default(),
    );
    let pvs = (0..cells.cells.len())
        .flat_map(|c| {
            full.visible(c)
                .filter(move |&k| k != c)
                .map(move |k| (c, k))
        })
        .collect();
    Outcome {
        tagged,
        cells,
        portals,
        pvs,
    }
}

fn apply(scene: &Scene, change: Change, props: &[usize], rng: &mut Rng) -> Scene {
    let mut s = scene.clone();
    match change {
        Change::Move(m) => {
            for n in &mut s.nodes {
                n.world = m * n.world;
            }
        }
        Change::ShuffleNodes => {
            // new_of[old] = new index.
            let mut order: Vec<usize> = (0..s.nodes.len()).collect();
            rng.shuffle(&mut order);
            let mut new_of = vec![0; order.len()];
            for (new, &old) in order.iter().enumerate() {
                new_of[old] = new;
            }
            let mut nodes: Vec<_> = order.iter().map(|&o| scene.nodes[o].clone()).collect();
            for n in &mut nodes {
                n.parent = n.parent.map(|p| new_of[p]);
                n.children = n.children.iter().map(|&c| new_of[c]).collect();
                rng.shuffle(&mut n.children);
            }
            s.nodes = nodes;
            s.roots = scene.roots.iter().map(|&r| new_of[r]).collect();
            rng.shuffle(&mut s.roots);
        }
        Change::ShuffleTriangles => {
            for mesh in &mut s.meshes {
                for p in &mesh.primitives {
                    let range = p.first_triangle..p.first_triangle + p.triangle_count;
                    let tris = &mut mesh.triangles[range];
                    rng.shuffle(tris);
                    for t in tris.iter_mut() {
                        t.rotate_left(rng.below(3));
                    }
                }
            }
        }
        Change::FlipProps => {
            let meshes: Vec<usize> = props.iter().filter_map(|&n| s.nodes[n].mesh).collect();
            // A mesh also drawn by a node that is not a prop keeps its winding.
            let shared = |m: usize| {
                s.nodes
                    .iter()
                    .enumerate()
                    .any(|(i, n)| n.mesh == Some(m) && !props.contains(&i))
            };
            let flip: Vec<usize> = meshes.iter().copied().filter(|&m| !shared(m)).collect();
            for m in flip {
                for t in &mut s.meshes[m].triangles {
                    t.swap(1, 2);
                }
            }
        }
    }
    s
}

/// Prop and detail nodes of a level: what `FlipProps` turns inside out.
fn props(o: &Outcome) -> Vec<usize> {
    let mut out = o.cells.prop_nodes();
    out.extend(o.tagged.tagging.detail.iter().map(|d| d.node));
    for r in &o.tagged.tagging.rooms {
        out.extend(r.detail.iter().copied());
    }
    out.sort_unstable();
    out.dedup();
    out
}

fn centroid(poly: &[DVec3]) -> DVec3 {
    poly.iter().copied().sum::<DVec3>() / poly.len() as f64
}

/// Compares `b` with `a` changed by `m`; returns what differs.
fn compare(a: &Outcome, b: &Outcome, m: DMat4, what: &str) -> Vec<String> {
    let s = m.transform_vector3(DVec3::X).length();
    let mut errs = Vec::new();
    // Points are the same within ten times the coarser of the two levels' tolerances (the
    // first scaled), plus the f64 rounding of coordinates as far out as the change moves them.
    let far = m.transform_point3(DVec3::ZERO).length();
    let tol = 10.0 * (a.cells.tolerance.distance * s).max(b.cells.tolerance.distance) + 1e-12 * far;
    // Cells: per room, each of `a` to the one of `b` whose centroid is where `m` puts it.
    let mut cell_of = vec![None; a.cells.cells.len()];
    let (mut rooms_a, mut rooms_b) = (BTreeMap::new(), BTreeMap::new());
    for (o, rooms) in [(a, &mut rooms_a), (b, &mut rooms_b)] {
        for (r, cells) in o.cells.room_cells.iter().enumerate() {
            rooms
                .entry(o.tagged.tagging.rooms[r].name.clone())
                .or_insert_with(Vec::new)
                .extend(cells.iter().copied());
        }
    }
    if rooms_a.len() != rooms_b.len() {
        errs.push(format!(
            "{what}: {} rooms vs {}",
            rooms_a.len(),
            rooms_b.len()
        ));
    }
    for (name, ca) in &rooms_a {
        let Some(cb) = rooms_b.get(name) else {
            errs.push(format!("{what}: room {name} lost"));
            continue;
        };
        if ca.len() != cb.len() {
            errs.push(format!(
                "{what}: room {name}: {} cells vs {}",
                ca.len(),
                cb.len()
            ));
            continue;
        }
        let mut used = vec![false; cb.len()];
        for &i in ca {
            let want = m.transform_point3(cell_centroid(&a.cells.cells[i]));
            let vol = a.cells.cells[i].volume * s.powi(3);
            let found = (0..cb.len()).filter(|&j| !used[j]).min_by(|&x, &y| {
                let dx = cell_centroid(&b.cells.cells[cb[x]]).distance(want);
                let dy = cell_centroid(&b.cells.cells[cb[y]]).distance(want);
                dx.total_cmp(&dy)
            });
            let Some(j) = found else { continue };
            let got = &b.cells.cells[cb[j]];
            let d = cell_centroid(got).distance(want);
            // Faces where they were within the tolerance move the volume by at most the
            // tolerance times the surface (a slab of f32 noise between two rooms' walls).
            let surface: f64 = got
                .poly
                .faces
                .iter()
                .map(|f| polygon_area(&f.points, f.plane.normal))
                .sum();
            if d > tol + 1e-6 * vol.cbrt() || (got.volume - vol).abs() > tol * surface + 1e-6 * vol
            {
                errs.push(format!(
                    "{what}: room {name}: cell {i} ({vol} m³) has no counterpart (nearest {} m³, {d} m off)",
                    got.volume
                ));
                continue;
            }
            used[j] = true;
            cell_of[i] = Some(cb[j]);
        }
    }
    if !errs.is_empty() {
        return errs;
    }
    // Portals: each of `a` to the one of `b` between the matched cells, centroid and normal
    // where `m` puts them.
    let (pa, pb) = (&a.portals.portals, &b.portals.portals);
    if pa.len() != pb.len() {
        errs.push(format!("{what}: {} portals vs {}", pa.len(), pb.len()));
    }
    let mut portal_of = vec![None; pa.len()];
    let mut used = vec![false; pb.len()];
    for (i, p) in pa.iter().enumerate() {
        let c = m.transform_point3(centroid(&p.polygon));
        let n = m.transform_vector3(p.normal).normalize();
        let from = cell_of[p.from];
        let to = p.to.map(|t| cell_of[t]);
        let area = p.area * s * s;
        let found = pb.iter().enumerate().find(|(j, q)| {
            !used[*j]
                && Some(q.from) == from
                && q.to.map(Some) == to
                && q.normal.dot(n) > 0.999
                && centroid(&q.polygon).distance(c) <= tol + 1e-6 * area.sqrt()
                && q.kind == p.kind
                && q.one_way == p.one_way
                && q.closed == p.closed
                && q.internal == p.internal
        });
        let Some((j, q)) = found else {
            errs.push(format!(
                "{what}: portal {i} ({} -> {:?}, {} m², centroid {c} after the change) has no counterpart",
                a.room_name(p.from),
                p.to.map(|t| a.room_name(t)),
                area,
            ));
            continue;
        };
        used[j] = true;
        portal_of[i] = Some(j);
        // An edge is where it is within the tolerance: the area within the perimeter's worth
        // of it (a 0.2 m door reveal in f32 data moves by 5e-7 m, 2.5e-6 of its area).
        let perimeter: f64 = (0..q.polygon.len())
            .map(|k| q.polygon[k].distance(q.polygon[(k + 1) % q.polygon.len()]))
            .sum();
        if (q.area - area).abs() > 1e-6 * area + 0.1 * perimeter * tol {
            errs.push(format!("{what}: portal {i}: area {area} vs {}", q.area));
        }
        if let (Some(ta), Some(tb)) = (p.transform, q.transform) {
            // The changed level's transform is the original conjugated by the change.
            let x = m.transform_point3(ta.transform_point3(centroid(&p.polygon)));
            let y = tb.transform_point3(c);
            if x.distance(y) > tol {
                errs.push(format!("{what}: portal {i}: transform moves {x} vs {y}"));
            }
        } else if p.transform.is_some() != q.transform.is_some() {
            errs.push(format!("{what}: portal {i}: transform presence differs"));
        }
    }
    for (j, r) in pb.iter().enumerate().filter(|(j, _)| !used[*j]) {
        errs.push(format!(
            "{what}: portal {j} of the changed level ({} -> {:?}, {} m², centroid {}) is new",
            b.room_name(r.from),
            r.to.map(|t| b.room_name(t)),
            r.area,
            centroid(&r.polygon)
        ));
    }
    for (i, p) in pa.iter().enumerate() {
        if let Some(j) = portal_of[i] {
            if p.partner.and_then(|k| portal_of[k]) != pb[j].partner {
                errs.push(format!("{what}: portal {i}: partner differs"));
            }
        }
    }
    if a.adjacency() != b.adjacency() {
        errs.push(format!("{what}: room adjacency differs"));
    }
    let moved: BTreeSet<(usize, usize)> = a
        .pvs
        .iter()
        .filter_map(|&(x, y)| Some((cell_of[x]?, cell_of[y]?)))
        .collect();
    if moved != b.pvs {
        errs.push(format!(
            "{what}: full PVS of {} pairs vs {} ({} only before, {} only after)",
            a.pvs.len(),
            b.pvs.len(),
            moved.difference(&b.pvs).count(),
            b.pvs.difference(&moved).count()
        ));
    }
    let (ca, cb) = (a.codes(), b.codes());
    if ca != cb {
        errs.push(format!("{what}: diagnostics {ca:?} vs {cb:?}"));
    }
    errs
}

/// Every sample, every third-party level (with its tag preset) and a generated building.
fn levels() -> Vec<(PathBuf, Option<&'static str>)> {
    let mut out = Vec::new();
    let mut samples: Vec<PathBuf> = std::fs::read_dir(common::root().join("samples"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| {
            matches!(
                p.extension().and_then(|e| e.to_str()),
                Some("gltf" | "glb" | "obj")
            )
        })
        .collect();
    samples.sort();
    out.extend(samples.into_iter().map(|p| (p, None)));
    for (name, preset) in [
        ("lportal_tutorial_simple.glb", None),
        ("lportal_tutorial_simple.obj", None),
        ("lportal_boxrooms.glb", None),
        ("lportal_boxrooms.obj", None),
        ("panda3d_culling.glb", Some("panda3d")),
        ("panda3d_culling.obj", Some("panda3d")),
        ("living_room.glb", None),
        ("occlusion_room.glb", None),
        ("navigation_level_mesh.obj", None),
        ("gi_zdm2.glb", None),
        ("pandora.obj", None),
        ("E1M2_godot.glb", None),
        ("MAP01_godot.glb", None),
    ] {
        out.push((fixture(name), preset));
    }
    out
}

/// Differences shown per level and change (the rest are counted).
const SHOW: usize = 4;

/// For working on one level: `METAMORPHIC_ONLY=<part of its path>` skips the others, and
/// `METAMORPHIC_SHOW_ALL=1` prints every difference found (with `-- --nocapture`).
fn selected(path: &Path) -> bool {
    std::env::var("METAMORPHIC_ONLY").map_or(true, |o| path.to_string_lossy().contains(&o))
}

fn show_all(found: &[String]) {
    if std::env::var_os("METAMORPHIC_SHOW_ALL").is_some() {
        for x in found {
            eprintln!("ALL {x}");
        }
    }
}

fn check_level_file(path: &Path, preset: Option<&str>) -> Vec<String> {
    if !selected(path) {
        return Vec::new();
    }
    let opts = portcullis::pipeline::LoadOptions {
        preset: preset.map(str::to_string),
        ..Default::default()
    };
    let mut t = load_tagged(path, &opts).unwrap_or_else(|d| panic!("{}: {d}", path.display()));
    // The stored glTF document plays no part in building; dropping it keeps clones cheap.
    t.scene.gltf = None;
    let base = run(t.scene.clone(), &t, DMat4::IDENTITY);
    let props = props(&base);
    let mut rng = Rng::from_state(0x5eed_0025 ^ path.as_os_str().len() as u64);
    let up = DVec3::from_array(t.config.cells.up);
    let file = path.file_name().unwrap().to_string_lossy();
    let mut errs = Vec::new();
    for (label, change) in changes(up) {
        let scene = apply(&base.tagged.scene, change, &props, &mut rng);
        let m = change.matrix();
        let out = run(scene, &t, m);
        let mut e = compare(&base, &out, m, &format!("{file} ({label})"));
        show_all(&e);
        if e.is_empty() {
            continue;
        }
        // One level's many differences under one change are one finding: show a few.
        let more = e.len().saturating_sub(SHOW);
        e.truncate(SHOW);
        if more > 0 {
            e.push(format!("{file} ({label}): {more} more"));
        }
        errs.extend(e);
    }
    errs
}

fn check_all(paths: impl IntoIterator<Item = (PathBuf, Option<&'static str>)>) {
    let errs: Vec<String> = paths
        .into_iter()
        .flat_map(|(p, preset)| check_level_file(&p, preset))
        .collect();
    assert!(
        errs.is_empty(),
        "{}\n{} difference(s)",
        errs.join("\n"),
        errs.len()
    );
}

#[test]
fn samples_are_invariant() {
    check_all(
        levels()
            .into_iter()
            .filter(|(p, _)| p.starts_with(common::root().join("samples"))),
    );
}

#[test]
fn third_party_levels_are_invariant() {
    check_all(
        levels()
            .into_iter()
            .filter(|(p, _)| !p.starts_with(common::root().join("samples"))),
    );
}

#[test]
fn a_generated_building_is_invariant() {
    let dir = tempfile::tempdir().unwrap();
    check_all([(common::generated_building(dir.path(), 100, 7), None)]);
}

/// The comparison is not blind: a level with one room moved by a metre differs.
#[test]
fn a_real_change_is_seen() {
    let opts = portcullis::pipeline::LoadOptions::default();
    let mut t = load_tagged(&sample("two_rooms.gltf"), &opts).unwrap();
    t.scene.gltf = None;
    let base = run(t.scene.clone(), &t, DMat4::IDENTITY);
    let mut scene = t.scene.clone();
    let lounge = (0..scene.nodes.len())
        .find(|&n| scene.node_label(n) == "lounge-room")
        .unwrap();
    scene.nodes[lounge].world = DMat4::from_translation(DVec3::X) * scene.nodes[lounge].world;
    for &c in &scene.nodes[lounge].children.clone() {
        scene.nodes[c].world = DMat4::from_translation(DVec3::X) * scene.nodes[c].world;
    }
    let out = run(scene, &t, DMat4::IDENTITY);
    assert!(!compare(&base, &out, DMat4::IDENTITY, "moved room").is_empty());
}

/// Tolerance stability (issue 25): the policy's tolerance times 0.25, 0.5, 2 and 4 gives the
/// same cells, portals, adjacency, PVS and diagnostics on every sample, shared level and a
/// generated building. panda3d, modelled a fraction of a millimetre to 5 mm off its own cells,
/// is held by cracks being an absolute width rather than a multiple of the tolerance (its gaps
/// spanned the whole sweep).
#[test]
fn results_do_not_hang_on_the_tolerance() {
    let dir = tempfile::tempdir().unwrap();
    let mut all = levels();
    all.push((common::generated_building(dir.path(), 100, 7), None));
    let mut errs = Vec::new();
    for (path, preset) in all.into_iter().filter(|(p, _)| selected(p)) {
        let opts = portcullis::pipeline::LoadOptions {
            preset: preset.map(str::to_string),
            ..Default::default()
        };
        let mut t = load_tagged(&path, &opts).unwrap_or_else(|d| panic!("{}: {d}", path.display()));
        t.scene.gltf = None;
        // What the crack width closed is counted only where a gap is wider than two
        // tolerances (a narrower one is no gap to the geometry): how many it says may change
        // with the tolerance, the cells and portals may not.
        let without_cracks = |mut r: Outcome| {
            r.tagged
                .diagnostics
                .0
                .retain(|d| d.code != Code::CRACKS_CLOSED);
            r
        };
        let base = without_cracks(run(t.scene.clone(), &t, DMat4::IDENTITY));
        let file = path.file_name().unwrap().to_string_lossy().to_string();
        let mut found = Vec::new();
        for factor in [0.25, 0.5, 2.0, 4.0] {
            let out = without_cracks(run_with(t.scene.clone(), &t, DMat4::IDENTITY, factor));
            found.extend(compare(
                &base,
                &out,
                DMat4::IDENTITY,
                &format!("{file} (tolerance x{factor})"),
            ));
        }
        show_all(&found);
        if !found.is_empty() {
            eprintln!("{file}: {} differences", found.len());
            errs.extend(found.into_iter().take(SHOW));
        }
    }
    assert!(errs.is_empty(), "{}", errs.join("\n"));
}
