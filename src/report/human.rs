//! Human-readable diagnostics, in the style of compiler messages:
//!
//! ```text
//! warning[TAG_NEAR_MISS]: `Kitchen_Room ` looks like a room tag but matches no rule (…)
//!   --> level.glb#/nodes/4 node `Root/Kitchen_Room `
//!   = hint: rename it to `Kitchen-Room`, or add a rule for this spelling in portcullis.toml
//! ```

use std::fmt::Write;

use super::style::Style;
use crate::diag::Diagnostic;

/// One finding as the terminal shows it: severity, code, message, location and hint.
pub fn diagnostic(d: &Diagnostic, style: &Style) -> String {
    let mut s = String::new();
    let _ = write!(
        s,
        "{}{}: {}",
        style.severity(d.severity),
        style.bold(&format!("[{}]", d.code)),
        d.message
    );
    let loc = d.location.to_string();
    if !loc.is_empty() {
        let _ = write!(s, "\n  {} {loc}", style.dim("-->"));
    }
    if let Some(h) = &d.hint {
        let _ = write!(s, "\n  {} {h}", style.dim("= hint:"));
    }
    s
}

/// Several findings, each as [`diagnostic`] shows it.
pub fn diagnostics<'a>(ds: impl IntoIterator<Item = &'a Diagnostic>, style: &Style) -> String {
    ds.into_iter()
        .map(|d| diagnostic(d, style) + "\n")
        .collect()
}
