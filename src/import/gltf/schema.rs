//! The few parts of the glTF schema the importer reads, as lenient serde structs.
//!
//! gltf-json's own validation rejects files we can read (KHR_mesh_quantization positions, unknown
//! required extensions we want to name ourselves), so the document is split into its root
//! members ([`Root`]) and each object is deserialized on its own: a malformed item is then
//! reported with its JSON pointer instead of one error for the whole file. Required fields are
//! `Option`s so their absence is reported by whoever needs them, with the pointer to the field.

use serde::de::DeserializeOwned;
use serde::Deserialize;
use serde_json::value::RawValue;
use serde_json::{Map, Value};

use super::Ctx;
use crate::diag::{Code, Diagnostic};
use crate::scene::json_text;

#[derive(Debug, Default, Deserialize)]
#[serde(default, rename_all = "camelCase")]
pub(crate) struct Asset {
    pub version: Option<String>,
}

#[derive(Debug, Default, Deserialize)]
#[serde(default, rename_all = "camelCase")]
pub(crate) struct SceneDef {
    pub nodes: Vec<u64>,
}

#[derive(Debug, Default, Deserialize)]
#[serde(default, rename_all = "camelCase")]
pub struct Node {
    pub name: Option<String>,
    pub children: Vec<u64>,
    pub mesh: Option<u64>,
    pub matrix: Option<Vec<f64>>,
    pub translation: Option<Vec<f64>>,
    pub rotation: Option<Vec<f64>>,
    pub scale: Option<Vec<f64>>,
    pub extras: Option<Value>,
    pub extensions: Option<Map<String, Value>>,
}

#[derive(Debug, Default, Deserialize)]
#[serde(default, rename_all = "camelCase")]
pub struct Mesh {
    pub name: Option<String>,
    pub primitives: Option<Vec<Primitive>>,
    pub extras: Option<Value>,
}

#[derive(Debug, Default, Deserialize)]
#[serde(default, rename_all = "camelCase")]
pub struct Primitive {
    pub attributes: Option<Attributes>,
    pub indices: Option<u64>,
    pub material: Option<u64>,
    pub mode: Option<u64>,
}

#[derive(Debug, Default, Deserialize)]
#[serde(default, rename_all = "camelCase")]
pub(crate) struct Accessor {
    pub buffer_view: Option<u64>,
    pub byte_offset: u64,
    pub component_type: Option<u64>,
    pub normalized: bool,
    pub count: Option<u64>,
    #[serde(rename = "type")]
    pub kind: Option<String>,
    /// Boxed: rare, and five times the size of the rest (a big level has 100 000 accessors).
    pub sparse: Option<Box<Sparse>>,
}

#[derive(Debug, Default, Deserialize)]
#[serde(default, rename_all = "camelCase")]
pub(crate) struct Sparse {
    pub count: Option<u64>,
    pub indices: Option<SparseIndices>,
    pub values: Option<SparseValues>,
}

#[derive(Debug, Default, Deserialize)]
#[serde(default, rename_all = "camelCase")]
pub(crate) struct SparseIndices {
    pub buffer_view: Option<u64>,
    pub byte_offset: u64,
    pub component_type: Option<u64>,
}

#[derive(Debug, Default, Deserialize)]
#[serde(default, rename_all = "camelCase")]
pub(crate) struct SparseValues {
    pub buffer_view: Option<u64>,
    pub byte_offset: u64,
}

#[derive(Debug, Default, Deserialize)]
#[serde(default, rename_all = "camelCase")]
pub(crate) struct BufferView {
    pub buffer: Option<u64>,
    pub byte_offset: u64,
    pub byte_length: Option<u64>,
    pub byte_stride: Option<u64>,
}

#[derive(Debug, Default, Deserialize)]
#[serde(default, rename_all = "camelCase")]
pub(crate) struct Buffer {
    pub uri: Option<String>,
    pub byte_length: Option<u64>,
}

#[derive(Debug, Default, Deserialize)]
#[serde(default, rename_all = "camelCase")]
pub struct Material {
    pub name: Option<String>,
    pub extras: Option<Value>,
    pub double_sided: bool,
}

/// The typed view of the document the importer works from.
#[derive(Debug, Default)]
pub struct Doc {
    pub scene: Option<u64>,
    /// The `tags` of a portcullis annotation in the root's extensions.
    pub stored_tags: Option<String>,
    /// What that annotation appended: the PVS's buffer view, the split indices' accessor.
    pub stored_appended: (Option<u64>, Option<u64>),
    pub scenes: Vec<SceneDef>,
    pub nodes: Vec<Node>,
    pub meshes: Vec<Mesh>,
    pub accessors: Vec<Accessor>,
    pub buffer_views: Vec<BufferView>,
    pub buffers: Vec<Buffer>,
    pub materials: Vec<Material>,
    /// The nodes `convert --split-by-cell` wrote as parts of another, ascending: left out,
    /// their node read with the mesh it gave up to them ([`Doc::restore_parts`]).
    pub parts: Vec<usize>,
}

/// The document's root members, each still text: the importer parses only what it reads, one
/// item at a time.
pub struct Root<'a> {
    members: Vec<(String, &'a RawValue)>,
}

impl<'a> Root<'a> {
    /// `None` if the document is not an object.
    pub fn new(text: &'a str) -> Option<Root<'a>> {
        json_text::members(text).map(|members| Root { members })
    }

    /// The members as byte ranges of `text`, the text they were read from.
    pub(crate) fn ranges(&self, text: &str) -> Vec<(String, std::ops::Range<usize>)> {
        self.members
            .iter()
            .map(|(k, v)| {
                let start = v.get().as_ptr() as usize - text.as_ptr() as usize;
                (k.clone(), start..start + v.get().len())
            })
            .collect()
    }

    fn get(&self, key: &str) -> Option<&'a RawValue> {
        self.members.iter().find(|(k, _)| k == key).map(|(_, v)| *v)
    }

    /// A member parsed (the text was checked to parse).
    pub(crate) fn value(&self, key: &str) -> Option<Value> {
        Some(serde_json::from_str(self.get(key)?.get()).unwrap_or_default())
    }
}

impl Doc {
    pub(crate) fn from_root(ctx: &Ctx, root: &Root) -> Result<Doc, Diagnostic> {
        let scene = match root.value("scene") {
            None => None,
            Some(v) => Some(v.as_u64().ok_or_else(|| {
                ctx.diag(
                    Code::GLTF_INVALID_JSON,
                    "/scene",
                    format!("`scene` must be a non-negative integer, found {v}"),
                )
            })?),
        };
        // The big arrays are read on two threads (a big level has a hundred thousand nodes,
        // accessors and buffer views); the first problem in the order below is reported.
        let ((scenes, nodes), ((meshes, accessors), buffer_views)) = rayon::join(
            || (array(ctx, root, "scenes"), array(ctx, root, "nodes")),
            || {
                rayon::join(
                    || {
                        rayon::join(
                            || array(ctx, root, "meshes"),
                            || array(ctx, root, "accessors"),
                        )
                    },
                    || array(ctx, root, "bufferViews"),
                )
            },
        );
        let stored = stored(root);
        Ok(Doc {
            scene,
            stored_tags: stored.0,
            stored_appended: stored.1,
            scenes: scenes?,
            nodes: nodes?,
            meshes: meshes?,
            accessors: accessors?,
            buffer_views: buffer_views?,
            buffers: array(ctx, root, "buffers")?,
            materials: array(ctx, root, "materials")?,
            parts: Vec::new(),
        }
        .restore_parts())
    }

    /// The level as it was before `convert --split-by-cell` wrote the nodes that reach into
    /// several cells as parts: each such node (no mesh, our `{mesh, parts}` object) has its
    /// mesh again and its parts are no children of it, so everything read from the file (the
    /// cells, the verdicts, the input hash) is the source's.
    fn restore_parts(mut self) -> Doc {
        #[derive(Deserialize)]
        struct Given {
            mesh: u64,
            parts: Vec<u64>,
        }
        for node in &mut self.nodes {
            let ours = (node.extensions.as_ref()).and_then(|e| e.get(crate::format::NAME));
            let Some(given) = ours.and_then(|v| Given::deserialize(v).ok()) else {
                continue;
            };
            if node.mesh.is_some() {
                continue;
            }
            node.mesh = Some(given.mesh);
            node.children.retain(|c| !given.parts.contains(c));
            (self.parts).extend(given.parts.iter().filter_map(|&p| usize::try_from(p).ok()));
        }
        self.parts.sort_unstable();
        self.parts.dedup();
        self
    }
}

/// The `tags` of the root's `PORTCULLIS_portals`, and the buffer view of its `visibility` and
/// the accessor of its `split` indices, read past everything else in the extension without
/// building it (a big level's annotation is most of its JSON).
type Stored = (Option<String>, (Option<u64>, Option<u64>));

fn stored(root: &Root) -> Stored {
    #[derive(Deserialize)]
    struct Extensions {
        #[serde(rename = "PORTCULLIS_portals")]
        portals: Option<Annotation>,
    }
    #[derive(Deserialize)]
    struct Annotation {
        tags: Option<String>,
        visibility: Option<Pointing>,
        split: Option<Split>,
    }
    #[derive(Deserialize)]
    struct Pointing {
        #[serde(rename = "bufferView")]
        buffer_view: Option<u64>,
    }
    #[derive(Deserialize)]
    struct Split {
        indices: Option<u64>,
    }
    let Some(ext) = root.get("extensions") else {
        return Default::default();
    };
    let Ok(Extensions { portals: Some(a) }) = serde_json::from_str(ext.get()) else {
        return Default::default();
    };
    let view = a.visibility.and_then(|v| v.buffer_view);
    (a.tags, (view, a.split.and_then(|s| s.indices)))
}

/// Deserializes the top-level array `key` item by item so an error names the item.
///
/// Each item is read from its text; one that does not read (or repeats a field, which a
/// `Value` would have collapsed) is read again from its `Value`, which decides, so results and
/// messages are those of reading the parsed document.
pub fn array<T: DeserializeOwned + Send>(
    ctx: &Ctx,
    root: &Root,
    key: &str,
) -> Result<Vec<T>, Diagnostic> {
    let Some(v) = root.get(key) else {
        return Ok(Vec::new());
    };
    // Read whole when every item reads: then each reads from its own text as it would alone.
    // Splitting the array into items first is a second pass over it, a tenth of a big level's
    // import, needed only to name the item that does not read.
    if json_text::is_array(v.get()) {
        if let Some(all) = read_whole::<T>(v.get()) {
            return Ok(all);
        }
    }
    let items: Option<Vec<&RawValue>> = json_text::is_array(v.get())
        .then(|| serde_json::from_str(v.get()).ok())
        .flatten();
    let Some(items) = items else {
        return Err(ctx
            .diag(
                Code::GLTF_INVALID_JSON,
                format!("/{key}"),
                format!("`{key}` must be an array"),
            )
            .hint("the exporter wrote an invalid glTF; check it with the Khronos glTF validator"));
    };
    let item = |i: usize, item: &RawValue| -> Result<T, Diagnostic> {
        match serde_json::from_str::<T>(item.get()) {
            Ok(t) => Ok(t),
            Err(_) => {
                let item: Value = serde_json::from_str(item.get()).unwrap_or_default();
                T::deserialize(&item).map_err(|e| {
                    ctx.diag(
                        Code::GLTF_INVALID_JSON,
                        format!("/{key}/{i}"),
                        format!("{key}[{i}] does not follow the glTF schema: {e}"),
                    )
                    .hint(
                        "the exporter wrote an invalid glTF; check it with the Khronos glTF validator",
                    )
                })
            }
        }
    };
    items
        .iter()
        .enumerate()
        .map(|(i, it)| item(i, it))
        .collect()
}

/// An array's items, if every one reads. A big array (a big level's accessors are ten
/// megabytes of text) is cut into runs of items that are read on every thread: it is cut
/// after an object item (a `}`, then a comma, then a `{`), and each run is read as an array
/// of its own. A cut that is not between two items (the bytes were inside a string, or inside
/// an item) leaves the run before it unreadable: the text up to the cut ends inside a string
/// or with brackets open, which the one `]` added cannot all close. The whole array is then
/// read in one piece, which decides.
fn read_whole<T: DeserializeOwned + Send>(text: &str) -> Option<Vec<T>> {
    read_in_runs(text, 1 << 20)
}

/// [`read_whole`] with runs of about `run` bytes.
fn read_in_runs<T: DeserializeOwned + Send>(text: &str, run: usize) -> Option<Vec<T>> {
    use rayon::prelude::*;
    let one = || {
        let mut all = serde_json::from_str::<Vec<T>>(text).ok()?;
        // Grown by doubling; a big level's nodes would keep up to twice their room.
        all.shrink_to_fit();
        Some(all)
    };
    let text = text.trim();
    let cuts = item_cuts(text.as_bytes(), run);
    if cuts.is_empty() {
        return one();
    }
    let bounds: Vec<(usize, usize)> = std::iter::once(1)
        .chain(cuts.iter().map(|&c| c + 1))
        .zip(cuts.iter().copied().chain(std::iter::once(text.len() - 1)))
        .collect();
    let runs: Option<Vec<Vec<T>>> = bounds
        .par_iter()
        .map(|&(a, b)| {
            let run = format!("[{}]", &text[a..b]);
            serde_json::from_str::<Vec<T>>(&run).ok()
        })
        .collect();
    let Some(runs) = runs else {
        return one();
    };
    let mut all = Vec::with_capacity(runs.iter().map(Vec::len).sum());
    for r in runs {
        all.extend(r);
    }
    Some(all)
}

/// Commas of an array's text about every `run` bytes that may stand between two object items:
/// the last byte before is `}` and the next is `{`, spaces aside (see [`read_whole`] for why
/// a wrong guess is harmless).
fn item_cuts(b: &[u8], run: usize) -> Vec<usize> {
    let space = |c: u8| matches!(c, b' ' | b'\t' | b'\n' | b'\r');
    let mut cuts = Vec::new();
    let mut i = run;
    while i < b.len() {
        let Some(k) = b[i..].iter().position(|&c| c == b',') else {
            break;
        };
        let c = i + k;
        let before = b[..c].iter().rposition(|&x| !space(x)).map(|j| b[j]);
        let after = b[c + 1..]
            .iter()
            .position(|&x| !space(x))
            .map(|j| b[c + 1 + j]);
        if before == Some(b'}') && after == Some(b'{') {
            cuts.push(c);
            i = c + run;
        } else {
            i = c + 1;
        }
    }
    cuts
}

/// `i` as an index into a list of `len` items, if it is one.
pub fn index(i: u64, len: usize) -> Option<usize> {
    usize::try_from(i).ok().filter(|&i| i < len)
}

/// A primitive's attributes: each must be an accessor index, as the schema says, but only
/// POSITION is kept (a map per primitive was a tenth of a big level's import peak).
#[derive(Debug, Default)]
pub(crate) struct Attributes {
    pub position: Option<u64>,
}

impl<'de> Deserialize<'de> for Attributes {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> serde::de::Visitor<'de> for V {
            type Value = Attributes;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a map of attribute names to accessor indices")
            }
            fn visit_map<A: serde::de::MapAccess<'de>>(
                self,
                mut m: A,
            ) -> Result<Attributes, A::Error> {
                let mut out = Attributes::default();
                while let Some(k) = m.next_key::<std::borrow::Cow<'de, str>>()? {
                    let v: u64 = m.next_value()?;
                    if k == "POSITION" {
                        out.position = Some(v);
                    }
                }
                Ok(out)
            }
        }
        d.deserialize_map(V)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Read in runs, an array reads as it does whole, wherever the runs are cut: also when a
    /// cut guessed from the bytes falls inside a string or inside an item, and when an item
    /// does not read.
    #[test]
    fn runs_read_as_the_whole_array() {
        let items = [
            r#"{"name":"a},{b","children":[1,2]}"#,
            r#"{"name":"x","extras":{"list":[{"k":1},{"k":2}]}}"#,
            r#"{ "name" : "},\n{" }"#,
            r#"{"mesh":3}"#,
            r#"{"matrix":[1,0,0,0,0,1,0,0,0,0,1,0,0,0,0,1]}"#,
        ];
        let mut text = String::from("[");
        for k in 0..60 {
            if k > 0 {
                text.push_str(if k % 7 == 0 { " ,\n " } else { "," });
            }
            text.push_str(items[k % items.len()]);
        }
        text.push(']');
        let want: Vec<Node> = serde_json::from_str(&text).unwrap();
        let names =
            |v: &[Node]| -> Vec<Option<String>> { v.iter().map(|n| n.name.clone()).collect() };
        for run in 1..text.len() + 2 {
            let got: Vec<Node> = read_in_runs(&text, run).unwrap();
            assert_eq!(names(&got), names(&want), "run {run}");
            let extras: Vec<_> = got.iter().map(|n| n.extras.clone()).collect();
            let want_extras: Vec<_> = want.iter().map(|n| n.extras.clone()).collect();
            assert_eq!(extras, want_extras, "run {run}");
        }
        // An item that does not read fails the array, however it is cut.
        let bad = text.replacen(r#"{"mesh":3}"#, r#"{"mesh":"three"}"#, 1);
        for run in 1..bad.len() + 2 {
            assert!(read_in_runs::<Node>(&bad, run).is_none(), "run {run}");
        }
    }

    /// Cuts are taken only between a `}` and a `{`, about `run` bytes apart.
    #[test]
    fn cuts_fall_between_objects() {
        let text = br#"[{"a":1},{"b":[2,3]} , {"c":"},{"},{}]"#;
        let cuts = item_cuts(text, 1);
        for &c in &cuts {
            assert_eq!(text[c], b',');
        }
        assert_eq!(cuts, vec![8, 21, 30, 34]);
    }
}
