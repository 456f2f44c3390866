//! A reader for Quake-family brush maps (.map) that turns every brush into a closed triangle
//! mesh: an oracle for the tests, sharing no code with the crate (it calls nothing of
//! `portcullis`).
//!
//! Face lines are recognised one by one, whatever the file says about its format:
//!
//! - Quake standard: `( x y z ) ( x y z ) ( x y z ) TEXTURE xoff yoff rot xscale yscale`
//! - Valve 220: `( x y z ) ( x y z ) ( x y z ) TEXTURE [ ux uy uz uoff ] [ vx vy vz voff ] rot xscale yscale`
//! - Quake 2 (and Hexen 2, Quake 3): either of those followed by up to three more numbers
//!   (`contents flags value`) on the same line
//! - Quake 3 brush primitives (`brushDef { ... }`): the three points, then
//!   `( ( a b c ) ( d e f ) ) TEXTURE` and the optional numbers
//! - Doom 3 (`brushDef2`/`brushDef3 { ... }`): `( a b c d ) ( ( a b c ) ( d e f ) ) "TEXTURE"` and
//!   the optional numbers, the plane being `a*x + b*y + c*z + d = 0` with (a, b, c) pointing out
//!   of the brush (idPlane, as `idMapBrush::Parse` reads it), so `dist = -d`. Doom 3 writes an
//!   entity's brushes relative to its origin; they are returned as written.
//!
//! Patches (`patchDef2`, `patchDef3`) and any other `{ keyword { ... } }` primitive are skipped.
//! As in ericw-tools' parser (common/parser.cc), a token is a run of non-blank characters or a
//! quoted string, and a token starting `//` or `;` starts a comment to the end of the line. A
//! lone `{` or `}` is never a texture name; texture names such as `*water1`, `+0button`,
//! `e1u1/floor1_3`, `#lava` or Half-Life's `{grate` are single tokens.
//!
//! The plane of three points follows qbsp (ericw-tools, qbsp/map.cc and common/mapfile.cc,
//! `brush_t::parse_brush_face`):
//!
//! ```text
//! qvec3d ab = side.planepts[0] - side.planepts[1];
//! qvec3d cb = side.planepts[2] - side.planepts[1];
//! qvec3d normal = qv::normalize(qv::cross(ab, cb), length);
//! double dist = qv::dot(side.planepts[1], normal);
//! ```
//!
//! and that normal points out of the brush: the brush is the set of points behind every face.

use glam::DVec3;

/// One face of a brush: the plane `normal · p = dist`, the normal pointing out of the brush.
/// A face whose three points are collinear has a zero normal and a zero distance.
#[derive(Clone, Debug)]
pub struct Face {
    pub normal: DVec3,
    pub dist: f64,
    pub texture: String,
}

/// One brush: its faces as written, and its surface.
#[derive(Clone, Debug)]
pub struct Brush {
    pub faces: Vec<Face>,
    /// The 1-based line of the brush's `{`.
    pub line: usize,
    /// The closed surface, counter-clockwise seen from outside (`(b - a) × (c - a)` points out),
    /// in the map's own units and axes: each face's polygon as a fan. Nothing is shared between
    /// brushes; within a brush, vertices closer than 1e-5 are one point (bit for bit), so the
    /// faces meet exactly. Empty when the brush encloses no volume (fewer than four usable
    /// planes, unbounded, or flat).
    pub triangles: Vec<[DVec3; 3]>,
    /// One convex polygon per face that survived clipping, wound as the triangles, with the index
    /// of its face in `faces`. Empty when `triangles` is.
    pub polygons: Vec<(Vec<DVec3>, usize)>,
}

/// One entity: its key/value pairs in file order and its brushes.
#[derive(Clone, Debug)]
pub struct Entity {
    pub keys: Vec<(String, String)>,
    pub brushes: Vec<Brush>,
    /// The 1-based line of the entity's `{`.
    pub line: usize,
}

impl Entity {
    /// The value of `key`; the last one when the key is repeated (as Quake's tools do).
    pub fn get(&self, key: &str) -> Option<&str> {
        self.keys
            .iter()
            .rev()
            .find(|(k, _)| k == key)
            .map(|(_, v)| v.as_str())
    }

    /// The `classname`, or "" when there is none.
    pub fn classname(&self) -> &str {
        self.get("classname").unwrap_or("")
    }

    /// The `origin` key as three numbers, when it is there and well formed.
    pub fn origin(&self) -> Option<DVec3> {
        let v: Vec<f64> = self
            .get("origin")?
            .split_whitespace()
            .map(|s| s.parse::<f64>().ok().filter(|x| x.is_finite()))
            .collect::<Option<_>>()?;
        (v.len() == 3).then(|| DVec3::new(v[0], v[1], v[2]))
    }
}

impl Brush {
    /// Whether `p` is strictly inside the brush: behind every face plane by more than `margin`.
    /// Faces with no plane (collinear points) are ignored; a brush with no faces contains nothing.
    pub fn contains(&self, p: DVec3, margin: f64) -> bool {
        let mut any = false;
        for f in &self.faces {
            if f.normal == DVec3::ZERO {
                continue;
            }
            any = true;
            if f.normal.dot(p) - f.dist >= -margin {
                return false;
            }
        }
        any
    }
}

/// Quake units (inches, Z up) to metres, glTF Y up: (x, y, z) -> (x, z, -y) * 0.0254.
pub fn to_y_up_metres(p: DVec3) -> DVec3 {
    DVec3::new(p.x, p.z, -p.y) * 0.0254
}

/// Reads a whole .map file. A syntax error names its (1-based) line.
pub fn parse(text: &str) -> Result<Vec<Entity>, String> {
    let toks = tokenize(text)?;
    let mut p = Parser { toks, i: 0 };
    let mut entities = Vec::new();
    while let Some(t) = p.next() {
        // Doom 3 files start `Version 2`.
        if t.is("Version") && p.peek().is_some_and(|v| number(v).is_some()) {
            p.i += 1;
            continue;
        }
        if !t.is("{") {
            return Err(format!(
                "line {}: expected '{{' to open an entity, found {}",
                t.line,
                t.show()
            ));
        }
        entities.push(p.entity(t.line)?);
    }
    Ok(entities)
}

// ---------------------------------------------------------------------------------------------
// Tokens

#[derive(Clone, Debug)]
struct Tok {
    text: String,
    quoted: bool,
    line: usize,
}

impl Tok {
    /// An unquoted token spelled `s`.
    fn is(&self, s: &str) -> bool {
        !self.quoted && self.text == s
    }
    fn show(&self) -> String {
        if self.quoted {
            format!("\"{}\"", self.text)
        } else {
            format!("'{}'", self.text)
        }
    }
}

fn tokenize(text: &str) -> Result<Vec<Tok>, String> {
    let b = text.as_bytes();
    let mut toks = Vec::new();
    let (mut i, mut line) = (0, 1);
    while i < b.len() {
        let c = b[i];
        if c == b'\n' {
            line += 1;
            i += 1;
        } else if c <= b' ' {
            i += 1;
        } else if (c == b'/' && b.get(i + 1) == Some(&b'/')) || c == b';' {
            while i < b.len() && b[i] != b'\n' {
                i += 1;
            }
        } else if c == b'"' {
            let start_line = line;
            let start = i + 1;
            i += 1;
            loop {
                match b.get(i) {
                    None => {
                        return Err(format!(
                            "line {start_line}: end of file inside a quoted string"
                        ))
                    }
                    Some(b'"') => break,
                    // An escaped quote, unless it ends the line (qbsp: `"wad" "c:\foo\"`).
                    Some(b'\\')
                        if b.get(i + 1) == Some(&b'"')
                            && !matches!(b.get(i + 2), Some(b'\r' | b'\n') | None) =>
                    {
                        i += 2
                    }
                    Some(b'\n') => {
                        line += 1;
                        i += 1
                    }
                    Some(_) => i += 1,
                }
            }
            toks.push(Tok {
                text: String::from_utf8_lossy(&b[start..i]).into_owned(),
                quoted: true,
                line: start_line,
            });
            i += 1;
        } else {
            let start = i;
            while i < b.len() && b[i] > b' ' {
                i += 1;
            }
            toks.push(Tok {
                text: String::from_utf8_lossy(&b[start..i]).into_owned(),
                quoted: false,
                line,
            });
        }
    }
    Ok(toks)
}

fn number(t: &Tok) -> Option<f64> {
    if t.quoted {
        return None;
    }
    t.text.parse::<f64>().ok().filter(|x| x.is_finite())
}

// ---------------------------------------------------------------------------------------------
// Parser

struct Parser {
    toks: Vec<Tok>,
    i: usize,
}

/// How a brush block was written.
#[derive(Clone, Copy, PartialEq)]
enum Kind {
    /// `{ ( ... ) ... }`: Quake, Valve 220, Quake 2, or brush primitives without the keyword.
    Points,
    /// `{ brushDef { ... } }`: Quake 3 brush primitives.
    BrushDef,
    /// `{ brushDef2|brushDef3 { ... } }`: Doom 3 planes.
    BrushDef3,
}

/// A parsed face and the points that defined it (for the size of the starting polygons).
struct RawFace {
    face: Face,
    points: Vec<DVec3>,
}

impl Parser {
    fn next(&mut self) -> Option<Tok> {
        let t = self.toks.get(self.i).cloned();
        self.i += t.is_some() as usize;
        t
    }

    fn peek(&self) -> Option<&Tok> {
        self.toks.get(self.i)
    }

    fn last_line(&self) -> usize {
        self.toks.last().map_or(1, |t| t.line)
    }

    /// The next token, or an error naming the line where the file ended.
    fn need(&mut self, what: &str) -> Result<Tok, String> {
        let line = self.last_line();
        self.next()
            .ok_or_else(|| format!("line {line}: end of file while expecting {what}"))
    }

    fn expect(&mut self, s: &str) -> Result<Tok, String> {
        let t = self.need(&format!("'{s}'"))?;
        if t.is(s) {
            Ok(t)
        } else {
            Err(format!(
                "line {}: expected '{s}', found {}",
                t.line,
                t.show()
            ))
        }
    }

    fn num(&mut self, what: &str) -> Result<f64, String> {
        let t = self.need(what)?;
        number(&t).ok_or_else(|| format!("line {}: expected {what}, found {}", t.line, t.show()))
    }

    /// `( n n ... )` with `n` numbers.
    fn tuple(&mut self, n: usize) -> Result<Vec<f64>, String> {
        self.expect("(")?;
        let v = (0..n)
            .map(|_| self.num("a number"))
            .collect::<Result<Vec<_>, _>>()?;
        self.expect(")")?;
        Ok(v)
    }

    fn entity(&mut self, line: usize) -> Result<Entity, String> {
        let mut e = Entity {
            keys: Vec::new(),
            brushes: Vec::new(),
            line,
        };
        loop {
            let t = self.next().ok_or_else(|| {
                format!("line {line}: end of file inside the entity opened on this line")
            })?;
            if t.is("}") {
                return Ok(e);
            }
            if t.is("{") {
                if let Some(b) = self.brush(t.line)? {
                    e.brushes.push(b);
                }
                continue;
            }
            if !t.quoted && matches!(t.text.as_str(), "(" | ")" | "[" | "]") {
                return Err(format!(
                    "line {}: expected a key or '{{' or '}}', found {}",
                    t.line,
                    t.show()
                ));
            }
            let v = match self.next() {
                Some(v) if v.line == t.line && !(v.is("{") || v.is("}")) => v,
                _ => return Err(format!("line {}: key {} has no value", t.line, t.show())),
            };
            e.keys.push((t.text.trim().to_string(), v.text));
        }
    }

    /// The rest of a brush block after its `{`; `None` for a skipped primitive (a patch).
    fn brush(&mut self, line: usize) -> Result<Option<Brush>, String> {
        let first = self.peek().cloned().ok_or_else(|| {
            format!("line {line}: end of file inside the brush opened on this line")
        })?;
        let kind = if first.is("(") || first.is("}") {
            Kind::Points
        } else if first.quoted {
            return Err(format!(
                "line {}: expected a brush face or a primitive keyword, found {}",
                first.line,
                first.show()
            ));
        } else {
            self.i += 1;
            let kind = match first.text.to_ascii_lowercase().as_str() {
                "brushdef" => Kind::BrushDef,
                "brushdef2" | "brushdef3" => Kind::BrushDef3,
                _ => {
                    // patchDef2, patchDef3 or another primitive: skip `{ ... }` and the `}` after.
                    self.skip_block(&first)?;
                    self.expect("}")?;
                    return Ok(None);
                }
            };
            self.expect("{")?;
            kind
        };
        let mut raw = Vec::new();
        loop {
            let t = self.peek().cloned().ok_or_else(|| {
                format!("line {line}: end of file inside the brush opened on this line")
            })?;
            if t.is("}") {
                self.i += 1;
                break;
            }
            if kind == Kind::BrushDef3 && t.quoted {
                // A brush key/value pair (Doom 3 editors write them): skip.
                self.i += 1;
                self.need("a value")?;
                continue;
            }
            if !t.is("(") {
                return Err(format!(
                    "line {}: expected '(' to start a brush face or '}}', found {}",
                    t.line,
                    t.show()
                ));
            }
            raw.push(if kind == Kind::BrushDef3 {
                self.face_plane()?
            } else {
                self.face_points()?
            });
        }
        if kind != Kind::Points {
            self.expect("}")?;
        }
        Ok(Some(build(raw, line)))
    }

    /// Skips `{ ... }` (nested braces counted) after a primitive keyword.
    fn skip_block(&mut self, keyword: &Tok) -> Result<(), String> {
        let open = self.expect("{").map_err(|e| {
            format!(
                "{e} (after the primitive keyword {} on line {})",
                keyword.show(),
                keyword.line
            )
        })?;
        let mut depth = 1;
        while depth > 0 {
            let t = self.next().ok_or_else(|| {
                format!(
                    "line {}: end of file inside the {} block",
                    open.line, keyword.text
                )
            })?;
            if t.is("{") {
                depth += 1;
            } else if t.is("}") {
                depth -= 1;
            }
        }
        Ok(())
    }

    /// A texture name: any token but a brace, bracket or parenthesis.
    fn texture(&mut self) -> Result<Tok, String> {
        let t = self.need("a texture name")?;
        if !t.quoted && matches!(t.text.as_str(), "{" | "}" | "(" | ")" | "[" | "]") {
            return Err(format!(
                "line {}: expected a texture name, found {}",
                t.line,
                t.show()
            ));
        }
        Ok(t)
    }

    /// `( ( a b c ) ( d e f ) )`: a brush-primitives texture matrix.
    fn tex_matrix(&mut self) -> Result<(), String> {
        self.expect("(")?;
        self.tuple(3)?;
        self.tuple(3)?;
        self.expect(")")?;
        Ok(())
    }

    /// Up to three numbers (Quake 2 `contents flags value`) on `line`; a fourth is an error.
    /// Anything else is left for the caller (a `}` or the next face on the same line).
    fn trailing(&mut self, line: usize) -> Result<(), String> {
        let mut n = 0;
        while let Some(t) = self
            .peek()
            .filter(|t| t.line == line && number(t).is_some())
        {
            if n == 3 {
                return Err(format!(
                    "line {}: unexpected {} at the end of a brush face (more than three numbers \
                     after the texture definition)",
                    t.line,
                    t.show()
                ));
            }
            self.i += 1;
            n += 1;
        }
        Ok(())
    }

    /// A face given by three points, in any of the Quake-family texture styles.
    fn face_points(&mut self) -> Result<RawFace, String> {
        let mut pts = Vec::with_capacity(3);
        for _ in 0..3 {
            let v = self.tuple(3)?;
            pts.push(DVec3::new(v[0], v[1], v[2]));
        }
        // Brush primitives: the texture matrix comes before the name.
        let bp = self.peek().is_some_and(|t| t.is("("));
        if bp {
            self.tex_matrix()?;
        }
        let tex = self.texture()?;
        let mut last = tex.line;
        if !bp {
            if self.peek().is_some_and(|t| t.is("[")) {
                for _ in 0..2 {
                    self.expect("[")?;
                    for _ in 0..4 {
                        self.num("a Valve 220 texture axis number")?;
                    }
                    self.expect("]")?;
                }
                for _ in 0..3 {
                    self.num("a Valve 220 rotation or scale")?;
                }
            } else {
                for _ in 0..5 {
                    self.num("a texture offset, rotation or scale")?;
                }
            }
            last = self.toks[self.i - 1].line;
        }
        self.trailing(last)?;
        // qbsp: normal = (p0 - p1) × (p2 - p1), dist = p1 · normal.
        let n = (pts[0] - pts[1]).cross(pts[2] - pts[1]);
        let len = n.length();
        let (normal, dist) = if len < 1e-6 || !len.is_finite() {
            (DVec3::ZERO, 0.0)
        } else {
            let n = n / len;
            (n, pts[1].dot(n))
        };
        Ok(RawFace {
            face: Face {
                normal,
                dist,
                texture: tex.text,
            },
            points: pts,
        })
    }

    /// A Doom 3 face: `( a b c d ) ( ( .. ) ( .. ) ) "texture" [n n n]`.
    fn face_plane(&mut self) -> Result<RawFace, String> {
        let v = self.tuple(4)?;
        self.tex_matrix()?;
        let tex = self.texture()?;
        self.trailing(tex.line)?;
        let n = DVec3::new(v[0], v[1], v[2]);
        let len = n.length();
        let (normal, dist) = if len < 1e-6 {
            (DVec3::ZERO, 0.0)
        } else {
            (n / len, -v[3] / len)
        };
        Ok(RawFace {
            face: Face {
                normal,
                dist,
                texture: tex.text,
            },
            points: vec![normal * dist],
        })
    }
}

// ---------------------------------------------------------------------------------------------
// Geometry

/// A point is on a plane when within this distance of it (map units): small, so that faces are
/// cut where the planes really meet; vertices that then come out almost together (planes that
/// nearly meet at one point) are merged by [`MERGE`]. Tried on ericw-tools' testmaps and on
/// random brushes of up to a hundred planes: 1e-7 to 1e-6 leave every brush closed.
const ON_EPSILON: f64 = 1e-7;

/// Vertices of one brush closer than this are one vertex (map units): ten times the tests'
/// 1e-6 for matching vertices, so that no two vertices of a brush are near that limit.
const MERGE: f64 = 1e-5;

fn build(raw: Vec<RawFace>, line: usize) -> Brush {
    let faces: Vec<Face> = raw.iter().map(|r| r.face.clone()).collect();
    let mut brush = Brush {
        faces,
        line,
        triangles: Vec::new(),
        polygons: Vec::new(),
    };
    // The planes that count: a normal, and not a repeat of an earlier plane (qbsp drops both
    // a duplicate and an opposite plane; an opposite one leaves no volume and is caught below).
    let mut planes: Vec<usize> = Vec::new();
    for (i, f) in brush.faces.iter().enumerate() {
        if f.normal == DVec3::ZERO {
            continue;
        }
        let dup = planes.iter().any(|&j| {
            let g = &brush.faces[j];
            (g.normal - f.normal).abs().max_element() < 1e-6 && (g.dist - f.dist).abs() < 1e-4
        });
        if !dup {
            planes.push(i);
        }
    }
    if planes.len() < 4 {
        return brush;
    }
    // Starting polygons large enough to hold the brush, from the extent of its defining points.
    let extent = raw
        .iter()
        .flat_map(|r| r.points.iter())
        .map(|p| p.abs().max_element())
        .fold(0.0f64, f64::max);
    let size = (extent * 16.0).max(1_048_576.0);
    let mut polygons = Vec::new();
    for &i in &planes {
        let f = &brush.faces[i];
        let mut poly = base_polygon(f.normal, f.dist, size);
        for &j in &planes {
            if j == i {
                continue;
            }
            let g = &brush.faces[j];
            poly = clip_behind(&poly, g.normal, g.dist, j);
            if poly.len() < 3 {
                break;
            }
        }
        let poly = snap(&brush.faces, i, &poly);
        if poly.len() >= 3 && polygon_area(&poly) > 1e-12 {
            polygons.push((poly, i));
        }
    }
    // Faces meet at vertices computed in each face apart; where a vertex comes out a little
    // differently in two faces (rounding, or planes that nearly meet at one point), merge
    // vertices closer than MERGE, the first seen standing for the others.
    let mut seen: Vec<DVec3> = Vec::new();
    for (poly, _) in &mut polygons {
        for v in poly.iter_mut() {
            match seen.iter().find(|r| r.distance(*v) < MERGE) {
                Some(r) => *v = *r,
                None => seen.push(*v),
            }
        }
        poly.dedup();
        while poly.len() > 1 && poly.first() == poly.last() {
            poly.pop();
        }
    }
    polygons.retain(|(p, _)| p.len() >= 3 && polygon_area(p) > 1e-12);
    // Unbounded (a vertex still near the starting polygons' rim) or too few faces: no volume.
    let unbounded = polygons
        .iter()
        .flat_map(|(p, _)| p.iter())
        .any(|v| v.abs().max_element() > size * 0.25);
    if unbounded || polygons.len() < 4 {
        return brush;
    }
    let mut triangles = Vec::new();
    for (poly, _) in &polygons {
        for k in 1..poly.len() - 1 {
            triangles.push([poly[0], poly[k], poly[k + 1]]);
        }
    }
    let volume: f64 = triangles
        .iter()
        .map(|t| t[0].dot(t[1].cross(t[2])))
        .sum::<f64>()
        / 6.0;
    if volume <= 1e-9 {
        return brush;
    }
    brush.triangles = triangles;
    brush.polygons = polygons;
    brush
}

/// A polygon vertex, with the plane of the edge from it to the next vertex (`None` for the
/// edges of the starting square).
type Vertex = (DVec3, Option<usize>);

/// A square of half-size `size` on the plane, centred on the plane's point nearest the origin,
/// counter-clockwise seen from the side the normal points to.
fn base_polygon(n: DVec3, dist: f64, size: f64) -> Vec<Vertex> {
    let a = if n.x.abs() < 0.6 {
        DVec3::X
    } else if n.y.abs() < 0.6 {
        DVec3::Y
    } else {
        DVec3::Z
    };
    let u = (a - n * a.dot(n)).normalize();
    let v = n.cross(u); // u × v = n
    let c = n * dist;
    [(-u - v), (u - v), (u + v), (-u + v)]
        .into_iter()
        .map(|w| (c + w * size, None))
        .collect()
}

/// The part of a convex polygon behind plane `j` (`n · p = dist`), points within
/// [`ON_EPSILON`] of the plane kept; the new edge along the plane is labelled `j`.
fn clip_behind(poly: &[Vertex], n: DVec3, dist: f64, j: usize) -> Vec<Vertex> {
    let d: Vec<f64> = poly.iter().map(|(p, _)| n.dot(*p) - dist).collect();
    if d.iter().all(|&x| x <= ON_EPSILON) {
        return poly.to_vec();
    }
    if d.iter().all(|&x| x >= -ON_EPSILON) {
        return Vec::new();
    }
    let mut out = Vec::with_capacity(poly.len() + 1);
    for k in 0..poly.len() {
        let ((p, label), dp) = (poly[k], d[k]);
        let (q, dq) = (poly[(k + 1) % poly.len()].0, d[(k + 1) % poly.len()]);
        if dp <= ON_EPSILON {
            // A kept point whose edge runs into the front: on the plane, the edge from it now
            // runs along the plane; behind it, the edge keeps its plane up to the crossing.
            let on = dp >= -ON_EPSILON;
            out.push((
                p,
                if on && dq > ON_EPSILON {
                    Some(j)
                } else {
                    label
                },
            ));
        }
        if dp < -ON_EPSILON && dq > ON_EPSILON {
            out.push((p + (q - p) * (dp / (dp - dq)), Some(j)));
        } else if dp > ON_EPSILON && dq < -ON_EPSILON {
            out.push((p + (q - p) * (dp / (dp - dq)), label));
        }
    }
    out
}

/// The polygon of face `i` with each vertex moved to the meeting point of its three planes
/// (face `i` and its two edges' planes), computed from the sorted plane indices so that every
/// face sharing the vertex gets the same bits. A vertex whose planes meet badly (nearly
/// parallel, or a solution far from the clipped point) is left where clipping put it.
/// Repeated vertices are dropped.
fn snap(faces: &[Face], i: usize, poly: &[Vertex]) -> Vec<DVec3> {
    let mut out: Vec<DVec3> = Vec::with_capacity(poly.len());
    for k in 0..poly.len() {
        let (p, after) = poly[k];
        let before = poly[(k + poly.len() - 1) % poly.len()].1;
        let mut v = p;
        if let (Some(a), Some(b)) = (before, after) {
            if a != b && a != i && b != i {
                let mut t = [i, a, b];
                t.sort_unstable();
                let (f1, f2, f3) = (&faces[t[0]], &faces[t[1]], &faces[t[2]]);
                let c23 = f2.normal.cross(f3.normal);
                let det = f1.normal.dot(c23);
                if det.abs() > 1e-9 {
                    let x = (c23 * f1.dist
                        + f3.normal.cross(f1.normal) * f2.dist
                        + f1.normal.cross(f2.normal) * f3.dist)
                        / det;
                    if x.distance(p) < 1e-3 {
                        v = x;
                    }
                }
            }
        }
        if out.last() != Some(&v) {
            out.push(v);
        }
    }
    while out.len() > 1 && out.first() == out.last() {
        out.pop();
    }
    out
}

fn polygon_area(poly: &[DVec3]) -> f64 {
    let mut s = DVec3::ZERO;
    for k in 1..poly.len() - 1 {
        s += (poly[k] - poly[0]).cross(poly[k + 1] - poly[0]);
    }
    s.length() * 0.5
}

/// ericw-tools' `testmaps/` folder: `ERICW_TESTMAPS`, or the copy beside the project in
/// `../shared/levels/ericw-tools/testmaps` (the maps are ericw-tools', GPL, not shipped here).
pub fn testmaps_dir() -> std::path::PathBuf {
    std::env::var_os("ERICW_TESTMAPS")
        .map(std::path::PathBuf::from)
        .unwrap_or_else(|| {
            std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("../shared/levels/ericw-tools/testmaps")
        })
}

/// What a brush-map benchmark runs on: the maps folder and the `.map` names given on the
/// command line (E1M1 and qbspfeatures by default); `None`, said why, without the folder.
pub fn maps_to_bench() -> Option<(std::path::PathBuf, Vec<String>)> {
    let dir = testmaps_dir();
    if !dir.is_dir() {
        eprintln!("set ERICW_TESTMAPS to ericw-tools' testmaps folder (the maps are not shipped)");
        return None;
    }
    let mut maps: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| a.ends_with(".map"))
        .collect();
    if maps.is_empty() {
        maps = vec!["E1M1-edited-ents.map".into(), "qbspfeatures.map".into()];
    }
    Some((dir, maps))
}
