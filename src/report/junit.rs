//! JUnit XML, which every CI system renders: one test case per file, failing when the file
//! fails the gate (errors, or warnings with `--deny warnings`) and erroring when it could not
//! be checked; every diagnostic is listed in the case's text. No timings, so the report is
//! the same bytes for the same input.

use std::fmt::Write;

use super::file::FileReport;
use crate::diag::Severity;

/// Escapes text for XML content and attributes; characters XML 1.0 forbids are dropped.
fn esc(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for ch in s.chars() {
        match ch {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&apos;"),
            '\t' | '\n' | '\r' => out.push(ch),
            c if (c as u32) < 0x20 || c == '\u{FFFE}' || c == '\u{FFFF}' => {}
            c => out.push(c),
        }
    }
    out
}

/// The `--format junit` report: one test case per file, failed by errors (warnings if denied).
pub fn report(files: &[FileReport], deny_warnings: bool) -> String {
    let fails = |f: &FileReport| {
        !f.failed
            && (f.count(Severity::Error) > 0 || (deny_warnings && f.count(Severity::Warning) > 0))
    };
    let failures = files.iter().filter(|f| fails(f)).count();
    let errors = files.iter().filter(|f| f.failed).count();
    let mut x = String::from("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n");
    let counts = format!(
        "tests=\"{}\" failures=\"{failures}\" errors=\"{errors}\" skipped=\"0\"",
        files.len()
    );
    let _ = writeln!(x, "<testsuites name=\"portcullis check\" {counts}>");
    let _ = writeln!(x, "  <testsuite name=\"portcullis check\" {counts}>");
    for f in files {
        let name = esc(&f.file.to_string_lossy());
        let _ = writeln!(
            x,
            "    <testcase name=\"{name}\" classname=\"portcullis.check\" file=\"{name}\">"
        );
        let body: String = f
            .diagnostics
            .iter()
            .map(|d| format!("{d}\n"))
            .collect::<String>();
        let summary = format!(
            "{} error(s), {} warning(s)",
            f.count(Severity::Error),
            f.count(Severity::Warning)
        );
        let first = f
            .diagnostics
            .iter()
            .max_by_key(|d| d.severity)
            .map_or("", |d| d.code.as_str());
        if f.failed {
            let _ = writeln!(
                x,
                "      <error message=\"could not be checked\" type=\"{first}\">{}</error>",
                esc(&body)
            );
        } else if fails(f) {
            let _ = writeln!(
                x,
                "      <failure message=\"{}\" type=\"{first}\">{}</failure>",
                esc(&summary),
                esc(&body)
            );
        } else if !body.is_empty() {
            let _ = writeln!(x, "      <system-out>{}</system-out>", esc(&body));
        }
        let _ = writeln!(x, "    </testcase>");
    }
    x.push_str("  </testsuite>\n</testsuites>\n");
    x
}

#[cfg(test)]
mod tests {
    use super::esc;

    #[test]
    fn escapes_markup_and_drops_control_characters() {
        assert_eq!(esc("a<b>&\"c'\u{1}"), "a&lt;b&gt;&amp;&quot;c&apos;");
    }
}
