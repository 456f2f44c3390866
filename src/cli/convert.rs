//! `portcullis convert IN... -o OUT | --out-dir DIR`: the level with the `PORTCULLIS_portals`
//! extension added, written atomically; inputs are never overwritten unless `--in-place`.

use std::path::{Path, PathBuf};

use clap::Args;
use rayon::prelude::*;

use portcullis::diag::policy::Policy;
use portcullis::diag::{Code, Diagnostic, Location, Severity};
use portcullis::export::output::{self, Output};
use portcullis::export::{CellGeometry, Target};
use portcullis::pipeline;
use portcullis::report::{human, style::Style, Totals};
use portcullis::vis::{Method, Pvs};

use super::LevelArgs;

#[derive(Debug, Args)]
pub struct ConvertArgs {
    /// Level files: .gltf, .glb, .obj, .map (Quake-family brush maps), and
    /// .usd/.usda/.usdc/.usdz with the `usd` feature;
    /// `-` reads standard input (glTF/GLB recognised by their first bytes, anything else read
    /// as OBJ).
    #[arg(required = true, value_name = "FILE")]
    pub files: Vec<PathBuf>,

    /// Output file (.gltf, .glb, or .usda for USD with cells and portals as `portcullis:`
    /// attributes), for a single input; `-` writes to standard output (in --out-format).
    #[arg(short, long, value_name = "OUT", conflicts_with_all = ["out_dir", "in_place"])]
    pub output: Option<PathBuf>,

    /// Output folder: each input is written there as NAME.glb (or --out-format gltf).
    #[arg(long, value_name = "DIR", conflicts_with = "in_place")]
    pub out_dir: Option<PathBuf>,

    /// Format for --out-dir outputs.
    #[arg(long, value_name = "glb|gltf", default_value = "glb", value_parser = ["glb", "gltf"])]
    pub out_format: String,

    /// Replace each glTF input by its annotated version (atomically).
    #[arg(long)]
    pub in_place: bool,

    /// Leave out the cells' draw lists: by default the triangles of every node that reaches
    /// into several cells are copied into one index buffer sorted by cell, and each cell names
    /// its ranges of it (the extension's `split` and `cells[].draws`), so an engine draws
    /// only what its visible cells hold. Without them a cell names whole nodes only.
    #[arg(long, conflicts_with = "split_by_cell")]
    pub no_draw_lists: bool,

    /// Write each node that reaches into several cells as child nodes, one per set of cells
    /// (its parts, with the node's materials and every vertex attribute), so that each cell's
    /// `nodes` alone name what it draws: for engines and importers that can only show and
    /// hide nodes (Godot, Unity, Blender). The node keeps its transform and gives up its mesh.
    #[arg(long)]
    pub split_by_cell: bool,

    /// Also write a debug glTF (.glb) of the cells (translucent, per room) and portals
    /// (coloured by kind and direction), for any glTF viewer. One input only.
    #[arg(long, value_name = "OUT.glb")]
    pub debug: Option<PathBuf>,

    /// Also write a top-down SVG map of the cells and portals. One input only.
    #[arg(long, value_name = "OUT.svg")]
    pub svg: Option<PathBuf>,

    /// With --svg: highlight this cell and the cells in its PVS (computed by --vis, or full).
    #[arg(long, value_name = "CELL", requires = "svg")]
    pub pvs_of: Option<usize>,

    /// The PVS stored in the extension's `visibility`: flood, fast, full, sampled (a lower
    /// bound; not for engines), or none to leave it out.
    #[arg(long = "vis", value_name = "METHOD", default_value = "full",
          value_parser = ["none", "flood", "fast", "full", "sampled"])]
    pub vis_method: String,

    /// Also write the cell graph as a Quake portal file (PRT1) for Quake-family tools; one input
    /// only. `-o OUT.prt` writes only that.
    #[arg(long, value_name = "OUT.prt")]
    pub prt: Option<PathBuf>,

    /// The levels are meant to be closed: openings to the exterior are LEAK errors, and
    /// --debug draws each leak's path (same as `[check] sealed = true`).
    #[arg(long)]
    pub sealed: bool,

    /// Exit with 1 when there are warnings, not only errors.
    #[arg(long, value_name = "warnings", value_parser = ["warnings"])]
    pub deny: Option<String>,

    #[command(flatten)]
    pub level: LevelArgs,
}

fn same_file(a: &Path, b: &Path) -> bool {
    match (std::fs::canonicalize(a), std::fs::canonicalize(b)) {
        (Ok(x), Ok(y)) => x == y,
        _ => false,
    }
}

/// Where one input goes.
fn output_for(a: &ConvertArgs, input: &Path) -> Result<PathBuf, Diagnostic> {
    if a.in_place {
        return Ok(input.to_path_buf());
    }
    if let Some(o) = &a.output {
        return Ok(o.clone());
    }
    if let Some(dir) = &a.out_dir {
        let stem = input.file_stem().unwrap_or_default().to_string_lossy();
        return Ok(dir.join(format!("{stem}.{}", a.out_format)));
    }
    Err(Diagnostic::new(
        Code::OUTPUT_FAILED,
        "no output given",
        Location::file(input),
    )
    .hint("give -o OUT.glb for one input, or --out-dir DIR for several"))
}

/// What converting one file produced, reported in input order once all are done.
struct Outcome {
    diagnostics: Vec<Diagnostic>,
    summary: String,
}

fn convert_one(a: &ConvertArgs, input: &Path) -> Result<Outcome, Diagnostic> {
    let out = output_for(a, input)?;
    let target = target_of(a, input, &out)?;
    if target == Target::Prt {
        return convert_to_prt(a, input, &out);
    }
    let (t, policy) = load(a, input)?;
    let mut level = pipeline::build(t);
    if let Some(c) = a.pvs_of.filter(|&c| c >= level.cells.cells.len()) {
        return Err(Diagnostic::new(
            Code::OUTPUT_FAILED,
            format!(
                "--pvs-of {c}: the level has {} cells",
                level.cells.cells.len()
            ),
            Location::file(input),
        )
        .hint("give a cell index from `portcullis inspect`"));
    }
    super::alloc::release_free_memory();
    let method = Method::parse(&a.vis_method);
    let pvs_method = method.unwrap_or(Method::Full);
    let pvs = (method.is_some() || a.pvs_of.is_some()).then(|| {
        let note = pipeline::transform_depth_note(&level, input);
        level.diagnostics.extend(note);
        let (pvs, note) = pipeline::pvs_noted(&level, pvs_method, input);
        level.diagnostics.extend(note);
        pvs
    });
    if pvs.is_some() {
        super::alloc::release_free_memory();
    }
    let stored = method.and(pvs.as_ref()).map(|p| (p, pvs_method));
    let leaks = pipeline::check(&mut level, a.sealed);
    let sightlines = audit_sightlines(&mut level, pvs.as_ref());
    let prt = a.prt.as_ref().map(|path| {
        let (text, d) = portcullis::prt::write(level.cells.cells.len(), &level.portals, path);
        level.diagnostics.extend(d);
        (path, text)
    });
    level.diagnostics.in_file_units(level.tagged.scene.to_file);
    let diagnostics = policy.apply(level.diagnostics.0.clone());
    // The outputs that show the problem are written whatever the verdict; the products only
    // when the run will exit 0, so a failed run never leaves one for the next step to take.
    let shown = Shown {
        leaks,
        sightlines,
        pvs: pvs.as_ref(),
    };
    write_shows(a, &level, shown)?;
    let fails = diagnostics.iter().any(|d| {
        d.severity == Severity::Error || (a.deny.is_some() && d.severity == Severity::Warning)
    });
    let (cells, portals) = (level.cells.cells.len(), level.portals.portals.len());
    let summary = if fails {
        format!(
            "{}: {cells} cells, {portals} portals; nothing written to `{}` (the run fails)",
            input.display(),
            out.display()
        )
    } else {
        let geometry = match (a.split_by_cell, a.no_draw_lists) {
            (true, _) => CellGeometry::SplitNodes,
            (false, true) => CellGeometry::WholeNodes,
            (false, false) => CellGeometry::DrawLists,
        };
        let to = output_of(&out, target).with_geometry(geometry);
        output::level(&level, stored, &to)?;
        if let Some((path, text)) = &prt {
            output::bytes(&Output::file(path, Target::Prt), text.as_bytes())?;
        }
        summary(input, &out, cells, portals)
    };
    let outcome = Outcome {
        diagnostics,
        summary,
    };
    pipeline::drop_elsewhere((level, pvs));
    Ok(outcome)
}

/// Where the main output goes: `-` is standard output.
fn output_of(out: &Path, target: Target) -> Output<'_> {
    if out == Path::new("-") {
        Output::stdout(target)
    } else {
        Output::file(out, target)
    }
}

/// What `out` is written as (standard output in `--out-format`), refused before any work when
/// portcullis does not write it or it is the input itself.
fn target_of(a: &ConvertArgs, input: &Path, out: &Path) -> Result<Target, Diagnostic> {
    let target = if out == Path::new("-") {
        Some(if a.out_format == "gltf" {
            Target::Gltf
        } else {
            Target::Glb
        })
    } else {
        Target::from_path(out).filter(|t| t.is_level())
    };
    let target = target.ok_or_else(|| {
        Diagnostic::new(
            Code::OUTPUT_FORMAT_UNKNOWN,
            format!(
                "cannot write `{}`: portcullis writes .gltf, .glb and .usda",
                out.display()
            ),
            Location::file(out),
        )
        .hint("name the output .glb, .gltf or .usda")
    })?;
    if target != Target::Prt && !a.in_place && same_file(out, input) {
        return Err(Diagnostic::new(
            Code::OUTPUT_WOULD_OVERWRITE_INPUT,
            format!("the output `{}` is the input file", out.display()),
            Location::file(input),
        )
        .hint("write somewhere else, or pass --in-place to replace the input on purpose"));
    }
    Ok(target)
}

/// The level read and tagged, and what its configuration asks to hear.
fn load(a: &ConvertArgs, input: &Path) -> Result<(pipeline::Tagged, Policy), Diagnostic> {
    let reading = super::huge_pages::reading(input);
    let t = pipeline::load_tagged(input, &a.level.load_options())?;
    drop(reading);
    if a.in_place && (t.scene.gltf.is_none() || input == Path::new("-")) {
        return Err(Diagnostic::new(
            Code::OUTPUT_FORMAT_UNKNOWN,
            format!(
                "--in-place needs a glTF input; `{}` is not one",
                input.display()
            ),
            Location::file(input),
        )
        .hint("write the glTF with -o OUT.glb instead"));
    }
    let policy = t.config.check.policy().map_err(|e| {
        Diagnostic::new(
            Code::CONFIG_INVALID,
            format!("[check] in the configuration: {e}"),
            Location::file(t.config.path.clone().unwrap_or_else(|| input.to_path_buf())),
        )
        .hint("fix the code or severity name in portcullis.toml")
    })?;
    Ok((t, policy))
}

/// `[check] sightlines`: the PVS (the full one when none was computed) audited by rays; the
/// findings join the level's, the missed sightlines are returned for `--debug`.
fn audit_sightlines(level: &mut pipeline::Level, pvs: Option<&Pvs>) -> Vec<Vec<glam::DVec3>> {
    let rays = level.config().check.sightlines;
    if rays == 0 {
        return Vec::new();
    }
    let fresh;
    let audited = match pvs {
        Some(p) => p,
        None => {
            fresh = pipeline::pvs(level, Method::Full);
            &fresh
        }
    };
    let audit = pipeline::audit(level, audited, rays);
    level.diagnostics.extend(audit.diagnostics);
    audit.lines
}

/// What `--debug` and `--svg` show besides the cells and portals.
struct Shown<'a> {
    leaks: Vec<Vec<glam::DVec3>>,
    sightlines: Vec<Vec<glam::DVec3>>,
    pvs: Option<&'a Pvs>,
}

/// `--debug` and `--svg`, written whatever the verdict: they show the problem.
fn write_shows(a: &ConvertArgs, level: &pipeline::Level, shown: Shown) -> Result<(), Diagnostic> {
    if let Some(path) = &a.debug {
        let extras = portcullis::export::debug::DebugExtras {
            overlaps: level
                .cells
                .overlaps
                .iter()
                .map(|o| o.region.clone())
                .collect(),
            leaks: shown.leaks,
            sightlines: shown.sightlines,
        };
        let bytes = portcullis::export::debug::debug_glb(level, &extras);
        output::bytes(&Output::file(path, Target::Debug), &bytes)?;
    }
    if let Some(path) = &a.svg {
        let visible = a.pvs_of.map(|c| {
            let seen: Vec<usize> = match shown.pvs {
                Some(p) if c < p.cells() => p.visible(c).filter(|&v| v != c).collect(),
                _ => Vec::new(),
            };
            (c, seen)
        });
        let svg = portcullis::export::svg::svg_map(
            level,
            visible.as_ref().map(|(c, v)| (*c, v.as_slice())),
        );
        output::bytes(&Output::file(path, Target::Svg), svg.as_bytes())?;
    }
    Ok(())
}

/// `-o OUT.prt`: only the portal file.
fn convert_to_prt(a: &ConvertArgs, input: &Path, out: &Path) -> Result<Outcome, Diagnostic> {
    let reading = super::huge_pages::reading(input);
    let tagged = pipeline::load_tagged(input, &a.level.load_options())?;
    drop(reading);
    let mut level = pipeline::build(tagged);
    let (text, d) = portcullis::prt::write(level.cells.cells.len(), &level.portals, out);
    level.diagnostics.extend(d);
    level.diagnostics.in_file_units(level.tagged.scene.to_file);
    let fails = level.diagnostics.0.iter().any(|d| {
        d.severity == Severity::Error || (a.deny.is_some() && d.severity == Severity::Warning)
    });
    let summary = if fails {
        format!(
            "{}: nothing written to `{}` (the run fails)",
            input.display(),
            out.display()
        )
    } else {
        output::bytes(&Output::file(out, Target::Prt), text.as_bytes())?;
        summary(
            input,
            out,
            level.cells.cells.len(),
            level.portals.portals.len(),
        )
    };
    Ok(Outcome {
        diagnostics: level.diagnostics.0.clone(),
        summary,
    })
}

/// `IN -> OUT: N cells, M portals`, the line each converted file ends with.
fn summary(input: &Path, out: &Path, cells: usize, portals: usize) -> String {
    format!(
        "{} -> {}: {cells} cells, {portals} portals",
        input.display(),
        out.display()
    )
}

pub fn run(a: &ConvertArgs, style: &Style) -> i32 {
    if a.files.len() > 1 && (a.debug.is_some() || a.svg.is_some() || a.prt.is_some()) {
        eprintln!("error: --debug, --svg and --prt take one input");
        return 2;
    }
    if a.files.len() > 1 && a.output.is_some() {
        eprintln!("error: -o takes one input; use --out-dir DIR for several");
        return 2;
    }
    if let Err(e) = preflight(a) {
        eprintln!("error: {e}");
        return 2;
    }
    if a.files
        .iter()
        .filter(|f| f.as_path() == Path::new("-"))
        .count()
        > 1
    {
        eprintln!("error: standard input (`-`) can be read once");
        return 2;
    }
    // Files are converted in parallel; reports are printed in input order, so the output is
    // the same whatever the thread count.
    let progress = progress_bar(a.files.len() as u64);
    let outcomes: Vec<Result<Outcome, Diagnostic>> = a
        .files
        .par_iter()
        .map(|f| {
            let r = convert_one(a, f);
            progress.inc(1);
            r
        })
        .collect();
    progress.finish_and_clear();
    let mut totals = Totals::default();
    for r in outcomes {
        totals.files += 1;
        match r {
            Ok(o) => {
                totals.add(o.diagnostics.iter());
                eprint!("{}", human::diagnostics(o.diagnostics.iter(), style));
                eprintln!("{}", o.summary);
            }
            Err(d) => {
                totals.failed += 1;
                totals.add([&d]);
                eprintln!("{}", human::diagnostic(&d, style));
            }
        }
    }
    eprintln!("{}", totals.line());
    totals.exit_code(a.deny.is_some())
}

/// Every argument that can be checked before work starts, so a mistake in one costs no
/// conversion and leaves no output: the output folders exist, and no two inputs would be
/// written to the same file.
fn preflight(a: &ConvertArgs) -> Result<(), String> {
    if let Some(dir) = &a.out_dir {
        if !dir.is_dir() {
            return Err(format!("--out-dir `{}` is not a folder", dir.display()));
        }
    }
    let named = [
        ("-o", a.output.as_ref()),
        ("--debug", a.debug.as_ref()),
        ("--svg", a.svg.as_ref()),
        ("--prt", a.prt.as_ref()),
    ];
    for (flag, path) in named {
        let Some(path) = path.filter(|p| p.as_path() != Path::new("-")) else {
            continue;
        };
        let parent = path.parent().filter(|p| !p.as_os_str().is_empty());
        if let Some(parent) = parent.filter(|p| !p.is_dir()) {
            return Err(format!(
                "{flag} `{}`: the folder `{}` does not exist\n  hint: create it first, or write somewhere else",
                path.display(),
                parent.display()
            ));
        }
    }
    if a.out_dir.is_some() {
        let mut seen: std::collections::HashMap<PathBuf, &Path> = Default::default();
        for f in &a.files {
            let Ok(out) = output_for(a, f) else { continue };
            if let Some(first) = seen.insert(out.clone(), f) {
                return Err(format!(
                    "`{}` and `{}` would both be written to `{}`\n  hint: convert them in separate runs with different --out-dir folders, or rename one",
                    first.display(),
                    f.display(),
                    out.display()
                ));
            }
        }
    }
    Ok(())
}

/// A progress bar on a terminal; nothing in pipes, in CI, or for a single file.
fn progress_bar(n: u64) -> indicatif::ProgressBar {
    use std::io::IsTerminal;
    if n < 2 || !std::io::stderr().is_terminal() || std::env::var_os("CI").is_some() {
        return indicatif::ProgressBar::hidden();
    }
    let bar = indicatif::ProgressBar::new(n);
    if let Ok(style) =
        indicatif::ProgressStyle::with_template("{bar:40} {pos}/{len} levels {elapsed}")
    {
        bar.set_style(style);
    }
    bar
}
