//! Reading a .bsp: its header, its lump table and the few records vis needs (the leafs, the
//! world model's leaf count, and for ambient sounds the chain leaf → marksurface → face →
//! texinfo → texture name). Every other lump stays bytes the writer copies unread, so it
//! comes out exactly as it went in. Every count and offset is checked against the bytes
//! present before anything is read or sized by it.

use std::path::{Path, PathBuf};

use super::error;
use crate::diag::Diagnostic;

/// The .bsp dialects vis writes into. They differ in the header, the lump table and the
/// sizes of the leaf, face and marksurface records.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    /// Quake's BSP29 (also Hexen II's, which only widens the model records).
    Bsp29,
    /// "BSP2": BSP29 with 32-bit indices and float leaf bounds.
    Bsp2,
    /// "2PSB" (RMQ's BSP2): 32-bit indices, short leaf bounds.
    Bsp2Rmq,
    /// Half-Life's BSP30: BSP29's layout; its water textures start with `!`.
    HalfLife,
    /// Quake 2's IBSP version 38: clusters, and the PHS beside the PVS.
    Quake2,
    /// Qbism's "QBSP" version 38: Quake 2 with 32-bit records.
    Qbism,
}

impl Format {
    /// How messages and reports name it.
    pub fn name(self) -> &'static str {
        match self {
            Format::Bsp29 => "BSP29",
            Format::Bsp2 => "BSP2",
            Format::Bsp2Rmq => "2PSB",
            Format::HalfLife => "Half-Life BSP30",
            Format::Quake2 => "Quake 2 IBSP 38",
            Format::Qbism => "Quake 2 Qbism QBSP 38",
        }
    }
    /// Quake 2's kind: leafs name clusters, the visibility lump holds PVS and PHS per cluster.
    pub fn has_clusters(self) -> bool {
        matches!(self, Format::Quake2 | Format::Qbism)
    }
    fn lump_names(self) -> &'static [&'static str] {
        if self.has_clusters() {
            &Q2_LUMPS
        } else {
            &Q1_LUMPS
        }
    }
    fn header_len(self) -> usize {
        if self.has_clusters() {
            8 + 19 * 8
        } else {
            4 + 15 * 8
        }
    }
    /// The visibility lump's index.
    pub fn vis_lump(self) -> usize {
        if self.has_clusters() {
            3
        } else {
            4
        }
    }
    /// The leafs lump's index.
    pub fn leafs_lump(self) -> usize {
        if self.has_clusters() {
            8
        } else {
            10
        }
    }
    /// Bytes of one leaf record.
    pub fn leaf_size(self) -> usize {
        match self {
            Format::Bsp29 | Format::HalfLife | Format::Quake2 => 28,
            Format::Bsp2 => 44,
            Format::Bsp2Rmq => 32,
            Format::Qbism => 52,
        }
    }
    /// Where in a Quake 1 family leaf record its four ambient levels are.
    pub(crate) fn ambient_offset(self) -> usize {
        match self {
            Format::Bsp2 => 40,
            Format::Bsp2Rmq => 28,
            _ => 24,
        }
    }
    /// Marksurfaces and faces use 32-bit indices.
    fn wide(self) -> bool {
        matches!(self, Format::Bsp2 | Format::Bsp2Rmq)
    }
}

/// Quake 1 family lump names, in header order.
pub const Q1_LUMPS: [&str; 15] = [
    "entities",
    "planes",
    "textures",
    "vertexes",
    "visibility",
    "nodes",
    "texinfo",
    "faces",
    "lighting",
    "clipnodes",
    "leafs",
    "marksurfaces",
    "edges",
    "surfedges",
    "models",
];

/// Quake 2 lump names, in header order.
pub const Q2_LUMPS: [&str; 19] = [
    "entities",
    "planes",
    "vertexes",
    "visibility",
    "nodes",
    "texinfo",
    "faces",
    "lighting",
    "leafs",
    "leaffaces",
    "leafbrushes",
    "edges",
    "surfedges",
    "models",
    "brushes",
    "brushsides",
    "pop",
    "areas",
    "areaportals",
];

const Q1_TEXTURES: usize = 2;
const Q1_TEXINFO: usize = 6;
const Q1_FACES: usize = 7;
const Q1_MARKSURFACES: usize = 11;
const Q1_MODELS: usize = 14;

/// One lump's place in the file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Lump {
    /// Byte offset from the start of the file.
    pub offset: usize,
    /// Bytes.
    pub len: usize,
}

/// The fields of a leaf record vis reads or writes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Leaf {
    /// Quake 1 family: where the leaf's PVS row starts in the visibility lump (-1: none).
    pub visofs: i32,
    /// Quake 2: the leaf's cluster (-1: solid, none).
    pub cluster: i32,
    /// The leaf's bounding box, as stored (shorts widened, or BSP2's floats).
    pub mins: [f32; 3],
    /// See `mins`.
    pub maxs: [f32; 3],
    /// Quake 1 family: the first of its marksurfaces and how many.
    pub first_mark: usize,
    /// See `first_mark`.
    pub marks: usize,
    /// Quake 1 family: water, sky, slime, lava levels.
    pub ambient: [u8; 4],
}

/// What follows the last lump: BSPX extension lumps (their offsets are absolute, so moving
/// the lumps before them means rewriting their table), or bytes of unknown meaning, kept.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Tail {
    /// Nothing after the lumps (but padding).
    None,
    /// A BSPX table: each lump's name and bytes, in table order.
    Bspx(Vec<([u8; 24], Vec<u8>)>),
    /// Something else, copied as it is.
    Raw(Vec<u8>),
}

/// A .bsp read: its bytes, where its lumps are, and its leafs.
#[derive(Debug, Clone)]
pub struct Bsp {
    /// For messages.
    pub path: PathBuf,
    /// The dialect.
    pub format: Format,
    /// Hexen II: BSP29 or BSP2 with 80-byte model records (so its leaf count sits elsewhere).
    pub hexen2: bool,
    /// The file's bytes, as read.
    pub bytes: Vec<u8>,
    /// One per header entry, in header order.
    pub lumps: Vec<Lump>,
    /// Every leaf, leaf 0 (Quake 1's shared solid leaf) first.
    pub leafs: Vec<Leaf>,
    /// Quake 1 family: the world's leafs that have a PVS row (leafs 1..=visleafs).
    /// Quake 2: the clusters the leafs name (the highest plus one).
    pub vis_units: usize,
    /// After the lumps.
    pub tail: Tail,
}

fn i32_at(b: &[u8], at: usize) -> i32 {
    b.get(at..at + 4)
        .map_or(0, |s| i32::from_le_bytes([s[0], s[1], s[2], s[3]]))
}
fn u32_at(b: &[u8], at: usize) -> u32 {
    i32_at(b, at) as u32
}
fn i16_at(b: &[u8], at: usize) -> i16 {
    b.get(at..at + 2)
        .map_or(0, |s| i16::from_le_bytes([s[0], s[1]]))
}
fn u16_at(b: &[u8], at: usize) -> u16 {
    i16_at(b, at) as u16
}
fn f32_at(b: &[u8], at: usize) -> f32 {
    f32::from_bits(u32_at(b, at))
}

/// Reads a .bsp file. `Err` when it cannot be read as one of the [`Format`]s.
pub fn read(path: &Path) -> Result<Bsp, Diagnostic> {
    let bytes = std::fs::read(path).map_err(|e| {
        Diagnostic::new(
            crate::diag::Code::IO_READ_FAILED,
            format!("cannot read `{}`: {e}", path.display()),
            crate::diag::Location::file(path),
        )
        .hint("check the path and permissions")
    })?;
    parse(bytes, path)
}

/// Reads .bsp bytes (`path` is for messages).
pub fn parse(bytes: Vec<u8>, path: &Path) -> Result<Bsp, Diagnostic> {
    let format = format_of(&bytes, path)?;
    let lumps = lump_table(&bytes, format, path)?;
    let mut bsp = Bsp {
        path: path.to_path_buf(),
        format,
        hexen2: false,
        tail: Tail::None,
        leafs: Vec::new(),
        vis_units: 0,
        lumps,
        bytes,
    };
    bsp.tail = bsp.tail_of()?;
    bsp.leafs = bsp.read_leafs()?;
    if format.has_clusters() {
        bsp.vis_units = bsp.clusters()?;
    } else {
        bsp.hexen2 = bsp.is_hexen2()?;
        bsp.vis_units = bsp.visleafs()?;
    }
    Ok(bsp)
}

/// The dialect from the first eight bytes.
fn format_of(b: &[u8], path: &Path) -> Result<Format, Diagnostic> {
    if b.len() < 4 {
        return Err(error::truncated(
            path,
            "a .bsp starts with a 4-byte magic or version".into(),
            b.len(),
        ));
    }
    let magic = &b[0..4];
    let version = i32_at(b, 4);
    let f = match magic {
        b"BSP2" => Format::Bsp2,
        b"2PSB" => Format::Bsp2Rmq,
        b"IBSP" | b"QBSP" if b.len() < 8 => {
            return Err(error::truncated(
                path,
                "a Quake 2 .bsp has a version after its magic".into(),
                b.len(),
            ))
        }
        b"IBSP" if version == 38 => Format::Quake2,
        b"QBSP" if version == 38 => Format::Qbism,
        b"IBSP" => {
            let game = match version {
                46 => " (Quake 3)",
                47 => " (Return to Castle Wolfenstein, Enemy Territory)",
                _ => "",
            };
            return Err(error::unsupported(
                path,
                format!("IBSP version {version}{game} is not a Quake 2 .bsp (version 38)"),
            ));
        }
        _ => match i32_at(b, 0) {
            29 => Format::Bsp29,
            30 => Format::HalfLife,
            v => {
                let shown: String = magic
                    .iter()
                    .map(|&c| if c.is_ascii_graphic() { c as char } else { '.' })
                    .collect();
                return Err(error::unsupported(
                    path,
                    format!("the file starts with `{shown}` (version {v}), which is no .bsp portcullis knows"),
                ));
            }
        },
    };
    if b.len() < f.header_len() {
        return Err(error::truncated(
            path,
            format!("a {} header takes {} bytes", f.name(), f.header_len()),
            b.len(),
        ));
    }
    Ok(f)
}

/// The lump table, each lump inside the file and off the header. A lump that starts inside
/// the file but runs past its end is a cut file; one that starts past the end, or before
/// the header ends, a damaged table.
fn lump_table(b: &[u8], f: Format, path: &Path) -> Result<Vec<Lump>, Diagnostic> {
    let first = if f.has_clusters() { 8 } else { 4 };
    let names = f.lump_names();
    let mut lumps = Vec::with_capacity(names.len());
    for (i, name) in names.iter().enumerate() {
        let (ofs, len) = (i32_at(b, first + 8 * i), i32_at(b, first + 8 * i + 4));
        if ofs < 0 || len < 0 {
            return Err(error::lump_range(
                path,
                name,
                format!("has offset {ofs} and length {len}; neither may be negative"),
            ));
        }
        lumps.push(Lump {
            offset: ofs as usize,
            len: len as usize,
        });
    }
    let mut order: Vec<usize> = (0..lumps.len()).filter(|&i| lumps[i].len > 0).collect();
    order.sort_by_key(|&i| (lumps[i].offset, i));
    for i in order {
        let l = lumps[i];
        let end = l.offset + l.len;
        if l.offset < f.header_len() {
            return Err(error::lump_range(
                path,
                names[i],
                format!(
                    "starts at byte {}, inside the {}-byte header",
                    l.offset,
                    f.header_len()
                ),
            ));
        }
        if l.offset > b.len() {
            return Err(error::lump_range(
                path,
                names[i],
                format!(
                    "starts at byte {}, past the end of the file ({} bytes)",
                    l.offset,
                    b.len()
                ),
            ));
        }
        if end > b.len() {
            return Err(error::truncated(
                path,
                format!("lump `{}` runs from byte {} to {end}", names[i], l.offset),
                b.len(),
            ));
        }
    }
    Ok(lumps)
}

impl Bsp {
    /// The name of lump `i`, for messages.
    pub fn lump_name(&self, i: usize) -> &'static str {
        self.format.lump_names().get(i).copied().unwrap_or("?")
    }
    /// Lump `i`'s bytes (checked in range when read; an empty lump may point anywhere).
    pub fn lump(&self, i: usize) -> &[u8] {
        let l = self.lumps[i];
        if l.len == 0 {
            return &[];
        }
        &self.bytes[l.offset..l.offset + l.len]
    }
    /// The header's bytes.
    pub fn header(&self) -> &[u8] {
        &self.bytes[..self.format.header_len()]
    }
    /// How many `size`-byte records lump `i` holds, refusing a part record.
    fn records(&self, i: usize, size: usize) -> Result<usize, Diagnostic> {
        let len = self.lumps[i].len;
        if len % size != 0 {
            return Err(error::lump_range(
                &self.path,
                self.lump_name(i),
                format!("has {len} bytes, not a whole number of {size}-byte records"),
            ));
        }
        Ok(len / size)
    }

    fn read_leafs(&self) -> Result<Vec<Leaf>, Diagnostic> {
        let f = self.format;
        let li = f.leafs_lump();
        let n = self.records(li, f.leaf_size())?;
        let b = self.lump(li);
        let mut out = Vec::with_capacity(n);
        for i in 0..n {
            let r = &b[i * f.leaf_size()..(i + 1) * f.leaf_size()];
            let short3 = |at: usize| [0, 1, 2].map(|k| f32::from(i16_at(r, at + 2 * k)));
            let float3 = |at: usize| [0, 1, 2].map(|k| f32_at(r, at + 4 * k));
            let leaf = match f {
                Format::Bsp29 | Format::HalfLife => Leaf {
                    visofs: i32_at(r, 4),
                    cluster: -1,
                    mins: short3(8),
                    maxs: short3(14),
                    first_mark: usize::from(u16_at(r, 20)),
                    marks: usize::from(u16_at(r, 22)),
                    ambient: [r[24], r[25], r[26], r[27]],
                },
                Format::Bsp2 => Leaf {
                    visofs: i32_at(r, 4),
                    cluster: -1,
                    mins: float3(8),
                    maxs: float3(20),
                    first_mark: u32_at(r, 32) as usize,
                    marks: u32_at(r, 36) as usize,
                    ambient: [r[40], r[41], r[42], r[43]],
                },
                Format::Bsp2Rmq => Leaf {
                    visofs: i32_at(r, 4),
                    cluster: -1,
                    mins: short3(8),
                    maxs: short3(14),
                    first_mark: u32_at(r, 20) as usize,
                    marks: u32_at(r, 24) as usize,
                    ambient: [r[28], r[29], r[30], r[31]],
                },
                Format::Quake2 => Leaf {
                    visofs: -1,
                    cluster: i32::from(i16_at(r, 4)),
                    mins: short3(8),
                    maxs: short3(14),
                    first_mark: 0,
                    marks: 0,
                    ambient: [0; 4],
                },
                Format::Qbism => Leaf {
                    visofs: -1,
                    cluster: i32_at(r, 4),
                    mins: float3(12),
                    maxs: float3(24),
                    first_mark: 0,
                    marks: 0,
                    ambient: [0; 4],
                },
            };
            out.push(leaf);
        }
        Ok(out)
    }

    /// Quake 2: how many clusters the leafs name.
    fn clusters(&self) -> Result<usize, Diagnostic> {
        let mut n = 0usize;
        for (i, l) in self.leafs.iter().enumerate() {
            if l.cluster < -1 {
                return Err(error::bad_index(
                    &self.path,
                    "leafs",
                    i,
                    format!(
                        "is in cluster {}; a cluster is -1 (none) or more",
                        l.cluster
                    ),
                ));
            }
            // More clusters than leafs is a damaged number, and rows are sized by it.
            if l.cluster as usize >= self.leafs.len() && l.cluster >= 0 {
                return Err(error::bad_index(
                    &self.path,
                    "leafs",
                    i,
                    format!(
                        "is in cluster {}, more clusters than the map has leafs ({})",
                        l.cluster,
                        self.leafs.len()
                    ),
                ));
            }
            n = n.max((l.cluster + 1) as usize);
        }
        Ok(n)
    }

    /// Hexen II's models are 80 bytes, Quake's 64; a lump both divide is taken for the one
    /// whose world model is consistent with the leafs (Quake's first).
    fn is_hexen2(&self) -> Result<bool, Diagnostic> {
        let len = self.lumps[Q1_MODELS].len;
        let (q1, h2) = (len % 64 == 0, len % 80 == 0);
        Ok(match (q1, h2) {
            (true, false) => false,
            (false, true) => true,
            (false, false) => {
                return Err(error::lump_range(
                    &self.path,
                    "models",
                    format!("has {len} bytes, a whole number of neither Quake's 64-byte nor Hexen II's 80-byte models"),
                ))
            }
            (true, true) => {
                let fits = |at: usize| {
                    let v = i32_at(self.lump(Q1_MODELS), at);
                    v >= 0 && (v as usize) < self.leafs.len()
                };
                !fits(52) && fits(68)
            }
        })
    }

    /// Quake 1 family: the world model's `visleafs`, which sizes every PVS row.
    fn visleafs(&self) -> Result<usize, Diagnostic> {
        let size = if self.hexen2 { 80 } else { 64 };
        if self.records(Q1_MODELS, size)? == 0 {
            return Err(error::lump_range(
                &self.path,
                "models",
                "is empty: the map has no world model".into(),
            ));
        }
        let v = i32_at(self.lump(Q1_MODELS), if self.hexen2 { 68 } else { 52 });
        if v < 0 || v as usize >= self.leafs.len() {
            return Err(error::bad_index(
                &self.path,
                "models",
                0,
                format!(
                    "(the world) says it has {v} visible leafs; the leafs lump holds {} leafs, leaf 0 among them",
                    self.leafs.len()
                ),
            ));
        }
        Ok(v as usize)
    }

    /// What follows the aligned end of the last lump.
    fn tail_of(&self) -> Result<Tail, Diagnostic> {
        let end = self
            .lumps
            .iter()
            .map(|l| l.offset + l.len)
            .max()
            .unwrap_or(0)
            .max(self.format.header_len());
        let start = end.div_ceil(4) * 4;
        let Some(rest) = self.bytes.get(start..).filter(|r| !r.is_empty()) else {
            return Ok(Tail::None);
        };
        if rest.len() < 8 || &rest[..4] != b"BSPX" {
            return Ok(Tail::Raw(rest.to_vec()));
        }
        let n = i32_at(rest, 4);
        if n < 0 || (n as usize).saturating_mul(32) > rest.len() - 8 {
            return Err(error::lump_range(
                &self.path,
                "BSPX",
                format!("claims {n} extension lumps, more than its table's bytes hold"),
            ));
        }
        let mut out = Vec::with_capacity(n as usize);
        for k in 0..n as usize {
            let e = &rest[8 + 32 * k..8 + 32 * (k + 1)];
            let mut name = [0u8; 24];
            name.copy_from_slice(&e[..24]);
            let (ofs, len) = (i32_at(e, 24), i32_at(e, 28));
            let shown = String::from_utf8_lossy(&name)
                .trim_end_matches('\0')
                .to_string();
            let inside = ofs >= 0 && len >= 0 && (ofs as usize + len as usize) <= self.bytes.len();
            if !inside {
                return Err(error::lump_range(
                    &self.path,
                    "BSPX",
                    format!("lump `{shown}` at byte {ofs} of {len} bytes lies outside the file"),
                ));
            }
            let (ofs, len) = (ofs as usize, len as usize);
            out.push((name, self.bytes[ofs..ofs + len].to_vec()));
        }
        Ok(Tail::Bspx(out))
    }
}

/// The Quake 1 family records ambient sounds read: marksurfaces, faces, texinfo, textures.
impl Bsp {
    /// The faces leaf `leaf` lists (through its marksurfaces).
    pub(crate) fn leaf_faces(&self, leaf: usize) -> Result<Vec<usize>, Diagnostic> {
        let l = self.leafs[leaf];
        let size = if self.format.wide() { 4 } else { 2 };
        let n = self.records(Q1_MARKSURFACES, size)?;
        if l.first_mark.checked_add(l.marks).is_none_or(|end| end > n) {
            return Err(error::bad_index(
                &self.path,
                "leafs",
                leaf,
                format!(
                    "lists marksurfaces {} to {}; the lump holds {n}",
                    l.first_mark,
                    l.first_mark.saturating_add(l.marks)
                ),
            ));
        }
        let b = self.lump(Q1_MARKSURFACES);
        Ok((l.first_mark..l.first_mark + l.marks)
            .map(|m| {
                if size == 4 {
                    u32_at(b, 4 * m) as usize
                } else {
                    usize::from(u16_at(b, 2 * m))
                }
            })
            .collect())
    }

    /// How many faces the faces lump holds.
    pub(crate) fn faces(&self) -> Result<usize, Diagnostic> {
        self.records(Q1_FACES, if self.format.wide() { 28 } else { 20 })
    }

    /// How many texinfo records there are.
    pub(crate) fn texinfos(&self) -> Result<usize, Diagnostic> {
        self.records(Q1_TEXINFO, 40)
    }

    /// Face `face`'s texinfo (`face` below [`Bsp::faces`]).
    pub(crate) fn face_texinfo(&self, face: usize) -> Result<usize, Diagnostic> {
        let b = self.lump(Q1_FACES);
        let t = if self.format.wide() {
            i32_at(b, 28 * face + 16)
        } else {
            i32::from(i16_at(b, 20 * face + 10))
        };
        let n = self.texinfos()?;
        if t < 0 || t as usize >= n {
            return Err(error::bad_index(
                &self.path,
                "faces",
                face,
                format!("has texinfo {t}; the texinfo lump holds {n}"),
            ));
        }
        Ok(t as usize)
    }

    /// Each texinfo's texture name (lower case, up to its NUL), `None` for a texture the
    /// textures lump leaves out (offset -1) or a texinfo naming none there.
    pub(crate) fn texinfo_names(&self) -> Result<Vec<Option<Vec<u8>>>, Diagnostic> {
        let tex = self.lump(Q1_TEXTURES);
        let count = if tex.len() >= 4 { i32_at(tex, 0) } else { 0 };
        if count < 0 || (count as usize).saturating_mul(4).saturating_add(4) > tex.len().max(4) {
            return Err(error::lump_range(
                &self.path,
                "textures",
                format!(
                    "claims {count} textures, more than its {} bytes hold",
                    tex.len()
                ),
            ));
        }
        let mut names = Vec::with_capacity(count as usize);
        for m in 0..count as usize {
            let ofs = i32_at(tex, 4 + 4 * m);
            let name = if ofs < 0 {
                None
            } else {
                let at = ofs as usize;
                let Some(raw) = tex.get(at..at + 16) else {
                    return Err(error::bad_index(
                        &self.path,
                        "textures",
                        m,
                        format!("starts at byte {at} of a {}-byte lump", tex.len()),
                    ));
                };
                let end = raw.iter().position(|&c| c == 0).unwrap_or(16);
                Some(raw[..end].to_ascii_lowercase())
            };
            names.push(name);
        }
        let info = self.lump(Q1_TEXINFO);
        let mut out = Vec::with_capacity(self.texinfos()?);
        for t in 0..self.texinfos()? {
            let m = i32_at(info, 40 * t + 32);
            let name = match usize::try_from(m).ok().and_then(|m| names.get(m)) {
                Some(n) => n.clone(),
                None if names.is_empty() => None,
                None => {
                    return Err(error::bad_index(
                        &self.path,
                        "texinfo",
                        t,
                        format!("names texture {m}; the textures lump holds {}", names.len()),
                    ))
                }
            };
            out.push(name);
        }
        Ok(out)
    }
}
