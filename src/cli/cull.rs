//! `portcullis cull LEVEL --cameras FILE`: what each camera sees, by the runtime an engine
//! would run ([`portcullis::runtime`]), so a designer can ask "what is drawn from here".

use std::io::{BufRead, Write};
use std::path::{Path, PathBuf};

use clap::Args;
use serde_json::{json, Value};

use portcullis::diag::{Code, Diagnostic, Location as At};
use portcullis::report::{human, style::Style};
use portcullis::runtime::answer::{answer, CameraLine};
use portcullis::runtime::{Doors, DrawList, Level, Meshes, Trace, TraceOptions, View, ViewCost};

/// How `cull` writes its answers, each as soon as its camera is traced.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum CullFormat {
    /// Text for people.
    Human,
    /// One JSON array, one object per camera in order (written as the cameras are traced).
    Json,
    /// One JSON object per line, per camera in order: for fly-throughs of any length.
    Jsonl,
}

#[derive(Debug, Args)]
pub struct CullArgs {
    /// A level written by `portcullis convert` (.glb or .gltf with the PORTCULLIS_portals
    /// extension).
    #[arg(value_name = "LEVEL")]
    pub level: PathBuf,

    /// Cameras, one JSON object per line: {"eye":[x,y,z], "look":[x,y,z] (a direction),
    /// "up":[x,y,z], "fov_y":degrees, "aspect":width/height, "near":metres}. `up` defaults to
    /// [0,1,0], `fov_y` to 60, `aspect` to 16/9, `near` to 0.05; blank lines are skipped. `-`
    /// reads them from standard input as they come. A file is checked whole before any answer
    /// is written; from standard input or a pipe, a bad line stops the run where it is.
    #[arg(long, value_name = "FILE")]
    pub cameras: PathBuf,

    /// Output format: human, json (an array, one object per camera in order) or jsonl (one
    /// object per line). Answers are written as the cameras are traced: memory does not grow
    /// with their number.
    #[arg(long, value_enum, default_value = "human")]
    pub format: CullFormat,

    /// Close a portal (the extension's index) and its partner, as a door at run time. Repeat
    /// for several; a portal (or its partner) given twice, or with --open too, is an error.
    #[arg(long = "closed", value_name = "PORTAL")]
    pub closed: Vec<usize>,

    /// Open a portal the level starts with closed. Repeat for several.
    #[arg(long = "open", value_name = "PORTAL")]
    pub open: Vec<usize>,

    /// Portals one path may cross at most.
    #[arg(long, value_name = "N", default_value_t = TraceOptions::default().max_depth)]
    pub max_depth: usize,

    /// Mirrors and teleporters one path may cross at most.
    #[arg(long, value_name = "N", default_value_t = TraceOptions::default().max_transform_depth)]
    pub transform_depth: usize,

    /// Walk every portal without the stored PVS as a prefilter (for comparing).
    #[arg(long)]
    pub no_pvs: bool,

    /// Also price each view as an engine would draw it: triangles and draw calls submitted
    /// by the visible cells' draw lists, by their nodes drawn whole, and by frustum culling
    /// alone (each node's box culled against the view in all three), and per visible cell
    /// the triangles of its draw list; a summary per view at the end (human format).
    #[arg(long)]
    pub stats: bool,

    /// Also print what each view draws, `Level::draw_list` of the cells seen without a
    /// transform: `"draw": {"nodes": [glTF node, ...], "ranges": [[node, primitive, first,
    /// count], ...]}` (nodes drawn whole; ranges of the split indices). An entry seen through
    /// a mirror or teleporter gets its own cell's list, drawn moved. Human format: the counts.
    #[arg(long)]
    pub draw_lists: bool,
}

/// Prints `d` as every subcommand prints a diagnostic; `cull` stops with exit 2.
fn fail(d: Diagnostic, style: &Style) -> i32 {
    eprintln!("{}", human::diagnostic(&d, style));
    2
}

const CAMERA_HINT: &str = "one JSON object per line, e.g. {\"eye\":[1,1.6,2],\"look\":[1,0,0],\"up\":[0,1,0],\"fov_y\":70,\"aspect\":1.78,\"near\":0.05}";

/// The camera on line `i` (0-based) of `path`, `None` for a blank line, or what is wrong
/// with it.
fn parse_camera(path: &Path, i: usize, line: &str) -> Result<Option<View>, Diagnostic> {
    let bad = |m: String| {
        Diagnostic::new(
            Code::CULL_CAMERA_INVALID,
            m,
            At::file(path).with_line(i + 1),
        )
        .hint(CAMERA_HINT)
    };
    // The line is the location; serde's own "at line 1 column N" would name another line.
    let c = CameraLine::parse(line).map_err(|e| {
        let text = e.to_string();
        let what = text
            .rsplit_once(" at line ")
            .map_or(text.as_str(), |(w, _)| w);
        bad(format!("not a camera: {what} (column {})", e.column()))
    })?;
    let Some(c) = c else {
        return Ok(None);
    };
    c.view()
        .map(Some)
        .map_err(|e| bad(format!("not a usable camera: {e}")))
}

fn unreadable(path: &Path, e: std::io::Error) -> Diagnostic {
    Diagnostic::new(
        Code::IO_READ_FAILED,
        format!("the cameras file cannot be read: {e}"),
        At::file(path),
    )
    .hint("check the path given with --cameras")
}

/// The cameras' lines, from the file or (for `-`) standard input, read as they come.
fn camera_lines(path: &Path) -> Result<Box<dyn BufRead>, Diagnostic> {
    if path == Path::new("-") {
        return Ok(Box::new(std::io::stdin().lock()));
    }
    let f = std::fs::File::open(path).map_err(|e| unreadable(path, e))?;
    Ok(Box::new(std::io::BufReader::new(f)))
}

/// A regular file's cameras are all checked before any answer is written (a bad line is an
/// error with nothing printed); keeps nothing but the first problem.
fn check_cameras(path: &Path) -> Result<(), Diagnostic> {
    let regular = path != Path::new("-") && std::fs::metadata(path).is_ok_and(|m| m.is_file());
    if !regular {
        return Ok(());
    }
    for (i, line) in camera_lines(path)?.lines().enumerate() {
        let line = line.map_err(|e| unreadable(path, e))?;
        parse_camera(path, i, &line)?;
    }
    Ok(())
}

pub fn run(a: &CullArgs, style: &Style) -> i32 {
    if let Err(d) = check_cameras(&a.cameras) {
        return fail(d, style);
    }
    // An empty file is reported as every other command reports it, not as a parse failure.
    if std::fs::metadata(&a.level).is_ok_and(|m| m.is_file() && m.len() == 0) {
        let d = Diagnostic::new(
            Code::INPUT_EMPTY,
            format!("`{}` is empty (0 bytes)", a.level.display()),
            At::file(&a.level),
        )
        .hint("the export may have failed; export the level again, then `portcullis convert` it");
        return fail(d, style);
    }
    let level = match Level::load(&a.level) {
        Ok(l) => l,
        Err(e) => {
            let d = if e.unreadable {
                Diagnostic::new(
                    Code::IO_READ_FAILED,
                    format!("the level {}", e.kind),
                    At::file(&e.path),
                )
            } else {
                Diagnostic::new(
                    Code::CULL_NOT_CONVERTED,
                    format!("the level {}", e.kind),
                    At::file(&e.path).with_pointer("/extensions/PORTCULLIS_portals"),
                )
            };
            return fail(d.hint(e.hint), style);
        }
    };
    if let Some(message) = contradictory_doors(a, &level) {
        eprintln!("error: {message}");
        return 2;
    }
    let mut doors = Doors::new(&level);
    for (&p, closed) in a
        .closed
        .iter()
        .map(|p| (p, true))
        .chain(a.open.iter().map(|p| (p, false)))
    {
        if p >= level.portals() {
            let d = Diagnostic::new(
                Code::CULL_PORTAL_UNKNOWN,
                format!(
                    "portal {p} does not exist: the level has {} portals",
                    level.portals()
                ),
                At::file(&a.level).with_pointer("/extensions/PORTCULLIS_portals/portals"),
            )
            .hint("portal ids are the extension's indices; `portcullis inspect` lists them");
            return fail(d, style);
        }
        doors.set(&level, p, closed);
    }
    let opts = TraceOptions {
        max_depth: a.max_depth,
        max_transform_depth: a.transform_depth,
        use_pvs: !a.no_pvs,
    };
    let lines = match camera_lines(&a.cameras) {
        Ok(l) => l,
        Err(d) => return fail(d, style),
    };
    let meshes = match a.stats.then(|| Meshes::load(&a.level)).transpose() {
        Ok(m) => m,
        Err(e) => {
            let d = Diagnostic::new(
                Code::CULL_NOT_CONVERTED,
                format!("the level's meshes: {}", e.kind),
                At::file(&e.path),
            );
            return fail(d.hint(e.hint), style);
        }
    };
    let mut out = std::io::BufWriter::new(std::io::stdout().lock());
    let scene = Scene {
        level: &level,
        doors: &doors,
        opts: &opts,
        meshes: meshes.as_ref(),
    };
    match stream(a, &scene, lines, &mut out) {
        Ok(Ok(())) => 0,
        Ok(Err(d)) => {
            let _ = out.flush();
            fail(d, style)
        }
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => 0,
        Err(e) => fail(
            Diagnostic::new(
                Code::OUTPUT_FAILED,
                format!("the results cannot be written: {e}"),
                At::file(&a.level),
            )
            .hint("check where stdout goes (a full disk, a closed pipe)"),
            style,
        ),
    }
}

/// Traces each camera as its line is read and writes its answer at once: nothing but the
/// trace's buffers is kept from one camera to the next. The outer error is the output's;
/// the inner one a camera line that stopped the run (from a pipe, where lines are not
/// checked first).
fn stream(
    a: &CullArgs,
    scene: &Scene,
    lines: Box<dyn BufRead>,
    out: &mut dyn Write,
) -> std::io::Result<Result<(), Diagnostic>> {
    let Scene {
        level,
        doors,
        opts,
        meshes,
    } = *scene;
    let mut trace = Trace::default();
    let mut list = DrawList::default();
    let mut total = ViewCost::default();
    let mut n = 0;
    if a.format == CullFormat::Json {
        out.write_all(b"[")?;
    }
    for (i, line) in lines.lines().enumerate() {
        let line = match line {
            Ok(l) => l,
            Err(e) => return Ok(Err(unreadable(&a.cameras, e))),
        };
        let view = match parse_camera(&a.cameras, i, &line) {
            Ok(Some(v)) => v,
            Ok(None) => continue,
            Err(d) => return Ok(Err(d)),
        };
        level.trace(&view, doors, opts, &mut trace);
        let draws = a.draw_lists.then_some((level, &mut list));
        let mut r = answer(&trace, draws);
        if let Some(m) = meshes {
            let cost = level.cost(m, &view, &trace, &mut list);
            total += cost;
            r["submitted"] = json!(cost);
            for v in r["visible"].as_array_mut().into_iter().flatten() {
                if let Some(c) = v["cell"].as_u64() {
                    v["triangles"] = json!(level.cell_cost(m, c as usize, &mut list).triangles);
                }
            }
        }
        n += 1;
        match a.format {
            // As serde_json's pretty array: each element indented by two spaces.
            CullFormat::Json => {
                out.write_all(if n == 1 { b"\n" } else { b",\n" })?;
                let text = serde_json::to_string_pretty(&r).map_err(std::io::Error::other)?;
                for (k, l) in text.lines().enumerate() {
                    if k > 0 {
                        out.write_all(b"\n")?;
                    }
                    write!(out, "  {l}")?;
                }
            }
            CullFormat::Jsonl => {
                serde_json::to_writer(&mut *out, &r).map_err(std::io::Error::other)?;
                out.write_all(b"\n")?;
            }
            CullFormat::Human => human(out, level, n, &r)?,
        }
        // A pipe's reader sees each answer as its camera is done.
        if a.cameras == Path::new("-") {
            out.flush()?;
        }
    }
    if a.format == CullFormat::Json {
        out.write_all(if n == 0 { b"]\n" } else { b"\n]\n" })?;
    }
    if let (Some(m), CullFormat::Human, true) = (meshes, a.format, n > 0) {
        summary(out, m, &total, n)?;
    }
    out.flush()?;
    Ok(Ok(()))
}

/// What every camera is traced against.
#[derive(Clone, Copy)]
struct Scene<'a> {
    level: &'a Level,
    doors: &'a Doors,
    opts: &'a TraceOptions,
    /// With `--stats`.
    meshes: Option<&'a Meshes>,
}

/// `--stats`' last lines: the mean per view of each way of drawing.
fn summary(out: &mut dyn Write, m: &Meshes, t: &ViewCost, views: usize) -> std::io::Result<()> {
    let all = m.triangles().max(1) as f64;
    let v = views as f64;
    writeln!(
        out,
        "{views} views of a level of {} triangles; submitted per view:",
        m.triangles()
    )?;
    for (what, s) in [
        ("draw lists", t.lists),
        ("whole nodes", t.nodes),
        ("frustum only", t.frustum),
    ] {
        writeln!(
            out,
            "  {what:<12}  {:>10.1} triangles ({:.2}%)  {:>8.1} draw calls",
            s.triangles as f64 / v,
            100.0 * s.triangles as f64 / v / all,
            s.calls as f64 / v
        )?;
    }
    Ok(())
}

/// Camera `number`'s answer as text.
fn human(out: &mut dyn Write, level: &Level, number: usize, r: &Value) -> std::io::Result<()> {
    let name = |c: &Value| match c.as_u64() {
        Some(c) => format!("cell {c} ({})", level.room(c as usize)),
        None => "the outside".to_string(),
    };
    {
        let i = number - 1;
        let visible = r["visible"].as_array().map_or(&[][..], |v| v.as_slice());
        let at = match r["location"].as_str() {
            Some("outside") => match r["nearest"].as_u64() {
                Some(n) => format!("outside every cell (nearest: cell {n})"),
                None => "outside every cell".to_string(),
            },
            Some(loc) => format!("{} of {}", loc, name(&r["cell"])),
            None => String::new(),
        };
        writeln!(
            out,
            "camera {}: {at}; {} visible, {} portals tested",
            i + 1,
            visible.len(),
            r["stats"]["portals_tested"]
        )?;
        if let Some(s) = r.get("submitted") {
            let part =
                |k: &str| format!("{} triangles in {} calls", s[k]["triangles"], s[k]["calls"]);
            writeln!(
                out,
                "  submitted: draw lists {}; whole nodes {}; frustum only {}",
                part("lists"),
                part("nodes"),
                part("frustum")
            )?;
        }
        if let Some(d) = r.get("draw") {
            let count = |d: &Value, k: &str| d[k].as_array().map_or(0, Vec::len);
            let moved: Vec<&Value> = visible.iter().filter_map(|v| v.get("draw")).collect();
            let mut line = format!(
                "  draw: {} nodes, {} ranges",
                count(d, "nodes"),
                count(d, "ranges")
            );
            if !moved.is_empty() {
                let sum = |k: &str| moved.iter().map(|d| count(d, k)).sum::<usize>();
                let views = if moved.len() == 1 { "view" } else { "views" };
                line += &format!(
                    "; through mirrors and teleporters: {} nodes, {} ranges in {} {views}",
                    sum("nodes"),
                    sum("ranges"),
                    moved.len()
                );
            }
            writeln!(out, "{line}")?;
        }
        for v in visible {
            let rect: Vec<String> = v["rect"]
                .as_array()
                .map(|a| {
                    a.iter()
                        .map(|x| format!("{:.3}", x.as_f64().unwrap_or(0.0)))
                        .collect()
                })
                .unwrap_or_default();
            let via: Vec<String> = v["via"]
                .as_array()
                .map(|a| a.iter().map(|x| x.to_string()).collect())
                .unwrap_or_default();
            let mut line = format!(
                "  {}  depth {}  rect [{}]",
                name(&v["cell"]),
                v["depth"],
                rect.join(", ")
            );
            if !via.is_empty() {
                line += &format!("  via {}", via.join(" "));
            }
            if let Some(t) = v.get("triangles") {
                line += &format!("  {t} triangles");
            }
            if v.get("transform").is_some() {
                line += if v["mirrored"] == json!(true) {
                    "  (mirrored)"
                } else {
                    "  (transformed)"
                };
            }
            writeln!(out, "{line}")?;
        }
    }
    Ok(())
}

/// `--closed` and `--open` that repeat a portal or disagree about one opening (a portal and its
/// partner are one door): what is wrong, for an error with exit 2.
fn contradictory_doors(a: &CullArgs, level: &Level) -> Option<String> {
    let mut seen: std::collections::HashMap<usize, (usize, bool)> = Default::default();
    let given = a.closed.iter().map(|&p| (p, true));
    for (p, closed) in given.chain(a.open.iter().map(|&p| (p, false))) {
        let door = level.partner(p).map_or(p, |q| q.min(p));
        let flag = |c: bool| if c { "--closed" } else { "--open" };
        if let Some(&(q, was)) = seen.get(&door) {
            return Some(if q == p && was == closed {
                format!("portal {p} is given twice ({} {p})", flag(closed))
            } else if q == p {
                format!("portal {p} is given with both --closed and --open")
            } else {
                format!(
                    "portals {q} and {p} are the two sides of one door ({} {q}, {} {p}); give one of them",
                    flag(was),
                    flag(closed)
                )
            });
        }
        seen.insert(door, (p, closed));
    }
    None
}
