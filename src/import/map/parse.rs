//! The text of a brush map: entities of key/value pairs and brushes of faces, in the formats
//! of the Quake family, told apart face by face (not by the file's extension or a header):
//!
//! - Quake: `( x y z ) ( x y z ) ( x y z ) TEXTURE xoff yoff rot xscale yscale`
//! - Valve 220: `... TEXTURE [ ux uy uz uoff ] [ vx vy vz voff ] rot xscale yscale`
//! - Quake 2 (and Quake 3, Hexen 2): either, followed on the same line by up to three more
//!   numbers (`contents flags value`)
//! - Quake 3 brush primitives (`brushDef { ... }`): the three points, `( ( ... ) ( ... ) )
//!   TEXTURE contents flags value`
//! - id Tech 4 (`brushDef3 { ... }`, also `brushDef2`): `( a b c d ) ( ( ... ) ( ... ) )
//!   "TEXTURE" ...`, the plane `a x + b y + c z + d = 0` with `(a, b, c)` out of the brush
//!
//! `patchDef2`/`patchDef3` and any other `{ keyword { ... } }` primitive are skipped and
//! counted. As in qbsp's tokenizer, a token is a run of non-blank characters or a quoted
//! string, and `//` starts a comment to the end of the line, so texture names such as
//! `*water1`, `+0button` or `{grate` are single tokens.

/// A token and the 1-based line it starts on.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Tok<'a> {
    pub text: &'a str,
    pub quoted: bool,
    pub line: usize,
}

/// One face: its plane, the normal out of the brush (`normal · p = dist`), and texture.
#[derive(Debug, Clone)]
pub(super) struct Face {
    pub normal: [f64; 3],
    pub dist: f64,
    pub texture: String,
    /// Quake 2 contents bits, when the face gives them.
    pub contents: Option<i64>,
}

/// A brush: its faces and where it starts.
#[derive(Debug, Clone)]
pub(super) struct Brush {
    pub faces: Vec<Face>,
    pub line: usize,
    /// An id Tech 4 brush (`brushDef3`): written relative to its entity's `origin`.
    pub relative: bool,
}

/// An entity: its keys in file order and its brushes.
#[derive(Debug, Clone)]
pub(super) struct Entity {
    pub keys: Vec<(String, String)>,
    pub brushes: Vec<Brush>,
    pub line: usize,
}

impl Entity {
    /// The value of `key`; the last when it is repeated, as Quake's tools read it.
    pub fn get(&self, key: &str) -> Option<&str> {
        self.keys
            .iter()
            .rev()
            .find(|(k, _)| k == key)
            .map(|(_, v)| v.as_str())
    }

    pub fn classname(&self) -> &str {
        self.get("classname").unwrap_or("")
    }
}

/// What went wrong, and on which line.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Error {
    pub line: usize,
    pub message: String,
    /// The brush's geometry, not the text, is wrong (collinear points).
    pub brush: bool,
}

/// The map's entities, and how many patches and other primitives were skipped.
pub(super) fn parse(text: &str) -> Result<(Vec<Entity>, usize), Error> {
    let toks = tokens(text)?;
    let mut p = Parser {
        toks,
        at: 0,
        skipped: 0,
    };
    // id Tech 4 maps open with their version (`Version 2`: Doom 3; `Version 3`: Quake 4).
    if p.peek().is_some_and(|t| !t.quoted && t.text == "Version") {
        p.at += 1;
        p.number()?;
    }
    let mut out = Vec::new();
    while p.peek().is_some() {
        out.push(p.entity()?);
    }
    Ok((out, p.skipped))
}

fn tokens(text: &str) -> Result<Vec<Tok<'_>>, Error> {
    let mut out = Vec::new();
    for (k, line) in text.lines().enumerate() {
        let n = k + 1;
        let mut rest = line;
        loop {
            rest = rest.trim_start();
            if rest.is_empty() || rest.starts_with("//") {
                break;
            }
            if let Some(q) = rest.strip_prefix('"') {
                let Some(end) = q.find('"') else {
                    return Err(err(n, "a quoted string is not closed on its line"));
                };
                out.push(Tok {
                    text: &q[..end],
                    quoted: true,
                    line: n,
                });
                rest = &q[end + 1..];
            } else {
                let end = rest.find(char::is_whitespace).unwrap_or(rest.len());
                out.push(Tok {
                    text: &rest[..end],
                    quoted: false,
                    line: n,
                });
                rest = &rest[end..];
            }
        }
    }
    Ok(out)
}

fn err(line: usize, message: impl Into<String>) -> Error {
    Error {
        line,
        message: message.into(),
        brush: false,
    }
}

struct Parser<'a> {
    toks: Vec<Tok<'a>>,
    at: usize,
    skipped: usize,
}

impl<'a> Parser<'a> {
    fn peek(&self) -> Option<&Tok<'a>> {
        self.toks.get(self.at)
    }

    fn last_line(&self) -> usize {
        self.toks.last().map_or(1, |t| t.line)
    }

    fn next(&mut self, what: &str) -> Result<Tok<'a>, Error> {
        let t = self.toks.get(self.at).cloned().ok_or_else(|| {
            err(
                self.last_line(),
                format!("the file ends where {what} was expected (a brace is not closed)"),
            )
        })?;
        self.at += 1;
        Ok(t)
    }

    fn expect(&mut self, want: &str) -> Result<Tok<'a>, Error> {
        let t = self.next(&format!("`{want}`"))?;
        if t.text != want || t.quoted {
            return Err(err(
                t.line,
                format!("`{want}` expected, found `{}`", t.text),
            ));
        }
        Ok(t)
    }

    fn number(&mut self) -> Result<f64, Error> {
        let t = self.next("a number")?;
        let v: f64 = t
            .text
            .parse()
            .map_err(|_| err(t.line, format!("a number expected, found `{}`", t.text)))?;
        if !v.is_finite() {
            return Err(err(
                t.line,
                format!("the number `{}` is not finite", t.text),
            ));
        }
        Ok(v)
    }

    fn is_number(t: Option<&Tok<'_>>, line: usize) -> bool {
        t.is_some_and(|t| !t.quoted && t.line == line && t.text.parse::<f64>().is_ok())
    }

    fn entity(&mut self) -> Result<Entity, Error> {
        let open = self.expect("{")?;
        let mut e = Entity {
            keys: Vec::new(),
            brushes: Vec::new(),
            line: open.line,
        };
        loop {
            let t = self.next("`}` closing the entity")?;
            match (t.text, t.quoted) {
                ("}", false) => return Ok(e),
                ("{", false) => {
                    if let Some(b) = self.brush(t.line)? {
                        e.brushes.push(b);
                    }
                }
                (_, true) => {
                    let v = self.next("a value")?;
                    if !v.quoted {
                        return Err(err(
                            v.line,
                            format!("the value of key `{}` must be quoted", t.text),
                        ));
                    }
                    e.keys.push((t.text.to_string(), v.text.to_string()));
                }
                _ => {
                    return Err(err(
                        t.line,
                        format!("a quoted key, `{{` or `}}` expected, found `{}`", t.text),
                    ))
                }
            }
        }
    }

    /// A brush after its `{`; `None` for a skipped primitive (a patch).
    fn brush(&mut self, line: usize) -> Result<Option<Brush>, Error> {
        let mut b = Brush {
            faces: Vec::new(),
            line,
            relative: false,
        };
        match self.peek().map(|t| (t.text, t.quoted)) {
            Some(("brushDef3", false)) | Some(("brushDef2", false)) => {
                self.at += 1;
                b.relative = true;
                self.expect("{")?;
                while self.peek().is_some_and(|t| t.text != "}" || t.quoted) {
                    if self.peek().is_some_and(|t| t.quoted) {
                        // A brush key/value pair (Doom 3 writes some).
                        self.at += 2;
                        continue;
                    }
                    b.faces.push(self.face_plane()?);
                }
                self.expect("}")?;
                self.expect("}")?;
                return Ok(Some(b));
            }
            Some(("brushDef", false)) => {
                // Quake 3 brush primitives: three points, a texture matrix, the texture.
                self.at += 1;
                self.expect("{")?;
                while self.peek().is_some_and(|t| t.text != "}" || t.quoted) {
                    b.faces.push(self.face_primitive()?);
                }
                self.expect("}")?;
                self.expect("}")?;
                return Ok(Some(b));
            }
            Some((word, false)) if word != "(" && word != "}" => {
                // patchDef2, patchDef3 and other primitives: skipped whole, braces balanced.
                self.skip_block(line)?;
                self.skipped += 1;
                return Ok(None);
            }
            _ => {}
        }
        loop {
            let t = self.peek().cloned().ok_or_else(|| {
                err(
                    self.last_line(),
                    "the file ends inside a brush (a `}` is missing)",
                )
            })?;
            if t.text == "}" && !t.quoted {
                self.at += 1;
                return Ok(Some(b));
            }
            b.faces.push(self.face_points()?);
        }
    }

    fn skip_block(&mut self, line: usize) -> Result<(), Error> {
        let mut depth = 1;
        while depth > 0 {
            let t = self
                .toks
                .get(self.at)
                .ok_or_else(|| err(line, "the file ends inside a patch (a `}` is missing)"))?;
            self.at += 1;
            if !t.quoted {
                match t.text {
                    "{" => depth += 1,
                    "}" => depth -= 1,
                    _ => {}
                }
            }
        }
        Ok(())
    }

    fn point(&mut self) -> Result<[f64; 3], Error> {
        self.expect("(")?;
        let p = [self.number()?, self.number()?, self.number()?];
        self.expect(")")?;
        Ok(p)
    }

    /// A face of three points (Quake, Valve 220, Quake 2).
    fn face_points(&mut self) -> Result<Face, Error> {
        let line = self.peek().map_or(0, |t| t.line);
        let (a, b, c) = (self.point()?, self.point()?, self.point()?);
        let tex = self.next("a texture name")?;
        if tex.text == "(" || tex.text == "[" || tex.text == "}" {
            return Err(err(
                tex.line,
                format!("a texture name expected, found `{}`", tex.text),
            ));
        }
        if self.peek().is_some_and(|t| t.text == "[" && !t.quoted) {
            for _ in 0..2 {
                self.expect("[")?;
                for _ in 0..4 {
                    self.number()?;
                }
                self.expect("]")?;
            }
            for _ in 0..3 {
                self.number()?;
            }
        } else {
            for _ in 0..5 {
                self.number()?;
            }
        }
        // Quake 2 contents, flags, value (and a Hexen 2 light value) on the same line.
        let contents = self.contents(tex.line, 4)?;
        face_through([a, b, c], tex.text, contents, line)
    }

    /// Up to `most` numbers after a face's texture on its line (`contents flags value`):
    /// the first, the contents, if any.
    fn contents(&mut self, line: usize, most: usize) -> Result<Option<i64>, Error> {
        let mut first = None;
        for _ in 0..most {
            if !Self::is_number(self.peek(), line) {
                break;
            }
            let x = self.number()?;
            first = first.or(Some(x as i64));
        }
        Ok(first)
    }

    /// `( ( a b c ) ( d e f ) )`: a texture matrix (Quake 3 and id Tech 4), not read.
    fn texture_matrix(&mut self) -> Result<(), Error> {
        self.expect("(")?;
        for _ in 0..2 {
            self.expect("(")?;
            for _ in 0..3 {
                self.number()?;
            }
            self.expect(")")?;
        }
        self.expect(")")?;
        Ok(())
    }

    /// A face of a Quake 3 `brushDef`: three points, a texture matrix, the texture and its
    /// contents, flags and value (contents 0, as Radiant writes most faces, say nothing: the
    /// texture's name decides then, as for Quake).
    fn face_primitive(&mut self) -> Result<Face, Error> {
        let line = self.peek().map_or(0, |t| t.line);
        let (a, b, c) = (self.point()?, self.point()?, self.point()?);
        self.texture_matrix()?;
        let tex = self.next("a texture name")?;
        let contents = self.contents(tex.line, 3)?.filter(|&c| c != 0);
        face_through([a, b, c], tex.text, contents, line)
    }

    /// A face of a plane equation (id Tech 4).
    fn face_plane(&mut self) -> Result<Face, Error> {
        let line = self.peek().map_or(0, |t| t.line);
        self.expect("(")?;
        let (a, b, c, d) = (
            self.number()?,
            self.number()?,
            self.number()?,
            self.number()?,
        );
        self.expect(")")?;
        self.texture_matrix()?;
        let tex = self.next("a texture name")?;
        while Self::is_number(self.peek(), tex.line) {
            self.number()?;
        }
        let len = (a * a + b * b + c * c).sqrt();
        if len == 0.0 {
            return Err(Error {
                line,
                message: "the face's plane has no normal".into(),
                brush: true,
            });
        }
        Ok(Face {
            normal: [a / len, b / len, c / len],
            dist: -d / len,
            texture: tex.text.to_string(),
            contents: None,
        })
    }
}

/// The face on the plane through three points, its normal `(a - b) × (c - b)` out of the brush
/// (qbsp's rule); collinear points are the brush's error.
fn face_through(
    [a, b, c]: [[f64; 3]; 3],
    texture: &str,
    contents: Option<i64>,
    line: usize,
) -> Result<Face, Error> {
    let (u, v) = (sub(a, b), sub(c, b));
    let n = cross(u, v);
    let len = dot(n, n).sqrt();
    let scale = dot(u, u).sqrt() * dot(v, v).sqrt();
    let flat = !len.is_finite() || len <= 1e-12 * scale.max(1e-300) || len == 0.0;
    let far = [a, b, c]
        .iter()
        .flatten()
        .fold(0.0f64, |m, x| m.max(x.abs()));
    if flat && (far.is_nan() || far >= super::WORLD) {
        // Points so far out that their differences round away: the distance is the fault.
        return Err(Error {
            line,
            message: format!(
                "a point of the face lies {far:e} units from the origin, beyond ±{}: too far out to give a plane (the engines of the Quake family reach ±32768)",
                super::WORLD
            ),
            brush: true,
        });
    }
    if flat {
        return Err(Error {
            line,
            message: "the face's three points are collinear: they give no plane".into(),
            brush: true,
        });
    }
    let normal = [n[0] / len, n[1] / len, n[2] / len];
    Ok(Face {
        normal,
        dist: dot(normal, b),
        texture: texture.to_string(),
        contents,
    })
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn faces_in_each_format_read_alike() {
        let text = r#"{
"classname" "worldspawn"
{
( 0 0 0 ) ( 0 1 0 ) ( 0 0 1 ) a 0 0 0 1 1
( 0 0 0 ) ( 0 1 0 ) ( 0 0 1 ) b [ 0 1 0 0 ] [ 0 0 -1 0 ] 0 1 1
( 0 0 0 ) ( 0 1 0 ) ( 0 0 1 ) *water 0 0 0 1 1 8 0 0
}
{
brushDef3
{
( -1 0 0 0 ) ( ( 1 0 0 ) ( 0 1 0 ) ) "textures/x" 0 0 0
}
}
{
patchDef2
{
"t" ( 3 3 0 0 0 ) ( ( ( 0 0 0 0 0 ) ) )
}
}
}
"#;
        let (es, skipped) = parse(text).unwrap();
        assert_eq!(skipped, 1);
        let f = &es[0].brushes[0].faces;
        // The normal of (p0 - p1) x (p2 - p1) for these points: -x.
        for face in f {
            assert_eq!(face.normal, [-1.0, 0.0, 0.0]);
            assert_eq!(face.dist, 0.0);
        }
        assert_eq!(f[2].contents, Some(8));
        assert_eq!(es[0].brushes[1].faces[0].normal, [-1.0, 0.0, 0.0]);
    }

    #[test]
    fn errors_name_their_line() {
        for (text, line) in [
            ("{\n\"classname\" \"worldspawn\"\n{\n( 0 0 0 ) ( 1 1 1 ) ( 2 2 2 ) t 0 0 0 1 1\n}\n}\n", 4),
            ("{\n\"classname\" \"worldspawn\"\n", 2),
            ("{\n{\n( 0 0 nan ) ( 1 0 0 ) ( 0 1 0 ) t 0 0 0 1 1\n}\n}\n", 3),
            ("{\n{\n( 0 0 0 ) ( 1 0 0 ) ( 0 1 0 ) t [ 1 0 0 ] 0 0\n}\n}\n", 3),
            ("}\n", 1),
        ] {
            let e = parse(text).unwrap_err();
            assert_eq!(e.line, line, "{text}: {}", e.message);
        }
    }
}
