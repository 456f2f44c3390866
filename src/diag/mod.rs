//! Diagnostics: what went wrong, where in the level, and how to fix it.
//!
//! Every stage reports through [`Diagnostic`] values rather than errors or log lines, so the
//! same finding can be rendered for a person, a CI system (JSON) or a later SARIF/JUnit report.
//! Codes are stable identifiers listed once in [`codes`]; their default severity lives there
//! too, so a user override (`--severity CODE=LEVEL`) has a single place to act on.
//!
//! A [`Location`] is the file, a node path, a JSON pointer or line or prim, and the 3D point.
//! `policy.rs` applies what the user asked to hear (`[check] ignore`/`severity` in the
//! configuration, `--ignore`/`--severity` on top) after every stage has run, so stages always
//! report everything. Invariants: a code never changes meaning, and new problems get new codes;
//! every code has a level in `samples/broken/` that triggers exactly it (or a reason in its README)
//! and a section in `docs/diagnostics.md` quoting what that level prints.

use std::fmt;
use std::path::PathBuf;

use serde::Serialize;

use crate::scene::SourceRef;

pub mod codes;
pub mod policy;

pub use codes::Code;

/// How bad a finding is; ordered, so `max` is the worst.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Severity {
    /// Worth knowing; never fails a run.
    Info,
    /// Probably wrong; fails a run under `--deny-warnings`.
    Warning,
    /// The output would be wrong or missing; the exit code is 1.
    Error,
}

impl fmt::Display for Severity {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Severity::Info => "info",
            Severity::Warning => "warning",
            Severity::Error => "error",
        })
    }
}

/// A path as text for reports: a name that is not UTF-8 is written lossily (each bad byte as
/// U+FFFD) but readably, never dropped (serde refuses such a path, and a whole report entry
/// became `null`).
pub fn lossy_path<S: serde::Serializer>(p: &std::path::Path, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(&p.to_string_lossy())
}

/// [`lossy_path`] for an optional path.
pub fn lossy_path_opt<S: serde::Serializer>(p: &Option<PathBuf>, s: S) -> Result<S::Ok, S::Error> {
    match p {
        Some(p) => lossy_path(p, s),
        None => s.serialize_none(),
    }
}

/// The bytes of a path whose name is not UTF-8 (what a script needs to open it again), else
/// `None`.
pub fn raw_path_bytes(p: &std::path::Path) -> Option<Vec<u8>> {
    p.to_str()
        .is_none()
        .then(|| p.as_os_str().as_encoded_bytes().to_vec())
}

/// A place in a level: the file, and as much of node path / JSON pointer / line / 3D point as
/// is known.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct Location {
    /// The file the finding is in (`None`: not about a file, e.g. a bad option).
    #[serde(
        skip_serializing_if = "Option::is_none",
        serialize_with = "lossy_path_opt"
    )]
    pub file: Option<PathBuf>,
    /// The node's slash-separated path, as in the designer's outliner.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub node: Option<String>,
    /// Where in the file: JSON pointer, line or USD prim.
    #[serde(flatten)]
    pub source: SourceRef,
    /// A world point (m) the problem is at, for the debug outputs and viewer.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub position: Option<[f64; 3]>,
    /// The same point in the file's own units, when they are not the scene's metres with Y
    /// up (a brush map's units, Z up): what the editor shows. See [`Diagnostics::in_file_units`].
    #[serde(skip_serializing_if = "Option::is_none")]
    pub file_position: Option<[f64; 3]>,
}

impl Location {
    /// A location naming only `file`; the `with_*` builders add the rest.
    pub fn file(file: impl Into<PathBuf>) -> Self {
        Location {
            file: Some(file.into()),
            ..Default::default()
        }
    }
    /// Adds where in the file (pointer, line or prim).
    pub(crate) fn with_source(mut self, source: SourceRef) -> Self {
        self.source = source;
        self
    }
    /// Adds a JSON pointer into the glTF document (`/nodes/3`).
    pub fn with_pointer(mut self, pointer: impl Into<String>) -> Self {
        self.source.pointer = Some(pointer.into());
        self
    }
    /// Adds a 1-based line of a text file.
    pub fn with_line(mut self, line: usize) -> Self {
        self.source.line = Some(line);
        self
    }
    /// Adds the node path.
    pub(crate) fn with_node(mut self, node: impl Into<String>) -> Self {
        self.node = Some(node.into());
        self
    }
    /// Adds a world point (m).
    pub(crate) fn with_position(mut self, p: [f64; 3]) -> Self {
        self.position = Some(p);
        self
    }
}

impl fmt::Display for Location {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mut wrote = false;
        if let Some(file) = &self.file {
            write!(f, "{}", file.display())?;
            wrote = true;
        }
        if let Some(line) = self.source.line {
            write!(f, ":{line}")?;
            wrote = true;
        }
        if let Some(p) = &self.source.pointer {
            write!(f, "#{p}")?;
            wrote = true;
        }
        if let Some(p) = &self.source.prim {
            write!(f, "@{p}")?;
            wrote = true;
        }
        if let Some(n) = &self.node {
            write!(f, "{}node `{n}`", if wrote { " " } else { "" })?;
            wrote = true;
        }
        if let Some([x, y, z]) = self.position {
            write!(
                f,
                "{}at ({x:.4}, {y:.4}, {z:.4})",
                if wrote { " " } else { "" }
            )?;
        }
        if let Some([x, y, z]) = self.file_position {
            write!(f, ", ({x:.1}, {y:.1}, {z:.1}) in the file's units")?;
        }
        Ok(())
    }
}

/// One finding: a stable code, how bad, what and where, and what to do about it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Diagnostic {
    /// Stable across releases; what `--ignore` and the config's `[check]` name.
    pub code: Code,
    /// The code's default unless a policy changed it.
    pub severity: Severity,
    /// One sentence naming the items involved.
    pub message: String,
    /// Where the designer should look.
    pub location: Location,
    /// What to do about it, when there is something to suggest.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub hint: Option<String>,
}

impl Diagnostic {
    /// A diagnostic with the code's default severity.
    pub fn new(code: Code, message: impl Into<String>, location: Location) -> Self {
        Diagnostic {
            code,
            severity: code.default_severity(),
            message: message.into(),
            location,
            hint: None,
        }
    }
    /// Adds what to do about it.
    pub fn hint(mut self, hint: impl Into<String>) -> Self {
        self.hint = Some(hint.into());
        self
    }
    /// Whether it fails the run.
    pub fn is_error(&self) -> bool {
        self.severity == Severity::Error
    }
}

impl fmt::Display for Diagnostic {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}[{}]: {}", self.severity, self.code, self.message)?;
        let loc = self.location.to_string();
        if !loc.is_empty() {
            write!(f, " ({loc})")?;
        }
        if let Some(h) = &self.hint {
            write!(f, "; hint: {h}")?;
        }
        Ok(())
    }
}

impl std::error::Error for Diagnostic {}

/// Diagnostics gathered by a stage, in the order found.
#[derive(Debug, Clone, Default, Serialize)]
#[serde(transparent)]
pub struct Diagnostics(pub Vec<Diagnostic>);

impl Diagnostics {
    /// Gives every position its point in the file's own units (`to_file`: the scene's
    /// `to_file`; `None` for a file in metres, Y up, which needs none), so that a leak in a
    /// brush map is found where the editor shows it.
    pub fn in_file_units(&mut self, to_file: Option<glam::DMat4>) {
        self.blame_precision();
        let Some(m) = to_file else { return };
        for d in &mut self.0 {
            if let Some(p) = d.location.position {
                let q = m.transform_point3(glam::DVec3::from_array(p));
                d.location.file_position = Some(q.to_array());
            }
        }
    }

    /// When the input's precision was too coarse (`TOLERANCE_CAPPED`), the findings rounding
    /// alone can cause say so in their hint: a level stored in f32 50 km from the origin has
    /// vertices 4 mm apart, and its leaks and overlaps named no cause but that.
    fn blame_precision(&mut self) {
        if !self.has(Code::TOLERANCE_CAPPED) {
            return;
        }
        const NOTE: &str = "the level's coordinates are too coarse here (see TOLERANCE_CAPPED): pieces meant to meet may miss by rounding alone; move the geometry nearer the origin first";
        let rounding = [
            Code::LEAK,
            Code::CELL_OVERLAP,
            Code::GRAPH_UNREACHABLE,
            Code::EXTERIOR_OPENINGS,
        ];
        for d in &mut self.0 {
            if rounding.contains(&d.code) && !d.hint.as_deref().is_some_and(|h| h.contains(NOTE)) {
                d.hint = Some(match d.hint.take() {
                    Some(h) => format!("{NOTE}; else {h}"),
                    None => NOTE.to_string(),
                });
            }
        }
    }

    /// Adds one, after those already there.
    pub fn push(&mut self, d: Diagnostic) {
        self.0.push(d);
    }
    /// Adds several, in their order.
    pub fn extend(&mut self, other: impl IntoIterator<Item = Diagnostic>) {
        self.0.extend(other);
    }
    /// In the order they were reported (stage order).
    pub fn iter(&self) -> std::slice::Iter<'_, Diagnostic> {
        self.0.iter()
    }
    /// How many there are.
    pub fn len(&self) -> usize {
        self.0.len()
    }
    /// True when nothing was reported.
    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }
    /// How many have `severity`.
    pub fn count(&self, severity: Severity) -> usize {
        self.0.iter().filter(|d| d.severity == severity).count()
    }
    /// Whether any would fail the run.
    pub fn has_errors(&self) -> bool {
        self.0.iter().any(Diagnostic::is_error)
    }
    /// Whether any diagnostic carries `code`.
    pub fn has(&self, code: Code) -> bool {
        self.0.iter().any(|d| d.code == code)
    }
}

impl IntoIterator for Diagnostics {
    type Item = Diagnostic;
    type IntoIter = std::vec::IntoIter<Diagnostic>;
    fn into_iter(self) -> Self::IntoIter {
        self.0.into_iter()
    }
}
