//! Command-line definitions. Each subcommand lives in its own file and returns an exit code;
//! flags are documented where they are defined, and `--help` shows those docs.

use std::path::PathBuf;

use clap::{Args, Parser, Subcommand, ValueEnum};

mod alloc;
pub mod bench;
pub mod check;
pub mod convert;
pub mod cull;
pub mod gen;
pub mod huge_pages;
pub mod inspect;
mod inspect_bsp;
pub mod schema;
pub mod view;
pub mod vis;

/// Cells and portals for game levels: import glTF / OBJ / USD, recognise rooms and portals from
/// the designer's tags, check them, and write an annotated glTF.
#[derive(Debug, Parser)]
#[command(name = "portcullis", version, about, long_about = None)]
pub struct Cli {
    /// When to colour output: auto (only on a terminal, and not with NO_COLOR), always, never.
    #[arg(long, global = true, default_value = "auto", value_parser = ["auto", "always", "never"])]
    pub color: String,

    #[command(subcommand)]
    pub command: Command,
}

#[derive(Debug, Subcommand)]
pub enum Command {
    /// Show what portcullis sees in each level: the scene (nodes, meshes, triangles, bounds,
    /// materials) and what the tags recognised (rooms, portals, bounds, footprints, ignored and
    /// detail nodes), with every near-miss name.
    Inspect(inspect::InspectArgs),
    /// Write each level as glTF with the PORTCULLIS_portals extension (cells, portals)
    /// added and nothing else changed.
    ///
    /// Arguments are checked before any work. A level with errors (or warnings, with
    /// `--deny warnings`) is not written, nor is its --prt, so a failed run leaves no output
    /// for the next step to take; --debug and --svg, which show the problem, still are. In a
    /// batch, the levels that pass are written. To write a level despite a finding, lower
    /// its severity in portcullis.toml (`[check] severity = { CODE = "warning" }`).
    Convert(convert::ConvertArgs),
    /// Check levels for CI: every diagnostic (tags, cells, portals, transforms, the cell
    /// graph, loops, leaks) as text, JSON, SARIF or JUnit; exit 0 clean, 1 errors (or
    /// warnings with --deny warnings), 2 could not run.
    Check(check::CheckArgs),
    /// Generate a building of N rooms on several storeys (doors, windows, L-shaped rooms,
    /// stairwells, furniture), tagged like a designer would, for benchmarks and trials.
    Gen(gen::GenArgs),
    /// Time every stage on generated buildings of several sizes (and the gltf crate's own
    /// read+write of the same file) and print one table.
    Bench(bench::BenchArgs),
    /// Print a JSON Schema portcullis ships (config, tags), or a built-in tag preset.
    Schema(schema::SchemaArgs),
    /// Print the PVS of each level (glTF, OBJ, USD or a Quake .prt), one line per cell as
    /// `c: v1 v2 ...`; `--report` times every method against the sampled lower bound.
    ///
    /// Given a Quake-family .bsp, writes the PVS of the .prt beside it into the .bsp instead,
    /// in place of ericw-tools vis (`qbsp map`, `portcullis vis map.bsp`, `light map`); its
    /// options are read as ericw's are typed (`-fast`, `-threads 2`, `-noambient`).
    Vis(vis::VisArgs),
    /// What each camera sees in a converted level, by the runtime an engine would run: the
    /// camera's cell, the cells reached through the portals in view with their screen
    /// rectangles, depth and path.
    Cull(cull::CullArgs),
    /// Write one HTML page that shows the level in 3D, offline in any browser: its geometry,
    /// cells by room, portals by kind, leaks and missed sightlines; pick a cell to light its
    /// PVS, fly the camera to see what its cell draws.
    View(view::ViewArgs),
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Format {
    /// Text for people, with colour on a terminal.
    Human,
    /// One JSON document on stdout, for scripts and CI.
    Json,
}

/// Options every level-reading subcommand shares.
#[derive(Debug, Clone, Args)]
pub struct LevelArgs {
    /// Tag preset: default, doom, godot, lportal, panda3d, quake, or auto (the default rules,
    /// and where they find no room, rooms generated in the air; experimental, docs/auto.md). Wins over the
    /// preset in portcullis.toml.
    #[arg(long = "tags", value_name = "PRESET")]
    pub tags: Option<String>,

    /// Configuration file. Without it, `portcullis.toml` next to each input is used if present.
    #[arg(long, value_name = "FILE")]
    pub config: Option<PathBuf>,

    /// OBJ: do not treat `/` in object names as a node hierarchy.
    #[arg(long)]
    pub obj_flat_names: bool,

    /// USD: the Python virtual environment holding usd-core (else $VIRTUAL_ENV, else the
    /// project's .venv). Needs a build with `--features usd`.
    #[arg(long, value_name = "DIR")]
    pub python_venv: Option<PathBuf>,

    /// Process only slice K of N of the inputs (1 <= K <= N): the inputs, globs expanded, are
    /// sorted by path and every Nth from the Kth taken, so N jobs given the same inputs and
    /// K = 1..N cover each input exactly once, whatever order the shell listed them in.
    #[arg(long, value_name = "K/N", value_parser = parse_shard)]
    pub shard: Option<Shard>,
}

impl LevelArgs {
    /// The options as given on the command line (without `--shard`), for a command suggested
    /// to the user: `--tags doom` given to `view` belongs in the `check` it suggests.
    pub fn echo(&self) -> String {
        let mut out = String::new();
        let mut add = |flag: &str, value: Option<String>| {
            out.push_str(&format!(" {flag}"));
            if let Some(v) = value {
                out.push(' ');
                out.push_str(&shell_word(&v));
            }
        };
        if let Some(t) = &self.tags {
            add("--tags", Some(t.clone()));
        }
        if let Some(c) = &self.config {
            add("--config", Some(c.display().to_string()));
        }
        if self.obj_flat_names {
            add("--obj-flat-names", None);
        }
        if let Some(v) = &self.python_venv {
            add("--python-venv", Some(v.display().to_string()));
        }
        out
    }
}

/// A word as a POSIX shell reads it back: as is when it holds only safe characters, else in
/// single quotes.
pub fn shell_word(s: &str) -> String {
    let safe = !s.is_empty()
        && s.chars()
            .all(|c| c.is_ascii_alphanumeric() || "-_./:=+,@%".contains(c));
    if safe {
        s.to_string()
    } else {
        format!("'{}'", s.replace('\'', "'\\''"))
    }
}

/// `--shard K/N`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Shard {
    /// 1-based.
    pub k: usize,
    pub n: usize,
}

fn parse_shard(s: &str) -> Result<Shard, String> {
    let bad = || format!("`{s}` is not K/N with 1 <= K <= N (e.g. 2/8)");
    let (k, n) = s.split_once('/').ok_or_else(bad)?;
    let (k, n) = (
        k.trim().parse::<usize>().map_err(|_| bad())?,
        n.trim().parse::<usize>().map_err(|_| bad())?,
    );
    if k == 0 || n == 0 || k > n {
        return Err(bad());
    }
    Ok(Shard { k, n })
}

/// The inputs of one shard, in the order given: the inputs ranked by path (ties by position),
/// and those whose rank is K-1 modulo N kept. Says on stderr how many it kept.
pub fn shard_inputs(files: Vec<PathBuf>, shard: Option<Shard>) -> Vec<PathBuf> {
    let Some(s) = shard else { return files };
    let mut order: Vec<usize> = (0..files.len()).collect();
    order.sort_by(|&a, &b| {
        files[a]
            .as_os_str()
            .cmp(files[b].as_os_str())
            .then(a.cmp(&b))
    });
    let mut keep = vec![false; files.len()];
    for (rank, &i) in order.iter().enumerate() {
        keep[i] = rank % s.n == s.k - 1;
    }
    let total = files.len();
    let kept: Vec<PathBuf> = files
        .into_iter()
        .zip(keep)
        .filter_map(|(f, k)| k.then_some(f))
        .collect();
    eprintln!("shard {}/{}: {} of {total} inputs", s.k, s.n, kept.len());
    kept
}

impl LevelArgs {
    pub fn load_options(&self) -> portcullis::pipeline::LoadOptions {
        portcullis::pipeline::LoadOptions {
            preset: self.tags.clone(),
            config: self.config.clone(),
            import: portcullis::import::ImportOptions {
                obj_split_paths: !self.obj_flat_names,
                python_venv: self.python_venv.clone(),
                map_scale: None,
            },
        }
    }
}

/// The command line, parsed: `vis` also reads ericw-tools vis's single-dash options.
pub fn parse() -> Result<Cli, clap::Error> {
    use clap::CommandFactory;
    let cli = Cli::command();
    let ours = cli
        .find_subcommand("vis")
        .into_iter()
        .flat_map(|c| c.get_arguments())
        .chain(cli.get_arguments())
        .filter_map(|a| a.get_long().map(str::to_string))
        .collect();
    Cli::try_parse_from(vis::ericw_args::rewrite(
        std::env::args_os().collect(),
        &ours,
    ))
}

/// Runs the parsed command line; returns the process exit code.
pub fn run(cli: Cli) -> i32 {
    let style = portcullis::report::style::Style::for_stdout(&cli.color);
    match cli.command {
        Command::Inspect(mut a) => {
            a.files = shard_inputs(expand_inputs(&a.files), a.level.shard);
            inspect::run(&a, &style)
        }
        Command::Convert(mut a) => {
            a.files = shard_inputs(expand_inputs(&a.files), a.level.shard);
            convert::run(
                &a,
                &portcullis::report::style::Style::for_stderr(&cli.color),
            )
        }
        Command::Check(mut a) => {
            a.files = shard_inputs(expand_inputs(&a.files), a.level.shard);
            check::run(&a, &style)
        }
        Command::Gen(a) => gen::run(&a),
        Command::Bench(a) => bench::run(&a),
        Command::Schema(a) => schema::run(&a),
        Command::Cull(a) => cull::run(
            &a,
            &portcullis::report::style::Style::for_stderr(&cli.color),
        ),
        Command::View(a) => {
            // The same rule as the other commands': an empty shard processes nothing.
            if shard_inputs(vec![a.file.clone()], a.level.shard).is_empty() {
                return 0;
            }
            view::run(
                &a,
                &portcullis::report::style::Style::for_stderr(&cli.color),
            )
        }
        Command::Vis(mut a) => {
            a.files = shard_inputs(expand_inputs(&a.files), a.level.shard);
            vis::run(
                &a,
                &portcullis::report::style::Style::for_stderr(&cli.color),
            )
        }
    }
}

/// Expands glob patterns among the inputs (for shells that do not, and for quoted patterns);
/// a pattern matching nothing is kept as given so it is reported as a missing file.
pub fn expand_inputs(files: &[PathBuf]) -> Vec<PathBuf> {
    let mut out = Vec::new();
    for f in files {
        let s = f.to_string_lossy();
        let is_pattern = s.contains(['*', '?', '[']) && !f.exists();
        let matches: Vec<PathBuf> = if is_pattern {
            glob::glob(&s)
                .map(|g| g.flatten().collect())
                .unwrap_or_default()
        } else {
            Vec::new()
        };
        if matches.is_empty() {
            out.push(f.clone());
        } else {
            out.extend(matches);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::shell_word;

    #[test]
    fn shell_words_read_back_as_given() {
        assert_eq!(shell_word("levels/e1m2.glb"), "levels/e1m2.glb");
        assert_eq!(shell_word("my level.glb"), "'my level.glb'");
        assert_eq!(shell_word("it's.glb"), "'it'\\''s.glb'");
        assert_eq!(shell_word(""), "''");
    }
}
