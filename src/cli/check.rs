//! `portcullis check FILE|GLOB...`: the CI gate. Every diagnostic of every stage plus the
//! level checks (portals, transforms, graph, loops, leaks), reported as text, JSON, SARIF or
//! JUnit. A file portcullis already annotated is checked through its stored annotation — what
//! an engine will load — unless `--recompute`.

use std::path::{Path, PathBuf};

use clap::{Args, ValueEnum};
use rayon::prelude::*;

use portcullis::diag::policy::{self, Policy};
use portcullis::diag::{Code, Diagnostic, Location};
use portcullis::pipeline;
use portcullis::report::file::FileReport;
use portcullis::report::{human, style::Style, Totals};

use super::LevelArgs;

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum CheckFormat {
    /// Text for people, with colour on a terminal.
    Human,
    /// One JSON document: every file's diagnostics and the totals.
    Json,
    /// SARIF 2.1.0, for code-scanning services.
    Sarif,
    /// JUnit XML, one test case per file, for CI test reports.
    Junit,
}

#[derive(Debug, Args)]
pub struct CheckArgs {
    /// Level files or glob patterns: .gltf, .glb, .obj, .map (Quake-family brush maps), and
    /// .usd/.usda/.usdc/.usdz with the `usd` feature (annotated files are checked through
    /// their stored annotation); `-` reads standard input.
    #[arg(required = true, value_name = "FILE")]
    pub files: Vec<PathBuf>,

    /// Report format.
    #[arg(long, value_enum, default_value = "human")]
    pub format: CheckFormat,

    /// Write the report to this file (atomically) instead of standard output; the summary
    /// line still goes to standard error.
    #[arg(short, long, value_name = "FILE")]
    pub output: Option<PathBuf>,

    /// Never report this code (repeat, or separate codes with commas). Adds to `[check]
    /// ignore` in portcullis.toml.
    #[arg(long, value_name = "CODE", value_delimiter = ',', value_parser = policy::parse_code)]
    pub ignore: Vec<Code>,

    /// Report CODE at LEVEL (error, warning, info); repeat for several. Wins over `[check]
    /// severity` in portcullis.toml.
    #[arg(long, value_name = "CODE=LEVEL", value_parser = policy::parse_override)]
    pub severity: Vec<(Code, portcullis::diag::Severity)>,

    /// Exit with 1 when there are warnings, not only errors.
    #[arg(long, value_name = "warnings", value_parser = ["warnings"])]
    pub deny: Option<String>,

    /// The levels are meant to be closed: every opening to the exterior is a LEAK error with
    /// the shortest path from a player start (same as `[check] sealed = true`).
    #[arg(long)]
    pub sealed: bool,

    /// Audit the PVS against the level's real geometry with N rays per cell from random points
    /// (seeded), traced through its triangles, open portals, the outside, mirrors and
    /// teleporters: each pair of cells a ray joins that the PVS lacks is a
    /// PVS_MISSES_SIGHTLINE error (same as `[check] sightlines = N`). A file with a stored
    /// annotation has its stored PVS audited.
    #[arg(long, value_name = "N")]
    pub sightlines: Option<usize>,

    /// Also write the `portcullis view` page of the level with this report's diagnostics listed
    /// beside it (click one to fly to it): a CI artifact next to SARIF or JUnit. One input.
    #[arg(long, value_name = "REPORT.html")]
    pub html: Option<PathBuf>,

    /// Also write the first leak's path as a point file (qbsp's .pts: a point every 2 units,
    /// `x y z` a line, in the input's own units and axes) for the editor to show (TrenchBroom:
    /// File > Load Point File). Only when there is a leak (with --sealed). One input.
    #[arg(long, value_name = "LEAK.pts")]
    pub pts: Option<PathBuf>,

    /// Rebuild cells and portals from the geometry even when the file carries a stored
    /// annotation, and check those.
    #[arg(long)]
    pub recompute: bool,

    #[command(flatten)]
    pub level: LevelArgs,
}

impl CheckArgs {
    fn policy(&self) -> Policy {
        let mut p = Policy::default();
        for c in &self.ignore {
            p.ignore(*c);
        }
        for (c, s) in &self.severity {
            p.set(*c, *s);
        }
        p
    }
}

/// Checks one file; never fails, since a file that cannot be read is itself a finding. With
/// the report, the leak paths found, in the file's own units (see `Scene::to_file`).
fn check_one(a: &CheckArgs, input: &Path, cli_policy: &Policy) -> (FileReport, Leaks) {
    let mut report = FileReport {
        file: input.to_path_buf(),
        failed: false,
        annotated: false,
        cells: None,
        portals: None,
        diagnostics: Vec::new(),
    };
    let reading = super::huge_pages::reading(input);
    let loaded = pipeline::load_tagged(input, &a.level.load_options());
    drop(reading);
    let t = match loaded {
        Ok(t) => t,
        Err(d) => {
            report.failed = true;
            report.diagnostics = cli_policy.apply([d]);
            return (report, Leaks::default());
        }
    };
    let policy = match t.config.check.policy() {
        Ok(p) => p.merged(cli_policy),
        Err(e) => {
            let at = t.config.path.clone().unwrap_or_else(|| input.to_path_buf());
            report.failed = true;
            report.diagnostics = vec![Diagnostic::new(
                Code::CONFIG_INVALID,
                format!("[check] in the configuration: {e}"),
                Location::file(at),
            )
            .hint("fix the code or severity name in portcullis.toml")];
            return (report, Leaks::default());
        }
    };
    let opts = pipeline::GateOptions {
        sealed: a.sealed,
        rays: a.sightlines.unwrap_or(t.config.check.sightlines),
        recompute: a.recompute,
    };
    let to_file = t.scene.to_file;
    let checked = pipeline::check_file(t, &opts, input);
    report.annotated = checked.annotated;
    report.cells = checked.counts.map(|c| c.0);
    report.portals = checked.counts.map(|c| c.1);
    report.diagnostics = policy.apply(checked.diagnostics);
    (
        report,
        Leaks {
            paths: checked.leaks,
            to_file,
        },
    )
}

/// The leak paths of one file and how to take them to its own units.
#[derive(Default)]
struct Leaks {
    paths: Vec<Vec<glam::DVec3>>,
    to_file: Option<glam::DMat4>,
}

impl Leaks {
    /// The first path as a point file: a point every 2 file units (5 cm in a file of metres),
    /// corners included, `x y z` a line; `None` without a leak.
    fn point_file(&self) -> Option<String> {
        let path = self.paths.first().filter(|p| !p.is_empty())?;
        let m = self.to_file.unwrap_or(glam::DMat4::IDENTITY);
        let step = if self.to_file.is_some() { 2.0 } else { 0.05 };
        let pts: Vec<glam::DVec3> = path.iter().map(|p| m.transform_point3(*p)).collect();
        let mut out = String::new();
        let mut put = |p: glam::DVec3| out.push_str(&format!("{:.3} {:.3} {:.3}\n", p.x, p.y, p.z));
        put(pts[0]);
        for w in pts.windows(2) {
            let n = (w[0].distance(w[1]) / step).ceil().max(1.0) as usize;
            (1..=n).for_each(|k| put(w[0].lerp(w[1], k as f64 / n as f64)));
        }
        Some(out)
    }
}

fn render(a: &CheckArgs, files: &[FileReport], totals: &Totals, style: &Style) -> String {
    use portcullis::report::{json, junit, sarif};
    let pretty = |v: serde_json::Value| {
        let mut s = serde_json::to_string_pretty(&v).unwrap_or_default();
        s.push('\n');
        s
    };
    match a.format {
        CheckFormat::Human => {
            let mut out = String::new();
            for f in files {
                out.push_str(&human::diagnostics(f.diagnostics.iter(), style));
                let what = match (f.failed, f.cells, f.portals) {
                    (true, _, _) => "could not be checked".to_string(),
                    (false, Some(c), Some(p)) => format!(
                        "{c} cells, {p} portals{}: {}",
                        if f.annotated { " (stored)" } else { "" },
                        f.status()
                    ),
                    _ => f.status().to_string(),
                };
                out.push_str(&format!("{}: {what}\n", f.file.display()));
            }
            out
        }
        CheckFormat::Json => pretty(json::report(files, totals)),
        CheckFormat::Sarif => pretty(sarif::report(files)),
        CheckFormat::Junit => junit::report(files, a.deny.is_some()),
    }
}

pub fn run(a: &CheckArgs, style: &Style) -> i32 {
    if a.html.is_some() && a.files.len() != 1 {
        eprintln!("error: --html takes one input (a page shows one level)");
        return 2;
    }
    if a.pts.is_some() && a.files.len() != 1 {
        eprintln!("error: --pts takes one input (a point file is one level's leak)");
        return 2;
    }
    let policy = a.policy();
    let (reports, leaks): (Vec<FileReport>, Vec<Leaks>) =
        a.files.par_iter().map(|f| check_one(a, f, &policy)).unzip();
    let mut totals = Totals::default();
    for r in &reports {
        totals.files += 1;
        totals.failed += usize::from(r.failed);
        totals.add(r.diagnostics.iter());
    }
    let plain = Style::plain();
    let text = render(
        a,
        &reports,
        &totals,
        if a.output.is_some() { &plain } else { style },
    );
    match &a.output {
        Some(path) if path != Path::new("-") => {
            if let Err(e) = portcullis::export::atomic::write(path, text.as_bytes()) {
                eprintln!(
                    "error[{}]: cannot write `{}`: {e}",
                    Code::OUTPUT_FAILED,
                    path.display()
                );
                return 2;
            }
        }
        _ => {
            use std::io::Write;
            let mut out = std::io::stdout().lock();
            // The report first, then the summary on stderr, in that order on a terminal.
            if out
                .write_all(text.as_bytes())
                .and_then(|_| out.flush())
                .is_err()
            {
                return 2;
            }
        }
    }
    if let (Some(path), Some(report)) = (&a.html, reports.first()) {
        if let Err(d) = write_html(a, report, path) {
            eprintln!("{}", portcullis::report::human::diagnostic(&d, style));
            return 2;
        }
    }
    if let (Some(path), Some(leaks)) = (&a.pts, leaks.first()) {
        match leaks.point_file() {
            Some(text) => {
                if let Err(e) = portcullis::export::atomic::write(path, text.as_bytes()) {
                    let d = portcullis::export::atomic::failed(path, e);
                    eprintln!("{}", portcullis::report::human::diagnostic(&d, style));
                    return 2;
                }
            }
            None => eprintln!("note: no leak, so `{}` was not written", path.display()),
        }
    }
    eprintln!("{}", totals.line());
    totals.exit_code(a.deny.is_some())
}

/// `--html`: the level's page with this report's diagnostics beside it. A file that could not
/// be checked has no level to show; the report says why.
fn write_html(a: &CheckArgs, report: &FileReport, path: &Path) -> Result<(), Diagnostic> {
    if report.failed {
        return Ok(());
    }
    let (page, _) = super::view::build_page(
        &report.file,
        &a.level,
        a.sealed,
        a.sightlines,
        Some(&report.diagnostics),
    )?;
    use portcullis::export::{output, Target};
    output::bytes(&output::Output::file(path, Target::Html), page.as_bytes()).map(drop)
}
