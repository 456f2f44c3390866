//! `portcullis vis FILE...`: the PVS of each level, one line per cell as `c: v1 v2 ...` in the
//! cell order of the extension (or of the .prt file), or with `--report` a table of run time,
//! visible pairs and over-estimate against the sampled lower bound for every method. A .bsp
//! input is ericw-tools vis's job instead (`bsp.rs`), and ericw's single-dash options are
//! read too (`ericw_args.rs`).

use std::io::Write;
use std::path::{Path, PathBuf};

use clap::Args;

use portcullis::diag::{Code, Diagnostic, Location};
use portcullis::pipeline::graph as load;
use portcullis::report::{human, style::Style, Totals};
use portcullis::vis::{self, Method, VisOptions};

use super::LevelArgs;

mod bsp;
pub(super) mod ericw_args;

#[derive(Debug, Args)]
pub struct VisArgs {
    /// Levels: .gltf, .glb, .obj, .map (Quake-family brush maps), .usd*, or a Quake portal file
    /// .prt (PRT1, PRT2, PRT1-AM); or a Quake-family .bsp, which gets the PVS of the .prt
    /// beside it written in, as ericw-tools vis does (`vis map` means map.bsp).
    #[arg(required = true, value_name = "FILE")]
    pub files: Vec<PathBuf>,

    /// flood (reachability), fast (Quake's might-see), full (portal flow with separating
    /// planes, conservative), sampled (random sightlines: a lower bound).
    #[arg(long, default_value = "full", value_parser = ["flood", "fast", "full", "sampled"])]
    pub method: String,

    /// Sightlines per directed portal for `sampled` and the report's lower bound.
    #[arg(long, value_name = "N")]
    pub samples: Option<usize>,

    /// Worker threads (default: one per core). The result is the same for any count.
    #[arg(long, value_name = "N")]
    pub threads: Option<usize>,

    /// Transformed portals (mirrors, teleporters) one sightline may pass through; default from
    /// `[vis] transform_depth`, else the built-in bound.
    #[arg(long, value_name = "N")]
    pub transform_depth: Option<usize>,

    /// Portal tests the full flow may make in all before it cuts the remaining portals short
    /// (conservatively); default from `[vis] flow_budget`, else 33554432.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u64).range(1..))]
    pub flow_budget: Option<u64>,

    /// Instead of the PVS, print per level and method: run time, visible pairs, and the
    /// over-estimate against the sampled lower bound (with its sample count).
    #[arg(long)]
    pub report: bool,

    /// With --report, rays per cell for the ray-traced lower bound: random sightlines traced
    /// through the level's triangles (`check --sightlines`); 0 for none. Not for .prt files.
    #[arg(long, value_name = "N", default_value_t = 200, requires = "report")]
    pub rays: usize,

    /// With --report, the methods to time (comma-separated; default all four).
    #[arg(long, value_name = "LIST", requires = "report", value_delimiter = ',')]
    pub methods: Vec<String>,

    /// For a .bsp input: the portal file to read (default: the .bsp's name with .prt, where
    /// qbsp writes it).
    #[arg(
        long,
        value_name = "FILE",
        help_heading = "Quake .bsp (as ericw-tools vis)"
    )]
    pub prt: Option<PathBuf>,

    /// ericw-tools vis's `-fast`: the `fast` method (Quake's might-see, no portal flow).
    #[arg(
        long,
        conflicts_with = "method",
        help_heading = "Quake .bsp (as ericw-tools vis)"
    )]
    pub fast: bool,

    /// ericw-tools vis's `-level N` (0-4: how many of its separating-plane tests run).
    /// Accepted; the full flow always runs all its tests, as `-level 4`, the default.
    #[arg(long = "level", value_name = "N", value_parser = clap::value_parser!(u8).range(0..=4), help_heading = "Quake .bsp (as ericw-tools vis)")]
    pub test_level: Option<u8>,

    /// Write every ambient sound level 0 (Quake 1 family .bsp).
    #[arg(long, help_heading = "Quake .bsp (as ericw-tools vis)")]
    pub noambient: bool,

    /// No ambient sky sound.
    #[arg(long, help_heading = "Quake .bsp (as ericw-tools vis)")]
    pub noambientsky: bool,

    /// No ambient water sound.
    #[arg(long, help_heading = "Quake .bsp (as ericw-tools vis)")]
    pub noambientwater: bool,

    /// No ambient sound from slime (which Quake plays as water).
    #[arg(long, help_heading = "Quake .bsp (as ericw-tools vis)")]
    pub noambientslime: bool,

    /// No ambient lava sound.
    #[arg(long, help_heading = "Quake .bsp (as ericw-tools vis)")]
    pub noambientlava: bool,

    /// More about a .bsp run: the portal graph, method, threads and times.
    #[arg(long, help_heading = "Quake .bsp (as ericw-tools vis)")]
    pub verbose: bool,

    /// No summary line for a .bsp run (ericw's `-noverbose`, `-quiet`).
    #[arg(long, help_heading = "Quake .bsp (as ericw-tools vis)")]
    pub quiet: bool,

    /// ericw-tools vis options that change nothing here, as typed (for a note).
    #[arg(long, hide = true, value_name = "OPTION")]
    pub ericw_ignored: Vec<String>,

    /// ericw-tools vis options portcullis does not do, as typed (refused).
    #[arg(long, hide = true, value_name = "OPTION")]
    pub ericw_refused: Vec<String>,

    #[command(flatten)]
    pub level: LevelArgs,
}

pub(super) fn options(a: &VisArgs, loaded: &load::Loaded, method: Method) -> VisOptions {
    let cfg = &loaded.config;
    VisOptions {
        method,
        samples: a
            .samples
            .or(cfg.vis.samples)
            .unwrap_or(vis::DEFAULT_SAMPLES),
        threads: a.threads,
        transform_depth: a.transform_depth.unwrap_or(loaded.transform_depth),
        flow_budget: (a.flow_budget).unwrap_or_else(|| portcullis::pipeline::flow_budget(cfg)),
        ..Default::default()
    }
}

/// The methods `--report` times: `--methods` (checked by [`run`] first), else all four.
pub(super) fn chosen_methods(a: &VisArgs) -> Vec<Method> {
    let methods: Vec<Method> = a.methods.iter().filter_map(|m| Method::parse(m)).collect();
    if methods.is_empty() {
        Method::ALL.to_vec()
    } else {
        methods
    }
}

pub fn run(a: &VisArgs, style: &Style) -> i32 {
    let mut totals = Totals::default();
    if let Some(m) = a.methods.iter().find(|m| Method::parse(m).is_none()) {
        eprintln!("error: --methods: `{m}` is not flood, fast, full or sampled");
        return 2;
    }
    if let Err(code) = bsp::ericw_options(a) {
        return code;
    }
    let methods = chosen_methods(a);
    let files: Vec<PathBuf> = a.files.iter().map(|f| bsp::resolve(f)).collect();
    let bsp_only = files.iter().all(|f| portcullis::export::Target::is_bsp(f));
    if a.report && !bsp_only {
        println!("| level | cells | portals | method | threads | time | cpu | pairs | over lower bound | samples | over ray-traced | rays |");
        println!("|---|---|---|---|---|---|---|---|---|---|---|---|");
    }
    for f in &files {
        totals.files += 1;
        let done = if portcullis::export::Target::is_bsp(f) {
            bsp::one(a, f)
        } else {
            one(a, f, &methods)
        };
        match done {
            Ok(diags) => {
                totals.add(diags.iter());
                eprint!("{}", human::diagnostics(diags.iter(), style));
            }
            Err(d) => {
                totals.failed += 1;
                totals.add([&d]);
                eprintln!("{}", human::diagnostic(&d, style));
            }
        }
    }
    if files.len() > 1 || totals.failed > 0 {
        eprintln!("{}", totals.line());
    }
    totals.exit_code(false)
}

fn one(a: &VisArgs, f: &Path, methods: &[Method]) -> Result<Vec<Diagnostic>, Diagnostic> {
    let reading = super::huge_pages::reading(f);
    let loaded = load::load(f, &a.level.load_options());
    drop(reading);
    let mut loaded = loaded?;
    if loaded.graph.has_transforms() {
        let depth = options(a, &loaded, Method::Full).transform_depth;
        loaded.diagnostics.push(vis::transform_depth_note(f, depth));
    }
    let g = &loaded.graph;
    let method = Method::parse(&a.method).unwrap_or(Method::Full);
    if !a.report {
        let opts = options(a, &loaded, method);
        let c = vis::computed(g, &opts);
        if c.cut_short > 0 {
            let note = vis::flow_budget_note(f, c.cut_short, c.sources, opts.flow_budget);
            loaded.diagnostics.push(note);
        }
        let pvs = c.pvs;
        let mut out = std::io::BufWriter::new(std::io::stdout().lock());
        if a.files.len() > 1 {
            writeln!(out, "# {}", f.display()).map_err(|e| stdout_failed(f, e))?;
        }
        pvs.write_text(&mut out)
            .and_then(|_| out.flush())
            .map_err(|e| stdout_failed(f, e))?;
        return Ok(loaded.diagnostics.0);
    }
    let lower_opts = options(a, &loaded, Method::Sampled);
    let cpu0 = cpu_seconds();
    let (lower, lower_time) = vis::timed(g, &lower_opts);
    let lower_cpu = cpu_seconds().zip(cpu0).map(|(b, a)| b - a);
    // The bound from the level's own triangles, beside the one from its portals.
    let traced = loaded
        .level
        .as_ref()
        .filter(|_| a.rays > 0)
        .map(|l| portcullis::pipeline::audit(l, &lower, a.rays).seen);
    let threads = a
        .threads
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    for &m in methods {
        let (pvs, time, cpu) = if m == Method::Sampled {
            (lower.clone(), lower_time, lower_cpu)
        } else {
            let c0 = cpu_seconds();
            let (p, t) = vis::timed(g, &options(a, &loaded, m));
            (p, t, cpu_seconds().zip(c0).map(|(b, a)| b - a))
        };
        let over = pvs.pairs() as f64 / lower.pairs().max(1) as f64 - 1.0;
        let missing = lower.missing_from(&pvs).len();
        let rays = match &traced {
            Some(t) => {
                let over = pvs.pairs() as f64 / t.pairs().max(1) as f64 - 1.0;
                let missing = t.missing_from(&pvs).len();
                let note = if missing > 0 && m != Method::Sampled {
                    format!(" ({missing} ray-traced pairs missing)")
                } else {
                    String::new()
                };
                format!("{:+.1}%{note} | {}", over * 100.0, a.rays)
            }
            None => "– | –".to_string(),
        };
        println!(
            "| {} | {} | {} | {} | {} | {:.3} s | {} | {} | {:+.1}%{} | {} | {rays} |",
            f.file_name().unwrap_or_default().to_string_lossy(),
            g.level_cells(),
            g.portals.len(),
            m.name(),
            threads,
            time.as_secs_f64(),
            cpu.map_or("–".to_string(), |c| format!("{c:.2} s")),
            pvs.pairs(),
            over * 100.0,
            if missing > 0 && m != Method::Sampled {
                format!(" ({missing} lower-bound pairs missing)")
            } else {
                String::new()
            },
            lower_opts.samples,
        );
    }
    Ok(loaded.diagnostics.0)
}

/// CPU time of this process so far (user + system, all threads), from /proc on Linux: the
/// report shows it beside the wall time, which other load on the machine inflates.
fn cpu_seconds() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    // Fields after the command name (which may hold spaces) in parentheses.
    let rest = &stat[stat.rfind(')')? + 2..];
    let f: Vec<&str> = rest.split_whitespace().collect();
    let utime: f64 = f.get(11)?.parse().ok()?;
    let stime: f64 = f.get(12)?.parse().ok()?;
    Some((utime + stime) / 100.0)
}

fn stdout_failed(f: &Path, e: std::io::Error) -> Diagnostic {
    Diagnostic::new(
        Code::OUTPUT_FAILED,
        format!(
            "cannot write the PVS of `{}` to standard output: {e}",
            f.display()
        ),
        Location::file(f),
    )
    .hint("check where standard output goes (a full disk, a closed pipe)")
}
