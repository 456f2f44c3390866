//! The JSON Schemas in schemas/, embedded so the binary validates without the source tree, and
//! one place that runs them.
//!
//! `schemas/config.schema.json` holds the config file and, under `$defs/ruleSet`, a preset;
//! `schemas/tags.schema.json` the extras keys; `schemas/PORTCULLIS_portals.schema.json` the
//! extension. A test validates every built-in preset against the rule-set schema.

use serde_json::Value;

/// A schema portcullis ships.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Schema {
    /// `portcullis.toml` (after TOML → JSON).
    Config,
    /// A tag preset (the rule-set definition inside the config schema).
    RuleSet,
    /// The extras keys designers use.
    Tags,
    /// The `PORTCULLIS_portals` root extension object.
    Portals,
    /// The `PORTCULLIS_portals` node extension object.
    PortalsNode,
}

pub(crate) const CONFIG: &str = include_str!("../schemas/config.schema.json");
pub(crate) const TAGS: &str = include_str!("../schemas/tags.schema.json");
pub(crate) const PORTALS: &str = include_str!("../schemas/PORTCULLIS_portals.schema.json");

/// (file name, text) of every shipped schema, for `portcullis schema`.
pub const FILES: &[(&str, &str)] = &[
    ("config.schema.json", CONFIG),
    ("tags.schema.json", TAGS),
    ("PORTCULLIS_portals.schema.json", PORTALS),
];

fn schema_value(s: Schema) -> Value {
    // The embedded schemas are ours and parsed by tests; failure is a build defect.
    let parse = |t: &str| serde_json::from_str::<Value>(t).expect("embedded schema is valid JSON");
    match s {
        Schema::Config => parse(CONFIG),
        Schema::Tags => parse(TAGS),
        Schema::Portals => parse(PORTALS),
        Schema::PortalsNode => {
            let root = parse(PORTALS);
            serde_json::json!({
                "$schema": "https://json-schema.org/draft/2020-12/schema",
                "$defs": root["$defs"].clone(),
                "$ref": "#/$defs/node"
            })
        }
        Schema::RuleSet => {
            let config = parse(CONFIG);
            serde_json::json!({
                "$schema": "https://json-schema.org/draft/2020-12/schema",
                "$defs": config["$defs"].clone(),
                "$ref": "#/$defs/ruleSet"
            })
        }
    }
}

/// Validates `instance`; returns one line per problem, `pointer: message`, empty when valid.
pub fn validate(schema: Schema, instance: &Value) -> Vec<String> {
    let validator =
        jsonschema::validator_for(&schema_value(schema)).expect("embedded schema compiles");
    validator
        .iter_errors(instance)
        .map(|e| {
            let path = e.instance_path().to_string();
            format!("{}: {e}", if path.is_empty() { "/" } else { path.as_str() })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn schemas_compile_and_judge() {
        for s in [
            Schema::Config,
            Schema::RuleSet,
            Schema::Tags,
            Schema::Portals,
            Schema::PortalsNode,
        ] {
            jsonschema::validator_for(&schema_value(s)).unwrap();
        }
        assert!(validate(
            Schema::Config,
            &serde_json::json!({"tags": {"preset": "godot"}})
        )
        .is_empty());
        let errs = validate(
            Schema::Config,
            &serde_json::json!({"tags": {"preset": "unreal"}}),
        );
        assert_eq!(errs.len(), 1);
        assert!(errs[0].starts_with("/tags/preset"), "{errs:?}");
        assert!(!validate(Schema::Config, &serde_json::json!({"tagz": {}})).is_empty());
        let rule_missing_pattern =
            serde_json::json!({"tags": {"rule": [{"id": "x", "kind": "room"}]}});
        assert!(!validate(Schema::Config, &rule_missing_pattern).is_empty());
        assert!(validate(
            Schema::Tags,
            &serde_json::json!({"room": "kitchen", "one_way": "yes"})
        )
        .is_empty());
        assert!(!validate(Schema::Tags, &serde_json::json!({"one_way": "maybe"})).is_empty());
    }
}
