//! The neutral in-memory model every importer fills.
//!
//! Importers differ wildly (glTF node trees with instancing, flat OBJ object lists, USD prims);
//! every later stage sees only this model, so it must be able to say where each item came from
//! (for diagnostics) and must keep the original glTF so the exporter can write it back faithfully.
//!
//! Invariants kept by every importer:
//! - all coordinates are f64, Y-up, in metres; `Node::world` maps mesh-local positions to world;
//! - a mesh used by several nodes is stored once and referenced by each (instancing);
//! - `Node::parent`/`Node::children` form a forest whose roots are `Scene::roots`, parents
//!   before children in `Scene::nodes` order is *not* promised, use `roots` + `children`;
//! - every triangle index is in range of its mesh's `positions`, and every position is finite
//!   (non-finite input is reported and the offending triangles are dropped).
//!
//! For glTF the scene keeps the original document and buffer bytes (`GltfSource`). The document is
//! kept as its JSON text, not a `serde_json::Value` (ten times the text's size on a big level);
//! `json_text.rs` reads parts of it (root members, array lengths, runs of an array's elements found
//! by a scan of the checked text, which the parallel writer hands out as work) and checks a text
//! the way a `Value` parse would. The importer keeps where the root members lie
//! (`GltfSource::members_at`), so the exporter does not scan the text again.
//!
//! A .glb read into memory becomes its BIN chunk in place (the tail moved to the front) and is let
//! go once the meshes are built (`GltfSource::release_bin`); the exporter copies it back from the
//! file (`write_buffer`/`buffer_data`) and refuses if the file's length or modification time
//! changed since it was read. The JSON text is let go the same way as soon as it is parsed (before
//! the meshes are built, the importer's peak) and read back by `GltfSource::text` when the exporter
//! or a reader of the stored annotation asks for it (`TextInFile`: where it lies, and its XXH3
//! hash, which the text read back must match). Read the text only through
//! `text`/`members`/`subset`/`document`, never the `json` field. `summary.rs` computes what
//! `inspect` shows.

use std::path::{Path, PathBuf};

use glam::{DMat4, DVec3};
use serde::Serialize;

pub(crate) mod json_text;
pub mod summary;

/// Index into [`Scene::nodes`].
pub type NodeId = usize;
/// Index into [`Scene::meshes`].
pub type MeshId = usize;
/// Index into [`Scene::materials`].
pub type MaterialId = usize;

/// The file format a scene was read from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Format {
    /// glTF JSON (`.gltf`), buffers inline or beside it.
    Gltf,
    /// Binary glTF (`.glb`).
    Glb,
    /// Wavefront OBJ.
    Obj,
    /// USD (`.usd`, `.usda`, `.usdc`, `.usdz`), read through the `usd` feature.
    Usd,
    /// A Quake-family brush map (`.map`), its brushes as closed meshes.
    Map,
}

impl Format {
    /// The lower-case name used in reports and JSON (`gltf`, `glb`, `obj`, `usd`).
    pub fn name(self) -> &'static str {
        match self {
            Format::Gltf => "gltf",
            Format::Glb => "glb",
            Format::Obj => "obj",
            Format::Usd => "usd",
            Format::Map => "map",
        }
    }
}

/// How finely a file stored its coordinates: what the tolerance policy starts from
/// (`geom::tolerance`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Precision {
    /// IEEE single precision (glTF accessors, USD `point3f`).
    Binary32,
    /// IEEE double precision, or text whose digits are not known.
    Binary64,
    /// Decimal text with at most this many significant digits in any coordinate (an OBJ
    /// exporter writing `%g` keeps six): the last digit is all the file holds, whatever the
    /// parser reads it into.
    Decimal(u32),
}

impl Precision {
    /// What a format stores, before its reader has seen the digits.
    pub(crate) fn of_format(f: Format) -> Precision {
        match f {
            Format::Gltf | Format::Glb | Format::Usd => Precision::Binary32,
            // Brush corners are plane intersections computed in f64.
            Format::Obj | Format::Map => Precision::Binary64,
        }
    }

    /// How many spacings apart two stored copies of one point may be: what the tolerance is.
    /// Sixteen f32 ulps: one for storage, the rest for the transforms the exporter composed
    /// in f32 before storing (LPortal BoxRooms baked from its USD copy lost a full-wall
    /// portal pair at four, tests/import_usd.rs, and its blocks stopped lining up at two:
    /// sixteen keeps a quarter of the tolerance above that). Eight units of a decimal's last
    /// digit: the rounding to text is half a unit, and what the writer computed in binary
    /// before printing is far below a unit of six or seven digits.
    pub(crate) fn steps(self) -> f64 {
        match self {
            Precision::Binary32 => 16.0,
            Precision::Binary64 | Precision::Decimal(_) => 8.0,
        }
    }

    /// The spacing of stored numbers as large as `max_abs`: one ulp in binary (bounded by the
    /// machine epsilon times the number), one unit of the last significant digit in decimal
    /// (never finer than double precision holds).
    pub fn spacing(self, max_abs: f64) -> f64 {
        let max_abs = max_abs.max(0.0);
        let binary64 = 16.0 * f64::EPSILON * max_abs;
        match self {
            Precision::Binary32 => f32::EPSILON as f64 * max_abs,
            Precision::Binary64 => binary64,
            Precision::Decimal(digits) => {
                if !(max_abs > 0.0 && max_abs.is_finite()) {
                    return binary64;
                }
                let lead = max_abs.log10().floor() as i32;
                10f64
                    .powi(lead + 1 - digits.clamp(1, 17) as i32)
                    .max(binary64)
            }
        }
    }
}

/// Where an item came from in its source file, so a diagnostic can point a designer at it.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize)]
pub struct SourceRef {
    /// JSON pointer into a glTF document (`/nodes/3`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub pointer: Option<String>,
    /// 1-based line in a text file (OBJ).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub line: Option<usize>,
    /// USD prim path.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub prim: Option<String>,
}

impl SourceRef {
    /// A place given by a JSON pointer only.
    pub fn pointer(p: impl Into<String>) -> Self {
        SourceRef {
            pointer: Some(p.into()),
            ..Default::default()
        }
    }
    /// A place given by a 1-based line only.
    pub fn line(l: usize) -> Self {
        SourceRef {
            line: Some(l),
            ..Default::default()
        }
    }
}

/// One node of the scene tree: a transform, maybe a mesh, and the names tags read.
#[derive(Debug, Clone)]
pub struct Node {
    /// As the designer wrote it in the DCC tool; tags read it, reports show it.
    pub name: Option<String>,
    /// `None` for a root.
    pub parent: Option<NodeId>,
    /// In file order.
    pub children: Vec<NodeId>,
    /// Local-to-world transform (column vectors, glTF convention).
    pub world: DMat4,
    /// The mesh it draws (shared with other nodes when instanced).
    pub mesh: Option<MeshId>,
    /// The item's extras (glTF `extras`, USD custom data/attributes) as parsed JSON.
    pub extras: Option<serde_json::Value>,
    /// Where the node is in the file.
    pub source: SourceRef,
}

/// A run of triangles sharing one material (a glTF primitive, an OBJ `usemtl` span).
#[derive(Debug, Clone)]
pub struct Primitive {
    /// `None`: the triangles have no material.
    pub material: Option<MaterialId>,
    /// Range into [`Mesh::triangles`].
    pub first_triangle: usize,
    /// How many triangles from `first_triangle`.
    pub triangle_count: usize,
    /// Where the primitive is in the file.
    pub source: SourceRef,
    /// A glTF primitive's triangles as the file indexes them, for writing what each cell
    /// draws in the primitive's own indices (`None`: other formats, whose output is written
    /// from the scene's triangles).
    pub file: Option<Box<FileTriangles>>,
}

/// A glTF primitive's triangles as its file indexes them (strips and fans unrolled into
/// lists, in the specification's vertex order), each with the scene triangle it became.
#[derive(Debug, Clone, Default)]
pub struct FileTriangles {
    /// Indices into the primitive's own vertex attributes.
    pub triangles: Vec<[u32; 3]>,
    /// Per file triangle, its index into [`Mesh::triangles`], or `u32::MAX` when it was
    /// dropped (a repeated corner, a non-finite position).
    pub scene: Vec<u32>,
}

/// Triangles in mesh-local space, stored once however many nodes draw them.
#[derive(Debug, Clone)]
pub struct Mesh {
    /// The mesh's own name (not its node's), if the file gave one.
    pub name: Option<String>,
    /// Mesh-local positions.
    pub positions: Vec<DVec3>,
    /// Indices into `positions`, all in range.
    pub triangles: Vec<[u32; 3]>,
    /// The material runs covering `triangles`.
    pub primitives: Vec<Primitive>,
    /// The mesh's extras, as parsed JSON.
    pub extras: Option<serde_json::Value>,
    /// Where the mesh is in the file.
    pub source: SourceRef,
}

/// A material: tags may match its name or extras.
#[derive(Debug, Clone)]
pub struct Material {
    /// As the designer named it.
    pub name: Option<String>,
    /// The material's extras, as parsed JSON.
    pub extras: Option<serde_json::Value>,
    /// Whether both faces of its triangles are drawn. `false` only where the format says the
    /// back is culled (glTF's `doubleSided`, a brush face but a liquid's): which cells draw a
    /// triangle depends on it (`cells::draws`).
    pub double_sided: bool,
    /// Where the material is in the file.
    pub source: SourceRef,
}

/// The original glTF, kept so the exporter can add its extension and change nothing else.
#[derive(Debug, Clone)]
pub struct GltfSource {
    /// The document's JSON text as read, or empty while it lies in the input file
    /// (`json_file`): read it through [`GltfSource::text`]. Text, not a `Value`: a parsed
    /// document takes about ten times the room of its text, and a big level's JSON is most of
    /// the file. The importer has checked that it parses.
    pub(crate) json: String,
    /// Where the text is in the input file, when the importer let it go.
    pub(crate) json_file: Option<TextInFile>,
    /// The text read back from `json_file`, once asked for.
    pub(crate) reloaded: std::sync::OnceLock<String>,
    /// Resolved data of every buffer, in document order (GLB BIN chunk, data: URI or file).
    /// A GLB's BIN chunk is empty here once [`GltfSource::release_bin`] let it go; read the
    /// buffers through [`GltfSource::buffer_data`].
    pub buffers: Vec<Vec<u8>>,
    /// The directory external URIs are relative to.
    pub base_dir: PathBuf,
    /// Where buffer 0 lies in the input file, when it is a GLB's BIN chunk.
    pub bin_file: Option<BinInFile>,
    /// The root members as [`GltfSource::members`] gives them, as byte ranges of `json`,
    /// when the importer found them (so the export does not scan the text again).
    pub members_at: Option<Vec<(String, std::ops::Range<usize>)>>,
    /// What an earlier annotation by portcullis appended, left out of `buffers` already and
    /// dropped from the document when it is written again.
    pub(crate) earlier: Option<Earlier>,
    /// How many nodes an earlier `convert --split-by-cell` wrote as parts of others (left out
    /// on import, their nodes read whole): such a document is not written again.
    pub(crate) parts: usize,
}

/// The tail an earlier annotation appended (see `import::gltf::earlier`): buffer views and
/// accessors from an index on, and their bytes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Earlier {
    /// The first of the annotation's buffer views; all after it are its too.
    pub views: usize,
    /// The first of its accessors (the document's length when it has none).
    pub accessors: usize,
    /// The buffer holding its bytes and where they start in it, or `None` when the buffer
    /// holds nothing else (and is the last).
    pub cut: (usize, Option<usize>),
}

impl Earlier {
    /// Drops the tail from the root member `key` (`bufferViews`, `accessors` or `buffers`);
    /// whether that left it an empty array, which glTF does not allow (the caller removes it).
    pub(crate) fn drop_from(&self, key: &str, v: &mut serde_json::Value) -> bool {
        let Some(a) = v.as_array_mut() else {
            return false;
        };
        match key {
            "bufferViews" => a.truncate(self.views),
            "accessors" => a.truncate(self.accessors),
            "buffers" => match self.cut {
                (b, None) => a.truncate(b),
                (b, Some(len)) => {
                    if let Some(o) = a.get_mut(b).and_then(serde_json::Value::as_object_mut) {
                        o.insert("byteLength".into(), len.into());
                    }
                }
            },
            _ => {}
        }
        a.is_empty()
    }

    /// Drops the tail's bytes from the buffers' data.
    pub(crate) fn drop_bytes(&self, buffers: &mut Vec<Vec<u8>>, bin: &mut Option<BinInFile>) {
        match self.cut {
            (b, None) => {
                buffers.truncate(b);
                if b == 0 {
                    *bin = None;
                }
            }
            (b, Some(len)) => {
                if let Some(data) = buffers.get_mut(b) {
                    data.truncate(len);
                }
                if let Some(f) = bin.as_mut().filter(|_| b == 0) {
                    f.len = f.len.min(len);
                }
            }
        }
    }
}

/// The JSON text of a glTF as it lies in the input file, and its hash: the importer lets the
/// text go as soon as it is parsed, and [`GltfSource::text`] reads it back when the exporter
/// (or a reader of the stored annotation) asks for it. On a big level the text is a sixth of
/// the peak memory (27 MB of 10 000 rooms), and nothing between the importer and the exporter
/// reads it. The hash makes sure the text read back is the text that was parsed.
#[derive(Debug, Clone)]
pub(crate) struct TextInFile {
    path: PathBuf,
    at: std::ops::Range<u64>,
    hash: u64,
}

impl TextInFile {
    /// Empties `text`, the verbatim copy of bytes `at` of the file at `path`.
    pub(crate) fn release(text: &mut String, path: &Path, at: std::ops::Range<u64>) -> TextInFile {
        let hash = xxhash_rust::xxh3::xxh3_64(text.as_bytes());
        *text = String::new();
        TextInFile {
            path: path.to_path_buf(),
            at,
            hash,
        }
    }

    /// The text, from the file; an error if it is not the text that was let go.
    fn read_back(&self) -> std::io::Result<String> {
        use std::io::{Read, Seek, SeekFrom};
        let changed = || {
            std::io::Error::other(format!(
                "the input `{}` changed while it was being converted; convert it again",
                self.path.display()
            ))
        };
        // Errors name the input: the exporter reports them against the file it was writing.
        let unreadable = |e: std::io::Error| {
            std::io::Error::new(
                e.kind(),
                format!("cannot read the input `{}` again: {e}", self.path.display()),
            )
        };
        let mut f = std::fs::File::open(&self.path).map_err(unreadable)?;
        f.seek(SeekFrom::Start(self.at.start)).map_err(unreadable)?;
        let len = usize::try_from(self.at.end - self.at.start).map_err(|_| changed())?;
        let mut buf = vec![0u8; len];
        f.read_exact(&mut buf).map_err(|e| match e.kind() {
            std::io::ErrorKind::UnexpectedEof => changed(),
            _ => unreadable(e),
        })?;
        if xxhash_rust::xxh3::xxh3_64(&buf) != self.hash {
            return Err(changed());
        }
        String::from_utf8(buf).map_err(|_| changed())
    }
}

/// A GLB's BIN chunk in the input file, to read back at export instead of holding it through
/// the pipeline (on a big level it is half the file and a seventh of the peak memory).
#[derive(Debug, Clone)]
pub struct BinInFile {
    /// The input file the chunk is in.
    pub path: PathBuf,
    /// Where the chunk's bytes start in the file.
    pub offset: u64,
    /// The chunk's length in bytes.
    pub len: usize,
    /// The file as it was read (length, modification time): if it differs at export, the
    /// chunk is not read back from a changed file.
    pub file_len: u64,
    /// The file's modification time when read, if the platform gives one.
    pub modified: Option<std::time::SystemTime>,
    /// True once buffer 0 was emptied.
    pub released: bool,
}

impl GltfSource {
    /// A document held in memory: its JSON text (which must parse) and each buffer's data,
    /// external URIs resolving from `base_dir`.
    pub(crate) fn in_memory(json: String, buffers: Vec<Vec<u8>>, base_dir: &Path) -> GltfSource {
        GltfSource {
            json,
            json_file: None,
            reloaded: Default::default(),
            buffers,
            base_dir: base_dir.to_path_buf(),
            bin_file: None,
            members_at: None,
            earlier: None,
            parts: 0,
        }
    }

    /// The document's JSON text, read back from the input file if the importer let it go (an
    /// error if the file cannot be read or no longer holds it).
    pub fn text(&self) -> std::io::Result<&str> {
        let Some(file) = &self.json_file else {
            return Ok(&self.json);
        };
        if let Some(t) = self.reloaded.get() {
            return Ok(t);
        }
        let t = file.read_back()?;
        Ok(self.reloaded.get_or_init(|| t))
    }

    /// The whole document parsed (`Null` if the text does not parse, which the importer rules
    /// out).
    pub fn document(&self) -> std::io::Result<serde_json::Value> {
        Ok(serde_json::from_str(self.text()?).unwrap_or_default())
    }

    /// An object holding only the root members `keys` (those present), parsed: what a reader of
    /// a few members needs without parsing a big level's whole document.
    pub fn subset(&self, keys: &[&str]) -> std::io::Result<serde_json::Value> {
        let members = self.members()?.unwrap_or_default();
        let picked = members
            .into_iter()
            .filter(|(k, _)| keys.contains(&k.as_str()))
            .filter_map(|(k, v)| Some((k, serde_json::from_str(v).ok()?)));
        Ok(serde_json::Value::Object(picked.collect()))
    }

    /// The root object's members in document order, each as its text; a repeated key keeps its
    /// first place and its last value, as a parsed `Value` does. `None` if the root is not an
    /// object.
    pub fn members(&self) -> std::io::Result<Option<Vec<(String, &str)>>> {
        let json = self.text()?;
        if let Some(at) = &self.members_at {
            let text = |r: &std::ops::Range<usize>| json.get(r.clone());
            return Ok(at
                .iter()
                .map(|(k, r)| Some((k.clone(), text(r)?)))
                .collect());
        }
        let Some(members) = json_text::members(json) else {
            return Ok(None);
        };
        Ok(Some(
            members.into_iter().map(|(k, v)| (k, v.get())).collect(),
        ))
    }

    /// Lets buffer 0 go when it is the BIN chunk of the file at `path`, as it still is on disk
    /// (`meta`): [`GltfSource::buffer_data`] reads it back.
    pub fn release_bin(&mut self, meta: &std::fs::Metadata) {
        let Some(b) = self.bin_file.as_mut() else {
            return;
        };
        if b.released
            || meta.len() != b.file_len
            || self.buffers.first().map(Vec::len) != Some(b.len)
        {
            return;
        }
        b.modified = meta.modified().ok();
        b.released = true;
        self.buffers[0] = Vec::new();
    }

    /// The released BIN chunk's reader, positioned at the chunk (an error if the file changed
    /// since it was read); `None` when nothing was released.
    fn released_bin(&self) -> Option<std::io::Result<std::io::Take<std::fs::File>>> {
        use std::io::{Read, Seek};
        let b = self.bin_file.as_ref().filter(|b| b.released)?;
        Some((|| {
            let mut f = std::fs::File::open(&b.path)?;
            let meta = f.metadata()?;
            if meta.len() != b.file_len || meta.modified().ok() != b.modified {
                return Err(std::io::Error::other(format!(
                    "the input `{}` changed while it was being converted; convert it again",
                    b.path.display()
                )));
            }
            f.seek(std::io::SeekFrom::Start(b.offset))?;
            Ok(f.take(b.len as u64))
        })())
    }

    /// Each buffer's length (a released BIN chunk's too).
    pub(crate) fn buffer_lens(&self) -> Vec<usize> {
        let mut lens: Vec<usize> = self.buffers.iter().map(Vec::len).collect();
        if let (Some(b), Some(first)) = (self.bin_file.as_ref(), lens.first_mut()) {
            if b.released {
                *first = b.len;
            }
        }
        lens
    }

    /// Buffer `i` as a reader of the input file and its length, if it is a released BIN
    /// chunk (an error if the file changed since it was read).
    pub(crate) fn released_buffer(
        &self,
        i: usize,
    ) -> Option<std::io::Result<(std::io::Take<std::fs::File>, u64)>> {
        let len = self.bin_file.as_ref()?.len as u64;
        (i == 0)
            .then(|| self.released_bin())
            .flatten()
            .map(|r| r.map(|r| (r, len)))
    }

    /// Writes buffer `i`, a released BIN chunk straight from the input file.
    pub(crate) fn write_buffer(&self, i: usize, w: &mut dyn std::io::Write) -> std::io::Result<()> {
        if i == 0 {
            if let Some(r) = self.released_bin() {
                let want = self.bin_file.as_ref().map_or(0, |b| b.len as u64);
                if std::io::copy(&mut r?, w)? != want {
                    return Err(std::io::Error::other("the input file was cut short"));
                }
                return Ok(());
            }
        }
        w.write_all(self.buffers.get(i).map_or(&[], Vec::as_slice))
    }

    /// Every buffer's data, reading a released BIN chunk back from the input file (an error if
    /// the file changed since it was read).
    pub fn buffer_data(&self) -> std::io::Result<std::borrow::Cow<'_, [Vec<u8>]>> {
        let Some(r) = self.released_bin() else {
            return Ok(std::borrow::Cow::Borrowed(&self.buffers));
        };
        let mut data = Vec::with_capacity(self.bin_file.as_ref().map_or(0, |b| b.len));
        std::io::Read::read_to_end(&mut r?, &mut data)?;
        let mut all = self.buffers.clone();
        all[0] = data;
        Ok(std::borrow::Cow::Owned(all))
    }
}

/// A level as read from any format: a node tree, meshes and materials (see the module).
#[derive(Debug, Clone)]
pub struct Scene {
    /// The file the scene was read from (`-` for standard input).
    pub path: PathBuf,
    /// The format it was read from.
    pub format: Format,
    /// All nodes; a [`NodeId`] indexes it.
    pub nodes: Vec<Node>,
    /// The top-level nodes, in file order.
    pub roots: Vec<NodeId>,
    /// All meshes; a [`MeshId`] indexes it.
    pub meshes: Vec<Mesh>,
    /// All materials; a [`MaterialId`] indexes it.
    pub materials: Vec<Material>,
    /// The original glTF document and buffers (glTF and GLB input only).
    pub gltf: Option<GltfSource>,
    /// From the scene's metres and +Y up back to the file's own units and axes, when they
    /// differ (a brush map's inches and Z up): for what is written for the file's own editor,
    /// such as a leak's point file.
    pub to_file: Option<glam::DMat4>,
    /// The tag preset a portcullis annotation in the input names (its `tags`): what a file
    /// portcullis wrote was tagged with, so it is read back the same way.
    pub stored_tags: Option<String>,
    /// The narrowest gap (m) the format's own compiler lets anything through, when it has one:
    /// for a brush map qbsp's 0.2 units (it drops portals with fewer than three edges longer).
    /// Narrower gaps are cracks, whatever the level's shortest edge says.
    pub crack_width: Option<f64>,
    /// How finely the file stored the mesh positions.
    pub precision: Precision,
}

impl Scene {
    /// An empty scene read from `path`.
    pub fn new(path: PathBuf, format: Format) -> Self {
        Scene {
            path,
            format,
            nodes: Vec::new(),
            roots: Vec::new(),
            meshes: Vec::new(),
            materials: Vec::new(),
            gltf: None,
            stored_tags: None,
            to_file: None,
            crack_width: None,
            precision: Precision::of_format(format),
        }
    }

    /// Adds a node under `parent` (or as a root) and returns its id.
    pub fn add_node(&mut self, mut node: Node) -> NodeId {
        let id = self.nodes.len();
        node.parent = node.parent.filter(|&p| p < id);
        match node.parent {
            Some(p) => self.nodes[p].children.push(id),
            None => self.roots.push(id),
        }
        self.nodes.push(node);
        id
    }

    /// The node's name, or a stable placeholder for unnamed nodes.
    pub fn node_label(&self, id: NodeId) -> String {
        match &self.nodes[id].name {
            Some(n) if !n.is_empty() => n.clone(),
            _ => format!("#{id}"),
        }
    }

    /// Slash-separated names from the root down to `id`, the path designers see in their
    /// outliner; used in every diagnostic that points at a node.
    pub fn node_path(&self, id: NodeId) -> String {
        let mut parts = vec![self.node_label(id)];
        let mut cur = self.nodes[id].parent;
        let mut guard = 0;
        while let Some(p) = cur {
            parts.push(self.node_label(p));
            cur = self.nodes[p].parent;
            guard += 1;
            if guard > self.nodes.len() {
                break;
            }
        }
        parts.reverse();
        parts.join("/")
    }

    /// Nodes in depth-first pre-order from the roots (each node once).
    pub fn walk(&self) -> Vec<NodeId> {
        let mut out = Vec::with_capacity(self.nodes.len());
        let mut seen = vec![false; self.nodes.len()];
        let mut stack: Vec<NodeId> = self.roots.iter().rev().copied().collect();
        while let Some(n) = stack.pop() {
            if std::mem::replace(&mut seen[n], true) {
                continue;
            }
            out.push(n);
            stack.extend(self.nodes[n].children.iter().rev().copied());
        }
        out
    }

    /// Distinct material names used by a mesh, in primitive order.
    pub fn mesh_material_names(&self, mesh: MeshId) -> Vec<Option<&str>> {
        let mut out: Vec<Option<&str>> = Vec::new();
        for p in &self.meshes[mesh].primitives {
            let n = p
                .material
                .and_then(|m| self.materials.get(m))
                .and_then(|m| m.name.as_deref());
            if !out.contains(&n) {
                out.push(n);
            }
        }
        out
    }

    /// How `node`'s triangles keep their winding in world space ([`Winding::order`]): a
    /// transform with a negative determinant (a scale of -1 on one axis, how DCC tools mirror
    /// an instance) turns every triangle inside out, so its corners are reversed, as renderers
    /// do when they flip the front face for such a node. Asked once per node: a determinant per
    /// triangle was a visible share of a whole conversion.
    pub fn winding(&self, node: NodeId) -> Winding {
        Winding {
            mirrored: self.nodes[node].world.determinant() < 0.0,
        }
    }

    /// World-space positions of one node's mesh (empty if it has none).
    pub fn world_positions(&self, node: NodeId) -> Vec<DVec3> {
        let n = &self.nodes[node];
        match n.mesh {
            Some(m) => self.meshes[m]
                .positions
                .iter()
                .map(|p| n.world.transform_point3(*p))
                .collect(),
            None => Vec::new(),
        }
    }

    /// World-space positions of the vertices a node's triangles use (bounds ignore vertices
    /// no triangle references, as renderers do).
    pub fn world_positions_used(&self, node: NodeId) -> Vec<DVec3> {
        self.world_positions_used_iter(node).collect()
    }

    /// [`Scene::world_positions_used`] one at a time: most callers only fold them into a box
    /// or a maximum, and on a big level the lists were a few hundred megabytes allocated and
    /// freed again.
    pub(crate) fn world_positions_used_iter(
        &self,
        node: NodeId,
    ) -> impl Iterator<Item = DVec3> + '_ {
        let n = &self.nodes[node];
        let world = n.world;
        let positions: &[DVec3] = n.mesh.map_or(&[], |m| &self.meshes[m].positions);
        let mut used = vec![false; positions.len()];
        for t in n.mesh.map_or(&[][..], |m| &self.meshes[m].triangles) {
            for &i in t {
                if let Some(u) = used.get_mut(i as usize) {
                    *u = true;
                }
            }
        }
        positions
            .iter()
            .zip(used)
            .filter(|(_, u)| *u)
            .map(move |(p, _)| world.transform_point3(*p))
    }

    /// Where a marker node stands (a player start, an occupant): the centre of its mesh's box
    /// when it has a mesh (an OBJ object, a spawn pad), else its origin.
    pub fn place(&self, node: NodeId) -> DVec3 {
        let mut b = crate::geom::aabb::Aabb::EMPTY;
        for p in self.world_positions_used_iter(node) {
            b.add(p);
        }
        if b.is_empty() {
            self.nodes[node].world.transform_point3(DVec3::ZERO)
        } else {
            (b.min + b.max) * 0.5
        }
    }

    /// Triangles drawn by the scene, counting each instance of a mesh.
    pub fn triangle_count(&self) -> usize {
        self.walk()
            .into_iter()
            .filter_map(|n| self.nodes[n].mesh)
            .map(|m| self.meshes[m].triangles.len())
            .sum()
    }
}

/// A node's winding in world space, from [`Scene::winding`].
#[derive(Debug, Clone, Copy)]
pub struct Winding {
    /// The transform's determinant is negative, so triangles flip their winding.
    pub mirrored: bool,
}

impl Winding {
    /// A triangle's corners in the order that keeps its winding in world space.
    pub fn order(self, t: [u32; 3]) -> [u32; 3] {
        if self.mirrored {
            [t[0], t[2], t[1]]
        } else {
            t
        }
    }
}
