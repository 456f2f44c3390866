//! Reading tag values out of `extras` (glTF extras, USD custom data), where designers put
//! flat, Blender-custom-property-friendly keys. The keys are documented in
//! schemas/tags.schema.json.

use serde_json::Value;

/// What an extras key said.
#[derive(Debug, Clone, PartialEq)]
pub enum ExtrasValue {
    /// The key is absent or switched off (`false`, `0`, `"no"`, null).
    Off,
    /// The key is switched on without naming anything (`true`, `1`, `"1"`, `"yes"`).
    On,
    /// The key names something (a room, a target).
    Named(String),
    /// The key holds a value of a type that means nothing here.
    Invalid(String),
}

/// Looks up a dotted key (`egg_scalars.portal`), also inside a `portcullis` object so that
/// tools which namespace their properties work too.
pub fn lookup<'a>(extras: &'a Value, key: &str) -> Option<&'a Value> {
    let direct = descend(extras, key);
    direct.or_else(|| extras.get("portcullis").and_then(|ns| descend(ns, key)))
}

fn descend<'a>(mut v: &'a Value, key: &str) -> Option<&'a Value> {
    for part in key.split('.') {
        v = v.as_object()?.get(part)?;
    }
    Some(v)
}

pub fn read(extras: Option<&Value>, key: &str) -> ExtrasValue {
    let Some(v) = extras.and_then(|e| lookup(e, key)) else {
        return ExtrasValue::Off;
    };
    classify(v)
}

fn classify(v: &Value) -> ExtrasValue {
    match v {
        Value::Null => ExtrasValue::Off,
        Value::Bool(b) => flag(*b),
        Value::Number(n) => flag(n.as_f64().is_some_and(|x| x != 0.0)),
        Value::String(s) => {
            let t = s.trim();
            match t.to_ascii_lowercase().as_str() {
                "" | "0" | "false" | "no" | "off" => ExtrasValue::Off,
                "1" | "true" | "yes" | "on" => ExtrasValue::On,
                _ => ExtrasValue::Named(t.to_string()),
            }
        }
        Value::Array(_) | Value::Object(_) => {
            ExtrasValue::Invalid(format!("expected a string or a boolean, found {v}"))
        }
    }
}

fn flag(b: bool) -> ExtrasValue {
    if b {
        ExtrasValue::On
    } else {
        ExtrasValue::Off
    }
}

/// A boolean attribute (`one_way`, `closed`): `None` when absent.
pub fn read_bool(extras: Option<&Value>, key: &str) -> Option<bool> {
    match read(extras, key) {
        ExtrasValue::On => Some(true),
        ExtrasValue::Off => extras.and_then(|e| lookup(e, key)).map(|_| false),
        _ => None,
    }
}

/// A string attribute (`portal_kind`, `teleport_exit`, `source_room`).
pub fn read_string(extras: Option<&Value>, key: &str) -> Option<String> {
    match extras.and_then(|e| lookup(e, key)) {
        Some(Value::String(s)) if !s.trim().is_empty() => Some(s.trim().to_string()),
        _ => None,
    }
}

/// A number attribute (`priority`, `footprint_height`).
pub fn read_number(extras: Option<&Value>, key: &str) -> Option<f64> {
    match extras.and_then(|e| lookup(e, key))? {
        Value::Number(n) => n.as_f64(),
        Value::String(s) => s.trim().parse().ok(),
        _ => None,
    }
    .filter(|x: &f64| x.is_finite())
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn values_classify_as_designers_write_them() {
        let e = json!({"a": true, "b": "kitchen", "c": 0, "d": "1", "e": [1], "egg_scalars": {"portal": "1"},
                       "portcullis": {"one_way": true}});
        assert_eq!(read(Some(&e), "a"), ExtrasValue::On);
        assert_eq!(read(Some(&e), "b"), ExtrasValue::Named("kitchen".into()));
        assert_eq!(read(Some(&e), "c"), ExtrasValue::Off);
        assert_eq!(read(Some(&e), "d"), ExtrasValue::On);
        assert!(matches!(read(Some(&e), "e"), ExtrasValue::Invalid(_)));
        assert_eq!(read(Some(&e), "egg_scalars.portal"), ExtrasValue::On);
        assert_eq!(read(Some(&e), "missing"), ExtrasValue::Off);
        assert_eq!(read_bool(Some(&e), "one_way"), Some(true));
        assert_eq!(read_bool(Some(&e), "c"), Some(false));
        assert_eq!(read_bool(Some(&e), "zzz"), None);
    }
}
