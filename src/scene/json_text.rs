//! Reading parts of a JSON text without parsing all of it into a `Value`: a big level's glTF
//! JSON is tens of megabytes, and most of it (accessors, buffer views) is only ever copied.

use std::collections::HashMap;
use std::fmt;

use serde::de::{DeserializeSeed, Deserializer, IgnoredAny, MapAccess, SeqAccess, Visitor};
use serde_json::value::RawValue;

/// The members of the object `text`, in order, each as its text. A repeated key keeps its first
/// place and its last value, as `serde_json::Map` (an `IndexMap`) does. `None` if `text` is not
/// an object.
pub fn members(text: &str) -> Option<Vec<(String, &RawValue)>> {
    struct Members;
    impl<'de> Visitor<'de> for Members {
        type Value = Vec<(String, &'de RawValue)>;
        fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
            f.write_str("a JSON object")
        }
        fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<Self::Value, A::Error> {
            let mut out: Vec<(String, &'de RawValue)> = Vec::new();
            let mut at: HashMap<String, usize> = HashMap::new();
            while let Some(key) = map.next_key::<String>()? {
                let value: &'de RawValue = map.next_value()?;
                match at.get(&key) {
                    Some(&i) => out[i].1 = value,
                    None => {
                        at.insert(key.clone(), out.len());
                        out.push((key, value));
                    }
                }
            }
            Ok(out)
        }
    }
    serde_json::Deserializer::from_str(text)
        .deserialize_map(Members)
        .ok()
}

/// A key serde_json's `Value` parser does not keep as a key (it marks a raw value): a text
/// holding it is left to that parser.
pub(crate) const RAW_VALUE_KEY: &str = "$serde_json::private::RawValue";

/// Checks that `bytes` hold one JSON value as parsing them into a `Value` would, with the same
/// error at the same place (same parser, same order), without building it. An `Err` whose
/// message names [`RAW_VALUE_KEY`] means: parse into a `Value` to know.
pub fn check(bytes: &[u8]) -> Result<(), serde_json::Error> {
    let mut de = serde_json::Deserializer::from_slice(bytes);
    de.deserialize_any(Walk)?;
    de.end()
}

struct Walk;

impl<'de> Visitor<'de> for Walk {
    type Value = ();
    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("any JSON value")
    }
    fn visit_bool<E>(self, _: bool) -> Result<(), E> {
        Ok(())
    }
    fn visit_i64<E>(self, _: i64) -> Result<(), E> {
        Ok(())
    }
    fn visit_u64<E>(self, _: u64) -> Result<(), E> {
        Ok(())
    }
    fn visit_f64<E>(self, _: f64) -> Result<(), E> {
        Ok(())
    }
    fn visit_str<E>(self, _: &str) -> Result<(), E> {
        Ok(())
    }
    fn visit_unit<E>(self) -> Result<(), E> {
        Ok(())
    }
    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<(), A::Error> {
        while seq.next_element_seed(WalkSeed)?.is_some() {}
        Ok(())
    }
    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<(), A::Error> {
        while let Some(raw_value_key) = map.next_key_seed(IsRawValueKey)? {
            if raw_value_key {
                return Err(serde::de::Error::custom(RAW_VALUE_KEY));
            }
            map.next_value_seed(WalkSeed)?;
        }
        Ok(())
    }
}

struct WalkSeed;

impl<'de> DeserializeSeed<'de> for WalkSeed {
    type Value = ();
    fn deserialize<D: Deserializer<'de>>(self, d: D) -> Result<(), D::Error> {
        d.deserialize_any(Walk)
    }
}

/// Reads a key (as a `Value` does: a string, escapes checked) and says if it is
/// [`RAW_VALUE_KEY`].
pub(crate) struct IsRawValueKey;

impl<'de> DeserializeSeed<'de> for IsRawValueKey {
    type Value = bool;
    fn deserialize<D: Deserializer<'de>>(self, d: D) -> Result<bool, D::Error> {
        d.deserialize_str(self)
    }
}

impl<'de> Visitor<'de> for IsRawValueKey {
    type Value = bool;
    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("a string key")
    }
    fn visit_str<E>(self, v: &str) -> Result<bool, E> {
        Ok(v == RAW_VALUE_KEY)
    }
}

/// Whether `text` is a JSON array (a member's text has no surrounding whitespace).
pub(crate) fn is_array(text: &str) -> bool {
    text.trim_start().starts_with('[')
}

/// The number of elements of the array `text`; `None` if it is not an array.
pub(crate) fn array_len(text: &str) -> Option<usize> {
    struct Count;
    impl<'de> Visitor<'de> for Count {
        type Value = usize;
        fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
            f.write_str("a JSON array")
        }
        fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<usize, A::Error> {
            let mut n = 0;
            while seq.next_element::<IgnoredAny>()?.is_some() {
                n += 1;
            }
            Ok(n)
        }
    }
    serde_json::Deserializer::from_str(text)
        .deserialize_seq(Count)
        .ok()
}

/// The elements of a JSON array's text, each as its own text, taken a run at a time: what the
/// parallel writer hands out as work without parsing the array first. The text must be valid
/// JSON (every text here was checked on import); on anything else the elements found are
/// meaningless but the scan still ends.
pub(crate) struct Elements<'a> {
    text: &'a str,
    /// Where the next element (or the closing bracket) starts looking from.
    pos: usize,
    /// Elements handed out so far.
    pub count: usize,
}

impl<'a> Elements<'a> {
    /// The elements of `array`; `None` if it is not an array.
    pub(crate) fn of(array: &'a str) -> Option<Elements<'a>> {
        let start = array.len() - array.trim_start().len();
        (array.as_bytes().get(start) == Some(&b'[')).then_some(Elements {
            text: array,
            pos: start + 1,
            count: 0,
        })
    }

    /// The next elements, at least one and about `bytes` of text, as the text running from
    /// the first's start to the last's end (commas and whitespace between them included), and
    /// how many there are; `None` once the array is done.
    pub fn run(&mut self, bytes: usize) -> Option<(&'a str, usize)> {
        let b = self.text.as_bytes();
        let mut start = None;
        let mut end = self.pos;
        let mut n = 0;
        loop {
            let i = skip_space(b, self.pos);
            match b.get(i) {
                None | Some(b']') => {
                    self.pos = b.len();
                    break;
                }
                Some(b',') => {
                    self.pos = i + 1;
                    continue;
                }
                Some(_) => {}
            }
            let s = *start.get_or_insert(i);
            end = skip_value(b, i);
            self.pos = end;
            n += 1;
            if end - s >= bytes {
                break;
            }
        }
        self.count += n;
        start.map(|s| (&self.text[s..end], n))
    }
}

/// Each element's text in a run of elements from [`Elements::run`].
pub(crate) fn split_run(run: &str) -> impl Iterator<Item = &str> {
    let b = run.as_bytes();
    let mut pos = 0;
    std::iter::from_fn(move || {
        let i = skip_space(b, pos);
        let i = if b.get(i) == Some(&b',') {
            skip_space(b, i + 1)
        } else {
            i
        };
        if i >= b.len() {
            return None;
        }
        pos = skip_value(b, i);
        Some(&run[i..pos])
    })
}

fn skip_space(b: &[u8], mut i: usize) -> usize {
    while i < b.len() && matches!(b[i], b' ' | b'\t' | b'\n' | b'\r') {
        i += 1;
    }
    i
}

/// The end of the value starting at `i` (valid JSON assumed): strings to their closing quote,
/// objects and arrays to their matching bracket, anything else to the next delimiter.
fn skip_value(b: &[u8], i: usize) -> usize {
    let string_end = |mut j: usize| {
        while j < b.len() {
            match b[j] {
                b'"' => return j + 1,
                b'\\' => j += 2,
                _ => j += 1,
            }
        }
        b.len()
    };
    match b.get(i) {
        Some(b'"') => string_end(i + 1),
        Some(b'{' | b'[') => {
            let mut depth = 0usize;
            let mut j = i;
            while j < b.len() {
                match b[j] {
                    b'"' => {
                        j = string_end(j + 1);
                        continue;
                    }
                    b'{' | b'[' => depth += 1,
                    b'}' | b']' => {
                        depth -= 1;
                        if depth == 0 {
                            return j + 1;
                        }
                    }
                    _ => {}
                }
                j += 1;
            }
            b.len()
        }
        _ => {
            let mut j = i;
            while j < b.len() && !matches!(b[j], b',' | b']' | b'}' | b' ' | b'\t' | b'\n' | b'\r')
            {
                j += 1;
            }
            j.max(i + 1).min(b.len())
        }
    }
}

/// Each glTF node's name (`None` where a node has no string name, or is not an object).
pub(crate) fn node_names(src: &super::GltfSource) -> Vec<Option<String>> {
    let Ok(Some(members)) = src.members() else {
        return Vec::new();
    };
    let Some((_, nodes)) = members.iter().find(|(k, _)| k == "nodes") else {
        return Vec::new();
    };
    let nodes: Vec<&RawValue> = serde_json::from_str(nodes).unwrap_or_default();
    nodes
        .iter()
        .map(|n| {
            let node: serde_json::Value = serde_json::from_str(n.get()).ok()?;
            node.get("name")?.as_str().map(str::to_string)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Runs of any size cover every element once, in order, each exactly as a parser reads it:
    /// strings holding brackets, commas, quotes and backslashes, nesting, numbers, whitespace.
    #[test]
    fn element_runs_are_the_elements() {
        let text = r#" [ {"a": "x]\\\",}[", "b": [1, [2, {}]]} , "s\"]" ,-1.5e3,true ,null,[],
            {"c":{"d":"}}"}} ,0 ] "#;
        let want: Vec<&RawValue> = serde_json::from_str(text).unwrap();
        for size in [0, 1, 7, 40, 1000] {
            let mut e = Elements::of(text).unwrap();
            let mut got = Vec::new();
            while let Some((run, n)) = e.run(size) {
                let items: Vec<&str> = split_run(run).collect();
                assert_eq!(items.len(), n, "size {size}: {run:?}");
                got.extend(items);
            }
            assert_eq!(e.count, want.len());
            let want: Vec<&str> = want.iter().map(|r| r.get()).collect();
            assert_eq!(got, want, "size {size}");
        }
        assert!(Elements::of(r#"{"a": 1}"#).is_none());
        assert_eq!(Elements::of(" [ ] ").unwrap().run(10), None);
    }

    #[test]
    fn members_keep_first_place_and_last_value() {
        let m = members(r#"{"a": 1, "b": [2, 3], "a": {"x": 4}}"#).unwrap();
        let got: Vec<(&str, &str)> = m.iter().map(|(k, v)| (k.as_str(), v.get())).collect();
        assert_eq!(got, vec![("a", r#"{"x": 4}"#), ("b", "[2, 3]")]);
        let v: serde_json::Value =
            serde_json::from_str(r#"{"a": 1, "b": [2, 3], "a": {"x": 4}}"#).unwrap();
        let keys: Vec<&String> = v.as_object().unwrap().keys().collect();
        assert_eq!(keys, vec!["a", "b"]);
        assert!(members("[1]").is_none());
    }

    #[test]
    fn check_fails_where_a_value_parse_fails() {
        let cases: [&[u8]; 12] = [
            br#"{"a": [1, 2,]}"#,
            br#"{"a": 1e400}"#,
            br#"{"a": "\ud800"}"#,
            b"{\"a\": \"\xff\"}",
            br#"{"a": 1} x"#,
            br#"{"a" 1}"#,
            br#"{"\q": 1}"#,
            br#"[1, {"b": tru}]"#,
            br#"{"a": "x
"}"#,
            br#"  {"a": [{}, [], null, true, -0, 1.5e3, "\u00e9"]}  "#,
            br#"{"a": 1, "a": 2}"#,
            br#""#,
        ];
        for bytes in cases {
            let want =
                serde_json::from_slice::<serde_json::Value>(bytes).map_err(|e| e.to_string());
            let got = check(bytes).map_err(|e| e.to_string());
            assert_eq!(want.map(|_| ()), got, "{}", String::from_utf8_lossy(bytes));
        }
        let deep = format!("{}{}", "[".repeat(200), "]".repeat(200));
        assert_eq!(
            serde_json::from_str::<serde_json::Value>(&deep)
                .map(|_| ())
                .map_err(|e| e.to_string()),
            check(deep.as_bytes()).map_err(|e| e.to_string())
        );
        let e = check(br#"{"a": {"$serde_json::private::RawValue": "1"}}"#).unwrap_err();
        assert!(e.to_string().contains(RAW_VALUE_KEY));
    }

    #[test]
    fn arrays_are_counted() {
        let m = members(r#"{"a": [ {"b": [1,2]}, 3, "x" ], "o": {}}"#).unwrap();
        assert!(is_array(m[0].1.get()));
        assert_eq!(array_len(m[0].1.get()), Some(3));
        assert!(!is_array(m[1].1.get()));
        assert_eq!(array_len(m[1].1.get()), None);
    }
}
