//! `portcullis.toml`: the project configuration. Found next to the input or given with
//! `--config`; TOML, converted to JSON and validated against schemas/config.schema.json before
//! it is used, so a typo in a key is an error with its path rather than a silently ignored
//! setting.
//!
//! The effective rule set is the config's rules before the preset's (or instead, with `replace`),
//! and `--tags` wins over the config's preset.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::diag::{Code, Diagnostic, Location};
use crate::schema::{self, Schema};
use crate::tags::presets;
use crate::tags::rules::{RuleSet, RuleSetSpec, RuleSpec};

/// The crack width of glTF, OBJ and USD levels when `[cells] crack_width` is unset (m): wider
/// than the gaps f32 rounding and hand modelling leave where blocks were meant to meet (up to
/// 5 mm on the shared Panda3D level), narrow enough that a 2 cm slit is an opening.
pub const DEFAULT_CRACK_WIDTH: f64 = 0.008;

/// `[cells] max_cell_width` when unset (m): 630 Quake units, about qbsp's `-maxnodesize` of
/// 1,024 units once halving is counted (a cell of up to this width in place of a leaf of up to
/// 1,024 cut at its middle). On E1M1, e3m4 and retrojam1 it keeps the PVS over the ray bound
/// tighter than vis's with fewer cell pairs than qbsp's portals (docs/performance.md).
pub const DEFAULT_MAX_CELL_WIDTH: f64 = 16.0;

/// The configuration file looked for next to a level.
pub(crate) const FILE_NAME: &str = "portcullis.toml";

/// A `portcullis.toml`: each section overrides the built-in defaults for that stage.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Config {
    /// `[tags]`: the preset and any rules of the level's own.
    #[serde(default)]
    pub tags: TagsConfig,
    /// `[cells]`: how rooms become cells.
    #[serde(default)]
    pub cells: CellsConfig,
    /// `[portals]`: how portals are found and matched.
    #[serde(default)]
    pub portals: PortalsConfig,
    /// `[vis]`: the PVS method and its limits.
    #[serde(default)]
    pub vis: VisConfig,
    /// `[check]`: diagnostic severities and the checks' thresholds.
    #[serde(default)]
    pub check: CheckConfig,
    /// `[import]`: how files are read.
    #[serde(default)]
    pub import: ImportConfig,
    /// `[auto]`: how `--tags auto` finds rooms.
    #[serde(default)]
    pub auto: crate::auto::AutoConfig,
    /// Where the configuration was read from (None: built-in defaults).
    #[serde(skip)]
    pub path: Option<PathBuf>,
}

/// `[tags]`: which naming convention a level follows.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TagsConfig {
    /// A built-in preset's name (`godot`, `lportal`, `panda3d`); `None`: auto-detect.
    pub preset: Option<String>,
    /// Overrides the preset's case rule for room names.
    pub case_sensitive: Option<bool>,
    /// Overrides the preset's wildcard character (see `RuleSetSpec::wildcard`).
    pub wildcard: Option<char>,
    /// Overrides the preset's sky materials (see `RuleSetSpec::sky`): a pattern on material
    /// names, or `""` for none.
    pub sky: Option<String>,
    /// The `rules` replace the preset's rather than being tried before them.
    #[serde(default)]
    pub replace: bool,
    /// `[[tags.rule]]`: the level's own rules, tried first.
    #[serde(default, rename = "rule")]
    pub rules: Vec<RuleSpec>,
}

/// `[cells]`: how rooms become convex cells.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct CellsConfig {
    /// A cell with more planes than this is reported (engines test every plane per frame).
    pub max_planes: usize,
    /// Cells of different rooms overlapping by more than this volume (m³) are reported.
    pub overlap_volume: f64,
    /// Extrusion height of footprints (m). Unset: up to the geometry above each footprint
    /// vertex, else `default_height`.
    pub footprint_height: Option<f64>,
    /// Height used where nothing is above a footprint and the level's top is too close (m).
    /// Unset: the level's storey height, the median clearance above its footprints.
    pub default_height: Option<f64>,
    /// The largest distance tolerance allowed (m); see ARCHITECTURE.md, Numerics.
    pub max_tolerance: f64,
    /// Treat small meshes of a room that touch fewer than two sides of the rest of the room
    /// as props: they are rendered by the cell containing them but do not shape it.
    pub detect_props: bool,
    /// The level's up direction (glTF and portcullis's importers use +Y).
    pub up: [f64; 3],
    /// Gaps narrower than this (m) are cracks: closed where blocks meet (no cell, no leak) and
    /// between blockers of an opening (no portal, no split portal). One absolute width for the
    /// solid-block reading and the portal stage alike, never taken from a room's size. Unset:
    /// the format's own, qbsp's 0.2 units for a brush map (`[import] map_scale` converts it),
    /// [`DEFAULT_CRACK_WIDTH`] for glTF, OBJ and USD.
    // Left out of the input hash's settings when unset, so annotations written before the
    // key existed are not all reported stale.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub crack_width: Option<f64>,
    /// No cell of a room built of solid blocks is wider than this (m) across any of its
    /// faces' directions: wider ones are halved until none is. A cell-to-cell PVS is as loose
    /// as its widest cells (qbsp caps its leafs the same way, `-maxnodesize`, 1,024 units).
    // Left out of the input hash's settings at its default, as `crack_width` when unset.
    #[serde(skip_serializing_if = "is_default_cell_width")]
    pub max_cell_width: f64,
    /// The distance tolerance is the policy's times this (1 in every run of the tool; not a
    /// configuration key). For tests that check a result does not hang on the exact value
    /// the policy picks.
    #[serde(skip, default = "one")]
    pub tolerance_factor: f64,
}

fn one() -> f64 {
    1.0
}

fn is_default_cell_width(w: &f64) -> bool {
    *w == DEFAULT_MAX_CELL_WIDTH
}

impl Default for CellsConfig {
    fn default() -> Self {
        CellsConfig {
            max_planes: 32,
            overlap_volume: 1e-3,
            footprint_height: None,
            default_height: None,
            max_tolerance: crate::geom::tolerance::DEFAULT_MAX_DISTANCE,
            detect_props: true,
            up: [0.0, 1.0, 0.0],
            crack_width: None,
            max_cell_width: DEFAULT_MAX_CELL_WIDTH,
            tolerance_factor: 1.0,
        }
    }
}

/// `[portals]`: how openings become portals.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct PortalsConfig {
    /// Parallel cell faces facing each other at most this far apart (m) are bridged across
    /// the wall between them.
    pub max_wall_thickness: f64,
    /// Give each opening its convex hull as one portal instead of an exact convex partition.
    pub conservative: bool,
    /// Derive portals to the exterior (openings no other cell shares).
    pub exterior: bool,
    /// The earlier name of `[cells] crack_width`, still read: when that is unset, this is
    /// the crack width (see [`CellsConfig::crack_width`]).
    // Left out of the input hash's settings when unset, so annotations written before the
    // key existed are not all reported stale.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub min_opening_width: Option<f64>,
}

impl Default for PortalsConfig {
    fn default() -> Self {
        PortalsConfig {
            max_wall_thickness: 0.5,
            conservative: false,
            exterior: true,
            min_opening_width: None,
        }
    }
}

/// `[vis]`: the PVS stage.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct VisConfig {
    /// Transformed portals (mirrors, teleporters) one sightline may pass through. Unset: the
    /// default bound (see `vis::DEFAULT_TRANSFORM_DEPTH`).
    pub transform_depth: Option<usize>,
    /// Sightlines per directed portal for the `sampled` method.
    pub samples: Option<usize>,
    /// Portal tests the `full` flow may make in all (see `vis::DEFAULT_FLOW_BUDGET`).
    pub flow_budget: Option<u64>,
}

/// `[import]`: how files are read.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ImportConfig {
    /// Metres per brush-map unit (`None`: Quake's inch, 0.0254).
    pub map_scale: Option<f64>,
}

/// `[check]`: what `check` (and `convert`) treat as a problem.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CheckConfig {
    /// The level is meant to be closed: every opening to the exterior is a leak (an error).
    pub sealed: bool,
    /// Rays per cell for the PVS audit against the level's geometry (0: none).
    pub sightlines: usize,
    /// Codes never reported for levels this configuration applies to.
    pub ignore: Vec<String>,
    /// Severity overrides, `CODE = "error" | "warning" | "info"`.
    pub severity: std::collections::BTreeMap<String, String>,
}

impl CheckConfig {
    /// What this section asks to hear: its `ignore` and `severity` as a policy. Unknown code
    /// or severity names are errors the schema cannot catch (codes are not in it).
    pub fn policy(&self) -> Result<crate::diag::policy::Policy, crate::diag::policy::PolicyError> {
        crate::diag::policy::Policy::from_names(&self.ignore, &self.severity)
    }
}

/// The configuration next to `input`, if there is one.
pub(crate) fn discover(input: &Path) -> Option<PathBuf> {
    let dir = input
        .parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let p = dir.join(FILE_NAME);
    p.is_file().then_some(p)
}

/// Reads and validates a configuration file.
pub fn load(path: &Path) -> Result<Config, Diagnostic> {
    let text = std::fs::read_to_string(path).map_err(|e| {
        let code = if e.kind() == std::io::ErrorKind::NotFound {
            Code::CONFIG_NOT_FOUND
        } else {
            Code::IO_READ_FAILED
        };
        Diagnostic::new(
            code,
            format!("cannot read configuration `{}`: {e}", path.display()),
            Location::file(path),
        )
        .hint("check the --config path")
    })?;
    parse(&text, path)
}

/// Parses configuration text; `path` is for messages.
pub fn parse(text: &str, path: &Path) -> Result<Config, Diagnostic> {
    let invalid = |msg: String, hint: &str| {
        Diagnostic::new(Code::CONFIG_INVALID, msg, Location::file(path)).hint(hint.to_string())
    };
    let value: serde_json::Value = toml::from_str(text).map_err(|e| {
        invalid(
            format!("`{}` is not valid TOML: {}", path.display(), e.message()),
            "fix the TOML syntax at the position given",
        )
    })?;
    let errors = schema::validate(Schema::Config, &value);
    if !errors.is_empty() {
        return Err(invalid(
            format!("`{}` does not follow the configuration schema:\n  {}", path.display(), errors.join("\n  ")),
            "see schemas/config.schema.json (`portcullis schema config.schema.json`) for the keys and values allowed",
        ));
    }
    let mut cfg: Config = serde_json::from_value(value).map_err(|e| {
        invalid(
            format!("`{}`: {e}", path.display()),
            "see schemas/config.schema.json",
        )
    })?;
    if let (Some(a), Some(b)) = (cfg.cells.crack_width, cfg.portals.min_opening_width) {
        if a != b {
            return Err(invalid(
                format!("`{}` sets both [cells] crack_width ({a}) and its earlier name [portals] min_opening_width ({b})", path.display()),
                "keep [cells] crack_width and delete [portals] min_opening_width",
            ));
        }
    }
    cfg.cells.crack_width = cfg.cells.crack_width.or(cfg.portals.min_opening_width);
    cfg.path = Some(path.to_path_buf());
    Ok(cfg)
}

/// The effective tag rules: `cli_preset` (from `--tags`) wins over the config's preset; the
/// config's rules come before the preset's (or replace them with `replace = true`).
pub fn rule_set(cfg: &Config, cli_preset: Option<&str>) -> Result<RuleSet, Diagnostic> {
    let name = cli_preset
        .or(cfg.tags.preset.as_deref())
        .unwrap_or("default");
    let at = || cfg.path.clone().map(Location::file).unwrap_or_default();
    let mut spec: RuleSetSpec = presets::spec(name).ok_or_else(|| {
        Diagnostic::new(
            Code::TAGS_PRESET_UNKNOWN,
            format!("there is no tag preset called `{name}`"),
            at(),
        )
        .hint(format!(
            "choose one of: {}",
            presets::names().collect::<Vec<_>>().join(", ")
        ))
    })?;
    if let Some(cs) = cfg.tags.case_sensitive {
        spec.case_sensitive = cs;
    }
    if let Some(w) = cfg.tags.wildcard {
        spec.wildcard = Some(w);
    }
    if let Some(sky) = &cfg.tags.sky {
        spec.sky = Some(sky.clone()).filter(|s| !s.is_empty());
    }
    if !cfg.tags.rules.is_empty() {
        if cfg.tags.replace {
            spec.rules = cfg.tags.rules.clone();
        } else {
            let mut rules = cfg.tags.rules.clone();
            rules.append(&mut spec.rules);
            spec.rules = rules;
        }
        spec.name = format!(
            "{name}+{}",
            cfg.path
                .as_deref()
                .map(|p| p.display().to_string())
                .unwrap_or_else(|| "config".into())
        );
    }
    RuleSet::compile(&spec).map_err(|e| {
        Diagnostic::new(Code::TAGS_RULE_INVALID, e.to_string(), at())
            .hint("fix the rule's pattern (Rust regex syntax) in the configuration")
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn config_rules_come_first_and_cli_preset_wins() {
        let cfg = parse(
            "[tags]\npreset = \"lportal\"\n[[tags.rule]]\nid = \"studio.room\"\nkind = \"room\"\npattern = '^RM_(?P<name>.+)$'\n",
            Path::new("portcullis.toml"),
        )
        .unwrap();
        let rs = rule_set(&cfg, None).unwrap();
        assert_eq!(rs.rules[0].spec.id, "studio.room");
        assert!(rs.rules.iter().any(|r| r.spec.id == "lportal.room"));
        let rs = rule_set(&cfg, Some("godot")).unwrap();
        assert!(rs.rules.iter().any(|r| r.spec.id == "godot.room"));
        assert!(!rs.rules.iter().any(|r| r.spec.id == "lportal.room"));
    }

    #[test]
    fn typos_and_bad_values_are_errors_with_paths() {
        let e = parse("[tags]\npresett = \"godot\"\n", Path::new("p.toml")).unwrap_err();
        assert_eq!(e.code, Code::CONFIG_INVALID);
        assert!(e.message.contains("presett"), "{}", e.message);
        let e = parse("[tags\n", Path::new("p.toml")).unwrap_err();
        assert_eq!(e.code, Code::CONFIG_INVALID);
        let cfg = parse(
            "[[tags.rule]]\nid = \"x\"\nkind = \"room\"\npattern = '(('\n",
            Path::new("p.toml"),
        )
        .unwrap();
        assert_eq!(
            rule_set(&cfg, None).unwrap_err().code,
            Code::TAGS_RULE_INVALID
        );
        assert_eq!(
            rule_set(&Config::default(), Some("unreal"))
                .unwrap_err()
                .code,
            Code::TAGS_PRESET_UNKNOWN
        );
    }
}
