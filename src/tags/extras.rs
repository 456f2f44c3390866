//! Reading tag values out of `extras` (glTF extras, USD custom data), where designers put
//! flat, Blender-custom-property-friendly keys. The keys are documented in
//! schemas/tags.schema.json.

use serde_json::Value;

/// What an extras key said.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum ExtrasValue {
    /// The key is absent or switched off (`false`, `0`, `"no"`, null).
    Off,
    /// The key is switched on without naming anything (`true`, `1`, `"1"`, `"yes"`).
    On,
    /// The key names something (a room, a target).
    Named(String),
    /// The key holds a value of a type that means nothing here.
    Invalid(ExtrasError),
}

/// Why an extras value cannot be read as what its key asks for; the value is kept to be named.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub(crate) enum ExtrasError {
    /// Neither a name nor a flag: a number other than 1 and 0, an array or an object.
    #[error("expected a name (a string) or a flag (true, false, 1, 0), found {0}")]
    NotANameOrFlag(Value),
    /// Neither a whole number nor a non-empty string, where an identifier is asked for.
    #[error("expected an identifier (a whole number or a string), found {0}")]
    NotAnId(Value),
}

/// Looks up a dotted key (`egg_scalars.portal`), also inside a `portcullis` object so that
/// tools which namespace their properties work too.
pub(crate) fn lookup<'a>(extras: &'a Value, key: &str) -> Option<&'a Value> {
    let direct = descend(extras, key);
    direct.or_else(|| extras.get("portcullis").and_then(|ns| descend(ns, key)))
}

fn descend<'a>(mut v: &'a Value, key: &str) -> Option<&'a Value> {
    for part in key.split('.') {
        v = v.as_object()?.get(part)?;
    }
    Some(v)
}

/// The value at `key` (dots descend into objects), read as a tag would use it.
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
        // 1 and 0 are flags (Panda3D's egg scalars write `portal=1`); any other number is
        // neither a flag nor a name (`"room": 5` is a slip for `"room": "5"` or true).
        Value::Number(n) => match n.as_f64() {
            Some(1.0) => ExtrasValue::On,
            Some(0.0) => ExtrasValue::Off,
            _ => ExtrasValue::Invalid(ExtrasError::NotANameOrFlag(v.clone())),
        },
        Value::String(s) => {
            let t = s.trim();
            match t.to_ascii_lowercase().as_str() {
                "" | "0" | "false" | "no" | "off" => ExtrasValue::Off,
                "1" | "true" | "yes" | "on" => ExtrasValue::On,
                _ => ExtrasValue::Named(t.to_string()),
            }
        }
        Value::Array(_) | Value::Object(_) => {
            ExtrasValue::Invalid(ExtrasError::NotANameOrFlag(v.clone()))
        }
    }
}

/// An identifier written into a rule's room template (`sector_${value}` of Doom's
/// `"doom_sector": 12`): a whole number or a non-empty string.
pub(crate) fn read_id(extras: Option<&Value>, key: &str) -> Result<Option<String>, ExtrasError> {
    match extras.and_then(|e| lookup(e, key)) {
        None | Some(Value::Null) => Ok(None),
        Some(Value::Number(n)) if n.is_i64() || n.is_u64() => Ok(Some(n.to_string())),
        Some(Value::String(s)) if !s.trim().is_empty() => Ok(Some(s.trim().to_string())),
        Some(v) => Err(ExtrasError::NotAnId(v.clone())),
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
pub(crate) fn read_bool(extras: Option<&Value>, key: &str) -> Option<bool> {
    match read(extras, key) {
        ExtrasValue::On => Some(true),
        ExtrasValue::Off => extras.and_then(|e| lookup(e, key)).map(|_| false),
        _ => None,
    }
}

/// A string attribute (`portal_kind`, `teleport_exit`, `source_room`).
pub(crate) fn read_string(extras: Option<&Value>, key: &str) -> Option<String> {
    match extras.and_then(|e| lookup(e, key)) {
        Some(Value::String(s)) if !s.trim().is_empty() => Some(s.trim().to_string()),
        _ => None,
    }
}

/// A number attribute (`priority`, `footprint_height`).
pub(crate) fn read_number(extras: Option<&Value>, key: &str) -> Option<f64> {
    match extras.and_then(|e| lookup(e, key))? {
        Value::Number(n) => n.as_f64(),
        Value::String(s) => s.trim().parse().ok(),
        _ => None,
    }
    .filter(|x: &f64| x.is_finite())
}

/// The attribute keys whose values have a type of their own, with what each value must be:
/// a value of another type is reported (`TAG_EXTRAS_INVALID`) rather than quietly read as
/// something else.
pub(crate) fn attribute_problems(extras: Option<&Value>) -> Vec<(&'static str, String)> {
    let mut out = Vec::new();
    let Some(e) = extras else { return out };
    for key in ["priority", "footprint_height"] {
        let Some(v) = lookup(e, key) else { continue };
        match (key, read_number(extras, key)) {
            ("priority", Some(p)) if p.fract() == 0.0 => {}
            ("footprint_height", Some(h)) if h > 0.0 => {}
            _ => out.push((
                key,
                format!(
                    "expected {}, found {v}",
                    if key == "priority" {
                        "a whole number"
                    } else {
                        "a positive number (a height in the level's units)"
                    }
                ),
            )),
        }
    }
    for key in ["one_way", "closed"] {
        if let Some(v) = lookup(e, key) {
            if !matches!(classify(v), ExtrasValue::On | ExtrasValue::Off) {
                out.push((
                    key,
                    format!("expected a flag (true, false, 1, 0), found {v}"),
                ));
            }
        }
    }
    for key in ["source_room", "teleport_exit"] {
        if let Some(v) = lookup(e, key) {
            if !matches!(v, Value::String(s) if !s.trim().is_empty()) {
                out.push((key, format!("expected a name (a string), found {v}")));
            }
        }
    }
    out
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
        let odd = json!({"room": 5, "id": 12, "name": " a "});
        assert!(matches!(read(Some(&odd), "room"), ExtrasValue::Invalid(_)));
        assert_eq!(read_id(Some(&odd), "id"), Ok(Some("12".into())));
        assert_eq!(read_id(Some(&odd), "name"), Ok(Some("a".into())));
        assert_eq!(
            read_id(Some(&e), "e").unwrap_err().to_string(),
            "expected an identifier (a whole number or a string), found [1]"
        );
        let typed = json!({"priority": "high", "footprint_height": -2, "closed": "maybe",
                           "source_room": 3, "one_way": 1});
        let keys: Vec<&str> = attribute_problems(Some(&typed))
            .iter()
            .map(|p| p.0)
            .collect();
        assert_eq!(
            keys,
            ["priority", "footprint_height", "closed", "source_room"]
        );
        let fine = json!({"priority": 2, "footprint_height": "2.5", "closed": "yes"});
        assert!(attribute_problems(Some(&fine)).is_empty());
        assert_eq!(read(Some(&e), "d"), ExtrasValue::On);
        assert_eq!(
            read(Some(&e), "e"),
            ExtrasValue::Invalid(ExtrasError::NotANameOrFlag(json!([1])))
        );
        assert_eq!(read(Some(&e), "egg_scalars.portal"), ExtrasValue::On);
        assert_eq!(read(Some(&e), "missing"), ExtrasValue::Off);
        assert_eq!(read_bool(Some(&e), "one_way"), Some(true));
        assert_eq!(read_bool(Some(&e), "c"), Some(false));
        assert_eq!(read_bool(Some(&e), "zzz"), None);
    }
}
