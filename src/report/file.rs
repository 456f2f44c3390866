//! What one run found in one file, the unit every machine-readable report is built from.

use std::path::PathBuf;

use serde::Serialize;

use crate::diag::{Diagnostic, Severity};

/// What `check` found for one input file, as every report format shows it.
#[derive(Debug, Clone, Serialize)]
pub struct FileReport {
    /// The input as given on the command line (as text, lossily when the name is not UTF-8;
    /// the JSON report adds its bytes as `file_bytes` then).
    #[serde(serialize_with = "crate::diag::lossy_path")]
    pub file: PathBuf,
    /// The file could not be checked at all (unreadable, not a level); its diagnostics say why.
    /// In JSON `unprocessed`, so a level with errors is not reported `"failed": false`.
    #[serde(rename = "unprocessed")]
    pub failed: bool,
    /// Checked from its stored PORTCULLIS_portals annotation rather than rebuilt.
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub annotated: bool,
    /// How many cells the level has, when it got that far.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub cells: Option<usize>,
    /// How many portals the level has, when it got that far.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub portals: Option<usize>,
    /// The findings, after the policy (ignored codes dropped, severities changed).
    pub diagnostics: Vec<Diagnostic>,
}

impl FileReport {
    /// How many findings have severity `s`.
    pub fn count(&self, s: Severity) -> usize {
        self.diagnostics.iter().filter(|d| d.severity == s).count()
    }

    /// `failed`, `errors`, `warnings` or `ok`.
    pub fn status(&self) -> &'static str {
        if self.failed {
            "failed"
        } else if self.count(Severity::Error) > 0 {
            "errors"
        } else if self.count(Severity::Warning) > 0 {
            "warnings"
        } else {
            "ok"
        }
    }
}
