//! What a user asked to hear: codes ignored and severities changed, from `[check]` in the
//! configuration and from `--ignore` / `--severity` (which win), applied to findings after
//! every stage has run — the same model as the Khronos validator's issue overrides.

use std::collections::BTreeMap;

use super::{Code, Diagnostic, Severity};

/// The user's changes to the default severities: ignored codes and per-code severities.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Policy {
    ignore: Vec<Code>,
    severity: BTreeMap<Code, Severity>,
}

/// Why a code, a severity or an override the user wrote cannot be used.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PolicyError {
    /// A code the registry does not have, as written.
    #[error("unknown diagnostic code `{0}` (the codes are listed in docs/diagnostics.md)")]
    UnknownCode(String),
    /// A severity other than error, warning or info (trimmed, lower case).
    #[error("unknown severity `{0}`: use error, warning or info")]
    UnknownSeverity(String),
    /// An override without its `=`, as written.
    #[error("`{0}` is not CODE=LEVEL (e.g. CELL_OVERLAP=error)")]
    NotAnOverride(String),
}

/// `CODE`, checked against the registry, with the list of codes in the error.
pub fn parse_code(s: &str) -> Result<Code, PolicyError> {
    Code::parse(s.trim()).ok_or_else(|| PolicyError::UnknownCode(s.to_string()))
}

/// `error`, `warning` or `info` (any case).
pub(crate) fn parse_severity(s: &str) -> Result<Severity, PolicyError> {
    match s.trim().to_ascii_lowercase().as_str() {
        "error" => Ok(Severity::Error),
        "warning" | "warn" => Ok(Severity::Warning),
        "info" | "information" | "note" => Ok(Severity::Info),
        other => Err(PolicyError::UnknownSeverity(other.to_string())),
    }
}

/// `CODE=LEVEL`.
pub fn parse_override(s: &str) -> Result<(Code, Severity), PolicyError> {
    let (c, l) = s
        .split_once('=')
        .ok_or_else(|| PolicyError::NotAnOverride(s.to_string()))?;
    Ok((parse_code(c)?, parse_severity(l)?))
}

impl Policy {
    /// Drops every diagnostic with `code`.
    pub fn ignore(&mut self, code: Code) {
        if !self.ignore.contains(&code) {
            self.ignore.push(code);
        }
    }

    /// Reports `code` at `severity` instead of its default.
    pub fn set(&mut self, code: Code, severity: Severity) {
        self.severity.insert(code, severity);
    }

    /// `self` with `over`'s settings on top.
    pub fn merged(&self, over: &Policy) -> Policy {
        let mut out = self.clone();
        for c in &over.ignore {
            out.ignore(*c);
        }
        for (c, s) in &over.severity {
            out.set(*c, *s);
        }
        out
    }

    /// The policy of `ignore` codes and `severity` overrides, named as a user writes them
    /// (a configuration's `[check]` section). Unknown names are errors the schema cannot
    /// catch (codes are not in it).
    pub(crate) fn from_names<'a>(
        ignore: impl IntoIterator<Item = &'a String>,
        severity: impl IntoIterator<Item = (&'a String, &'a String)>,
    ) -> Result<Policy, PolicyError> {
        let mut p = Policy::default();
        for c in ignore {
            p.ignore(parse_code(c)?);
        }
        for (c, s) in severity {
            p.set(parse_code(c)?, parse_severity(s)?);
        }
        Ok(p)
    }

    /// The diagnostics the user wants, with their chosen severities.
    pub fn apply(&self, diags: impl IntoIterator<Item = Diagnostic>) -> Vec<Diagnostic> {
        diags
            .into_iter()
            .filter(|d| !self.ignore.contains(&d.code))
            .map(|mut d| {
                if let Some(s) = self.severity.get(&d.code) {
                    d.severity = *s;
                }
                d
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::diag::Location;

    #[test]
    fn ignores_and_overrides() {
        let mut p = Policy::default();
        p.ignore(Code::CELL_OVERLAP);
        let (c, s) = parse_override("LEAK=warning").unwrap();
        p.set(c, s);
        let out = p.apply([
            Diagnostic::new(Code::CELL_OVERLAP, "x", Location::default()),
            Diagnostic::new(Code::LEAK, "y", Location::default()),
        ]);
        assert_eq!(out.len(), 1);
        assert_eq!(out[0].severity, Severity::Warning);
        assert_eq!(
            parse_override("LEAK"),
            Err(PolicyError::NotAnOverride("LEAK".into()))
        );
        assert_eq!(
            parse_override("NOPE=error"),
            Err(PolicyError::UnknownCode("NOPE".into()))
        );
        assert_eq!(
            parse_override("LEAK= Fatal").unwrap_err().to_string(),
            "unknown severity `fatal`: use error, warning or info"
        );
    }
}
