//! Tag rules as data: what a rule file says (serde) and the compiled form that matches names.
//!
//! A rule recognises one kind of thing (room, portal, …) from one source (extras key, node name
//! or material name). Name and material rules are regular expressions whose named groups carry
//! the parts of the name that matter (`name`, `target`, `source`); templates such as
//! `cell${target}` turn those parts into room names, which is how `portal_3to5_1` (Panda3D)
//! comes to link room `cell3` to room `cell5`.

use regex::{Regex, RegexBuilder};
use serde::{Deserialize, Serialize};

/// What a rule recognises.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TagKind {
    /// A room: the node and its subtree are one room.
    Room,
    /// A group of rooms (Godot's RoomGroup): no volume of its own.
    Roomgroup,
    /// An authored portal polygon.
    Portal,
    /// A convex mesh giving a room's volume instead of its geometry's hull.
    Bound,
    /// A floor polygon extruded upward into a room's volume.
    Footprint,
    /// Geometry that neither bounds cells nor blocks sight and is not rendered by cells.
    Ignore,
    /// Props: rendered by the cell containing them, never bounding a cell or blocking sight.
    Detail,
    /// A player start: the seed for leak searches.
    PlayerStart,
    /// An occupant (a monster, an item, any place a player can reach): like a player start,
    /// it tells the air around it from the void and seeds leak searches.
    Occupant,
}

impl TagKind {
    /// The kind's name in configs, extras and reports (`room`, `player_start`).
    pub fn as_str(self) -> &'static str {
        match self {
            TagKind::Room => "room",
            TagKind::Roomgroup => "roomgroup",
            TagKind::Portal => "portal",
            TagKind::Bound => "bound",
            TagKind::Footprint => "footprint",
            TagKind::Ignore => "ignore",
            TagKind::Detail => "detail",
            TagKind::PlayerStart => "player_start",
            TagKind::Occupant => "occupant",
        }
    }
}

/// Where a rule looks.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MatchOn {
    /// The node's name.
    #[default]
    Name,
    /// The name of a material the node's mesh uses.
    Material,
    /// A key of the node's extras.
    Extras,
}

/// How a room's volume is found when the rule does not say otherwise.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum VolumeHint {
    /// Convex hull of the room's structural geometry, unless a bound or footprint is found.
    #[default]
    Geometry,
    /// The room node's own mesh is a floor footprint (Panda3D `cellN`).
    Footprint,
    /// The room node's own mesh is its bound volume.
    Bound,
}

/// Which way an authored portal quad's front faces.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Facing {
    /// Out of its source room (Godot, LPortal).
    #[default]
    Out,
    /// Back into its source room (Panda3D).
    In,
}

/// What a portal does to sight passing through it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PortalKind {
    /// An opening: sight passes straight through.
    #[default]
    Plain,
    /// Reflects sight back into the room it is in.
    Mirror,
    /// Sight continues from its exit portal, elsewhere in the level.
    Teleporter,
}

impl PortalKind {
    /// The kind named `s` in extras (`portal`, `door`, `mirror`, `teleport`...; any case).
    pub fn parse(s: &str) -> Option<PortalKind> {
        match s.to_ascii_lowercase().as_str() {
            "plain" | "portal" | "door" | "window" => Some(PortalKind::Plain),
            "mirror" => Some(PortalKind::Mirror),
            "teleporter" | "teleport" => Some(PortalKind::Teleporter),
            _ => None,
        }
    }
}

/// One rule as written in a preset or in `portcullis.toml` (`[[tags.rule]]`).
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RuleSpec {
    /// Stable identifier shown in reports, e.g. `godot.room`.
    pub id: String,
    /// What the rule recognises.
    pub kind: TagKind,
    /// Where the rule looks: name, material name or extras.
    #[serde(default)]
    pub on: MatchOn,
    /// Regular expression for `on = "name"` / `"material"`; named groups `name`, `target`,
    /// `source` feed the templates below.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pattern: Option<String>,
    /// Extras key for `on = "extras"`; dots descend into objects (`egg_scalars.portal`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub key: Option<String>,
    /// Template for the room this rule names (rooms, bounds, footprints), e.g. `cell${name}`;
    /// for an extras rule, `${value}` is the key's value read as an identifier
    /// (`sector_${value}`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub room: Option<String>,
    /// Template for a portal's source room (else the room the portal sits in).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub source: Option<String>,
    /// Template for a portal's target room.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub target: Option<String>,
    /// Portals it recognises pass sight one way.
    #[serde(default, skip_serializing_if = "is_false")]
    pub one_way: bool,
    /// Portals it recognises start closed.
    #[serde(default, skip_serializing_if = "is_false")]
    pub closed: bool,
    /// Portals it recognises are mirrors or teleporters (default: plain).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub portal_kind: Option<PortalKind>,
    /// How the rooms it recognises get their volume (default: their geometry).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub volume: Option<VolumeHint>,
    /// For portal rules: which way the authored quad's front faces. `out` of its source room
    /// (Godot, LPortal; the default) or `in`, back into it (Panda3D).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub faces: Option<Facing>,
    /// A name this rule accepts, shown in near-miss hints.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub example: Option<String>,
}

fn is_false(b: &bool) -> bool {
    !*b
}

/// A preset or a config's rule list.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RuleSetSpec {
    /// The preset's or config's name, reported as the tagging's `preset`.
    pub name: String,
    /// A line about the convention, for people reading the preset.
    #[serde(default)]
    pub description: String,
    /// Names compare case-sensitively (default: no, as Godot).
    #[serde(default)]
    pub case_sensitive: bool,
    /// Godot's wildcard: in a name, everything from this character up to the tag suffix is
    /// ignored (`kitchen*2-portal` is `kitchen-portal`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub wildcard: Option<char>,
    /// Tried in order: the first rule that matches a source decides.
    #[serde(default, rename = "rule")]
    pub rules: Vec<RuleSpec>,
    /// Rooms are also generated in the geometry no rule claims (`--tags auto`).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub generate: bool,
    /// Materials that are the open sky (a regular expression on the material's name): their
    /// surfaces bound rooms and are drawn, but sight passes through them to the outside, as
    /// Doom draws its sky flat (`F_SKY1`) as the sky, not as a ceiling. A renderer drawing such
    /// a ceiling single-sided shows, from above, what lies under it; only an opening lets the
    /// outside see in.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sky: Option<String>,
}

/// A rule ready to match.
#[derive(Debug, Clone)]
pub(crate) struct Rule {
    pub(crate) spec: RuleSpec,
    pub(crate) regex: Option<Regex>,
}

/// Why a rule cannot be compiled; each names the rule by its `id`.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub(crate) enum RuleError {
    /// An extras rule without the key it reads.
    #[error("rule `{rule}` matches on extras but has no `key`")]
    NoKey {
        /// The rule's id.
        rule: String,
    },
    /// A name or material rule without its pattern.
    #[error("rule `{rule}` matches on {on:?} but has no `pattern`")]
    NoPattern {
        /// The rule's id.
        rule: String,
        /// What it matches on.
        on: MatchOn,
    },
    /// A pattern the regex crate refuses.
    #[error("rule `{rule}` has an invalid pattern `{pattern}`: {why}")]
    BadPattern {
        /// The rule's id.
        rule: String,
        /// The pattern as written.
        pattern: String,
        /// The regex error's reason, on one line.
        why: String,
    },
}

/// A compiled rule set.
#[derive(Debug, Clone)]
pub struct RuleSet {
    /// As in [`RuleSetSpec::name`].
    pub name: String,
    /// Room names compare case-sensitively.
    pub case_sensitive: bool,
    /// As in [`RuleSetSpec::wildcard`].
    pub wildcard: Option<char>,
    /// As in [`RuleSetSpec::generate`].
    pub generate: bool,
    /// As in [`RuleSetSpec::sky`], compiled.
    pub sky: Option<Regex>,
    pub(crate) rules: Vec<Rule>,
    /// The literal prefixes and suffixes of the name rules, for near misses.
    pub(crate) affixes: Vec<Affix>,
    /// Per material rule (its index), the words it accepts at a name's end, for near misses.
    pub(crate) material_words: Vec<(usize, Vec<String>)>,
}

/// The parts a rule pulled out of a name or extras value.
#[derive(Debug, Clone, Default)]
pub(crate) struct RuleMatch {
    pub(crate) rule: usize,
    pub(crate) room: Option<String>,
    pub(crate) source: Option<String>,
    pub(crate) target: Option<String>,
}

/// `NAME` of `NAME.001`: a name ending in a dot and three or more digits, as Blender numbers a
/// duplicate (`Room.12` is a name of its own).
pub(crate) fn numbered_duplicate_stem(text: &str) -> Option<&str> {
    let (stem, digits) = text.rsplit_once('.')?;
    (!stem.is_empty() && digits.len() >= 3 && digits.bytes().all(|b| b.is_ascii_digit()))
        .then_some(stem)
}

/// A rule's pattern compiled as the rule set compares names; an error names the rule (`rule`).
fn pattern(p: &str, case_sensitive: bool, rule: &str) -> Result<Regex, RuleError> {
    RegexBuilder::new(p)
        .case_insensitive(!case_sensitive)
        .size_limit(1 << 20)
        .build()
        .map_err(|e| {
            // The regex error draws a caret under the pattern over several lines; a
            // diagnostic is one line, so keep the pattern and the reason.
            let text = e.to_string();
            let why = text
                .lines()
                .rev()
                .find_map(|l| l.strip_prefix("error: "))
                .unwrap_or(text.as_str())
                .to_string();
            RuleError::BadPattern {
                rule: rule.to_string(),
                pattern: p.to_string(),
                why,
            }
        })
}

impl RuleSet {
    /// Compiles a spec; an invalid pattern or a rule missing its pattern/key is an error
    /// naming the rule.
    pub(crate) fn compile(spec: &RuleSetSpec) -> Result<RuleSet, RuleError> {
        let mut rules = Vec::with_capacity(spec.rules.len());
        for r in &spec.rules {
            let regex = match r.on {
                MatchOn::Extras => {
                    if r.key.as_deref().unwrap_or("").is_empty() {
                        return Err(RuleError::NoKey { rule: r.id.clone() });
                    }
                    None
                }
                MatchOn::Name | MatchOn::Material => {
                    let p = r.pattern.as_deref().ok_or_else(|| RuleError::NoPattern {
                        rule: r.id.clone(),
                        on: r.on,
                    })?;
                    let re = pattern(p, spec.case_sensitive, &r.id)?;
                    Some(re)
                }
            };
            rules.push(Rule {
                spec: r.clone(),
                regex,
            });
        }
        let affixes = affixes(&rules);
        let material_words = material_words(&rules);
        let sky = (spec.sky.as_deref())
            .map(|p| pattern(p, spec.case_sensitive, "sky"))
            .transpose()?;
        Ok(RuleSet {
            name: spec.name.clone(),
            case_sensitive: spec.case_sensitive,
            wildcard: spec.wildcard,
            generate: spec.generate,
            sky,
            rules,
            affixes,
            material_words,
        })
    }

    /// Removes the wildcard part of a name: from the wildcard character up to the last `-`
    /// after it (the tag suffix), or to the end when no suffix follows.
    pub(crate) fn strip_wildcard<'a>(&self, name: &'a str) -> std::borrow::Cow<'a, str> {
        let Some(w) = self.wildcard else {
            return name.into();
        };
        let Some(star) = name.find(w) else {
            return name.into();
        };
        let rest = &name[star..];
        match rest.rfind('-') {
            Some(dash) => format!("{}{}", &name[..star], &rest[dash..]).into(),
            None => name[..star].to_string().into(),
        }
    }

    /// The first rule of `on` that accepts `text`, with its captures expanded. A name no rule
    /// accepts is tried again without a DCC's numbered-duplicate suffix (`portal.001`, as
    /// Blender names a copy), so copies keep the original's tag.
    pub(crate) fn match_text(&self, on: MatchOn, text: &str) -> Option<RuleMatch> {
        self.match_exactly(on, text).or_else(|| {
            let stem = numbered_duplicate_stem(text)?;
            self.match_exactly(on, stem)
        })
    }

    fn match_exactly(&self, on: MatchOn, text: &str) -> Option<RuleMatch> {
        let text = self.strip_wildcard(text);
        self.rules
            .iter()
            .enumerate()
            .filter(|(_, r)| r.spec.on == on)
            .find_map(|(i, r)| {
                let re = r.regex.as_ref()?;
                // Most names match no rule: telling that is cheaper than asking for captures.
                if !re.is_match(&text) {
                    return None;
                }
                let caps = re.captures(&text)?;
                let get = |g: &str| caps.name(g).map(|m| m.as_str().to_string());
                let expand = |tpl: &Option<String>, group: &str| -> Option<String> {
                    match tpl {
                        Some(t) => {
                            let mut out = String::new();
                            caps.expand(t, &mut out);
                            Some(out)
                        }
                        None => get(group),
                    }
                    // A DCC keeps stray spaces in names; a room is not named by them.
                    .map(|s| s.trim().to_string())
                    .filter(|s| !s.is_empty())
                };
                Some(RuleMatch {
                    rule: i,
                    room: expand(&r.spec.room, "name"),
                    source: expand(&r.spec.source, "source"),
                    target: expand(&r.spec.target, "target"),
                })
            })
    }

    /// A name as `same_name` compares it: two names are the same when their keys are equal.
    pub(crate) fn name_key(&self, a: &str) -> String {
        if self.case_sensitive {
            a.to_string()
        } else {
            a.to_lowercase()
        }
    }

    /// Whether two room names are the same under this rule set's case rule.
    pub(crate) fn same_name(&self, a: &str, b: &str) -> bool {
        if self.case_sensitive {
            a == b
        } else {
            a.to_lowercase() == b.to_lowercase()
        }
    }
}

/// What separates the words of a tag name (`Kitchen-room`, `portal_hall`, `Room.001`).
pub(crate) const SEPARATORS: [char; 4] = ['-', '_', '.', ' '];

/// A literal word a name rule requires at one end of a name, next to a separator: `room` of
/// `NAME-room` (a suffix after `-`), `portal` of `portal_TARGET` (a prefix before `_`).
#[derive(Debug, Clone)]
pub(crate) struct Affix {
    pub rule: usize,
    /// Lower case, without the separator.
    pub word: String,
    pub separator: char,
    pub prefix: bool,
}

/// The affixes of every name rule, read from its pattern's literal prefix and suffix.
pub(crate) fn affixes(rules: &[Rule]) -> Vec<Affix> {
    use regex_syntax::hir::literal::{ExtractKind, Extractor};
    let mut out = Vec::new();
    for (i, r) in rules.iter().enumerate() {
        let (MatchOn::Name, Some(pattern)) = (r.spec.on, r.spec.pattern.as_deref()) else {
            continue;
        };
        let Ok(hir) = regex_syntax::parse(pattern) else {
            continue;
        };
        for prefix in [true, false] {
            let kind = if prefix {
                ExtractKind::Prefix
            } else {
                ExtractKind::Suffix
            };
            let seq = Extractor::new().kind(kind).extract(&hir);
            // One literal, longer than a separator: what a name must start or end with.
            let Some([lit]) = seq.literals() else {
                continue;
            };
            let Ok(text) = std::str::from_utf8(lit.as_bytes()) else {
                continue;
            };
            let text = text.to_lowercase();
            let split = if prefix {
                text.strip_suffix(SEPARATORS)
                    .map(|w| (w, text.chars().last()))
            } else {
                text.strip_prefix(SEPARATORS)
                    .map(|w| (w, text.chars().next()))
            };
            if let Some((word, Some(separator))) = split {
                if word.chars().count() >= 3 && !word.contains(SEPARATORS) {
                    out.push(Affix {
                        rule: i,
                        word: word.to_string(),
                        separator,
                        prefix,
                    });
                }
            }
        }
    }
    out
}

/// For each material rule (its index), the words it accepts at the end of a name; computed
/// once per rule set, as the affixes are.
pub(crate) fn material_words(rules: &[Rule]) -> Vec<(usize, Vec<String>)> {
    rules
        .iter()
        .enumerate()
        .filter(|(_, r)| r.spec.on == MatchOn::Material)
        .map(|(i, r)| (i, rule_material_words(r)))
        .collect()
}

/// The words a material rule accepts at the end of a name: its example's last part, and the
/// literal endings its pattern allows (`nodraw`, `skip`, `caulk`), lower case.
fn rule_material_words(r: &Rule) -> Vec<String> {
    use regex_syntax::hir::literal::{ExtractKind, Extractor};
    let mut out: Vec<String> = r
        .spec
        .example
        .iter()
        .map(|e| e.rsplit('/').next().unwrap_or(e).to_lowercase())
        .collect();
    if let Some(hir) = r
        .spec
        .pattern
        .as_deref()
        .and_then(|p| regex_syntax::parse(p).ok())
    {
        let seq = Extractor::new().kind(ExtractKind::Suffix).extract(&hir);
        for lit in seq.literals().unwrap_or(&[]) {
            if let Ok(text) = std::str::from_utf8(lit.as_bytes()) {
                let w = text.rsplit('/').next().unwrap_or(text).to_lowercase();
                if w.chars().count() >= 3 && w.chars().all(char::is_alphanumeric) {
                    out.push(w);
                }
            }
        }
    }
    out.sort();
    out.dedup();
    out
}
