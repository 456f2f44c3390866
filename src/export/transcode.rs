//! Serializing JSON text straight from its parser, without building a `Value` in between.
//!
//! Most of a big level's glTF JSON (accessors, meshes, buffer views) is written back unchanged;
//! parsing it into a `Value`, cloning that and dropping both cost more than the whole write. The
//! bytes are those the `Value` would serialize to: the same parser reads every number and
//! string, the same serializer writes them, in the same order. The one difference, a repeated
//! key (a `Value` keeps one), is refused so the caller can take the slow path; so is the key a
//! `Value` parser reads as a marker ([`json_text::RAW_VALUE_KEY`]).

use std::borrow::Cow;
use std::cell::RefCell;
use std::collections::HashSet;
use std::fmt;

use serde::de::{self, DeserializeSeed, Deserializer, MapAccess, SeqAccess, Visitor};
use serde::ser::{self, Serialize, SerializeMap, SerializeSeq, Serializer};

use crate::scene::json_text;

/// The error message of a repeated key.
const REPEATED: &str = "portcullis: repeated JSON key";

/// JSON text that serializes as the `Value` it parses to (see the module's note on keys).
pub(crate) struct Transcode<'a>(pub &'a str);

/// Appends what [`Transcode`] writes of `text` in compact form: `text` itself when it is
/// already that ([`is_compact_form`]), which is a byte scan instead of a parse and a write
/// of every value. A level written by a tool that writes compact JSON (ours, most
/// exporters' .glb) is copied nearly whole.
pub(crate) fn write_compact(text: &str, out: &mut Vec<u8>) -> serde_json::Result<()> {
    if is_compact_form(text) {
        out.extend_from_slice(text.as_bytes());
        Ok(())
    } else {
        serde_json::to_writer(out, &Transcode(text))
    }
}

/// Whether `text` is one JSON value exactly as its `Value` serializes, compact: no space
/// between tokens, strings without escapes, integers as a `Value` keeps them (within u64 or
/// i64, not `-0`), numbers with a fraction or exponent as the serializer writes the `f64`
/// the parser reads, no repeated key (nor the marker key) in an object. `false` when unsure:
/// the caller then transcodes, which decides.
pub(crate) fn is_compact_form(text: &str) -> bool {
    let b = text.as_bytes();
    matches!(Compact { b }.value(0, 0), Some(end) if end == b.len())
}

/// Keys of one object compared for repeats; objects with more are left to the parser.
const KEYS: usize = 16;

/// The scanner of [`is_compact_form`]: each step takes a position and returns the position
/// after what it read, `None` when the text is not in compact form there.
struct Compact<'a> {
    b: &'a [u8],
}

impl Compact<'_> {
    /// Under serde_json's nesting limit (128): deeper text is left to the parser.
    const DEPTH: usize = 100;

    fn value(&self, i: usize, depth: usize) -> Option<usize> {
        match *self.b.get(i)? {
            b'{' => self.object(i + 1, depth + 1),
            b'[' => self.array(i + 1, depth + 1),
            b'"' => self.string(i + 1),
            b't' => self.word(i, b"true"),
            b'f' => self.word(i, b"false"),
            b'n' => self.word(i, b"null"),
            b'-' | b'0'..=b'9' => self.number(i),
            _ => None,
        }
    }

    fn word(&self, i: usize, w: &[u8]) -> Option<usize> {
        (self.b.get(i..i + w.len())? == w).then_some(i + w.len())
    }

    /// A string from after its opening quote: no escape and no control character (those
    /// the serializer may write another way).
    fn string(&self, i: usize) -> Option<usize> {
        let rest = self.b.get(i..)?;
        let n = rest
            .iter()
            .position(|&c| c == b'"' || c == b'\\' || c < 0x20)?;
        (rest[n] == b'"').then_some(i + n + 1)
    }

    fn array(&self, mut i: usize, depth: usize) -> Option<usize> {
        if depth > Self::DEPTH {
            return None;
        }
        if self.b.get(i) == Some(&b']') {
            return Some(i + 1);
        }
        loop {
            i = self.value(i, depth)?;
            match *self.b.get(i)? {
                b',' => i += 1,
                b']' => return Some(i + 1),
                _ => return None,
            }
        }
    }

    fn object(&self, mut i: usize, depth: usize) -> Option<usize> {
        if depth > Self::DEPTH {
            return None;
        }
        if self.b.get(i) == Some(&b'}') {
            return Some(i + 1);
        }
        let mut keys: [&[u8]; KEYS] = [&[]; KEYS];
        let mut n = 0;
        loop {
            if self.b.get(i) != Some(&b'"') || n == KEYS {
                return None;
            }
            let end = self.string(i + 1)?;
            let key = &self.b[i + 1..end - 1];
            if key == json_text::RAW_VALUE_KEY.as_bytes() || keys[..n].contains(&key) {
                return None;
            }
            keys[n] = key;
            n += 1;
            if self.b.get(end) != Some(&b':') {
                return None;
            }
            i = self.value(end + 1, depth)?;
            match *self.b.get(i)? {
                b',' => i += 1,
                b'}' => return Some(i + 1),
                _ => return None,
            }
        }
    }

    fn number(&self, i: usize) -> Option<usize> {
        let len = self.b[i..]
            .iter()
            .position(|c| !matches!(c, b'-' | b'+' | b'.' | b'e' | b'E' | b'0'..=b'9'))
            .unwrap_or(self.b.len() - i);
        let t = std::str::from_utf8(&self.b[i..i + len]).ok()?;
        let digits = t.strip_prefix('-').unwrap_or(t);
        // JSON's grammar: no leading zero, a digit after the sign.
        let lead = digits.as_bytes();
        if lead.first().is_none_or(|c| !c.is_ascii_digit())
            || (lead[0] == b'0' && lead.get(1).is_some_and(u8::is_ascii_digit))
        {
            return None;
        }
        let kept = if digits.bytes().all(|c| c.is_ascii_digit()) {
            // An integer: a `Value` keeps it as u64 (positive) or i64 (negative, and not -0,
            // which becomes the float -0.0); beyond those it is a float.
            if t.starts_with('-') {
                t.parse::<i64>().is_ok_and(|v| v != 0)
            } else {
                t.parse::<u64>().is_ok()
            }
        } else {
            // A float: written back the same only if the serializer writes this very text
            // for the number the parser reads from it.
            let Ok(v) = serde_json::from_str::<f64>(t) else {
                return None;
            };
            let mut buf = Vec::with_capacity(32);
            serde_json::to_writer(&mut buf, &v).is_ok() && buf == t.as_bytes()
        };
        kept.then_some(i + len)
    }
}

impl Serialize for Transcode<'_> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut de = serde_json::Deserializer::from_str(self.0);
        de.deserialize_any(Out(s)).map_err(ser::Error::custom)
    }
}

/// A deserializer handed to a serializer: serializing it transcodes its one value.
struct Once<D>(RefCell<Option<D>>);

impl<'de, D: Deserializer<'de>> Serialize for Once<D> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let d = self
            .0
            .borrow_mut()
            .take()
            .ok_or_else(|| ser::Error::custom("a value serialized twice"))?;
        d.deserialize_any(Out(s)).map_err(ser::Error::custom)
    }
}

/// The visitor that writes what it visits to its serializer.
struct Out<S>(S);

impl<'de, S: Serializer> Visitor<'de> for Out<S> {
    type Value = S::Ok;

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("any JSON value")
    }
    fn visit_bool<E: de::Error>(self, v: bool) -> Result<S::Ok, E> {
        self.0.serialize_bool(v).map_err(E::custom)
    }
    fn visit_i64<E: de::Error>(self, v: i64) -> Result<S::Ok, E> {
        self.0.serialize_i64(v).map_err(E::custom)
    }
    fn visit_u64<E: de::Error>(self, v: u64) -> Result<S::Ok, E> {
        self.0.serialize_u64(v).map_err(E::custom)
    }
    fn visit_f64<E: de::Error>(self, v: f64) -> Result<S::Ok, E> {
        self.0.serialize_f64(v).map_err(E::custom)
    }
    fn visit_str<E: de::Error>(self, v: &str) -> Result<S::Ok, E> {
        self.0.serialize_str(v).map_err(E::custom)
    }
    fn visit_unit<E: de::Error>(self) -> Result<S::Ok, E> {
        self.0.serialize_unit().map_err(E::custom)
    }
    fn visit_none<E: de::Error>(self) -> Result<S::Ok, E> {
        self.0.serialize_unit().map_err(E::custom)
    }
    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<S::Ok, A::Error> {
        let mut out = self.0.serialize_seq(None).map_err(de::Error::custom)?;
        while seq.next_element_seed(Element(&mut out))?.is_some() {}
        out.end().map_err(de::Error::custom)
    }
    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<S::Ok, A::Error> {
        let mut out = self.0.serialize_map(None).map_err(de::Error::custom)?;
        let mut seen = Seen::default();
        while let Some(key) = map.next_key_seed(Key)? {
            out.serialize_key(&*key).map_err(de::Error::custom)?;
            if key == json_text::RAW_VALUE_KEY || !seen.insert(key) {
                return Err(de::Error::custom(REPEATED));
            }
            map.next_value_seed(Member(&mut out))?;
        }
        out.end().map_err(de::Error::custom)
    }
}

/// One element of an array, transcoded into the array being written.
pub(crate) struct Element<'a, S>(pub(crate) &'a mut S);

impl<'de, S: SerializeSeq> DeserializeSeed<'de> for Element<'_, S> {
    type Value = ();
    fn deserialize<D: Deserializer<'de>>(self, d: D) -> Result<(), D::Error> {
        self.0
            .serialize_element(&Once(RefCell::new(Some(d))))
            .map_err(de::Error::custom)
    }
}

/// One member's value, transcoded into the object being written.
struct Member<'a, S>(&'a mut S);

impl<'de, S: SerializeMap> DeserializeSeed<'de> for Member<'_, S> {
    type Value = ();
    fn deserialize<D: Deserializer<'de>>(self, d: D) -> Result<(), D::Error> {
        self.0
            .serialize_value(&Once(RefCell::new(Some(d))))
            .map_err(de::Error::custom)
    }
}

/// A key, borrowed from the text unless it holds escapes.
struct Key;

impl<'de> DeserializeSeed<'de> for Key {
    type Value = Cow<'de, str>;
    fn deserialize<D: Deserializer<'de>>(self, d: D) -> Result<Self::Value, D::Error> {
        d.deserialize_str(KeyVisitor)
    }
}

struct KeyVisitor;

impl<'de> Visitor<'de> for KeyVisitor {
    type Value = Cow<'de, str>;
    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("a string key")
    }
    fn visit_borrowed_str<E: de::Error>(self, v: &'de str) -> Result<Self::Value, E> {
        Ok(Cow::Borrowed(v))
    }
    fn visit_str<E: de::Error>(self, v: &str) -> Result<Self::Value, E> {
        Ok(Cow::Owned(v.to_string()))
    }
}

/// The keys of one object so far: a list while short (most glTF objects have a handful of
/// keys), a set beyond.
#[derive(Default)]
struct Seen<'de> {
    list: Vec<Cow<'de, str>>,
    set: HashSet<Cow<'de, str>>,
}

impl<'de> Seen<'de> {
    const LIST: usize = 16;

    /// False if `key` was seen before.
    fn insert(&mut self, key: Cow<'de, str>) -> bool {
        if self.list.len() < Self::LIST {
            if self.list.contains(&key) {
                return false;
            }
            self.list.push(key);
            return true;
        }
        if self.set.is_empty() {
            self.set.extend(self.list.iter().cloned());
        }
        self.set.insert(key)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::SplitMix64;

    fn is_repeated(e: &serde_json::Error) -> bool {
        e.to_string().contains(REPEATED)
    }

    fn both(text: &str) -> (Vec<u8>, Vec<u8>) {
        let v: serde_json::Value = serde_json::from_str(text).unwrap();
        let a = serde_json::to_vec(&v).unwrap();
        let b = serde_json::to_vec(&Transcode(text)).unwrap();
        (a, b)
    }

    #[test]
    fn same_bytes_as_a_value() {
        let text = r#" { "b": [1, -0, -0.0, 1e300, 1.5e-7, 18446744073709551615, -9223372036854775808,
            12345678901234567890123, 0.1, 3.0],
            "a": {"x\u00e9\n\"": null, "y": true, "z": false, "": ""},
            "e": [], "o": {}, "s": "tab\t \ud83d\ude00 \u0001 /" } "#;
        let (a, b) = both(text);
        assert_eq!(String::from_utf8(a).unwrap(), String::from_utf8(b).unwrap());
        let v: serde_json::Value = serde_json::from_str(text).unwrap();
        let a = serde_json::to_vec_pretty(&v).unwrap();
        let b = serde_json::to_vec_pretty(&Transcode(text)).unwrap();
        assert_eq!(String::from_utf8(a).unwrap(), String::from_utf8(b).unwrap());
    }

    #[test]
    fn repeated_keys_are_refused() {
        let e = serde_json::to_vec(&Transcode(r#"{"a": [{"k": 1, "j": 2, "k": 3}]}"#)).unwrap_err();
        assert!(is_repeated(&e), "{e}");
        let many: Vec<String> = (0..40).map(|i| format!("\"k{i}\": {i}")).collect();
        let text = format!("{{{}, \"k39\": 0}}", many.join(","));
        assert!(is_repeated(
            &serde_json::to_vec(&Transcode(&text)).unwrap_err()
        ));
        let text = format!("{{{}}}", many.join(","));
        let (a, b) = both(&text);
        assert_eq!(a, b);
    }

    /// A random JSON text from tokens that are and are not in compact form.
    fn random_text(rng: &mut SplitMix64, depth: usize) -> String {
        const ATOMS: &[&str] = &[
            "0",
            "7",
            "-3",
            "-0",
            "1.0",
            "1.50",
            "-0.0",
            "0.1",
            "3.375",
            "1e5",
            "1E5",
            "1e+5",
            "2.5e-7",
            "1e300",
            "5e-324",
            "1.7976931348623157e308",
            "18446744073709551615",
            "18446744073709551616",
            "-9223372036854775808",
            "-9223372036854775809",
            "123456789012345678901",
            "true",
            "false",
            "null",
            "\"\"",
            "\"abc\"",
            "\"a\\nb\"",
            "\"\u{e9}/\"",
            "\"\\u00e9\"",
            "\"\\/\"",
        ];
        const KEYS: &[&str] = &["a", "b", "c", "é", "$serde_json::private::RawValue", "a\\n"];
        let space = |rng: &mut SplitMix64| if rng.below(8) == 0 { " " } else { "" };
        match if depth > 3 { 0 } else { rng.below(4) } {
            0 | 1 => ATOMS[rng.below(ATOMS.len())].to_string(),
            2 => {
                let n = rng.below(4);
                let items: Vec<String> = (0..n).map(|_| random_text(rng, depth + 1)).collect();
                format!(
                    "[{}{}]",
                    items.join(if rng.below(6) == 0 { ", " } else { "," }),
                    space(rng)
                )
            }
            _ => {
                let n = if rng.below(10) == 0 {
                    17 + rng.below(3)
                } else {
                    rng.below(4)
                };
                let items: Vec<String> = (0..n)
                    .map(|k| {
                        let key = if n > 16 {
                            format!("k{k}")
                        } else {
                            KEYS[rng.below(KEYS.len())].to_string()
                        };
                        let sep = if rng.below(8) == 0 { ": " } else { ":" };
                        format!("\"{key}\"{sep}{}", random_text(rng, depth + 1))
                    })
                    .collect();
                format!("{}{{{}}}", space(rng), items.join(","))
            }
        }
    }

    /// Text taken as already in compact form is what its `Value` writes, to the byte; what
    /// is not is transcoded, and `write_compact` writes what the transcoder writes. Compact
    /// text without escapes is taken as it is (so the fast path is not dead).
    #[test]
    fn compact_form_is_what_a_value_writes() {
        let mut rng = SplitMix64::new(5);
        let (mut taken, mut written) = (0, 0);
        for _ in 0..20_000 {
            let text = random_text(&mut rng, 0);
            let Ok(v) = serde_json::from_str::<serde_json::Value>(&text) else {
                continue;
            };
            let want = serde_json::to_string(&v).unwrap();
            let mut got = Vec::new();
            match write_compact(&text, &mut got) {
                Ok(()) => assert_eq!(String::from_utf8(got).unwrap(), want, "{text}"),
                Err(e) => {
                    assert!(is_repeated(&e), "{text}: {e}");
                    assert!(!is_compact_form(&text), "{text}");
                    continue;
                }
            }
            if is_compact_form(&text) {
                taken += 1;
                assert_eq!(text, want);
            }
            if is_compact_form(&want) {
                written += 1;
            } else {
                // Only an escape, a long object or the marker key sends written text back.
                assert!(
                    want.contains('\\') || want.contains("\"k16\"") || want.contains('$'),
                    "{want}"
                );
            }
        }
        assert!(
            taken > 1000 && written > 5000,
            "{taken} taken, {written} written"
        );
    }

    #[test]
    fn numbers_in_compact_form() {
        for (t, compact) in [
            ("0", true),
            ("-0", false),
            ("-1", true),
            ("1.0", true),
            ("1.00", false),
            ("1e5", false),
            ("100000.0", true),
            ("0.1", true),
            ("3.375", true),
            ("18446744073709551615", true),
            ("18446744073709551616", false),
            ("-9223372036854775808", true),
            ("-9223372036854775809", false),
            ("[1,2]", true),
            ("[1, 2]", false),
            (r#"{"a":1,"a":2}"#, false),
            (r#"{"a":"x\ny"}"#, false),
        ] {
            assert_eq!(is_compact_form(t), compact, "{t}");
        }
    }
}
