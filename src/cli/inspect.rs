//! `portcullis inspect FILE...`: what portcullis sees in each level.

use std::fmt::Write;
use std::path::PathBuf;

use clap::Args;
use serde::Serialize;

use portcullis::cells::CellSource;
use portcullis::diag::Diagnostic;
use portcullis::pipeline::{self, Level, Tagged};
use portcullis::report::{human, style::Style, Totals};
use portcullis::scene::summary::{summarize, Bounds, SceneSummary};
use portcullis::tags::rules::{PortalKind, TagKind, VolumeHint};

use super::{Format, LevelArgs};

#[derive(Debug, Args)]
pub struct InspectArgs {
    /// Level files: .gltf, .glb, .obj, .map (Quake-family brush maps), and
    /// .usd/.usda/.usdc/.usdz with the `usd` feature; a Quake .prt, or a Quake-family .bsp
    /// (its stored visibility, beside ours and the lower bound when its .prt is there).
    #[arg(required = true, value_name = "FILE")]
    pub files: Vec<PathBuf>,

    /// Output format.
    #[arg(long, value_enum, default_value = "human")]
    pub format: Format,

    /// Exit with 1 when there are warnings, not only errors.
    #[arg(long, value_name = "warnings", value_parser = ["warnings"])]
    pub deny: Option<String>,

    /// For files portcullis already annotated: check the stored extension against its schema
    /// and for internal consistency (indices in range, partners mutual).
    #[arg(long)]
    pub validate: bool,

    /// Cut meshes that span several cells along the cell planes, and report each cell's part
    /// (without it, such a mesh is listed whole in every cell it reaches into).
    #[arg(long)]
    pub split_geometry: bool,

    #[command(flatten)]
    pub level: LevelArgs,
}

/// The JSON view of one file.
#[derive(Debug, Serialize)]
struct FileReport {
    #[serde(serialize_with = "portcullis::diag::lossy_path")]
    path: PathBuf,
    /// The name's bytes when it is not UTF-8 (`path` is then written lossily).
    #[serde(skip_serializing_if = "Option::is_none")]
    path_bytes: Option<Vec<u8>>,
    /// False when the file could not be read at all.
    ok: bool,
    #[serde(
        skip_serializing_if = "Option::is_none",
        serialize_with = "portcullis::diag::lossy_path_opt"
    )]
    config: Option<PathBuf>,
    #[serde(skip_serializing_if = "Option::is_none")]
    scene: Option<SceneSummary>,
    #[serde(skip_serializing_if = "Option::is_none")]
    tags: Option<TagsView>,
    #[serde(skip_serializing_if = "Option::is_none")]
    cells: Option<Vec<CellView>>,
    /// Room meshes taken for props, and why (they render but do not shape cells).
    #[serde(skip_serializing_if = "Option::is_none")]
    props: Option<Vec<PropView>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    portals: Option<Vec<DerivedPortalView>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    tolerance: Option<f64>,
    /// What a stored PORTCULLIS_portals extension says, if the file has one.
    #[serde(skip_serializing_if = "Option::is_none")]
    annotation: Option<AnnotationView>,
    /// A Quake portal file's graph, for a .prt input.
    #[serde(skip_serializing_if = "Option::is_none")]
    prt: Option<PrtView>,
    /// What a Quake-family .bsp holds for vis, for a .bsp input.
    #[serde(skip_serializing_if = "Option::is_none")]
    bsp: Option<super::inspect_bsp::BspView>,
    /// What inspect ran, next to what `check` would (inspect builds; check also judges).
    #[serde(skip_serializing_if = "Option::is_none")]
    checks: Option<&'static str>,
    diagnostics: Vec<Diagnostic>,
}

/// What a Quake portal file holds.
#[derive(Debug, Serialize)]
struct PrtView {
    format: &'static str,
    cells: usize,
    leaves: usize,
    portals: usize,
    /// Cells no portal touches.
    isolated: usize,
}

/// Said under every level inspect builds: it runs the stages, not `check`'s judgements.
const FEWER_CHECKS: &str = "inspect reports what importing, tagging and building cells and \
portals found; `portcullis check` also checks portal pairing and shape, transforms, the cell \
graph, leaks and a stored annotation";

/// The report of a file that could not be read at all.
fn failed_report(path: &std::path::Path, d: Diagnostic) -> FileReport {
    bare_report(path, false, vec![d])
}

/// A report with nothing but its diagnostics.
fn bare_report(path: &std::path::Path, ok: bool, diagnostics: Vec<Diagnostic>) -> FileReport {
    FileReport {
        path: path.to_path_buf(),
        path_bytes: portcullis::diag::raw_path_bytes(path),
        ok,
        config: None,
        scene: None,
        tags: None,
        cells: None,
        props: None,
        portals: None,
        tolerance: None,
        annotation: None,
        prt: None,
        bsp: None,
        checks: None,
        diagnostics,
    }
}

/// A .prt input: its graph, as `vis` reads it.
fn prt_report(path: &std::path::Path) -> Result<FileReport, Diagnostic> {
    let (file, diagnostics) = portcullis::prt::read(path)?;
    let mut touched = vec![false; file.cells];
    for p in &file.portals {
        for c in [p.a, p.b] {
            if let Some(t) = touched.get_mut(c) {
                *t = true;
            }
        }
    }
    Ok(FileReport {
        prt: Some(PrtView {
            format: file.format.header(),
            cells: file.cells,
            leaves: file.leaves,
            portals: file.portals.len(),
            isolated: touched.iter().filter(|t| !**t).count(),
        }),
        ..bare_report(path, true, diagnostics)
    })
}

#[derive(Debug, Serialize)]
struct AnnotationView {
    generator: String,
    input_hash: String,
    /// The geometry or tags changed since the annotation was written.
    stale: bool,
    cells: usize,
    portals: usize,
    /// The stored PVS: its method, encoding and visible pairs.
    #[serde(skip_serializing_if = "Option::is_none")]
    visibility: Option<VisibilityView>,
}

#[derive(Debug, Serialize)]
struct VisibilityView {
    method: String,
    encoding: String,
    pairs: usize,
}

/// Summarises (and with `validate`, checks) a stored annotation.
fn annotation_view(t: &mut Tagged, validate: bool) -> Option<AnnotationView> {
    use portcullis::diag::{Code, Location};
    use portcullis::format::{self as extension, read};
    let stored = portcullis::check::stored::read(t, validate)?;
    t.diagnostics.extend(stored.diagnostics);
    let a = stored.annotated?;
    let src = t.scene.gltf.as_ref()?;
    let buffers = src.buffer_data().ok()?;
    let stored_pvs = read::visibility(&a, &src.subset(&["bufferViews"]).ok()?, &buffers);
    let visibility = match stored_pvs {
        Some(Ok(pvs)) => a.visibility.as_ref().map(|v| VisibilityView {
            method: v["method"].as_str().unwrap_or_default().to_string(),
            encoding: v["encoding"].as_str().unwrap_or_default().to_string(),
            pairs: pvs.pairs(),
        }),
        Some(Err(e)) => {
            if validate {
                t.diagnostics.push(
                    Diagnostic::new(
                        Code::ANNOTATION_INVALID,
                        format!("the stored annotation is invalid: {e}"),
                        Location::file(&t.scene.path)
                            .with_pointer(format!("/extensions/{}/visibility", extension::NAME)),
                    )
                    .hint("convert the level again to rewrite the annotation"),
                );
            }
            None
        }
        None => None,
    };
    Some(AnnotationView {
        generator: a.generator,
        input_hash: a.input_hash,
        stale: stored.stale,
        cells: a.cells.len(),
        portals: a.portals.len(),
        visibility,
    })
}

#[derive(Debug, Serialize)]
struct DerivedPortalView {
    from: usize,
    /// Target cell; null for the exterior.
    to: Option<usize>,
    from_room: String,
    to_room: Option<String>,
    kind: PortalKind,
    one_way: bool,
    closed: bool,
    /// A door's opening: closes with the door (`authored`).
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    door: bool,
    internal: bool,
    area: f64,
    /// Counter-clockwise seen from the source cell.
    polygon: Vec<[f64; 3]>,
    /// Direction of travel.
    normal: [f64; 3],
    #[serde(skip_serializing_if = "Option::is_none")]
    transform: Option<[f64; 16]>,
    #[serde(skip_serializing_if = "Option::is_none")]
    authored: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    partner: Option<usize>,
}

fn portals_view(level: &Level) -> Vec<DerivedPortalView> {
    let (t, cells, set) = (&level.tagged, &level.cells, &level.portals);
    let room = |c: usize| t.tagging.rooms[cells.cells[c].room].name.clone();
    set.portals
        .iter()
        .map(|p| DerivedPortalView {
            from: p.from,
            to: p.to,
            from_room: room(p.from),
            to_room: p.to.map(room),
            kind: p.kind,
            one_way: p.one_way,
            closed: p.closed,
            door: p.door,
            internal: p.internal,
            area: p.area,
            polygon: p.polygon.iter().map(|v| v.to_array()).collect(),
            normal: p.normal.to_array(),
            transform: p.transform.map(|m| m.to_cols_array()),
            authored: p.authored.map(|n| t.scene.node_path(n)),
            partner: p.partner,
        })
        .collect()
}

#[derive(Debug, Serialize)]
struct PropView {
    node: String,
    room: String,
    reason: portcullis::cells::PropReason,
}

fn props_view(level: &Level) -> Vec<PropView> {
    let (t, set) = (&level.tagged, &level.cells);
    set.props
        .iter()
        .map(|&portcullis::cells::Prop { node: n, reason }| PropView {
            node: t.scene.node_path(n),
            room: t
                .tagging
                .rooms
                .iter()
                .find(|r| r.structure.contains(&n))
                .map(|r| r.name.clone())
                .unwrap_or_default(),
            reason,
        })
        .collect()
}

#[derive(Debug, Serialize)]
struct CellView {
    room: String,
    source: CellSource,
    volume: f64,
    planes: usize,
    bounds: Bounds,
    /// Nodes the cell renders.
    nodes: Vec<String>,
    /// With --split-geometry: triangles of meshes cut to this cell.
    #[serde(skip_serializing_if = "Option::is_none")]
    split_triangles: Option<usize>,
}

fn cells_view(level: &Level, split: bool) -> Vec<CellView> {
    let (t, set) = (&level.tagged, &level.cells);
    let pieces = if split {
        portcullis::cells::split_geometry(&t.scene, set)
    } else {
        Vec::new()
    };
    set.cells
        .iter()
        .enumerate()
        .map(|(i, c)| CellView {
            split_triangles: split.then(|| {
                pieces
                    .iter()
                    .filter(|p| p.cell == i)
                    .map(|p| p.triangles.len())
                    .sum()
            }),
            room: t.tagging.rooms[c.room].name.clone(),
            source: c.source,
            volume: c.volume,
            planes: c.poly.faces.len(),
            bounds: Bounds {
                min: c.bounds.min.to_array(),
                max: c.bounds.max.to_array(),
                size: c.bounds.size().to_array(),
            },
            nodes: c.nodes.iter().map(|&n| t.scene.node_path(n)).collect(),
        })
        .collect()
}

#[derive(Debug, Serialize)]
struct TagsView {
    preset: String,
    /// What `--tags auto` generated, and with which settings.
    #[serde(skip_serializing_if = "Option::is_none")]
    generated: Option<portcullis::tags::Generated>,
    rooms: Vec<RoomView>,
    #[serde(skip_serializing_if = "Vec::is_empty")]
    room_groups: Vec<GroupView>,
    portals: Vec<AuthoredPortalView>,
    bounds: Vec<VolumeView>,
    footprints: Vec<VolumeView>,
    ignored: Vec<String>,
    detail: Vec<String>,
    player_starts: Vec<String>,
    /// Mesh nodes in no room.
    unassigned: Vec<String>,
    near_misses: Vec<NearMissView>,
}

#[derive(Debug, Serialize)]
struct RoomView {
    name: String,
    node: String,
    rule: String,
    volume: VolumeHint,
    #[serde(skip_serializing_if = "Option::is_none")]
    group: Option<String>,
    structure: Vec<String>,
    detail: Vec<String>,
}

#[derive(Debug, Serialize)]
struct GroupView {
    name: String,
    node: String,
    rooms: Vec<String>,
}

#[derive(Debug, Serialize)]
struct AuthoredPortalView {
    node: String,
    rule: String,
    /// The room the portal leads out of (resolved), if known.
    source: Option<String>,
    /// The room the portal leads into (resolved), if known.
    target: Option<String>,
    /// The target as written in the name or extras, resolved or not.
    #[serde(skip_serializing_if = "Option::is_none")]
    target_name: Option<String>,
    kind: PortalKind,
    one_way: bool,
    closed: bool,
    #[serde(skip_serializing_if = "Option::is_none")]
    teleport_exit: Option<String>,
}

#[derive(Debug, Serialize)]
struct VolumeView {
    node: String,
    rule: String,
    room: Option<String>,
}

#[derive(Debug, Serialize)]
struct NearMissView {
    node: String,
    name: String,
    kind: TagKind,
    rule: String,
    suggestion: String,
    slip: String,
}

fn tags_view(t: &Tagged) -> TagsView {
    let g = &t.tagging;
    let s = &t.scene;
    let room = |r: Option<usize>| r.map(|r| g.rooms[r].name.clone());
    let volume = |b: &portcullis::tags::VolumeNode| VolumeView {
        node: b.path.clone(),
        rule: b.rule.clone(),
        room: room(b.room),
    };
    let paths = |v: &[usize]| v.iter().map(|&n| s.node_path(n)).collect::<Vec<_>>();
    TagsView {
        preset: g.preset.clone(),
        generated: g.generated.as_deref().cloned(),
        rooms: g
            .rooms
            .iter()
            .map(|r| RoomView {
                name: r.name.clone(),
                node: r.path.clone(),
                rule: r.rule.clone(),
                volume: r.volume,
                group: r.group.map(|i| g.room_groups[i].name.clone()),
                structure: paths(&r.structure),
                detail: paths(&r.detail),
            })
            .collect(),
        room_groups: g
            .room_groups
            .iter()
            .map(|gr| GroupView {
                name: gr.name.clone(),
                node: s.node_path(gr.node),
                rooms: gr.rooms.iter().map(|&r| g.rooms[r].name.clone()).collect(),
            })
            .collect(),
        portals: g
            .portals
            .iter()
            .map(|p| AuthoredPortalView {
                node: p.path.clone(),
                rule: p.rule.clone(),
                source: room(p.source_room),
                target: room(p.target_room),
                target_name: p.target_name.clone(),
                kind: p.kind,
                one_way: p.one_way,
                closed: p.closed,
                teleport_exit: p.teleport_exit.map(|n| s.node_path(n)),
            })
            .collect(),
        bounds: g.bounds.iter().map(volume).collect(),
        footprints: g.footprints.iter().map(volume).collect(),
        ignored: g.ignored.iter().map(|n| n.path.clone()).collect(),
        detail: g.detail.iter().map(|n| n.path.clone()).collect(),
        player_starts: g.player_starts.iter().map(|n| n.path.clone()).collect(),
        unassigned: g.unassigned.iter().map(|n| n.path.clone()).collect(),
        near_misses: g
            .near_misses
            .iter()
            .map(|m| NearMissView {
                node: m.path.clone(),
                name: m.name.clone(),
                kind: m.kind,
                rule: m.rule.clone(),
                suggestion: m.suggestion.clone(),
                slip: m.slip.clone(),
            })
            .collect(),
    }
}

pub fn run(a: &InspectArgs, style: &Style) -> i32 {
    let opts = a.level.load_options();
    let mut totals = Totals::default();
    let mut reports = Vec::new();
    for path in &a.files {
        totals.files += 1;
        let is_bsp = portcullis::export::Target::is_bsp(path);
        if portcullis::export::Target::is_prt(path) || is_bsp {
            let made = if is_bsp {
                super::inspect_bsp::view(path, &opts).map(|(v, diags)| FileReport {
                    bsp: Some(v),
                    ..bare_report(path, true, diags)
                })
            } else {
                prt_report(path)
            };
            let report = made.unwrap_or_else(|d| {
                totals.failed += 1;
                failed_report(path, d)
            });
            totals.add(report.diagnostics.iter());
            if a.format == Format::Human {
                print!("{}", render_human(&report, style));
            }
            reports.push(report);
            continue;
        }
        let reading = super::huge_pages::reading(path);
        let loaded = pipeline::load_tagged(path, &opts);
        drop(reading);
        let report = match loaded {
            Ok(mut t) => {
                let annotation = annotation_view(&mut t, a.validate);
                let level = pipeline::build(t);
                totals.add(level.diagnostics.iter());
                FileReport {
                    path: path.clone(),
                    path_bytes: portcullis::diag::raw_path_bytes(path),
                    ok: true,
                    config: level.config().path.clone(),
                    scene: Some(summarize(level.scene())),
                    tags: Some(tags_view(&level.tagged)),
                    cells: Some(cells_view(&level, a.split_geometry)),
                    props: Some(props_view(&level)),
                    portals: Some(portals_view(&level)),
                    tolerance: Some(level.cells.tolerance.distance),
                    annotation,
                    prt: None,
                    bsp: None,
                    checks: Some(FEWER_CHECKS),
                    diagnostics: level.diagnostics.0.clone(),
                }
            }
            Err(d) => {
                totals.failed += 1;
                failed_report(path, d)
            }
        };
        totals.add(report.diagnostics.iter().filter(|_| !report.ok));
        if a.format == Format::Human {
            print!("{}", render_human(&report, style));
        }
        reports.push(report);
    }
    match a.format {
        Format::Human => println!("{}", style.bold(&totals.line())),
        Format::Json => {
            let doc = serde_json::json!({
                "tool": {"name": "portcullis", "version": env!("CARGO_PKG_VERSION")},
                "files": reports,
                "summary": totals,
            });
            match serde_json::to_string_pretty(&doc) {
                Ok(s) => println!("{s}"),
                Err(e) => {
                    eprintln!("error: cannot write the JSON report: {e}");
                    return 2;
                }
            }
        }
    }
    totals.exit_code(a.deny.is_some())
}

fn list(out: &mut String, title: &str, items: &[String], style: &Style) {
    if items.is_empty() {
        let _ = writeln!(out, "    {title}: {}", style.dim("none"));
    } else {
        let _ = writeln!(out, "    {title} ({}):", items.len());
        for i in items {
            let _ = writeln!(out, "      {i}");
        }
    }
}

/// The words shown after a portal for what is not plain about it.
fn portal_flags(kind: PortalKind, one_way: bool, closed: bool, internal: bool) -> Vec<String> {
    let mut flags = Vec::new();
    if kind != PortalKind::Plain {
        flags.push(format!("{kind:?}").to_lowercase());
    }
    for (on, word) in [
        (one_way, "one-way"),
        (closed, "closed"),
        (internal, "internal"),
    ] {
        if on {
            flags.push(word.to_string());
        }
    }
    flags
}

fn fmt3(v: [f64; 3]) -> String {
    let f = |x: f64| {
        let s = format!("{x:.3}");
        let s = s.trim_end_matches('0').trim_end_matches('.').to_string();
        if s == "-0" {
            "0".to_string()
        } else {
            s
        }
    };
    format!("[{}, {}, {}]", f(v[0]), f(v[1]), f(v[2]))
}

fn render_human(r: &FileReport, style: &Style) -> String {
    let mut out = String::new();
    let _ = writeln!(out, "{}", style.bold(&r.path.display().to_string()));
    if let Some(p) = &r.prt {
        render_prt(&mut out, p, style);
    }
    if let Some(b) = &r.bsp {
        super::inspect_bsp::render(&mut out, b, style);
    }
    if let Some(s) = &r.scene {
        render_scene(&mut out, s);
    }
    if let Some(a) = &r.annotation {
        render_annotation(&mut out, a);
    }
    if let Some(c) = &r.config {
        let _ = writeln!(out, "  config: {}", c.display());
    }
    if let Some(t) = &r.tags {
        render_tags(&mut out, t, style);
    }
    if let Some(cells) = &r.cells {
        render_cells(&mut out, cells, r.tolerance, style);
    }
    if let Some(props) = &r.props {
        let rows: Vec<String> = props
            .iter()
            .map(|p| format!("`{}` (room `{}`): {}", p.node, p.room, p.reason.describe()))
            .collect();
        list(
            &mut out,
            "props (rendered, not shaping cells)",
            &rows,
            style,
        );
    }
    if let Some(portals) = &r.portals {
        render_portals(&mut out, portals, style);
    }
    if !r.diagnostics.is_empty() {
        for d in &r.diagnostics {
            for line in human::diagnostic(d, style).lines() {
                let _ = writeln!(out, "  {line}");
            }
        }
    }
    if let Some(c) = r.checks {
        let _ = writeln!(out, "  {}", style.dim(&format!("note: {c}")));
    }
    out
}

/// A Quake portal file's graph, and that inspecting it can say no more (no level behind it).
fn render_prt(out: &mut String, p: &PrtView, style: &Style) {
    let _ = writeln!(
        out,
        "  portal file ({}): {} cells, {} leaves, {} portals, {} without a portal",
        p.format,
        p.cells,
        p.leaves,
        p.portals,
        match p.isolated {
            1 => "1 cell".to_string(),
            n => format!("{n} cells"),
        }
    );
    let _ = writeln!(
        out,
        "  {}",
        style.dim("`portcullis vis` computes its PVS; the level it came from is not here")
    );
}

/// What the scene holds: counts, bounds and material names.
fn render_scene(out: &mut String, s: &SceneSummary) {
    let _ = writeln!(
        out,
        "  scene ({}): {} nodes ({} with meshes), {} meshes, {} triangles, {} materials",
        s.format.name(),
        s.nodes,
        s.mesh_nodes,
        s.meshes,
        s.triangles,
        s.materials.len()
    );
    if let Some(b) = &s.bounds {
        let _ = writeln!(
            out,
            "  bounds: {} .. {} (size {})",
            fmt3(b.min),
            fmt3(b.max),
            fmt3(b.size)
        );
    }
    if !s.materials.is_empty() {
        let _ = writeln!(out, "  materials: {}", s.materials.join(", "));
    }
}

/// What a stored annotation says, and whether the level changed since it was written.
fn render_annotation(out: &mut String, a: &AnnotationView) {
    let _ = writeln!(
        out,
        "  annotation: {} cells, {} portals, by {}{}",
        a.cells,
        a.portals,
        a.generator,
        if a.stale {
            " (stale: the level changed since)"
        } else {
            ""
        }
    );
    if let Some(v) = &a.visibility {
        let _ = writeln!(
            out,
            "  visibility: {}, {} visible pairs ({})",
            v.method, v.pairs, v.encoding
        );
    }
}

/// Everything the tags recognised, one list per kind; lists that are usually empty are
/// left out when they are.
fn render_tags(out: &mut String, t: &TagsView, style: &Style) {
    let _ = writeln!(out, "  tags (preset {}):", t.preset);
    if let Some(g) = &t.generated {
        let _ = writeln!(
            out,
            "    generated: {} rooms from {} voxels of air; voxel {:.3} m, grid {} x {} x {}, split ratio {}, detail under {:.3} m²",
            g.boxes.len(),
            g.air_voxels,
            g.voxel,
            g.grid[0],
            g.grid[1],
            g.grid[2],
            g.split_ratio,
            g.detail_area
        );
    }
    let rooms: Vec<String> = t.rooms.iter().map(room_row).collect();
    list(out, "rooms", &rooms, style);
    let portals: Vec<String> = t.portals.iter().map(authored_portal_row).collect();
    list(out, "authored portals", &portals, style);
    let vol = |v: &[VolumeView]| -> Vec<String> {
        v.iter()
            .map(|b| {
                format!(
                    "`{}` room {} ({})",
                    b.node,
                    b.room.as_deref().unwrap_or("?"),
                    b.rule
                )
            })
            .collect()
    };
    list(out, "bounds", &vol(&t.bounds), style);
    list(out, "footprints", &vol(&t.footprints), style);
    if !t.room_groups.is_empty() {
        let groups: Vec<String> = t
            .room_groups
            .iter()
            .map(|g| format!("{} `{}`: {}", g.name, g.node, g.rooms.join(", ")))
            .collect();
        list(out, "room groups", &groups, style);
    }
    list(out, "ignored", &t.ignored, style);
    list(out, "detail (outside rooms)", &t.detail, style);
    if !t.player_starts.is_empty() {
        list(out, "player starts", &t.player_starts, style);
    }
    list(out, "mesh nodes in no room", &t.unassigned, style);
    let misses: Vec<String> = t
        .near_misses
        .iter()
        .map(|m| {
            format!(
                "`{}` almost matches {} ({}); `{}` would",
                m.node, m.rule, m.slip, m.suggestion
            )
        })
        .collect();
    list(out, "near misses", &misses, style);
}

/// One room: its node, rule, what it holds and where its volume comes from.
fn room_row(rm: &RoomView) -> String {
    let vol = match rm.volume {
        VolumeHint::Geometry => String::new(),
        v => format!(
            ", volume from {}",
            serde_json::to_value(v)
                .ok()
                .and_then(|v| v.as_str().map(str::to_string))
                .unwrap_or_default()
        ),
    };
    format!(
        "{}  `{}` ({}; {} structure, {} detail{vol}{})",
        rm.name,
        rm.node,
        rm.rule,
        rm.structure.len(),
        rm.detail.len(),
        rm.group
            .as_ref()
            .map(|g| format!(", group {g}"))
            .unwrap_or_default()
    )
}

/// One authored portal: the rooms it leads between (a name with `?` when it named a room
/// that was not found) and what is not plain about it.
fn authored_portal_row(p: &AuthoredPortalView) -> String {
    let side = |r: &Option<String>, n: Option<&String>| match (r, n) {
        (Some(r), _) => r.clone(),
        (None, Some(n)) => format!("{n}?"),
        (None, None) => "?".to_string(),
    };
    let flags = portal_flags(p.kind, p.one_way, p.closed, false);
    let flags = if flags.is_empty() {
        String::new()
    } else {
        format!(", {}", flags.join(", "))
    };
    format!(
        "`{}`  {} -> {} ({}{flags})",
        p.node,
        side(&p.source, None),
        side(&p.target, p.target_name.as_ref()),
        p.rule
    )
}

/// One row per cell, under a title that gives the tolerance the cells were built with.
fn render_cells(out: &mut String, cells: &[CellView], tolerance: Option<f64>, style: &Style) {
    let rows: Vec<String> = cells
        .iter()
        .enumerate()
        .map(|(i, c)| {
            let src = serde_json::to_value(c.source)
                .ok()
                .and_then(|v| v.as_str().map(str::to_string))
                .unwrap_or_default();
            let split = c
                .split_triangles
                .map(|n| format!(", {n} split triangles"))
                .unwrap_or_default();
            let renders = match c.nodes.len() {
                1 => "renders 1 node".to_string(),
                n => format!("renders {n} nodes"),
            };
            format!(
                "#{i} room {}: {src}, {:.3} m³, {} planes, {} .. {}, {renders}{split}",
                c.room,
                c.volume,
                c.planes,
                fmt3(c.bounds.min),
                fmt3(c.bounds.max),
            )
        })
        .collect();
    let mut title = "cells".to_string();
    if let Some(t) = tolerance {
        title = format!("cells (tolerance {t:.1e} m)");
    }
    list(out, &title, &rows, style);
}

/// The portals between cells one per row; those to the exterior, often many, as one total.
fn render_portals(out: &mut String, portals: &[DerivedPortalView], style: &Style) {
    let (exterior, linked): (Vec<&DerivedPortalView>, Vec<&DerivedPortalView>) =
        portals.iter().partition(|p| p.to.is_none());
    let rows: Vec<String> = linked
        .iter()
        .map(|p| {
            let mut flags = portal_flags(p.kind, p.one_way, p.closed, p.internal);
            match &p.authored {
                Some(a) if p.door => flags.push(format!("door `{a}`")),
                Some(a) => flags.push(format!("authored `{a}`")),
                None => {}
            }
            let b = portcullis::geom::aabb::Aabb::from_points(
                p.polygon
                    .iter()
                    .map(|v| glam::DVec3::from_array(*v))
                    .collect::<Vec<_>>()
                    .iter(),
            );
            format!(
                "cell {} ({}) -> cell {} ({}): {:.3} m², {} .. {}{}",
                p.from,
                p.from_room,
                p.to.unwrap_or(0),
                p.to_room.as_deref().unwrap_or(""),
                p.area,
                fmt3(b.min.to_array()),
                fmt3(b.max.to_array()),
                if flags.is_empty() {
                    String::new()
                } else {
                    format!(" [{}]", flags.join(", "))
                }
            )
        })
        .collect();
    list(out, "portals between cells", &rows, style);
    if !exterior.is_empty() {
        let area: f64 = exterior.iter().map(|p| p.area).sum();
        let _ = writeln!(
            out,
            "    exterior openings: {} portals, {:.3} m² in all",
            exterior.len(),
            area
        );
    }
}
