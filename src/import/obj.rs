//! Wavefront OBJ import.
//!
//! Hand-written rather than a crate because level work needs what general OBJ loaders drop:
//! `o` and `g` names kept apart (exporters write the scene tree into them, and room and portal
//! tags live in those names) and the line of every node, face and material, so that a finding
//! much later in the pipeline can still send the designer to the right line.
//!
//! Only positions, faces, names and material names are read; texture coordinates, normals and
//! smoothing carry nothing a cell-and-portal build uses.

mod text;

use std::collections::HashMap;
use std::path::Path;

use glam::{DMat4, DVec3};

use super::{ImportOptions, Imported};
use crate::diag::{Code, Diagnostic, Diagnostics, Location};
use crate::geom::triangulate::{triangulate_polygon, NotSimple};
use crate::scene::{
    Format, Material, MaterialId, Mesh, Node, NodeId, Precision, Primitive, Scene, SourceRef,
};

use text::{decode, strip_comment, tokens, trim};

/// Past this many per-item diagnostics of one kind, the rest are summed up in one, so a badly
/// broken export stays readable.
const MAX_REPORTED: usize = 20;

/// Longest statement text quoted back in a message.
const MAX_QUOTE: usize = 60;

/// Reads an OBJ from `bytes`; `path` names it in diagnostics.
pub fn import(
    bytes: &[u8],
    path: &Path,
    base_dir: &Path,
    opts: &ImportOptions,
) -> Result<Imported, Diagnostic> {
    text::check_text(bytes, path)?;
    let mut r = Reader::new(path, base_dir, opts);
    for (line, raw) in text::lines(bytes) {
        r.statement(line, &raw)?;
    }
    Ok(r.finish())
}

/// Faces gathered for one node; becomes its [`Mesh`].
#[derive(Default)]
struct MeshBuilder {
    /// File-wide vertex index → index in this mesh, so each mesh holds only what it uses.
    local: HashMap<u32, u32>,
    positions: Vec<DVec3>,
    triangles: Vec<[u32; 3]>,
    primitives: Vec<Primitive>,
}

/// A non-finite `v` and the faces dropped because of it.
struct NonFinite {
    line: usize,
    position: DVec3,
    faces: usize,
    first_face_line: usize,
    first_node: Option<NodeId>,
}

/// An unsupported keyword: how often, and where first.
struct Skipped {
    keyword: String,
    count: usize,
    first_line: usize,
}

struct Reader<'a> {
    path: &'a Path,
    base_dir: &'a Path,
    split_paths: bool,
    scene: Scene,
    diags: Diagnostics,
    /// Every `v` in the file, in order (OBJ indices are file-wide).
    positions: Vec<DVec3>,
    non_finite: HashMap<u32, NonFinite>,
    /// (parent, name) → node, so a repeated `o`/`g` name continues the same node.
    nodes_by_key: HashMap<(Option<NodeId>, String), NodeId>,
    builders: Vec<MeshBuilder>,
    object: Option<NodeId>,
    group: Option<NodeId>,
    /// Line of the `o`/`g` that selected the current node, to tell whether the material in
    /// effect was chosen for this node's faces or inherited from before it.
    select_line: usize,
    materials_by_name: HashMap<String, MaterialId>,
    material: Option<MaterialId>,
    material_line: Option<usize>,
    skipped: Vec<Skipped>,
    polygon_warnings: usize,
    /// How the vertex coordinates were written: how precise the file is.
    digits: Digits,
    stem: String,
    face: Vec<u32>,
}

impl<'a> Reader<'a> {
    fn new(path: &'a Path, base_dir: &'a Path, opts: &ImportOptions) -> Self {
        let stem = path
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .filter(|s| !s.is_empty() && s != "-")
            .unwrap_or_else(|| "obj".to_string());
        Reader {
            path,
            base_dir,
            split_paths: opts.obj_split_paths,
            scene: Scene::new(path.to_path_buf(), Format::Obj),
            diags: Diagnostics::default(),
            positions: Vec::new(),
            non_finite: HashMap::new(),
            nodes_by_key: HashMap::new(),
            builders: Vec::new(),
            object: None,
            group: None,
            select_line: 0,
            materials_by_name: HashMap::new(),
            material: None,
            material_line: None,
            skipped: Vec::new(),
            polygon_warnings: 0,
            digits: Digits::default(),
            stem,
            face: Vec::new(),
        }
    }

    fn at(&self, line: usize) -> Location {
        Location::file(self.path).with_line(line)
    }

    fn bad_statement(&self, line: usize, stmt: &[u8], why: &str) -> Diagnostic {
        Diagnostic::new(
            Code::OBJ_BAD_STATEMENT,
            format!("line {line}: cannot read `{}`: {why}", quote(stmt)),
            self.at(line),
        )
    }

    fn statement(&mut self, line: usize, raw: &[u8]) -> Result<(), Diagnostic> {
        let stmt = trim(strip_comment(raw));
        if stmt.is_empty() {
            return Ok(());
        }
        let kw_end = stmt
            .iter()
            .position(|b| b.is_ascii_whitespace())
            .unwrap_or(stmt.len());
        let (kw, rest) = (&stmt[..kw_end], trim(&stmt[kw_end..]));
        match kw {
            b"v" => self.vertex(line, stmt, rest),
            b"f" | b"fo" => self.face_statement(line, stmt, rest),
            b"o" => {
                self.object(line, rest);
                Ok(())
            }
            b"g" => {
                self.group(line, rest);
                Ok(())
            }
            b"usemtl" => {
                self.usemtl(line, rest);
                Ok(())
            }
            b"mtllib" => {
                self.mtllib(line, rest);
                Ok(())
            }
            // Attributes portcullis has no use for, and the body statements of free-form
            // geometry (already reported through its `curv`/`surf`).
            b"vt" | b"vn" | b"vp" | b"s" | b"mg" | b"cstype" | b"deg" | b"bmat" | b"step"
            | b"parm" | b"trim" | b"hole" | b"scrv" | b"sp" | b"end" | b"con" | b"lod"
            | b"bevel" | b"c_interp" | b"d_interp" | b"shadow_obj" | b"trace_obj" | b"ctech"
            | b"stech" | b"maplib" | b"usemap" | b"call" | b"csh" => Ok(()),
            _ if is_keyword(kw) => {
                self.skip(line, kw);
                Ok(())
            }
            _ => Err(self
                .bad_statement(line, stmt, "this is not an OBJ statement")
                .hint(
                    "each OBJ line starts with a keyword such as `v`, `f`, `o`, `g` or `usemtl`; \
                 fix or delete the line (a broken line break or a stray paste is common)",
                )),
        }
    }

    /// Lines, points, curves and unknown keywords: geometry this tool cannot use, counted so
    /// the user learns that part of the file was ignored.
    fn skip(&mut self, line: usize, kw: &[u8]) {
        let kw = decode(kw);
        match self.skipped.iter_mut().find(|s| s.keyword == kw) {
            Some(s) => s.count += 1,
            None => self.skipped.push(Skipped {
                keyword: kw,
                count: 1,
                first_line: line,
            }),
        }
    }

    fn vertex(&mut self, line: usize, stmt: &[u8], rest: &[u8]) -> Result<(), Diagnostic> {
        let mut xyz = [0.0f64; 3];
        let mut count = 0;
        for tok in tokens(rest) {
            let v = parse_f64(tok).ok_or_else(|| {
                let hint = if tok.contains(&b',') {
                    "use `.` as the decimal separator (the exporter may have used the system \
                     locale)"
                } else {
                    "a vertex is `v x y z` with optional `w` or `r g b`, all decimal numbers"
                };
                self.bad_statement(line, stmt, &format!("`{}` is not a number", quote(tok)))
                    .hint(hint)
            })?;
            if count < 3 {
                xyz[count] = v;
                self.digits.add(tok);
            }
            count += 1;
        }
        if !(3..=7).contains(&count) {
            return Err(self
                .bad_statement(
                    line,
                    stmt,
                    &format!("a vertex needs 3 coordinates (plus optional w or r g b), found {count} numbers"),
                )
                .hint("write the vertex as `v x y z`"));
        }
        if self.positions.len() >= u32::MAX as usize {
            return Err(self
                .bad_statement(line, stmt, "more than 4294967295 vertices")
                .hint("split the level into several files"));
        }
        let p = DVec3::from_array(xyz);
        if !p.is_finite() {
            self.non_finite.insert(
                self.positions.len() as u32,
                NonFinite {
                    line,
                    position: p,
                    faces: 0,
                    first_face_line: 0,
                    first_node: None,
                },
            );
        }
        self.positions.push(p);
        Ok(())
    }

    fn face_statement(&mut self, line: usize, stmt: &[u8], rest: &[u8]) -> Result<(), Diagnostic> {
        let mut face = std::mem::take(&mut self.face);
        face.clear();
        let res = self.parse_face(line, stmt, rest, &mut face);
        let res = res.map(|()| self.add_face(line, &face));
        self.face = face;
        res
    }

    fn parse_face(
        &self,
        line: usize,
        stmt: &[u8],
        rest: &[u8],
        face: &mut Vec<u32>,
    ) -> Result<(), Diagnostic> {
        for tok in tokens(rest) {
            let mut parts = tok.split(|&b| b == b'/');
            let v = parts.next().unwrap_or_default();
            let extra: Vec<&[u8]> = parts.collect();
            let malformed = || {
                self.bad_statement(
                    line,
                    stmt,
                    &format!("`{}` is not a vertex reference", quote(tok)),
                )
                .hint("face corners are `v`, `v/vt`, `v//vn` or `v/vt/vn`, with integer indices")
            };
            if extra.len() > 2
                || extra
                    .iter()
                    .any(|t| !t.is_empty() && parse_i64(t).is_none())
            {
                return Err(malformed());
            }
            let idx = parse_i64(v).ok_or_else(malformed)?;
            face.push(self.resolve(line, idx)?);
        }
        if face.len() < 3 {
            return Err(self
                .bad_statement(
                    line,
                    stmt,
                    &format!(
                        "a face needs at least 3 corners, this one has {}",
                        face.len()
                    ),
                )
                .hint("delete the face, or use `l` for a line (which portcullis ignores)"));
        }
        Ok(())
    }

    /// 1-based, or negative counting back from the last vertex read so far.
    fn resolve(&self, line: usize, idx: i64) -> Result<u32, Diagnostic> {
        let n = self.positions.len() as i64;
        let abs = if idx > 0 { idx - 1 } else { n + idx };
        if idx == 0 || abs < 0 || abs >= n {
            let what = if idx == 0 {
                "vertex index 0 (OBJ indices start at 1)".to_string()
            } else {
                format!("vertex {idx}")
            };
            return Err(Diagnostic::new(
                Code::OBJ_BAD_INDEX,
                format!(
                    "line {line}: a face refers to {what}, but only {n} vertices are defined \
                     before this line"
                ),
                self.at(line),
            )
            .hint(
                "indices are 1-based (or negative, counting back from the latest vertex) and \
                 must refer to a `v` above the face; the file may be truncated or concatenated \
                 from several exports without renumbering",
            ));
        }
        Ok(abs as u32)
    }

    /// The node faces go to now: the current group, else the object, else one named after
    /// the file (for files with no `o`/`g` at all).
    fn face_node(&mut self, line: usize) -> NodeId {
        if let Some(n) = self.group.or(self.object) {
            return n;
        }
        // Not made the current object: a later `g` is still "before any `o`", so top-level.
        let stem = self.stem.clone();
        self.child(None, &stem, line)
    }

    fn add_face(&mut self, line: usize, face: &[u32]) {
        let node = self.face_node(line);
        let bad: Vec<u32> = face
            .iter()
            .copied()
            .filter(|i| self.non_finite.contains_key(i))
            .collect();
        if !bad.is_empty() {
            for i in bad {
                if let Some(nf) = self.non_finite.get_mut(&i) {
                    if nf.faces == 0 {
                        nf.first_face_line = line;
                        nf.first_node = Some(node);
                    }
                    nf.faces += 1;
                }
            }
            return;
        }
        let tris = self.triangulate(line, node, face);
        let material = self.material;
        let prim_line = match self.material_line {
            Some(l) if l > self.select_line => l,
            _ => line,
        };
        let Some(b) = self.builders.get_mut(node) else {
            return;
        };
        let new_span = b.primitives.last().is_none_or(|p| p.material != material);
        if new_span {
            b.primitives.push(Primitive {
                material,
                first_triangle: b.triangles.len(),
                triangle_count: 0,
                source: SourceRef::line(prim_line),
                file: None,
            });
        }
        for t in &tris {
            let tri = t.map(|k| {
                let global = face[k];
                let next = b.positions.len() as u32;
                *b.local.entry(global).or_insert_with(|| {
                    b.positions.push(self.positions[global as usize]);
                    next
                })
            });
            b.triangles.push(tri);
        }
        if let Some(p) = b.primitives.last_mut() {
            p.triangle_count += tris.len();
        }
    }

    /// Triangles as corner indices into `face`.
    fn triangulate(&mut self, line: usize, node: NodeId, face: &[u32]) -> Vec<[usize; 3]> {
        let n = face.len();
        if n == 3 {
            return vec![[0, 1, 2]];
        }
        let pts: Vec<DVec3> = face.iter().map(|&i| self.positions[i as usize]).collect();
        let err = match triangulate_polygon(&pts) {
            Ok(t) => return t,
            Err(e) => e,
        };
        if err != NotSimple::Degenerate {
            self.polygon_warnings += 1;
            if self.polygon_warnings <= MAX_REPORTED {
                let why = match err {
                    NotSimple::TooLarge => {
                        format!("has {n} corners, too many to check for self-intersection")
                    }
                    NotSimple::Stuck => {
                        "could not be triangulated as a simple polygon (it may be far from flat)"
                            .to_string()
                    }
                    _ => "is self-intersecting (edges cross or touch in its plane)".to_string(),
                };
                self.diags.push(
                    Diagnostic::new(
                        Code::OBJ_POLYGON_SELF_INTERSECTING,
                        format!(
                            "line {line}: a {n}-sided face {why}; it was fan-triangulated, \
                             which may cover area outside the face"
                        ),
                        self.at(line).with_node(self.scene.node_path(node)),
                    )
                    .hint(
                        "split the face into simple, flat polygons or triangulate it in the \
                         modelling tool before export",
                    ),
                );
            }
        }
        // A zero-area face covers nothing whichever way it is cut; no need to bother the user.
        (1..n - 1).map(|i| [0, i, i + 1]).collect()
    }

    fn object(&mut self, line: usize, rest: &[u8]) {
        self.group = None;
        self.select_line = line;
        self.object = if rest.is_empty() {
            None
        } else {
            let name = decode(rest);
            Some(self.path_node(None, &name, line))
        };
    }

    fn group(&mut self, line: usize, rest: &[u8]) {
        self.select_line = line;
        let names: Vec<String> = tokens(rest).map(decode).collect();
        let name = names.join(" ");
        self.group = if name.is_empty() || name == "default" {
            None
        } else {
            Some(self.path_node(self.object, &name, line))
        };
    }

    /// Finds or makes the node for an `o`/`g` name under `parent`, splitting `a/b/c` into a
    /// chain when asked to, since exporters flatten scene trees into such names.
    fn path_node(&mut self, parent: Option<NodeId>, name: &str, line: usize) -> NodeId {
        let mut segments: Vec<&str> = if self.split_paths {
            name.split('/').filter(|s| !s.is_empty()).collect()
        } else {
            Vec::new()
        };
        if segments.is_empty() {
            segments.push(name);
        }
        let mut cur = parent;
        let mut id = 0;
        for seg in segments {
            id = self.child(cur, seg, line);
            cur = Some(id);
        }
        id
    }

    fn child(&mut self, parent: Option<NodeId>, name: &str, line: usize) -> NodeId {
        let key = (parent, name.to_string());
        if let Some(&id) = self.nodes_by_key.get(&key) {
            return id;
        }
        let id = self.scene.add_node(Node {
            name: Some(name.to_string()),
            parent,
            children: Vec::new(),
            world: DMat4::IDENTITY,
            mesh: None,
            extras: None,
            source: SourceRef::line(line),
        });
        self.builders.push(MeshBuilder::default());
        self.nodes_by_key.insert(key, id);
        id
    }

    fn usemtl(&mut self, line: usize, rest: &[u8]) {
        self.material_line = Some(line);
        if rest.is_empty() {
            self.material = None;
            return;
        }
        let name = decode(rest);
        let id = match self.materials_by_name.get(&name) {
            Some(&id) => id,
            None => {
                let id = self.scene.materials.len();
                self.scene.materials.push(Material {
                    name: Some(name.clone()),
                    extras: None,
                    double_sided: true,
                    source: SourceRef::line(line),
                });
                self.materials_by_name.insert(name, id);
                id
            }
        };
        self.material = Some(id);
    }

    /// Only existence is checked: portcullis needs material names, which `usemtl` gives, but a
    /// missing library usually means the level was copied without its companions.
    fn mtllib(&mut self, line: usize, rest: &[u8]) {
        if rest.is_empty() {
            return;
        }
        let whole = decode(rest);
        if self.base_dir.join(&whole).is_file() {
            return;
        }
        for tok in tokens(rest) {
            let name = decode(tok);
            let full = self.base_dir.join(&name);
            if !full.is_file() {
                self.diags.push(
                    Diagnostic::new(
                        Code::OBJ_MTL_MISSING,
                        format!(
                            "line {line}: material library `{name}` was not found (looked for `{}`)",
                            full.display()
                        ),
                        self.at(line),
                    )
                    .hint(
                        "copy the .mtl file next to the .obj; material names still come from \
                         `usemtl`, so the import itself is unaffected",
                    ),
                );
            }
        }
    }

    fn finish(mut self) -> Imported {
        let builders = std::mem::take(&mut self.builders);
        for (node, b) in builders.into_iter().enumerate() {
            if b.triangles.is_empty() {
                continue;
            }
            let mesh = self.scene.meshes.len();
            let n = &mut self.scene.nodes[node];
            self.scene.meshes.push(Mesh {
                name: n.name.clone(),
                positions: b.positions,
                triangles: b.triangles,
                primitives: b.primitives,
                extras: None,
                source: n.source.clone(),
            });
            n.mesh = Some(mesh);
        }
        self.scene.precision = self.digits.precision();
        self.report_non_finite();
        if !self.skipped.is_empty() {
            let list: Vec<String> = self
                .skipped
                .iter()
                .map(|s| format!("{} × `{}`", s.count, s.keyword))
                .collect();
            let first = self.skipped.iter().map(|s| s.first_line).min().unwrap_or(1);
            self.diags.push(
                Diagnostic::new(
                    Code::OBJ_UNSUPPORTED_STATEMENT,
                    format!(
                        "skipped statements that carry no faces: {} (first at line {first})",
                        list.join(", ")
                    ),
                    self.at(first),
                )
                .hint(
                    "only polygon faces (`f`) bound space; convert lines, points, curves or \
                     surfaces to meshes in the modelling tool if they should count",
                ),
            );
        }
        if self.polygon_warnings > MAX_REPORTED {
            self.diags.push(
                Diagnostic::new(
                    Code::OBJ_POLYGON_SELF_INTERSECTING,
                    format!(
                        "{} more faces were fan-triangulated for the same reason",
                        self.polygon_warnings - MAX_REPORTED
                    ),
                    Location::file(self.path),
                )
                .hint("triangulate the level in the modelling tool before export"),
            );
        }
        Imported {
            scene: self.scene,
            diagnostics: self.diags,
        }
    }

    fn report_non_finite(&mut self) {
        let mut used: Vec<(u32, &NonFinite)> = self
            .non_finite
            .iter()
            .filter(|(_, nf)| nf.faces > 0)
            .map(|(&i, nf)| (i, nf))
            .collect();
        used.sort_by_key(|(i, _)| *i);
        let mut out = Vec::new();
        for (i, nf) in used.iter().take(MAX_REPORTED) {
            let mut loc = Location::file(self.path).with_line(nf.line);
            if let Some(node) = nf.first_node {
                loc = loc.with_node(self.scene.node_path(node));
            }
            let p = nf.position;
            out.push(
                Diagnostic::new(
                    Code::GEOM_NON_FINITE,
                    format!(
                        "line {}: vertex {} is ({} {} {}); the {} face(s) using it were dropped, \
                         the first at line {}",
                        nf.line,
                        i + 1,
                        p.x,
                        p.y,
                        p.z,
                        nf.faces,
                        nf.first_face_line
                    ),
                    loc,
                )
                .hint(
                    "NaN or infinite coordinates usually come from a broken modifier or a \
                     division by zero in a script; fix or delete the vertex and re-export",
                ),
            );
        }
        if used.len() > MAX_REPORTED {
            let faces: usize = used[MAX_REPORTED..].iter().map(|(_, nf)| nf.faces).sum();
            out.push(
                Diagnostic::new(
                    Code::GEOM_NON_FINITE,
                    format!(
                        "{} more non-finite vertices; {faces} more face(s) were dropped",
                        used.len() - MAX_REPORTED
                    ),
                    Location::file(self.path),
                )
                .hint("fix the exporter or the modelling tool that writes NaN coordinates"),
            );
        }
        self.diags.extend(out);
    }
}

/// Keywords the OBJ family uses look like identifiers; anything else on a line is not OBJ.
fn is_keyword(kw: &[u8]) -> bool {
    kw.first().is_some_and(u8::is_ascii_alphabetic)
        && kw.iter().all(|b| b.is_ascii_alphanumeric() || *b == b'_')
}

fn parse_f64(tok: &[u8]) -> Option<f64> {
    std::str::from_utf8(tok).ok()?.parse().ok()
}

/// How the vertex coordinates were written: how many of them, the most significant digits
/// any has, and how many with each number of significant digits (17 and more together) that
/// go at least two places past the point.
#[derive(Default)]
struct Digits {
    total: u64,
    most: u32,
    fine: [u64; 18],
}

impl Digits {
    fn add(&mut self, tok: &[u8]) {
        let (digits, places) = written_digits(tok);
        self.total += 1;
        self.most = self.most.max(digits);
        if places >= 2 {
            self.fine[digits.min(17) as usize] += 1;
        }
    }

    /// What the digits say about the file: a writer that printed every coordinate to the
    /// same number of significant digits (`%g` keeps six) kept no more than that, and the
    /// tolerance must not assume it did. Its signature is numbers of every size using all
    /// those digits (or all but a trailing zero), well past the point (`2.99397`,
    /// `0.838305`). Files of round numbers (a hand-written `v 3 0 2.5`, or a shortest
    /// round-trip writer's `100004`) are exact as written: their f64 is all there is.
    fn precision(&self) -> Precision {
        let p = self.most.min(17) as usize;
        if !(5..17).contains(&p) {
            return Precision::Binary64;
        }
        if 3 * (self.fine[p] + self.fine[p - 1]) >= self.total {
            Precision::Decimal(p as u32)
        } else {
            Precision::Binary64
        }
    }
}

/// The significant digits of a decimal number as written, and how many places past the
/// point its last digit is (`-0.0012e3`: two digits, one place): the sign, the point, the
/// leading zeros and the exponent are not digits the writer kept.
fn written_digits(tok: &[u8]) -> (u32, i64) {
    let mut parts = tok.splitn(2, |&b| b == b'e' || b == b'E');
    let mantissa = parts.next().unwrap_or(tok);
    let exponent: i64 = parts
        .next()
        .and_then(|e| std::str::from_utf8(e).ok()?.parse().ok())
        .unwrap_or(0);
    let digits = mantissa.iter().filter(|b| b.is_ascii_digit());
    let significant = digits.skip_while(|&&b| b == b'0').count() as u32;
    let places = mantissa.iter().position(|&b| b == b'.').map_or(0, |dot| {
        mantissa[dot + 1..]
            .iter()
            .filter(|b| b.is_ascii_digit())
            .count()
    });
    // A hostile exponent (`1e-9223372036854775808`) saturates rather than overflows.
    (significant, (places as i64).saturating_sub(exponent))
}

fn parse_i64(tok: &[u8]) -> Option<i64> {
    std::str::from_utf8(tok).ok()?.parse().ok()
}

/// Statement text for a message: lossy, and cut short so one huge line cannot flood the output.
fn quote(b: &[u8]) -> String {
    let s = String::from_utf8_lossy(b);
    if s.chars().count() > MAX_QUOTE {
        let cut: String = s.chars().take(MAX_QUOTE).collect();
        format!("{cut}…")
    } else {
        s.into_owned()
    }
}
