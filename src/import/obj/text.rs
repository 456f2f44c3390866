//! The byte-level layer of the OBJ reader: is this text at all, and what are its logical lines.

use std::borrow::Cow;
use std::path::Path;

use crate::diag::{Code, Diagnostic, Location};

/// How much of the file decides whether invalid UTF-8 means "binary" or "legacy 8-bit text".
const SNIFF_LEN: usize = 1024;

/// Rejects files that are not text before the parser turns them into a confusing statement
/// error: a binary file saved as .obj (a COFF object file, a crashed export padded with NULs)
/// deserves a message that says so, with the first offending byte.
pub(super) fn check_text(bytes: &[u8], path: &Path) -> Result<(), Diagnostic> {
    let not_text = |msg: String| {
        Diagnostic::new(Code::OBJ_NOT_TEXT, msg, Location::file(path)).hint(
            "a Wavefront OBJ level is a text file; this may be a compiled object file or a \
             corrupt/truncated export: export the level again as Wavefront OBJ",
        )
    };
    if bytes.starts_with(&[0xFF, 0xFE]) || bytes.starts_with(&[0xFE, 0xFF]) {
        return Err(not_text(
            "the file starts with a UTF-16 byte-order mark (byte 0); OBJ is read as UTF-8 text"
                .into(),
        )
        .hint("save the file as UTF-8 or ASCII text"));
    }
    if let Some(off) = bytes.iter().position(|&b| b == 0) {
        return Err(not_text(format!(
            "byte {off} (0x{off:x}) is a NUL byte, which never occurs in a text file"
        )));
    }
    let head = &bytes[..bytes.len().min(SNIFF_LEN)];
    if let Err(e) = std::str::from_utf8(head) {
        // `error_len() == None` is only a multi-byte character cut by the sniff window.
        if e.error_len().is_some() {
            if let Some(off) = implausible_latin1(head) {
                return Err(not_text(format!(
                    "byte {} is not valid UTF-8 and byte {off} (0x{:02x}) is a control \
                     character, so this is not Latin-1 text either",
                    e.valid_up_to(),
                    head[off]
                )));
            }
        }
    }
    Ok(())
}

/// Old exporters write names in Latin-1 or Windows-1252; that is still text worth reading.
/// Text in those encodings has no C0 control characters besides whitespace and is mostly ASCII.
/// Returns the offset that shows the bytes are not such text.
fn implausible_latin1(head: &[u8]) -> Option<usize> {
    if let Some(off) = head
        .iter()
        .position(|&b| b < 0x20 && !matches!(b, b'\t' | b'\n' | b'\r' | 0x0b | 0x0c | 0x1a))
    {
        return Some(off);
    }
    let high = head.iter().filter(|&&b| b >= 0x80).count();
    if high * 4 > head.len() {
        return head.iter().position(|&b| b >= 0x80);
    }
    None
}

/// Logical lines: `\`-continued physical lines joined with a space, CR stripped, each with the
/// 1-based number of its first physical line (the one a user would open the file at).
pub(super) fn lines(bytes: &[u8]) -> impl Iterator<Item = (usize, Cow<'_, [u8]>)> + '_ {
    let bytes = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
    let mut phys = bytes.split(|&b| b == b'\n').enumerate().peekable();
    std::iter::from_fn(move || {
        let (i, first) = phys.next()?;
        let first = strip_cr(first);
        if !continues(first) {
            return Some((i + 1, Cow::Borrowed(first)));
        }
        let mut joined: Vec<u8> = Vec::with_capacity(first.len() * 2);
        let mut cur = first;
        loop {
            if continues(cur) && phys.peek().is_some() {
                let t = trim_end(cur);
                joined.extend_from_slice(&t[..t.len() - 1]);
                joined.push(b' ');
                match phys.next() {
                    Some((_, next)) => cur = strip_cr(next),
                    None => break,
                }
            } else {
                if continues(cur) {
                    // A continuation on the last line continues into nothing.
                    let t = trim_end(cur);
                    joined.extend_from_slice(&t[..t.len() - 1]);
                } else {
                    joined.extend_from_slice(cur);
                }
                break;
            }
        }
        Some((i + 1, Cow::Owned(joined)))
    })
}

fn strip_cr(l: &[u8]) -> &[u8] {
    l.strip_suffix(b"\r").unwrap_or(l)
}

fn continues(l: &[u8]) -> bool {
    trim_end(l).ends_with(b"\\")
}

pub(super) fn trim_end(l: &[u8]) -> &[u8] {
    let end = l
        .iter()
        .rposition(|b| !b.is_ascii_whitespace())
        .map_or(0, |i| i + 1);
    &l[..end]
}

pub(super) fn trim(l: &[u8]) -> &[u8] {
    let t = trim_end(l);
    let start = t
        .iter()
        .position(|b| !b.is_ascii_whitespace())
        .unwrap_or(t.len());
    &t[start..]
}

/// Cuts a `#` comment. Only a `#` at the start or after whitespace opens one, so that names
/// such as `Room#2` survive.
pub(super) fn strip_comment(l: &[u8]) -> &[u8] {
    for (i, &b) in l.iter().enumerate() {
        if b == b'#' && (i == 0 || l[i - 1].is_ascii_whitespace()) {
            return &l[..i];
        }
    }
    l
}

/// Whitespace-separated tokens.
pub(super) fn tokens(l: &[u8]) -> impl Iterator<Item = &[u8]> {
    l.split(|b| b.is_ascii_whitespace())
        .filter(|t| !t.is_empty())
}

/// Names are UTF-8 when they can be, else taken as Latin-1 (which every byte string is), so
/// a legacy file's names stay readable instead of turning into replacement characters.
pub(super) fn decode(b: &[u8]) -> String {
    match std::str::from_utf8(b) {
        Ok(s) => s.to_owned(),
        Err(_) => b.iter().map(|&c| c as char).collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn collect(s: &str) -> Vec<(usize, String)> {
        lines(s.as_bytes())
            .map(|(n, l)| (n, String::from_utf8_lossy(&l).into_owned()))
            .collect()
    }

    #[test]
    fn continuation_and_crlf() {
        let got = collect("v 1 \\\r\n 2 3\r\nf 1 2 3\\\n\\\n4\nx\\");
        assert_eq!(
            got,
            vec![
                (1, "v 1   2 3".to_string()),
                (3, "f 1 2 3  4".to_string()),
                (6, "x".to_string())
            ]
        );
    }

    #[test]
    fn comments() {
        assert_eq!(strip_comment(b"v 1 2 3 # c"), b"v 1 2 3 ");
        assert_eq!(strip_comment(b"# all"), b"");
        assert_eq!(strip_comment(b"o Room#2"), b"o Room#2");
    }

    #[test]
    fn text_sniffing() {
        let p = Path::new("x.obj");
        assert!(check_text(b"v 1 2 3\n", p).is_ok());
        assert!(check_text(b"o Caf\xe9\nv 1 2 3\n", p).is_ok());
        let e = check_text(b"v 1\x00 2", p).unwrap_err();
        assert_eq!(e.code, Code::OBJ_NOT_TEXT);
        assert!(e.message.contains("byte 3"));
        assert!(check_text(b"\x7fELF\x02\x01\x01\xff\x03\x04\x05\x06", p).is_err());
        assert!(check_text(b"\xff\xfev\x00", p).is_err());
    }
}
