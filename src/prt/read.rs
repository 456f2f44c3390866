//! Parsing .prt text. Every problem is a diagnostic with the line it is on and a hint; no
//! input panics, and counts from the file are checked before anything is sized by them.

use std::path::Path;

use glam::DVec3;

use crate::diag::{Code, Diagnostic, Location};
use crate::geom::plane::Plane;
use crate::vis::{VisGraph, VisPortal};

/// Which dialect of the Quake portal file a `.prt` is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PrtFormat {
    /// Quake's: one leaf per cell.
    Prt1,
    /// Quake 2's clusters: leaves grouped into the cells of the graph.
    Prt2,
    /// PRT1 with clusters: a leaf-to-cluster table, the portal lines naming clusters.
    Prt1Am,
}

impl PrtFormat {
    /// The file's first line for this format.
    pub fn header(self) -> &'static str {
        match self {
            PrtFormat::Prt1 => "PRT1",
            PrtFormat::Prt2 => "PRT2",
            PrtFormat::Prt1Am => "PRT1-AM",
        }
    }
}

/// One portal line: a polygon between two cells.
#[derive(Debug, Clone, PartialEq)]
pub struct PrtPortal {
    /// The cell the plane faces into.
    pub a: usize,
    /// The cell on the plane's back side.
    pub b: usize,
    /// The polygon's vertices, as written.
    pub points: Vec<DVec3>,
    /// 1-based line in the file.
    pub line: usize,
}

/// A parsed `.prt`: a portal graph without geometry for the cells.
#[derive(Debug, Clone, PartialEq)]
pub struct PrtFile {
    /// The dialect the header named.
    pub format: PrtFormat,
    /// Cells of the graph: clusters for PRT2 and PRT1-AM.
    pub cells: usize,
    /// Leaves (PRT2, PRT1-AM); equal to `cells` for PRT1.
    pub leaves: usize,
    /// In file order.
    pub portals: Vec<PrtPortal>,
    /// PRT2, PRT1-AM: the cluster of each leaf.
    pub leaf_cluster: Vec<usize>,
}

/// The most points a portal may have; the Quake tools' limit is 64, but nothing here depends
/// on it, so only absurd counts (a corrupt file) are refused.
const MAX_POINTS: usize = 1 << 16;
/// More cells or portals than this is a corrupt count, not a level.
const MAX_COUNT: usize = 1 << 26;

struct Lines<'a> {
    path: &'a Path,
    lines: std::iter::Peekable<std::iter::Enumerate<std::str::Lines<'a>>>,
    last: usize,
}

impl<'a> Lines<'a> {
    fn err(&self, code: Code, line: usize, msg: String, hint: &str) -> Diagnostic {
        Diagnostic::new(
            code,
            format!("{}: {msg}", self.path.display()),
            Location::file(self.path).with_line(line),
        )
        .hint(hint.to_string())
    }
    /// The next non-blank line, with its 1-based number.
    fn next(&mut self) -> Option<(usize, &'a str)> {
        for (i, l) in self.lines.by_ref() {
            if !l.trim().is_empty() {
                self.last = i + 1;
                return Some((i + 1, l));
            }
        }
        None
    }
    fn need(&mut self, what: &str) -> Result<(usize, &'a str), Diagnostic> {
        let last = self.last;
        self.next().ok_or_else(|| {
            self.err(
                Code::PRT_SYNTAX,
                last + 1,
                format!("the file ends where {what} was expected"),
                "the file is truncated; write it again with qbsp",
            )
        })
    }
    fn count(&mut self, what: &str) -> Result<usize, Diagnostic> {
        let (n, l) = self.need(what)?;
        let v: usize = l.trim().parse().map_err(|_| {
            self.err(
                Code::PRT_SYNTAX,
                n,
                format!("`{}` is not a count of {what}", l.trim()),
                "the header is the format line followed by one count per line",
            )
        })?;
        if v > MAX_COUNT {
            return Err(self.err(
                Code::PRT_SYNTAX,
                n,
                format!("{v} {what} is more than any level has"),
                "the count is corrupt",
            ));
        }
        Ok(v)
    }
}

/// Reads a .prt file.
pub fn read(path: &Path) -> Result<(PrtFile, Vec<Diagnostic>), Diagnostic> {
    let bytes = std::fs::read(path).map_err(|e| {
        Diagnostic::new(
            Code::IO_READ_FAILED,
            format!("cannot read `{}`: {e}", path.display()),
            Location::file(path),
        )
        .hint("check the path and permissions")
    })?;
    let text = String::from_utf8(bytes).map_err(|_| {
        Diagnostic::new(
            Code::PRT_SYNTAX,
            format!("`{}` is not a text file", path.display()),
            Location::file(path),
        )
        .hint("a .prt file is the text qbsp writes next to the .bsp")
    })?;
    parse(&text, path)
}

/// Parses .prt text (`path` is for messages). Non-fatal problems come back as diagnostics.
pub fn parse(text: &str, path: &Path) -> Result<(PrtFile, Vec<Diagnostic>), Diagnostic> {
    let mut ls = Lines {
        path,
        lines: text.lines().enumerate().peekable(),
        last: 0,
    };
    let format = ls.format()?;
    let (cells, leaves, nportals) = ls.counts(format)?;
    let mut diags = Vec::new();
    let mut portals = Vec::with_capacity(nportals.min(1 << 16));
    for _ in 0..nportals {
        let (n, l) = ls.need("a portal line")?;
        portals.push(portal_line(&ls, n, l, cells)?);
    }
    let leaf_cluster = match format {
        PrtFormat::Prt1 => Vec::new(),
        PrtFormat::Prt2 => ls.cluster_leaves(cells, leaves)?,
        PrtFormat::Prt1Am => ls.leaf_clusters(cells, leaves)?,
    };
    if let Some((n, _)) = ls.next() {
        diags.push(ls.err(
            Code::PRT_TRAILING_DATA,
            n,
            "text after the last record was ignored".into(),
            "the counts in the header may be too small",
        ));
    }
    for p in &portals {
        if Plane::from_polygon(&p.points).is_none() || p.a == p.b {
            diags.push(ls.err(
                Code::PRT_PORTAL_DEGENERATE,
                p.line,
                if p.a == p.b {
                    format!("the portal joins cell {} to itself; it was skipped", p.a)
                } else {
                    "the portal has no area; it was skipped (nothing can be seen through it)".into()
                },
                "qbsp writes these for nearly coplanar brushes; they change nothing",
            ));
        }
    }
    Ok((
        PrtFile {
            format,
            cells,
            leaves,
            portals,
            leaf_cluster,
        },
        diags,
    ))
}

impl Lines<'_> {
    /// The format line, which decides how the rest of the file reads.
    fn format(&mut self) -> Result<PrtFormat, Diagnostic> {
        let path = self.path;
        let (hl, header) = self.next().ok_or_else(|| {
            Diagnostic::new(
                Code::INPUT_EMPTY,
                format!("`{}` is empty", path.display()),
                Location::file(path),
            )
            .hint("a .prt file starts with PRT1, PRT2 or PRT1-AM")
        })?;
        Ok(match header.trim() {
            "PRT1" => PrtFormat::Prt1,
            "PRT2" => PrtFormat::Prt2,
            "PRT1-AM" => PrtFormat::Prt1Am,
            other => {
                return Err(self.err(
                    Code::PRT_UNKNOWN_FORMAT,
                    hl,
                    format!("`{}` is not a portal file format portcullis reads", short(other)),
                    "the first line must be PRT1, PRT2 or PRT1-AM (Quake 3's PRT1 with hint portals is not supported)",
                ))
            }
        })
    }

    /// The header's counts as (cells, leaves, portals), in the order each format lists them.
    fn counts(&mut self, format: PrtFormat) -> Result<(usize, usize, usize), Diagnostic> {
        Ok(match format {
            PrtFormat::Prt1 => {
                let c = self.count("cells")?;
                (c, c, self.count("portals")?)
            }
            PrtFormat::Prt2 => {
                let l = self.count("leaves")?;
                let c = self.count("clusters")?;
                (c, l, self.count("portals")?)
            }
            PrtFormat::Prt1Am => {
                let c = self.count("clusters")?;
                let p = self.count("portals")?;
                (c, self.count("leaves")?, p)
            }
        })
    }

    /// PRT2's cluster of each leaf, from one line per cluster listing its leaves up to -1
    /// (`usize::MAX` for a leaf no cluster lists).
    fn cluster_leaves(&mut self, cells: usize, leaves: usize) -> Result<Vec<usize>, Diagnostic> {
        let mut leaf_cluster = vec![usize::MAX; leaves];
        for c in 0..cells {
            let (n, l) = self.need("a cluster's leaf list")?;
            let mut ended = false;
            for t in l.split_whitespace() {
                if ended {
                    return Err(self.err(
                        Code::PRT_SYNTAX,
                        n,
                        format!("`{}` after the -1 that ends cluster {c}'s leaves", short(t)),
                        "one line per cluster: its leaves, then -1",
                    ));
                }
                if t == "-1" {
                    ended = true;
                    continue;
                }
                let leaf: usize = t.parse().map_err(|_| {
                    self.err(
                        Code::PRT_SYNTAX,
                        n,
                        format!("`{}` is not a leaf number", short(t)),
                        "one line per cluster: its leaves, then -1",
                    )
                })?;
                if leaf >= leaves {
                    return Err(self.err(Code::PRT_BAD_INDEX, n, format!("cluster {c} lists leaf {leaf}; the file has {leaves} leaves"), "the header's leaf count and the cluster lines disagree; write the file again with qbsp"));
                }
                leaf_cluster[leaf] = c;
            }
            if !ended {
                return Err(self.err(
                    Code::PRT_SYNTAX,
                    n,
                    format!("cluster {c}'s leaf list does not end with -1"),
                    "one line per cluster: its leaves, then -1",
                ));
            }
        }
        Ok(leaf_cluster)
    }

    /// PRT1-AM's cluster of each leaf, one number per leaf over as many lines as it takes
    /// (-1, no cluster, is `usize::MAX`).
    fn leaf_clusters(&mut self, cells: usize, leaves: usize) -> Result<Vec<usize>, Diagnostic> {
        let mut leaf_cluster = Vec::new();
        while leaf_cluster.len() < leaves {
            let (n, l) = self.need("the cluster of each leaf")?;
            for t in l.split_whitespace() {
                let c: i64 = t.parse().map_err(|_| {
                    self.err(
                        Code::PRT_SYNTAX,
                        n,
                        format!("`{}` is not a cluster number", short(t)),
                        "after the portals, one cluster number per leaf",
                    )
                })?;
                if c < -1 || c >= cells as i64 {
                    return Err(self.err(
                        Code::PRT_BAD_INDEX,
                        n,
                        format!(
                            "leaf {} is in cluster {c}; the file has {cells} clusters",
                            leaf_cluster.len()
                        ),
                        "the header's cluster count and the leaf table disagree",
                    ));
                }
                leaf_cluster.push(if c < 0 { usize::MAX } else { c as usize });
            }
        }
        Ok(leaf_cluster)
    }
}

fn short(s: &str) -> String {
    s.chars().take(40).collect()
}

fn portal_line(ls: &Lines, n: usize, l: &str, cells: usize) -> Result<PrtPortal, Diagnostic> {
    let hint = "a portal line is `<npoints> <cellA> <cellB> (x y z) ...`";
    let cleaned = l.replace(['(', ')'], " ");
    let mut toks = cleaned.split_whitespace();
    let mut int = |what: &str| -> Result<usize, Diagnostic> {
        let t = toks.next().ok_or_else(|| {
            ls.err(
                Code::PRT_SYNTAX,
                n,
                format!("the portal line ends before its {what}"),
                hint,
            )
        })?;
        t.parse().map_err(|_| {
            ls.err(
                Code::PRT_SYNTAX,
                n,
                format!("`{}` is not a {what}", short(t)),
                hint,
            )
        })
    };
    let np = int("point count")?;
    let a = int("first cell")?;
    let b = int("second cell")?;
    if !(3..=MAX_POINTS).contains(&np) {
        return Err(ls.err(
            Code::PRT_SYNTAX,
            n,
            format!("a portal with {np} points"),
            "a portal is a polygon of at least 3 points",
        ));
    }
    for c in [a, b] {
        if c >= cells {
            return Err(ls.err(Code::PRT_BAD_INDEX, n, format!("the portal names cell {c}; the file has {cells}"), "the header's cell count and the portal lines disagree; write the file again with qbsp"));
        }
    }
    let mut points = Vec::with_capacity(np);
    let rest: Vec<&str> = toks.collect();
    if rest.len() != 3 * np {
        return Err(ls.err(
            Code::PRT_SYNTAX,
            n,
            format!(
                "the portal says {np} points but gives {} numbers",
                rest.len()
            ),
            hint,
        ));
    }
    for xyz in rest.chunks(3) {
        let mut v = [0.0; 3];
        for (k, t) in xyz.iter().enumerate() {
            v[k] = t
                .parse::<f64>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or_else(|| {
                    ls.err(
                        Code::PRT_SYNTAX,
                        n,
                        format!("`{}` is not a finite coordinate", short(t)),
                        hint,
                    )
                })?;
        }
        points.push(DVec3::from(v));
    }
    Ok(PrtPortal {
        a,
        b,
        points,
        line: n,
    })
}

impl PrtFile {
    /// The portal graph: each portal line becomes two directed portals. `epsilon`: None for
    /// the default, 1e-9 of the extent plus the precision of the printed coordinates.
    pub fn graph(&self, epsilon: Option<f64>) -> VisGraph {
        let mut lo = DVec3::splat(f64::MAX);
        let mut hi = DVec3::splat(f64::MIN);
        for p in &self.portals {
            for v in &p.points {
                lo = lo.min(*v);
                hi = hi.max(*v);
            }
        }
        let extent = if lo.x <= hi.x {
            (hi - lo).length()
        } else {
            1.0
        };
        let max_abs = lo.abs().max(hi.abs()).max_element().max(0.0);
        let eps = epsilon.unwrap_or_else(|| {
            let p = crate::scene::Precision::Binary64;
            crate::geom::tolerance::Tolerance::derive(
                extent,
                p.spacing(max_abs),
                p.steps(),
                max_abs,
                f64::MAX,
            )
            .distance
        });
        let mut out = Vec::with_capacity(self.portals.len() * 2);
        for (i, p) in self.portals.iter().enumerate() {
            if p.a == p.b {
                continue;
            }
            let Some(mut plane) = Plane::from_polygon(&p.points) else {
                continue;
            };
            let [p0, p1, p2] = [p.points[0], p.points[1], p.points[2]];
            // Newell's normal is robust; the file's three-point rule decides only its sign.
            if plane.normal.dot((p0 - p1).cross(p2 - p1)) < 0.0 {
                plane = plane.flipped();
            }
            // `plane` faces into a: the portal from b into a travels along it.
            out.push(VisPortal {
                from: p.b,
                to: p.a,
                winding: p.points.clone(),
                plane,
                transform: None,
                origin: i,
            });
            out.push(VisPortal {
                from: p.a,
                to: p.b,
                winding: p.points.iter().rev().copied().collect(),
                plane: plane.flipped(),
                transform: None,
                origin: i,
            });
        }
        // Directed portals leaving a cell ascend by origin: A→B before B→A of one line.
        out.sort_by_key(|p| (p.origin, p.from != self.portals[p.origin].a));
        VisGraph::new(self.cells, out, eps)
    }
}
