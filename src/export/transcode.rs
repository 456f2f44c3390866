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
pub struct Transcode<'a>(pub &'a str);

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
}
