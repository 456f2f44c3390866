//! Tidy tests, in the style of rust-analyzer's: they read the source, not run it, and hold the
//! shape ARCHITECTURE.md promises. The pipeline's modules form layers, and a module may use
//! only modules in its own layer's past: an import that goes up the pipeline (a stage reaching
//! into a later one, or a helper into a stage) fails here with the file and line.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// The library's top-level modules, lowest first. A module may use modules of a lower rank,
/// and none of its own rank or above (modules of one rank know nothing of each other).
const LAYERS: &[&[&str]] = &[
    &["rng", "scc", "free", "schema", "disjoint"],
    &["geom"],
    &["scene"],
    &["diag"],
    &["import"],
    &["tags"],
    &["config"],
    &["cells"],
    &["portals"],
    &["level"],
    &["vis"],
    &["prt"],
    &["format"],
    &["check", "runtime"],
    &["export"],
    &["pipeline"],
    &["gen", "report"],
];

fn rank_of(module: &str) -> Option<usize> {
    LAYERS.iter().position(|l| l.contains(&module))
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            rust_files(&p, out);
        } else if p.extension().is_some_and(|e| e == "rs") {
            out.push(p);
        }
    }
}

/// The top-level module a file belongs to (`src/cells/split.rs` → `cells`), or None for the
/// crate root and the binaries (`lib.rs`, `main.rs`, `cli/`, `bin/`), which may use anything.
fn module_of(src: &Path, file: &Path) -> Option<String> {
    let rel = file.strip_prefix(src).unwrap();
    let first = rel.components().next()?.as_os_str().to_str()?.to_string();
    let name = first.trim_end_matches(".rs").to_string();
    match name.as_str() {
        "lib" | "main" | "cli" | "bin" => None,
        _ => Some(name),
    }
}

/// The code of a line, without its `//` comment (doc comments name other modules in links,
/// which is no dependency).
fn code(line: &str) -> &str {
    let mut in_str = false;
    let b = line.as_bytes();
    let mut i = 0;
    while i < b.len() {
        match b[i] {
            b'\\' if in_str => i += 1,
            b'"' => in_str = !in_str,
            b'/' if !in_str && b.get(i + 1) == Some(&b'/') => return &line[..i],
            _ => {}
        }
        i += 1;
    }
    line
}

/// Every top-level module a text names through `crate::` (also inside `use crate::{a, b::c}`
/// groups, across lines), with the line it is on.
fn crate_paths(text: &str) -> Vec<(String, usize)> {
    let code: String = text.lines().map(|l| format!("{}\n", code(l))).collect();
    let line_at = |pos: usize| code[..pos].matches('\n').count() + 1;
    let mut out = Vec::new();
    let ident = |s: &str| -> String {
        s.chars()
            .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
            .collect()
    };
    for (pos, _) in code.match_indices("crate::") {
        let before = code[..pos].chars().last();
        if before.is_some_and(|c| c.is_ascii_alphanumeric() || c == '_' || c == '$') {
            continue;
        }
        let rest = &code[pos + "crate::".len()..];
        if let Some(group) = rest.strip_prefix('{') {
            // the group's top-level items, each led by a module name
            let mut depth = 0;
            let mut start = true;
            for (i, c) in group.char_indices() {
                match c {
                    '{' => depth += 1,
                    '}' if depth == 0 => break,
                    '}' => depth -= 1,
                    ',' if depth == 0 => start = true,
                    c if start && !c.is_whitespace() => {
                        start = false;
                        out.push((ident(&group[i..]), line_at(pos + 8 + i)));
                    }
                    _ => {}
                }
            }
        } else {
            out.push((ident(rest), line_at(pos)));
        }
    }
    out
}

#[test]
fn imports_go_down_the_pipeline_only() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    files.sort();
    let mut wrong = Vec::new();
    let mut unranked = BTreeMap::new();
    for f in &files {
        let Some(from) = module_of(&src, f) else {
            continue;
        };
        let Some(r_from) = rank_of(&from) else {
            unranked.insert(from, f.clone());
            continue;
        };
        let text = std::fs::read_to_string(f).unwrap();
        // a file's unit tests (its last item, by convention) may drive the whole pipeline
        let text = text.split("#[cfg(test)]").next().unwrap();
        // `super::super::x` from a folder's file is `crate::x` too
        let text = text.replace("super::super::", "crate::");
        for (to, line) in crate_paths(&text) {
            if to == from || to.is_empty() {
                continue;
            }
            match rank_of(&to) {
                Some(r_to) if r_to < r_from => {}
                _ => wrong.push(format!(
                    "{}:{line}: `{from}` uses `{to}`, which is not below it in tests/tidy.rs LAYERS",
                    f.strip_prefix(&src).unwrap().display()
                )),
            }
        }
    }
    assert!(
        unranked.is_empty(),
        "modules missing from LAYERS in tests/tidy.rs: {unranked:?}"
    );
    assert!(
        wrong.is_empty(),
        "{} imports go up the pipeline:\n{}",
        wrong.len(),
        wrong.join("\n")
    );
}

#[test]
fn the_checker_sees_an_upward_import() {
    let text =
        "use crate::{geom::Vec3,\n    export::write};\nfn f() { crate::vis::run() } // crate::x\n";
    let found = crate_paths(text);
    assert_eq!(
        found,
        vec![
            ("geom".to_string(), 1),
            ("export".to_string(), 2),
            ("vis".to_string(), 3)
        ]
    );
    assert!(rank_of("export") > rank_of("cells"));
}

/// Longest a production function may be, in lines: beyond it a function holds several jobs
/// (issue 30). Unit tests, after a file's `#[cfg(test)]`, are not held to it.
const MAX_FUNCTION_LINES: usize = 120;

/// A line without its string and char literals and `//` comment, for counting braces.
fn braces_of(line: &str) -> String {
    let mut out = String::new();
    let mut chars = line.chars().peekable();
    while let Some(c) = chars.next() {
        match c {
            '"' => {
                while let Some(d) = chars.next() {
                    match d {
                        '\\' => {
                            chars.next();
                        }
                        '"' => break,
                        _ => {}
                    }
                }
            }
            // a char literal ('{', '\''), not a lifetime ('a)
            '\'' => {
                let mut look = chars.clone();
                let first = look.next();
                let lit = match first {
                    Some('\\') => true,
                    Some(_) => look.next() == Some('\''),
                    None => false,
                };
                if lit {
                    for d in chars.by_ref() {
                        if d == '\'' {
                            break;
                        }
                    }
                    if first == Some('\\') {
                        // `'\''`: the escaped quote was taken as the end
                        if chars.peek() == Some(&'\'') {
                            chars.next();
                        }
                    }
                }
            }
            '/' if chars.peek() == Some(&'/') => break,
            '{' | '}' => out.push(c),
            _ => {}
        }
    }
    out
}

/// Each function of `text` (before its unit tests) with its first line and length in lines.
fn function_lengths(text: &str) -> Vec<(String, usize, usize)> {
    let lines: Vec<&str> = text.lines().collect();
    let is_fn = |l: &str| -> Option<String> {
        let t = l.trim_start();
        let t = t.strip_prefix("pub ").unwrap_or(t);
        let t = if t.starts_with("pub(") {
            t.split_once(") ")?.1
        } else {
            t
        };
        let t = t.strip_prefix("const ").unwrap_or(t);
        let t = t.strip_prefix("unsafe ").unwrap_or(t);
        let rest = t.strip_prefix("fn ")?;
        Some(
            rest.chars()
                .take_while(|c| c.is_alphanumeric() || *c == '_')
                .collect(),
        )
    };
    let mut out = Vec::new();
    let mut i = 0;
    while i < lines.len() {
        if lines[i].trim_start().starts_with("#[cfg(test)]") {
            break;
        }
        let Some(name) = is_fn(lines[i]) else {
            i += 1;
            continue;
        };
        let (mut depth, mut started, mut j) = (0i64, false, i);
        while j < lines.len() {
            for c in braces_of(lines[j]).chars() {
                depth += if c == '{' { 1 } else { -1 };
                started = true;
            }
            if started && depth <= 0 {
                break;
            }
            if !started && lines[j].trim_end().ends_with(';') {
                break;
            }
            j += 1;
        }
        out.push((name, i + 1, j - i + 1));
        i = if started { j + 1 } else { i + 1 };
    }
    out
}

#[test]
fn no_production_function_is_longer_than_the_limit() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    files.sort();
    let mut long = Vec::new();
    for f in &files {
        let text = std::fs::read_to_string(f).unwrap();
        for (name, line, len) in function_lengths(&text) {
            if len > MAX_FUNCTION_LINES {
                long.push(format!(
                    "{}:{line}: `{name}` is {len} lines",
                    f.strip_prefix(&src).unwrap().display()
                ));
            }
        }
    }
    assert!(
        long.is_empty(),
        "functions over {MAX_FUNCTION_LINES} lines (split them by job):\n{}",
        long.join("\n")
    );
}

#[test]
fn the_length_counter_sees_strings_chars_and_nesting() {
    let text = "fn a() {\n    let s = \"}\";\n    let c = '{';\n    if x { y(); }\n}\n\
                pub(crate) fn b<'a>(x: &'a str) -> &'a str {\n    x // }\n}\n\
                fn c();\n#[cfg(test)]\nfn d() {\n}\n";
    let found = function_lengths(text);
    assert_eq!(
        found,
        vec![
            ("a".to_string(), 1, 5),
            ("b".to_string(), 6, 3),
            ("c".to_string(), 9, 1)
        ]
    );
}
