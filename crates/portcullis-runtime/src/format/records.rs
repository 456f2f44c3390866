//! The extension's objects, one struct per schema object, that both read and write (as
//! gltf-rs does): reading fills them with owned data (the defaults of their type parameters),
//! and the writer serializes the same structs over borrowed views of the level (rounded
//! numbers, iterators of planes), so a field's name, order and when it is left out are said
//! once. tests/convert.rs holds every written annotation to a read-then-serialized copy of
//! itself, and to schemas/PORTCULLIS_portals.schema.json.

use serde::{Deserialize, Serialize};
use serde_json::Value;

/// The root extension object.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, rename_all = "camelCase")]
pub struct Annotated {
    /// The format version ([`super::VERSION`]).
    pub version: u64,
    /// `portcullis` and the version that wrote it.
    pub generator: String,
    /// The input hash (`format/hash.rs`): `definition:hex`.
    pub input_hash: String,
    /// The distance tolerance the level was built with, in metres.
    pub tolerance: f64,
    /// The tag preset the level was read with, when not `default` (`--tags`, or `quake` for a
    /// brush map): a reader given none reads the file with it, so the file reads back as the
    /// level it was made from.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tags: Option<String>,
    /// How `--tags auto` found the rooms, when it did.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub generated: Option<GeneratedRecord>,
    /// Rooms of more than one cell (left out when every room is one cell).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub rooms: Vec<RoomRecord>,
    /// The convex cells.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub cells: Vec<CellRecord>,
    /// The portals between cells (and to the outside).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub portals: Vec<PortalRecord>,
    /// The occupants (glTF nodes) that stand inside a solid block: they mark no air and seed
    /// no leak search, as qbsp skips them, so a check of the file reads them as its source did.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub buried_occupants: Vec<usize>,
    /// The nodes split by cell, when some node's triangles lie in different cells.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub split: Option<SplitRecord>,
    /// The stored PVS, encoded (see [`super::visibility`]); [`super::read::visibility`]
    /// decodes it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub visibility: Option<Value>,
}

/// The settings and findings of `--tags auto`: enough to tell a reader the rooms were found,
/// not drawn, and to find them again.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, rename_all = "camelCase")]
pub struct GeneratedRecord {
    /// Edge of a voxel (m).
    pub voxel: f64,
    /// The split ratio (`[auto] split_ratio`).
    pub split_ratio: f64,
    /// Planes of less area (m²) did not cut the cells (`[auto] detail_area`); absent in files
    /// written before it existed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub detail_area: Option<f64>,
    /// Voxels along the level's own axes.
    pub grid: [usize; 3],
    /// The level's own axes (world directions), the grid's.
    pub axes: [[f64; 3]; 3],
    /// How many rooms were generated.
    pub rooms: usize,
}

/// A room cut into several cells.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RoomRecord {
    /// The room's name, as its cells name it.
    pub name: String,
    /// Its cells, by index.
    pub cells: Vec<usize>,
}

/// An axis-aligned box.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Bounds<F = f64> {
    /// The least corner.
    pub min: [F; 3],
    /// The greatest corner.
    pub max: [F; 3],
}

/// A convex cell: the intersection of its planes' inner half-spaces.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(
    deny_unknown_fields,
    bound(
        serialize = "Text: Serialize, Planes: Serialize, F: Serialize, Nodes: Serialize + IsEmpty, Draws: Serialize + IsEmpty"
    )
)]
pub struct CellRecord<
    Text = String,
    Planes = Vec<[f64; 4]>,
    F = f64,
    Nodes = Vec<usize>,
    Draws = Vec<[usize; 3]>,
> {
    /// The room the cell belongs to.
    pub room: Text,
    /// Where rooms nest, the higher wins a point both hold (absent: 0).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub priority: i64,
    /// `[nx, ny, nz, d]`, outward unit normals, `n · p <= d` inside.
    pub planes: Planes,
    /// The cell's bounding box.
    pub bounds: Bounds<F>,
    /// The glTF nodes whose geometry the cell draws.
    #[serde(default, skip_serializing_if = "IsEmpty::is_empty")]
    pub nodes: Nodes,
    /// Of the nodes split by cell ([`SplitRecord`]), what the cell draws: `[primitive, first,
    /// count]`, a range of [`SplitRecord::indices`] over the vertices of
    /// `split.primitives[primitive]`, ascending.
    #[serde(default, skip_serializing_if = "IsEmpty::is_empty")]
    pub draws: Draws,
}

/// The primitives of nodes whose triangles lie in different cells, each primitive's triangles
/// copied into one index accessor sorted by the cells they lie in, so a cell draws a range of
/// it (`CellRecord::draws`) over the primitive's own vertex attributes. A node split here is
/// drawn only through those ranges; every other node of a cell's `nodes` is drawn whole.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SplitRecord {
    /// The accessor (`SCALAR`, `UNSIGNED_INT`) holding every split primitive's indices.
    pub indices: usize,
    /// The split primitives, by glTF node and primitive index in its mesh.
    pub primitives: Vec<SplitPrimitive>,
}

/// One split primitive: where its triangles lie in [`SplitRecord::indices`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SplitPrimitive {
    /// The glTF node.
    pub node: usize,
    /// The primitive's index in the node's mesh.
    pub primitive: usize,
    /// Its first index in the accessor.
    pub first: usize,
    /// How many indices (three per triangle).
    pub count: usize,
}

/// A portal: a convex polygon from one cell into another (or to the outside).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, rename_all = "camelCase")]
pub struct PortalRecord<
    Polygon = Vec<[f64; 3]>,
    Cells = Vec<usize>,
    Kind = String,
    Transform = [f64; 16],
> {
    /// The polygon's corners, counter-clockwise seen from its first cell.
    pub polygon: Polygon,
    /// `[from, to]`, or `[from]` for an opening to the outside.
    pub cells: Cells,
    /// `mirror` or `teleporter`; absent for a plain opening.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub kind: Option<Kind>,
    /// Seen through from its first cell only.
    #[serde(default, skip_serializing_if = "is_false")]
    pub one_way: bool,
    /// A door authored closed: blocks sight until opened at run time.
    #[serde(default, skip_serializing_if = "is_false")]
    pub closed: bool,
    /// A door's opening: closes when the door (`node`) does; open at the start unless `closed`.
    #[serde(default, skip_serializing_if = "is_false")]
    pub door: bool,
    /// Between two cells of one room.
    #[serde(default, skip_serializing_if = "is_false")]
    pub internal: bool,
    /// Mirrors and teleporters: the column-major 4×4 matrix taking what lies beyond.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub transform: Option<Transform>,
    /// The portal of the same opening seen from the other side.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub partner: Option<usize>,
    /// The glTF node it was authored as.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub node: Option<usize>,
}

impl PortalRecord {
    /// The cell it is seen from.
    pub fn from(&self) -> usize {
        self.cells.first().copied().unwrap_or(0)
    }
    /// The cell it leads into (`None`: the outside).
    pub fn to(&self) -> Option<usize> {
        self.cells.get(1).copied()
    }
}

fn is_zero(x: &i64) -> bool {
    *x == 0
}

fn is_false(b: &bool) -> bool {
    !*b
}

/// Lists left out of an object when empty, owned when read or borrowed when written.
pub trait IsEmpty {
    /// Whether there is nothing to write.
    fn is_empty(&self) -> bool;
}

impl<T> IsEmpty for Vec<T> {
    fn is_empty(&self) -> bool {
        Vec::is_empty(self)
    }
}

impl<T> IsEmpty for &[T] {
    fn is_empty(&self) -> bool {
        <[T]>::is_empty(self)
    }
}
