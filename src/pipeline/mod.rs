//! The stages chained for one input file, as every subcommand runs them. Library users call
//! this too, or the stages one by one.
//!
//! It does config discovery, rule compilation, import and tagging for one file, and the stage calls
//! (`build_cells`, `build_portals`, `check_level`) that append each stage's diagnostics in stage
//! order.

use std::path::{Path, PathBuf};

pub mod graph;

use crate::cells::{self, CellSet};
use crate::config::{self, Config};
use crate::diag::Diagnostic;
use crate::export::gltf_out::OutFormat;
use crate::export::Target;
pub use crate::free::drop_elsewhere;
use crate::import::{self, ImportOptions};
pub use crate::level::Tagged;
use crate::tags::{self, rules::RuleSet};

/// What the user chose on the command line (or a library caller set).
#[derive(Debug, Clone, Default)]
pub struct LoadOptions {
    /// `--tags PRESET`: wins over the configuration's preset.
    pub preset: Option<String>,
    /// `--config FILE`: else `portcullis.toml` next to the input, else built-in defaults.
    pub config: Option<PathBuf>,
    /// How the importers read the file (OBJ names, the USD environment).
    pub import: ImportOptions,
}

/// The configuration that applies to `input`.
pub fn config_for(input: &Path, opts: &LoadOptions) -> Result<Config, Diagnostic> {
    match opts.config.as_deref() {
        Some(p) => config::load(p),
        None => match config::discover(input) {
            Some(p) => config::load(&p),
            None => Ok(Config::default()),
        },
    }
}

/// Imports and tags one file (`-` reads standard input). `Err` means the file could not be
/// processed at all.
pub fn load_tagged(input: &Path, opts: &LoadOptions) -> Result<Tagged, Diagnostic> {
    // A brush map's scale is in the configuration, so for one the configuration is read first;
    // any other file is read before it (an unreadable file is reported as such).
    let is_map = import::format_from_path(input) == Some(crate::scene::Format::Map);
    let early = if is_map {
        Some(config_for(input, opts)?)
    } else {
        None
    };
    let mut import_opts = opts.import.clone();
    if let Some(c) = &early {
        import_opts.map_scale = import_opts.map_scale.or(c.import.map_scale);
    }
    let imported = if input == Path::new("-") {
        read_stdin(opts)?
    } else {
        import::import_path(input, &import_opts)?
    };
    let config = match early {
        Some(c) => c,
        None => config_for(input, opts)?,
    };
    // A brush map is tagged by its importer: the `quake` preset unless one was chosen. A file
    // portcullis wrote is read with the preset it was made with, unless one was chosen.
    let stored = stored_preset(&imported.scene);
    let preset = opts.preset.as_deref().or_else(|| {
        config.tags.preset.is_none().then_some(())?;
        match imported.scene.format {
            crate::scene::Format::Map => Some("quake"),
            _ => stored.as_deref(),
        }
    });
    let rules = config::rule_set(&config, preset)?;
    Ok(tag(imported, config, rules))
}

/// The known tag preset a glTF's stored annotation was made with (its `tags`), if any.
fn stored_preset(scene: &crate::scene::Scene) -> Option<String> {
    let name = scene.stored_tags.as_deref()?;
    crate::tags::presets::spec(name).map(|_| name.to_string())
}

/// What of the configuration shapes the result, for the input hash: the rules as compiled
/// (every spec, case rule, wildcard) and the `[cells]` and `[portals]` sections. `[check]` and
/// `[vis]` change what is reported or how the PVS is found (the PVS records its method), not
/// the cells and portals.
fn settings_bytes(config: &Config, rules: &RuleSet) -> Vec<u8> {
    let specs: Vec<&crate::tags::rules::RuleSpec> = rules.rules.iter().map(|r| &r.spec).collect();
    serde_json::to_vec(&serde_json::json!({
        "rules": specs,
        "caseSensitive": rules.case_sensitive,
        "wildcard": rules.wildcard,
        "cells": config.cells,
        "portals": config.portals,
    }))
    .unwrap_or_default()
}

/// Tags an imported level with `rules` (library callers that import themselves use this).
pub fn tag(imported: import::Imported, config: Config, rules: RuleSet) -> Tagged {
    let mut tagging = tags::recognise(&imported.scene, &rules);
    tagging.settings = settings_bytes(&config, &rules);
    let mut diagnostics = imported.diagnostics;
    diagnostics.extend(tagging.diagnostics.iter().cloned());
    Tagged {
        scene: imported.scene,
        config,
        rules,
        tagging,
        diagnostics,
    }
}

/// A level piped in: glTF and GLB are recognised by their first bytes, anything else is read
/// as OBJ; relative references resolve from the current folder.
fn read_stdin(opts: &LoadOptions) -> Result<import::Imported, Diagnostic> {
    use std::io::Read;
    let path = Path::new("-");
    let mut bytes = Vec::new();
    std::io::stdin().read_to_end(&mut bytes).map_err(|e| {
        Diagnostic::new(
            crate::diag::Code::IO_READ_FAILED,
            format!("cannot read standard input: {e}"),
            crate::diag::Location::file(path),
        )
    })?;
    let format = import::sniff_format(&bytes).unwrap_or(crate::scene::Format::Obj);
    import::import_bytes(&bytes, path, format, Path::new("."), &opts.import)
}

/// The cells of a tagged level; their diagnostics are appended to `tagged.diagnostics`.
pub fn build_cells(tagged: &mut Tagged) -> CellSet {
    let mut set = cells::build_reaching(
        &tagged.scene,
        &tagged.tagging,
        &tagged.config.cells,
        tagged.config.portals.max_wall_thickness,
    );
    cells::drop_far_structure(
        &tagged.scene,
        &tagged.tagging,
        &mut set,
        tagged.config.portals.max_wall_thickness,
    );
    cells::split_areas(&mut tagged.tagging, &mut set);
    tagged.diagnostics.extend(set.diagnostics.iter().cloned());
    set
}

/// The portals of a tagged level with its cells; diagnostics are appended to
/// `tagged.diagnostics`.
pub fn build_portals(tagged: &mut Tagged, cells: &CellSet) -> crate::portals::PortalSet {
    let set = crate::portals::build(
        &tagged.scene,
        &tagged.tagging,
        cells,
        &tagged.config.portals,
    );
    tagged.diagnostics.extend(set.diagnostics.iter().cloned());
    set
}

/// `portcullis convert INPUT -o OUTPUT` with the defaults, for library users: cells, portals
/// and the full PVS, written atomically to a .glb or .gltf. Diagnostics are not checked (run
/// [`check_level`] for a gate); `Err` only when the level cannot be read or written.
pub fn convert_file(input: &Path, output: &Path) -> Result<(), Diagnostic> {
    let format = Target::from_path(output)
        .and_then(Target::gltf)
        .ok_or_else(|| {
            Diagnostic::new(
                crate::diag::Code::OUTPUT_FORMAT_UNKNOWN,
                "the output is neither .glb nor .gltf",
                crate::diag::Location::file(output),
            )
            .hint("name the output file .glb or .gltf")
        })?;
    let mut t = load_tagged(input, &LoadOptions::default())?;
    let cells = build_cells(&mut t);
    let portals = build_portals(&mut t, &cells);
    let pvs = full_pvs(&t, &cells, &portals);
    let opts = WriteOptions {
        pvs: Some((&pvs, crate::vis::Method::Full)),
        ..WriteOptions::file(output, format)
    };
    write(&t, &cells, &portals, &opts).map(drop)
}

/// How [`write()`] writes an annotated level.
#[derive(Debug, Clone, Copy)]
pub struct WriteOptions<'a> {
    /// The output file. Its folder decides the relative URIs of images and external buffers,
    /// also when the bytes are kept in memory.
    pub out: &'a Path,
    /// .glb or .gltf (see [`Target::from_path`]).
    pub format: OutFormat,
    /// A PVS to store in the extension, and the method that computed it.
    pub pvs: Option<(&'a crate::vis::Pvs, crate::vis::Method)>,
    /// Whether the bytes go to `out` or are returned.
    pub to: Destination,
}

/// Where [`write()`] puts the bytes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Destination {
    /// The file `out`, written atomically as it is made (a big level's output is never held
    /// whole in memory; a failed write leaves no file).
    File,
    /// Returned, for callers that send them elsewhere (standard output, a test).
    Memory,
}

impl<'a> WriteOptions<'a> {
    /// The level written to the file `out` as `format`, without a PVS.
    pub fn file(out: &'a Path, format: OutFormat) -> WriteOptions<'a> {
        WriteOptions {
            out,
            format,
            pvs: None,
            to: Destination::File,
        }
    }

    /// The level's bytes as `out` would hold them, kept in memory.
    pub fn memory(out: &'a Path, format: OutFormat) -> WriteOptions<'a> {
        WriteOptions {
            to: Destination::Memory,
            ..WriteOptions::file(out, format)
        }
    }
}

/// Writes the annotated level: the input glTF with the `PORTCULLIS_portals` extension added
/// and nothing else changed, or a new glTF for a level read from OBJ or USD. Returns the
/// bytes with [`Destination::Memory`], nothing with [`Destination::File`].
pub fn write(
    tagged: &Tagged,
    cells: &CellSet,
    portals: &crate::portals::PortalSet,
    opts: &WriteOptions,
) -> Result<Vec<u8>, Diagnostic> {
    let out = opts.out;
    match opts.to {
        Destination::File => crate::export::atomic::write_with(
            out,
            |f| write_to(tagged, cells, portals, opts, f),
            |e| crate::export::atomic::failed(out, e),
        )
        .map(|()| Vec::new()),
        Destination::Memory => {
            let mut bytes = std::io::Cursor::new(Vec::new());
            write_to(tagged, cells, portals, opts, &mut bytes)?;
            Ok(bytes.into_inner())
        }
    }
}

/// [`write`] into `sink`.
fn write_to(
    tagged: &Tagged,
    cells: &CellSet,
    portals: &crate::portals::PortalSet,
    opts: &WriteOptions,
    sink: &mut dyn crate::export::sink::Sink,
) -> Result<(), Diagnostic> {
    let (out, format, pvs) = (opts.out, opts.format, opts.pvs);
    use crate::export::gltf_out;
    use crate::format as extension;
    let scene = &tagged.scene;
    let tagging = &tagged.tagging;
    // The input hash is a pass over every position: it runs on a thread of its own while the
    // output is written, and is waited for when the writer reaches it.
    std::thread::scope(|s| {
        let hashing = std::thread::Builder::new()
            .spawn_scoped(s, || extension::input_hash(scene, tagging))
            .ok();
        // So are the input's root members while the annotation is built, when the importer
        // did not keep where they lie (then they are a pass over the JSON text).
        let members = scene.gltf.as_ref().and_then(|src| {
            std::thread::Builder::new()
                .spawn_scoped(s, || src.members().ok().flatten())
                .ok()
        });
        let hash = extension::InputHash::pending(Box::new(move || {
            hashing
                .and_then(|h| h.join().ok())
                .unwrap_or_else(|| extension::input_hash(scene, tagging))
        }));
        let mut ann = extension::build_deferred(&hash, tagging, cells, portals, &|n| {
            gltf_out::node_index(scene, n)
        });
        if let Some((p, m)) = pvs {
            ann.set_visibility(p, m);
        }
        if scene.gltf.is_none() {
            // A new glTF (from OBJ or USD) is not the input: hash what a reader of the written
            // file will import, or the annotation would read back as stale.
            if let Some(h) = written_hash(tagged, out, format) {
                ann.root["inputHash"] = serde_json::json!(h);
            }
        }
        let members = members.and_then(|m| m.join().ok()).flatten();
        gltf_out::write_to_with(scene, members, ann, out, format, sink)
    })
}

/// The input hash of the glTF written for a non-glTF level: written without annotation, read
/// back and tagged with the same rules.
fn written_hash(
    tagged: &Tagged,
    out: &Path,
    format: crate::export::gltf_out::OutFormat,
) -> Option<String> {
    use crate::export::{bake, gltf_out};
    let bytes = gltf_out::write_plain(&bake::world_space(&tagged.scene), format);
    let scene_format = match format {
        gltf_out::OutFormat::Glb => crate::scene::Format::Glb,
        gltf_out::OutFormat::Gltf => crate::scene::Format::Gltf,
    };
    let dir = out.parent().unwrap_or(Path::new("."));
    let back =
        import::import_bytes(&bytes, out, scene_format, dir, &ImportOptions::default()).ok()?;
    let mut tagging = tags::recognise(&back.scene, &tagged.rules);
    tagging.settings = tagged.tagging.settings.clone();
    Some(crate::format::input_hash(&back.scene, &tagging))
}

/// The checks of a built level (see [`crate::check`]); findings are appended to
/// `tagged.diagnostics`, and the leak polylines returned for debug output. `sealed` adds to
/// the configuration's `[check] sealed`.
pub fn check_level(
    tagged: &mut Tagged,
    cells: &CellSet,
    portals: &crate::portals::PortalSet,
    sealed: bool,
) -> Vec<Vec<glam::DVec3>> {
    let opts = crate::check::Options {
        sealed: sealed || tagged.config.check.sealed,
    };
    let subject = crate::check::Subject::built(tagged, cells, portals);
    let found = crate::check::run(&subject, &opts);
    tagged.diagnostics.extend(found.diagnostics);
    found.leaks
}

/// The full PVS of a level just built, through mirrors and teleporters as deep as the loop
/// check allows (or `[vis] transform_depth`), as `convert` stores it by default.
pub fn full_pvs(
    tagged: &Tagged,
    cells: &CellSet,
    portals: &crate::portals::PortalSet,
) -> crate::vis::Pvs {
    let depth =
        crate::vis::level_transform_depth(cells, portals, tagged.config.vis.transform_depth);
    let opts = crate::vis::VisOptions {
        transform_depth: depth,
        ..Default::default()
    };
    crate::vis::of_level(cells.cells.len(), portals, cells.tolerance.distance, &opts)
}

/// `check --sightlines`: audits `pvs` against the level's triangles with `rays` rays per cell.
pub fn audit_sightlines(
    tagged: &Tagged,
    cells: &CellSet,
    portals: &crate::portals::PortalSet,
    pvs: &crate::vis::Pvs,
    rays: usize,
) -> crate::check::sightlines::Audit {
    let subject = crate::check::Subject::built(tagged, cells, portals);
    let triangles =
        crate::portals::blocking_triangles(&tagged.scene, &tagged.tagging, &cells.props);
    let depth =
        crate::vis::level_transform_depth(cells, portals, tagged.config.vis.transform_depth);
    crate::check::sightlines::audit(&subject, &triangles, pvs, rays, depth)
}

/// `check --sightlines` on a stored annotation: its stored PVS (or, when it stores none, the
/// full PVS of its stored portals) against the level's triangles. Props are not known from an
/// annotation, so they block here (which only ever confirms fewer pairs).
pub fn audit_stored(
    tagged: &Tagged,
    annotated: &crate::format::Annotated,
    subject: &crate::check::Subject,
    rays: usize,
) -> crate::check::sightlines::Audit {
    let cells = annotated.cells.len();
    let stored = tagged.scene.gltf.as_ref().and_then(|src| {
        let buffers = src.buffer_data().ok()?;
        let doc = src.subset(&["bufferViews"]).ok()?;
        crate::format::read::visibility(annotated, &doc, &buffers)?.ok()
    });
    let depth =
        tagged.config.vis.transform_depth.unwrap_or_else(|| {
            crate::portals::loops::recursion_depth(subject.portals, subject.extent)
        });
    let pvs = stored.unwrap_or_else(|| {
        let opts = crate::vis::VisOptions {
            transform_depth: depth,
            ..Default::default()
        };
        crate::vis::of_level(cells, subject.portals, subject.eps, &opts)
    });
    let triangles = crate::portals::blocking_triangles(&tagged.scene, &tagged.tagging, &[]);
    crate::check::sightlines::audit(subject, &triangles, &pvs, rays, depth)
}

/// Hands the heap a stage freed (portals, the PVS) back to the system before the next
/// allocates its own: glibc's malloc keeps it otherwise, and the next stage's large blocks do
/// not always fit in it (on a big level, 30 MB more at the export after a PVS). The
/// `portcullis` binary allocates through jemalloc, which returns freed pages by itself after
/// 0.3 s, so there this only trims what C code allocated; it matters to library callers on
/// glibc's malloc.
pub fn release_free_memory() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: malloc_trim only returns free pages of the allocator's heap to the system.
    unsafe {
        libc::malloc_trim(0);
    }
}
