//! Terminal colour: on only when writing to a terminal (and NO_COLOR is unset), or when forced.

use std::io::IsTerminal;

use crate::diag::Severity;

/// Whether terminal output is coloured.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Style {
    /// ANSI colours on (a terminal, and `NO_COLOR` unset).
    pub color: bool,
}

impl Style {
    /// No colours: for files, pipes and tests.
    pub fn plain() -> Style {
        Style { color: false }
    }

    /// `choice` is `auto`, `always` or `never`.
    pub fn for_stdout(choice: &str) -> Style {
        let color = match choice {
            "always" => true,
            "never" => false,
            _ => std::io::stdout().is_terminal() && std::env::var_os("NO_COLOR").is_none(),
        };
        Style { color }
    }

    /// Like [`Style::for_stdout`], for messages on standard error.
    pub fn for_stderr(choice: &str) -> Style {
        let color = match choice {
            "always" => true,
            "never" => false,
            _ => std::io::stderr().is_terminal() && std::env::var_os("NO_COLOR").is_none(),
        };
        Style { color }
    }

    fn paint(&self, code: &str, s: &str) -> String {
        if self.color {
            format!("\x1b[{code}m{s}\x1b[0m")
        } else {
            s.to_string()
        }
    }
    /// `s` in bold when colour is on.
    pub fn bold(&self, s: &str) -> String {
        self.paint("1", s)
    }
    /// `s` dimmed when colour is on.
    pub fn dim(&self, s: &str) -> String {
        self.paint("2", s)
    }
    /// The severity's word in its colour.
    pub fn severity(&self, sev: Severity) -> String {
        let code = match sev {
            Severity::Error => "1;31",
            Severity::Warning => "1;33",
            Severity::Info => "1;36",
        };
        self.paint(code, &sev.to_string())
    }
}
