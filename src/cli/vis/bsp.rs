//! `portcullis vis MAP.bsp`: ericw-tools vis's job. The PVS of the portal file beside the
//! .bsp is written into it (atomically: a failed run leaves it as it was) and one summary
//! line printed; with `--report`, nothing is written and the .bsp's stored visibility is
//! set beside each method's and the sampled lower bound.

use std::path::{Path, PathBuf};
use std::time::Instant;

use portcullis::bsp::Ambient;
use portcullis::diag::Diagnostic;
use portcullis::pipeline::bsp::{self as job, BspInput};
use portcullis::vis::{self, Method};

use super::{options, VisArgs};

/// `vis map` as mappers type it: a name without extension that is no file means its .bsp,
/// as ericw-tools vis reads it.
pub(super) fn resolve(f: &Path) -> PathBuf {
    let bsp = f.with_extension("bsp");
    if f.extension().is_none() && !f.exists() && bsp.is_file() {
        bsp
    } else {
        f.to_path_buf()
    }
}

/// Says what ericw options given change nothing here; `Err(2)` after saying why, for one
/// portcullis cannot honour.
pub(super) fn ericw_options(a: &VisArgs) -> Result<(), i32> {
    if let Some(r) = a.ericw_refused.first() {
        let word = r.split_whitespace().next().unwrap_or(r);
        let why = match word {
            "-visdist" => "portcullis computes no distance-limited PVS; drop -visdist (the PVS is then the full one, as without it in ericw's vis)",
            "-phsonly" => "portcullis always writes the PVS and the PHS together; run `portcullis vis MAP.bsp` (it needs the .prt)",
            "-logfile" => "portcullis writes no log file; redirect its output instead: `portcullis vis map.bsp > map-vis.log 2>&1`",
            _ => "neither ericw-tools vis nor portcullis has this option; `portcullis vis --help` lists them",
        };
        eprintln!("error: `{r}` is not supported: {why}");
        return Err(2);
    }
    for i in &a.ericw_ignored {
        let word = i.split_whitespace().next().unwrap_or(i);
        let why = match word {
            "-nostate" | "-autoclean" | "-noautoclean" => {
                "portcullis keeps no state file between runs"
            }
            "-log" | "-nolog" | "-logappend" => {
                "portcullis writes no log file (redirect its output to keep one)"
            }
            "-gamedir"
            | "-basedir"
            | "-path"
            | "-filepriority"
            | "-defaultpaths"
            | "-nodefaultpaths"
            | "-q2rtx"
            | "-tex_saturation_boost" => "vis reads no game files",
            "-targetchecks" => "it tunes ericw's flow, not portcullis's",
            "-nocolor" => "colour is only used on a terminal (or give --color never)",
            _ => "it only changes what ericw's vis prints",
        };
        eprintln!("note: `{i}` was ignored: {why}");
    }
    if let Some(l) = a.test_level.filter(|&l| l < 4) {
        eprintln!("note: `-level {l}` was ignored: the full flow always runs every test, as ericw's -level 4 (its default) does");
    }
    Ok(())
}

/// The ambient classes the options leave on.
fn ambient(a: &VisArgs) -> Ambient {
    if a.noambient {
        return Ambient::none();
    }
    Ambient {
        water: !a.noambientwater,
        sky: !a.noambientsky,
        slime: !a.noambientslime,
        lava: !a.noambientlava,
    }
}

/// The method asked for: `--fast` (ericw's `-fast`) or `--method`.
fn method(a: &VisArgs) -> Method {
    if a.fast {
        Method::Fast
    } else {
        Method::parse(&a.method).unwrap_or(Method::Full)
    }
}

/// Vis of one .bsp: reads it and its portal file, computes, writes, says what it wrote.
pub(super) fn one(a: &VisArgs, f: &Path) -> Result<Vec<Diagnostic>, Diagnostic> {
    let t0 = Instant::now();
    let input = job::load_bsp(f, a.prt.as_deref(), &a.level.load_options())?;
    if a.report {
        return report(a, f, input);
    }
    let opts = options(a, &input.loaded, method(a));
    let mut diags = input.loaded.diagnostics.0.clone();
    let t1 = Instant::now();
    let vised = job::vis_bsp(&input, &opts, ambient(a))?;
    let pvs_time = t1.elapsed();
    if vised.computed.cut_short > 0 {
        diags.push(vis::flow_budget_note(
            &input.prt_path,
            vised.computed.cut_short,
            vised.computed.sources,
            opts.flow_budget,
        ));
    }
    job::write_bsp(f, &vised.written.bytes)?;
    if !a.quiet {
        let s = &vised.written.stats;
        let name = f.file_name().unwrap_or_default().to_string_lossy();
        let what = if input.bsp.format.has_clusters() {
            format!(
                "{} clusters: {} cluster pairs visible ({:.1} per cluster), {} hearable",
                s.clusters,
                s.pairs,
                s.pairs as f64 / s.clusters.max(1) as f64,
                s.hearable
            )
        } else {
            let [w, sky, sl, la] = s.ambient;
            format!(
                "{} leafs in {} clusters: {} leaf pairs visible ({:.1} per leaf); ambient sounds in {w} (water), {sky} (sky), {sl} (slime), {la} (lava) leafs",
                s.leafs,
                s.clusters,
                s.pairs,
                s.pairs as f64 / s.leafs.max(1) as f64
            )
        };
        println!(
            "{name}: {}, {what}; visdata {} bytes (from {}); {:.2} s",
            input.bsp.format.name(),
            s.vis_bytes,
            s.uncompressed,
            t0.elapsed().as_secs_f64()
        );
        if a.verbose {
            println!(
                "  {}: {} {}, {} portals; method {}, {} threads; PVS and writing {:.2} s",
                input.prt_path.display(),
                input.prt.format.header(),
                input.prt.cells,
                input.prt.portals.len(),
                opts.method.name(),
                opts.threads.map_or_else(
                    || rayon::current_num_threads().to_string(),
                    |t| t.to_string()
                ),
                pvs_time.as_secs_f64()
            );
        }
    }
    Ok(diags)
}

/// `vis MAP.bsp --report`: the .bsp's own visibility and each method's, in the .bsp's terms,
/// beside the sampled lower bound. Writes nothing.
fn report(a: &VisArgs, f: &Path, input: BspInput) -> Result<Vec<Diagnostic>, Diagnostic> {
    let unit = if input.bsp.format.has_clusters() {
        "cluster"
    } else {
        "leaf"
    };
    let lower_opts = options(a, &input.loaded, Method::Sampled);
    let (lower_pvs, lower_time) = vis::timed(&input.loaded.graph, &lower_opts);
    let lower = job::pairs_in_bsp_terms(&input, &lower_pvs);
    let name = f.file_name().unwrap_or_default().to_string_lossy();
    println!("| level | format | {unit}s | pvs | time | {unit} pairs | over lower bound | lower-bound pairs missing | visdata bytes |");
    println!("|---|---|---|---|---|---|---|---|---|");
    let row = |what: &str, time: String, s: &job::Side| {
        println!(
            "| {name} | {} | {} | {what} | {time} | {} | {:+.1}% | {} | {} |",
            input.bsp.format.name(),
            input.bsp.vis_units,
            s.pairs,
            (s.pairs as f64 / lower.max(1) as f64 - 1.0) * 100.0,
            s.missing,
            s.vis_bytes
        )
    };
    match job::stored_side(&input.bsp, Some((&input.map, &lower_pvs))) {
        Some((_, s)) => row("stored in the .bsp", "–".into(), &s),
        None => println!(
            "| {name} | {} | {} | stored in the .bsp: none (not vised) | – | – | – | – | 0 |",
            input.bsp.format.name(),
            input.bsp.vis_units
        ),
    }
    for m in super::chosen_methods(a) {
        let (pvs, time) = if m == Method::Sampled {
            (lower_pvs.clone(), lower_time)
        } else {
            vis::timed(&input.loaded.graph, &options(a, &input.loaded, m))
        };
        let s = job::side(&input, &pvs, &lower_pvs)?;
        row(m.name(), format!("{:.3} s", time.as_secs_f64()), &s);
    }
    Ok(input.loaded.diagnostics.0)
}
