//! Built-in presets. They are data (TOML, embedded at build time) in the same format as the
//! `[tags]` section of `portcullis.toml`, so a studio can copy one and edit it.

use super::rules::{RuleSet, RuleSetSpec};

/// (name, TOML text) of every preset.
pub const PRESETS: &[(&str, &str)] = &[
    ("auto", include_str!("presets/auto.toml")),
    ("default", include_str!("presets/default.toml")),
    ("doom", include_str!("presets/doom.toml")),
    ("godot", include_str!("presets/godot.toml")),
    ("lportal", include_str!("presets/lportal.toml")),
    ("panda3d", include_str!("presets/panda3d.toml")),
    ("quake", include_str!("presets/quake.toml")),
];

/// The built-in presets' names, for `--tags` and error hints.
pub fn names() -> impl Iterator<Item = &'static str> {
    PRESETS.iter().map(|(n, _)| *n)
}

/// The spec of a preset, or `None` for an unknown name.
pub fn spec(name: &str) -> Option<RuleSetSpec> {
    let (_, text) = PRESETS.iter().find(|(n, _)| n.eq_ignore_ascii_case(name))?;
    // The presets are ours and covered by tests; a parse failure is a build defect.
    let mut spec: RuleSetSpec =
        toml::from_str(text).unwrap_or_else(|e| panic!("built-in preset {name} is invalid: {e}"));
    // `auto` tags as `default` does, then generates rooms in the rest.
    if spec.generate && spec.rules.is_empty() {
        spec.rules = self::spec("default")?.rules;
    }
    Some(spec)
}

/// A preset as a `portcullis.toml` (issue 45): its comment, then a `[tags]` table naming it,
/// its rules as `[[tags.rule]]` replacing the built-in ones, so the file tags exactly as
/// `--tags NAME` does and can be edited from there. `None` for an unknown name.
pub fn as_config(name: &str) -> Option<String> {
    let (name, text) = PRESETS.iter().find(|(n, _)| n.eq_ignore_ascii_case(name))?;
    let spec = spec(name)?;
    let mut out: String = text
        .lines()
        .take_while(|l| l.starts_with('#'))
        .map(|l| format!("{l}\n"))
        .collect();
    out.push_str(&format!(
        "# The `{name}` preset as a portcullis.toml: {}.\n# Its rules replace the built-in ones (`replace = true`), so this file tags as `--tags {name}` does; edit from here.\n",
        spec.description.trim_end_matches('.')
    ));
    let mut tags = toml::Table::new();
    tags.insert("preset".into(), toml::Value::String(name.to_string()));
    tags.insert("replace".into(), toml::Value::Boolean(true));
    tags.insert(
        "case_sensitive".into(),
        toml::Value::Boolean(spec.case_sensitive),
    );
    if let Some(w) = spec.wildcard {
        tags.insert("wildcard".into(), toml::Value::String(w.to_string()));
    }
    if let Some(sky) = &spec.sky {
        tags.insert("sky".into(), toml::Value::String(sky.clone()));
    }
    let rules = toml::Value::try_from(&spec.rules).ok()?;
    tags.insert("rule".into(), rules);
    let mut root = toml::Table::new();
    root.insert("tags".into(), toml::Value::Table(tags));
    out.push_str(&toml::to_string(&root).ok()?);
    Some(out)
}

/// A compiled preset.
pub fn load(name: &str) -> Option<RuleSet> {
    let spec = spec(name)?;
    Some(RuleSet::compile(&spec).unwrap_or_else(|e| panic!("built-in preset {name}: {e}")))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_preset_parses_compiles_and_follows_the_schema() {
        for name in names() {
            let spec = spec(name).unwrap();
            assert_eq!(spec.name, name);
            RuleSet::compile(&spec).unwrap();
            let text = PRESETS.iter().find(|(n, _)| *n == name).unwrap().1;
            let as_json: serde_json::Value = toml::from_str(text).unwrap();
            let errs = crate::schema::validate(crate::schema::Schema::RuleSet, &as_json);
            assert!(errs.is_empty(), "{name}: {errs:?}");
        }
    }

    #[test]
    fn every_rule_accepts_its_own_example() {
        for name in names() {
            let rs = load(name).unwrap();
            for (i, r) in rs.rules.iter().enumerate() {
                if let Some(ex) = &r.spec.example {
                    let m = rs.match_text(r.spec.on, ex);
                    assert!(
                        m.is_some(),
                        "{name}: rule {} rejects its example {ex}",
                        r.spec.id
                    );
                    // An earlier rule may legitimately win (ordering is precedence), but the
                    // example must not be claimed by a rule of another kind.
                    let m = m.unwrap();
                    assert_eq!(
                        rs.rules[m.rule].spec.kind, r.spec.kind,
                        "{name}: {ex} ({i})"
                    );
                }
            }
        }
    }
}
