//! No cell reaches into a brush (issue 66, item 4). Every cell of three shared brush maps
//! (E1M1-edited-ents, LibreQuake e3m4, retrojam1) is sampled, seeded, and every sample is
//! judged against the planes of the map's structural brushes as qbsp reads them, parsed here by
//! a parser of the test's own (it shares no code with `src/import/map`). The other way round,
//! no brush's centre may lie in a cell either: a brush loose enough to sit whole inside one
//! cell (a box on a floor, in a window slot) is found whatever the samples hit.
//!
//! Before world brushes were all structure, those nothing held were props, which the cell
//! around them kept: here E1M1 had 10 samples of 70,070 inside a brush (up to 201 mm deep) and
//! 7 brush centres in a cell, e3m4 10 of 59,372 (813 mm) and 2, retrojam1 11 of 48,788
//! (187 mm) and 13. Now none: no sample lies inside a brush by any depth.

mod common;

use std::path::Path;

use common::rng::SplitMix64;
use glam::DVec3;

/// Metres per map unit (Quake's inch), and the map's (x, y, z), Z up, in the level's frame
/// (Y up): (x, z, -y).
const INCH: f64 = 0.0254;

fn to_level(p: DVec3) -> DVec3 {
    DVec3::new(p.x, p.z, -p.y)
}

/// How deep (m) a point must lie behind every plane of a brush to count as inside it: far
/// above the levels' tolerance (checked), far below qbsp's 0.2-unit crack width (5 mm).
const DEPTH: f64 = 1e-4;

/// Samples drawn in each cell (besides its vertices' centre).
const PER_CELL: usize = 64;

/// One brush: its outward planes (level frame, metres), corners, bounds and source line.
struct Brush {
    planes: Vec<(DVec3, f64)>,
    lo: DVec3,
    hi: DVec3,
    centre: DVec3,
    line: usize,
}

impl Brush {
    /// How deep `p` lies inside (positive: behind every plane by that much).
    fn depth(&self, p: DVec3) -> f64 {
        self.planes
            .iter()
            .map(|(n, d)| d - n.dot(p))
            .fold(f64::INFINITY, f64::min)
    }
}

/// A brush face as written: three points and the texture name.
struct Face {
    points: [DVec3; 3],
    texture: String,
}

/// The map's entities: key/values and brushes (faces, first line).
struct Entity {
    keys: Vec<(String, String)>,
    brushes: Vec<(Vec<Face>, usize)>,
}

impl Entity {
    fn get(&self, key: &str) -> Option<&str> {
        self.keys
            .iter()
            .find(|(k, _)| k == key)
            .map(|(_, v)| v.as_str())
    }
}

/// The three numbers of each `( x y z )` on a face line, and the texture name after them.
fn face(line: &str) -> Option<Face> {
    let mut points = Vec::new();
    let mut rest = line;
    for _ in 0..3 {
        let open = rest.find('(')?;
        let close = open + rest[open..].find(')')?;
        let v: Vec<f64> = rest[open + 1..close]
            .split_whitespace()
            .map(|t| t.parse().ok())
            .collect::<Option<_>>()?;
        if v.len() != 3 {
            return None;
        }
        points.push(DVec3::new(v[0], v[1], v[2]));
        rest = &rest[close + 1..];
    }
    Some(Face {
        points: [points[0], points[1], points[2]],
        texture: rest.split_whitespace().next()?.to_string(),
    })
}

/// A Quake or Valve 220 map, line by line (editors write one face a line); other primitives
/// (patches, brushDef) are skipped whole.
fn parse(text: &str) -> Vec<Entity> {
    let mut out = Vec::new();
    let mut depth = 0usize;
    let mut skip = 0usize;
    let mut brush: Option<(Vec<Face>, usize)> = None;
    for (i, raw) in text.lines().enumerate() {
        let line = raw.split("//").next().unwrap_or("").trim();
        if line.is_empty() {
            continue;
        }
        if skip > 0 {
            skip += line.matches('{').count();
            skip -= line.matches('}').count().min(skip);
            if skip == 0 {
                depth -= 1;
            }
            continue;
        }
        match line {
            "{" => {
                depth += 1;
                match depth {
                    1 => out.push(Entity {
                        keys: Vec::new(),
                        brushes: Vec::new(),
                    }),
                    _ => brush = Some((Vec::new(), i + 1)),
                }
            }
            "}" => {
                if let Some(b) = brush.take() {
                    out.last_mut().expect("in an entity").brushes.push(b);
                }
                depth -= 1;
            }
            _ if depth == 1 && line.starts_with('"') => {
                let q: Vec<&str> = line.split('"').collect();
                if q.len() >= 4 {
                    let e = out.last_mut().expect("in an entity");
                    e.keys.push((q[1].to_string(), q[3].to_string()));
                }
            }
            _ if depth == 2 && line.starts_with('(') => {
                let f = face(line).unwrap_or_else(|| panic!("line {}: a face", i + 1));
                brush.as_mut().expect("in a brush").0.push(f);
            }
            _ if depth == 2 => {
                // `patchDef2`, `brushDef`: not a Quake brush; skipped to its closing brace.
                brush = None;
                skip = 1 + line.matches('{').count();
            }
            _ => {}
        }
    }
    out
}

/// Whether qbsp reads a brush of entity `e` as a structural solid: a world brush
/// (`worldspawn`, `func_group`) that is not liquid (a `*` texture), not a tool brush (a `clip`,
/// `origin` or `trigger` face, or hint and skip faces only).
fn structural(e: &Entity, faces: &[Face]) -> bool {
    if !matches!(e.get("classname"), Some("worldspawn" | "func_group")) {
        return false;
    }
    let tex: Vec<String> = faces.iter().map(|f| f.texture.to_lowercase()).collect();
    let tool = |t: &str| matches!(t, "clip" | "origin") || t.starts_with("trigger");
    let hint = |t: &str| matches!(t, "hint" | "hintskip" | "skip");
    !(tex.iter().any(|t| t.starts_with('*') || tool(t)) || tex.iter().all(|t| hint(t)))
}

/// A brush's outward planes as qbsp takes three points, `(p0 - p1) × (p2 - p1)`, and its
/// corners (every three planes' meeting point behind the rest), in the level's frame.
fn brush(faces: &[Face], line: usize) -> Brush {
    let planes: Vec<(DVec3, f64)> = faces
        .iter()
        .map(|f| {
            let [p0, p1, p2] = f.points.map(|p| to_level(p) * INCH);
            let n = (p0 - p1).cross(p2 - p1).normalize();
            (n, n.dot(p1))
        })
        .collect();
    let corners = common::corners(&planes, 1e-6);
    assert!(
        corners.len() >= 4,
        "the brush at line {line} encloses nothing"
    );
    let lo = corners.iter().fold(DVec3::INFINITY, |a, &p| a.min(p));
    let hi = corners.iter().fold(DVec3::NEG_INFINITY, |a, &p| a.max(p));
    let centre = corners.iter().sum::<DVec3>() / corners.len() as f64;
    Brush {
        planes,
        lo,
        hi,
        centre,
        line,
    }
}

/// The structural brushes of a map.
fn brushes(path: &Path) -> Vec<Brush> {
    let text = std::fs::read_to_string(path).unwrap();
    parse(&text)
        .iter()
        .flat_map(|e| {
            e.brushes
                .iter()
                .filter(|(faces, _)| structural(e, faces))
                .map(|(faces, line)| brush(faces, *line))
        })
        .collect()
}

/// The brushes by box: a uniform grid of `size` metres, each bucket listing the brushes whose
/// box meets it.
struct Grid {
    size: f64,
    buckets: std::collections::HashMap<[i64; 3], Vec<usize>>,
}

impl Grid {
    fn new(brushes: &[Brush], size: f64) -> Grid {
        let mut buckets: std::collections::HashMap<[i64; 3], Vec<usize>> = Default::default();
        let key = |p: DVec3| (p / size).floor().as_i64vec3().to_array();
        for (i, b) in brushes.iter().enumerate() {
            let (lo, hi) = (key(b.lo), key(b.hi));
            for x in lo[0]..=hi[0] {
                for y in lo[1]..=hi[1] {
                    for z in lo[2]..=hi[2] {
                        buckets.entry([x, y, z]).or_default().push(i);
                    }
                }
            }
        }
        Grid { size, buckets }
    }

    fn near(&self, p: DVec3) -> &[usize] {
        let k = (p / self.size).floor().as_i64vec3().to_array();
        self.buckets.get(&k).map_or(&[], Vec::as_slice)
    }
}

/// What one map gave.
struct Judged {
    cells: usize,
    brushes: usize,
    samples: usize,
    /// (cell, brush line, point, depth) of each sample inside a brush.
    inside: Vec<(usize, usize, DVec3, f64)>,
    /// (brush line, cell) of each brush whose centre lies in a cell.
    centres: Vec<(usize, usize)>,
    /// The deepest any sample lies inside a brush (negative: outside all by that much).
    deepest: f64,
}

/// Samples every cell of the map at `path` (seeded by `seed`) against its structural brushes.
fn judge(path: &Path, seed: u64) -> Judged {
    let brushes = brushes(path);
    let grid = Grid::new(&brushes, 2.0);
    let level = common::built(path, None);
    let tolerance = level.cells.tolerance.distance;
    assert!(
        tolerance * 10.0 < DEPTH,
        "{}: tolerance {tolerance} m",
        path.display()
    );
    let mut rng = SplitMix64::new(seed);
    let mut out = Judged {
        cells: level.cells.cells.len(),
        brushes: brushes.len(),
        samples: 0,
        inside: Vec::new(),
        centres: Vec::new(),
        deepest: f64::NEG_INFINITY,
    };
    for (ci, cell) in level.cells.cells.iter().enumerate() {
        let poly = &cell.poly;
        let corners: Vec<DVec3> = poly.faces.iter().flat_map(|f| f.points.clone()).collect();
        let mut points = vec![corners.iter().sum::<DVec3>() / corners.len() as f64];
        let (lo, hi) = (cell.bounds.min, cell.bounds.max);
        for _ in 0..PER_CELL * 64 {
            if points.len() > PER_CELL {
                break;
            }
            let p = lo + (hi - lo) * DVec3::new(rng.unit(), rng.unit(), rng.unit());
            if poly.faces.iter().all(|f| f.plane.distance(p) <= 0.0) {
                points.push(p);
            }
        }
        out.samples += points.len();
        for p in points {
            for &b in grid.near(p) {
                let d = brushes[b].depth(p);
                out.deepest = out.deepest.max(d);
                if d > DEPTH {
                    out.inside.push((ci, brushes[b].line, p, d));
                }
            }
        }
    }
    for b in &brushes {
        for (ci, cell) in level.cells.cells.iter().enumerate() {
            let (lo, hi) = (cell.bounds.min, cell.bounds.max);
            if b.centre.cmplt(lo).any() || b.centre.cmpgt(hi).any() {
                continue;
            }
            if cell
                .poly
                .faces
                .iter()
                .all(|f| f.plane.distance(b.centre) < -DEPTH)
            {
                out.centres.push((b.line, ci));
            }
        }
    }
    out
}

#[test]
fn no_cell_of_a_shared_brush_map_reaches_into_a_brush() {
    let dir = common::testmaps::dir();
    let maps = [
        "E1M1-edited-ents.map",
        "LibreQuake/lq1/maps/src/e3/e3m4.map",
        "retrojam1_ericw.map",
    ];
    if !maps.iter().all(|m| dir.join(m).is_file()) {
        eprintln!(
            "skipped: the shared brush maps are not at {} (set ERICW_TESTMAPS; CI has ../shared beside the clone)",
            dir.display()
        );
        return;
    }
    let mut wrong = Vec::new();
    for (k, name) in maps.iter().enumerate() {
        let j = judge(&dir.join(name), 66 + k as u64);
        eprintln!(
            "{name}: {} cells, {} samples, {} inside one of {} structural brushes (deepest {:.3} mm); {} brush centres in a cell",
            j.cells,
            j.samples,
            j.inside.len(),
            j.brushes,
            j.deepest * 1e3,
            j.centres.len()
        );
        for (cell, line, p, d) in j.inside.iter().take(5) {
            wrong.push(format!(
                "{name}: cell {cell} at ({:.3}, {:.3}, {:.3}) lies {:.1} mm inside the brush at line {line}",
                p.x,
                p.y,
                p.z,
                d * 1e3
            ));
        }
        for (line, cell) in j.centres.iter().take(5) {
            wrong.push(format!(
                "{name}: the brush at line {line} has its centre in cell {cell}"
            ));
        }
    }
    assert!(wrong.is_empty(), "{}", wrong.join("\n"));
}
