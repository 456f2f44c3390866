//! Reading one input: the configuration that applies to it, the import (a file or standard
//! input), the tag rules, and the tagging that makes a [`Tagged`] level.

use std::path::{Path, PathBuf};

use crate::config::{self, Config};
use crate::diag::Diagnostic;
use crate::import::{self, ImportOptions};
use crate::level::Tagged;
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
    let mut settings = serde_json::json!({
        "rules": specs,
        "caseSensitive": rules.case_sensitive,
        "wildcard": rules.wildcard,
        "cells": config.cells,
        "portals": config.portals,
        "generate": rules.generate.then_some(&config.auto),
    });
    // Only when set, so the hash of a level whose rules name no sky is what it was before the
    // rules could.
    if let Some(sky) = &rules.sky {
        settings["sky"] = serde_json::json!(sky.as_str());
    }
    serde_json::to_vec(&settings).unwrap_or_default()
}

/// Tags an imported level with `rules` (library callers that import themselves use this).
pub fn tag(imported: import::Imported, config: Config, rules: RuleSet) -> Tagged {
    let mut tagging = tags::recognise(&imported.scene, &rules);
    tagging.settings = settings_bytes(&config, &rules);
    // Rooms are generated where geometry is in no tagged room: in a level nobody tagged, and
    // in the untagged rest of a level tagged in part. Tags win: the generated cells end on
    // the tagged cells' faces (`cells::generated`).
    if rules.generate && (tagging.rooms.is_empty() || !tagging.unassigned.is_empty()) {
        // Rooms are found, so not finding tagged ones is no news.
        (tagging.diagnostics.0).retain(|d| {
            d.code != crate::diag::Code::TAG_NO_ROOMS
                && d.code != crate::diag::Code::TAGS_PRESET_SUGGESTED
        });
        let found = crate::auto::generate(&imported.scene, &mut tagging, &config.auto);
        tagging.generated = Some(Box::new(found));
    }
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
