//! `portcullis view LEVEL [-o FILE.html]`: the level, its cells, portals and PVS in 3D, as one
//! HTML file that opens offline in any current browser.

use std::path::{Path, PathBuf};

use clap::Args;

use portcullis::diag::Diagnostic;
use portcullis::pipeline;
use portcullis::report::{human, style::Style, Totals};

use super::LevelArgs;

#[derive(Debug, Args)]
pub struct ViewArgs {
    /// The level: .gltf, .glb, .obj, .map (Quake-family brush maps), and USD with the `usd`
    /// feature.
    #[arg(value_name = "LEVEL")]
    pub file: PathBuf,

    /// The page to write (default: the level's name with .html, in the current folder).
    #[arg(short, long, value_name = "FILE.html")]
    pub output: Option<PathBuf>,

    /// Draw leak paths: the level is meant to be closed (as `check --sealed`).
    #[arg(long)]
    pub sealed: bool,

    #[command(flatten)]
    pub level: LevelArgs,
}

/// The page for one level: built as `check` builds it (cells, portals, checks, the full PVS
/// and, with `sightlines` rays per cell or `[check] sightlines`, the rays the PVS misses),
/// listing `listed` beside the view (`check --html` passes its report). Returns the page and
/// the level's diagnostics.
pub fn build_page(
    input: &Path,
    level: &LevelArgs,
    sealed: bool,
    sightlines: Option<usize>,
    listed: Option<&[Diagnostic]>,
) -> Result<(String, Vec<Diagnostic>), Diagnostic> {
    let mut built = pipeline::load(input, &level.load_options())?;
    let leaks = pipeline::check(&mut built, sealed);
    let pvs = pipeline::pvs(&built, portcullis::vis::Method::Full);
    let rays = sightlines.unwrap_or(built.config().check.sightlines);
    let mut sightlines = Vec::new();
    if rays > 0 {
        let audit = pipeline::audit(&built, &pvs, rays);
        built.diagnostics.extend(audit.diagnostics);
        sightlines = audit.lines;
    }
    built.diagnostics.in_file_units(built.tagged.scene.to_file);
    let diagnostics = built.diagnostics.0.clone();
    let title = input.file_name().map_or_else(
        || input.display().to_string(),
        |n| n.to_string_lossy().into_owned(),
    );
    let extras = portcullis::export::view::Extras {
        leaks: &leaks,
        sightlines: &sightlines,
        diagnostics: listed.unwrap_or(&[]),
    };
    let data = portcullis::export::view::payload(&title, &built, &pvs, &extras);
    Ok((portcullis::export::view::page(&data), diagnostics))
}

pub fn run(a: &ViewArgs, style: &Style) -> i32 {
    let out = a.output.clone().unwrap_or_else(|| {
        let stem = a.file.file_stem().unwrap_or_default().to_string_lossy();
        PathBuf::from(format!("{stem}.html"))
    });
    let mut totals = Totals {
        files: 1,
        ..Default::default()
    };
    let written = build_page(&a.file, &a.level, a.sealed, None, None).and_then(|(page, diags)| {
        use portcullis::export::{output, Target};
        output::bytes(&output::Output::file(&out, Target::Html), page.as_bytes())?;
        Ok(diags)
    });
    match written {
        Ok(diags) => {
            // The page is for looking; `check` is for the list.
            totals.add(diags.iter());
            eprintln!("{} -> {}", a.file.display(), out.display());
            if !diags.is_empty() {
                eprintln!(
                    "(`portcullis check{}{} {}` lists its diagnostics, `check --html` beside the view)",
                    a.level.echo(),
                    if a.sealed { " --sealed" } else { "" },
                    super::shell_word(&a.file.display().to_string())
                );
            }
        }
        Err(d) => {
            totals.failed += 1;
            totals.add([&d]);
            eprintln!("{}", human::diagnostic(&d, style));
        }
    }
    eprintln!("{}", totals.line());
    // The page is written whatever the level's findings (it is for looking at them), but the
    // exit code is the documented one: 1 when the level has errors.
    if totals.failed > 0 {
        2
    } else if totals.errors > 0 {
        1
    } else {
        0
    }
}
