//! Rendering diagnostics for people and machines. Stages only produce [`Diagnostic`] values;
//! how they look is decided here, once.
//!
//! `human.rs` (compiler-style messages: `severity[CODE]: message`, `-->` location, `= hint:`),
//! `style.rs` (colour only on a terminal, `NO_COLOR`), `Totals` (the summary line and the exit
//! code). `file.rs` is one file's result (`FileReport`), from which `json.rs` (the stable JSON
//! report), `sarif.rs` (SARIF 2.1.0: every code a rule with its default level and documentation
//! link; glTF pointers and node paths as logical locations, OBJ lines as regions, the 3D point and
//! hint as properties) and `junit.rs` (one test case per file: a `failure` when it fails the gate,
//! an `error` when it could not be read) are built. Invariant: no timings or absolute state in
//! reports, so the same input gives the same bytes.

pub mod file;
pub mod human;
pub mod json;
pub mod junit;
pub mod sarif;
pub mod style;

use serde::Serialize;

use crate::diag::{Diagnostic, Severity};

/// Counts over a run, for the closing summary line and the exit code.
#[derive(Debug, Clone, Copy, Default, Serialize, PartialEq, Eq)]
pub struct Totals {
    /// Files looked at, failed or not.
    pub files: usize,
    /// Files that could not be processed at all (in JSON `unprocessed`: a `"failed": 0`
    /// beside a level's errors read as if nothing had failed).
    #[serde(rename = "unprocessed")]
    pub failed: usize,
    /// Error findings over all files.
    pub errors: usize,
    /// Warning findings over all files.
    pub warnings: usize,
    /// Info findings over all files.
    pub infos: usize,
}

impl Totals {
    /// Counts `diags` by severity.
    pub fn add<'a>(&mut self, diags: impl IntoIterator<Item = &'a Diagnostic>) {
        for d in diags {
            match d.severity {
                Severity::Error => self.errors += 1,
                Severity::Warning => self.warnings += 1,
                Severity::Info => self.infos += 1,
            }
        }
    }

    /// 0 clean, 1 the level has errors (or warnings when denied), 2 the tool could not run.
    pub fn exit_code(&self, deny_warnings: bool) -> i32 {
        if self.failed > 0 {
            2
        } else if self.errors > 0 || (deny_warnings && self.warnings > 0) {
            1
        } else {
            0
        }
    }

    /// The closing summary line (`2 files: 1 error, 3 warnings`).
    pub fn line(&self) -> String {
        let plural = |n: usize, w: &str| format!("{n} {w}{}", if n == 1 { "" } else { "s" });
        let mut s = format!(
            "{}, {}, {}",
            plural(self.files, "file"),
            plural(self.errors, "error"),
            plural(self.warnings, "warning")
        );
        // Reading, building or writing: any of them may be what failed.
        if self.failed > 0 {
            s.push_str(&format!(", {} could not be processed", self.failed));
        }
        s
    }
}
