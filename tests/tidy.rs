//! Tidy tests, in the style of rust-analyzer's: they read the source, not run it, and hold the
//! shape ARCHITECTURE.md promises. The pipeline's modules form layers, and a module may use
//! only modules in its own layer's past: an import that goes up the pipeline (a stage reaching
//! into a later one, or a helper into a stage) fails here with the file and line, as does one
//! that a module promises never to make, whatever the ranks allow (`ONLY`). Files of one module
//! that use each other in a circle fail too: neither can be understood, tested or moved alone.
//! Test-only items (`#[cfg(test)]`) are exempt, as they may drive anything; only those items,
//! though: production code after a test helper is held like any other.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// The library's top-level modules, lowest first. A module may use modules of a lower rank,
/// and none of its own rank or above (modules of one rank know nothing of each other).
const LAYERS: &[&[&str]] = &[
    &["rng", "scc", "free", "schema", "disjoint"],
    &["format"],
    &["runtime"],
    &["geom"],
    &["scene"],
    &["diag"],
    &["import"],
    &["tags"],
    &["auto"],
    &["config"],
    &["cells"],
    &["portals"],
    &["level"],
    &["vis"],
    &["prt"],
    &["bsp"],
    &["export"],
    &["check"],
    &["pipeline"],
    &["buildings", "report"],
];

/// Modules that may use only the modules listed, whatever their rank allows: a promise about
/// what a module drags in that a rank cannot state. The runtime is what engines take, so it
/// may depend on the extension format's floor alone, never on the stages that wrote it.
const ONLY: &[(&str, &[&str])] = &[("runtime", &["format"])];

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
fn module_of(rel: &Path) -> Option<String> {
    let first = rel.components().next()?.as_os_str().to_str()?.to_string();
    let name = first.trim_end_matches(".rs").to_string();
    match name.as_str() {
        "lib" | "main" | "cli" | "bin" => None,
        _ => Some(name),
    }
}

/// The module path of a file relative to `src/` (`import/gltf/mesh.rs` → `import::gltf::mesh`,
/// `vis/mod.rs` → `vis`, `lib.rs` → the crate root), for what its `super::` and `self::` mean.
fn module_path(rel: &Path) -> Vec<String> {
    let mut p: Vec<String> = rel
        .with_extension("")
        .components()
        .map(|c| c.as_os_str().to_string_lossy().into_owned())
        .collect();
    if p.last().is_some_and(|l| l == "mod") || p == ["lib"] || p == ["main"] {
        p.pop();
    }
    p
}

/// The source folders of the workspace's crates: the converter, and the engine side
/// (`portcullis-runtime`, whose top-level modules are the converter's `format` and `runtime`,
/// re-exported, so LAYERS holds them too) and the engine plugins, which link only the engine side.
const SOURCE_ROOTS: &[&str] = &["src", "crates/portcullis-runtime/src"];

/// The roots whose top-level modules LAYERS ranks: the library's, wherever its modules live.
const LAYERED_ROOTS: &[&str] = &["src", "crates/portcullis-runtime/src"];

/// Every production file of every root in `roots`: (root, path relative to it, text).
fn sources_of(roots: &[&'static str]) -> Vec<(&'static str, PathBuf, String)> {
    roots
        .iter()
        .flat_map(|r| {
            production_sources(r)
                .into_iter()
                .map(|(rel, t)| (*r, rel, t))
        })
        .collect()
}

/// Every `.rs` file of `root` (a crate's `src/`) its library or binaries are built from,
/// relative to `root`, with its text. A module declared `#[cfg(test)] mod x;` is test code
/// throughout, so its files are left out, as its declaration is.
fn production_sources(root: &str) -> Vec<(PathBuf, String)> {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join(root);
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    files.sort();
    let all: Vec<(PathBuf, String)> = files
        .iter()
        .map(|f| {
            let rel = f.strip_prefix(&src).unwrap().to_path_buf();
            (rel, std::fs::read_to_string(f).unwrap())
        })
        .collect();
    let mut test_only = Vec::new();
    for (rel, text) in &all {
        for child in test_only_modules(text) {
            let mut p = module_path(rel);
            p.push(child);
            test_only.push(p);
        }
    }
    all.into_iter()
        .filter(|(rel, _)| !test_only.iter().any(|t| module_path(rel).starts_with(t)))
        .collect()
}

/// Each line of `text` as code alone: string and char literals emptied (`""`, `''`, raw ones
/// and ones over several lines too) and comments cut. Braces, `;` and paths in a literal are no
/// code, and doc comments name other modules in links, which is no dependency.
fn code_lines(text: &str) -> Vec<String> {
    let mut out = vec![String::new()];
    let mut chars = text.chars().peekable();
    // the identifier being read, to tell `r"..."` and `br#"..."#` from a name ending in `r`
    let mut word = String::new();
    while let Some(c) = chars.next() {
        let raw_hashes = (c == 'r' && (word.is_empty() || word == "b"))
            .then(|| {
                let mut look = chars.clone();
                let mut n = 0;
                while look.next_if_eq(&'#').is_some() {
                    n += 1;
                }
                (look.peek() == Some(&'"')).then_some(n)
            })
            .flatten();
        word = if c.is_alphanumeric() || c == '_' {
            word + &c.to_string()
        } else {
            String::new()
        };
        if let Some(n) = raw_hashes {
            for _ in 0..=n {
                chars.next();
            }
            out.last_mut().unwrap().push('"');
            while let Some(d) = chars.next() {
                match d {
                    '\n' => out.push(String::new()),
                    '"' => {
                        let mut look = chars.clone();
                        if (0..n).all(|_| look.next() == Some('#')) {
                            for _ in 0..n {
                                chars.next();
                            }
                            break;
                        }
                    }
                    _ => {}
                }
            }
            out.last_mut().unwrap().push('"');
            word.clear();
            continue;
        }
        match c {
            '\n' => out.push(String::new()),
            '"' => {
                out.last_mut().unwrap().push('"');
                while let Some(d) = chars.next() {
                    match d {
                        // an escape, perhaps of the line's end
                        '\\' => out.extend((chars.next() == Some('\n')).then(String::new)),
                        '\n' => out.push(String::new()),
                        '"' => break,
                        _ => {}
                    }
                }
                out.last_mut().unwrap().push('"');
            }
            // a char literal ('{', '\''), not a lifetime ('a)
            '\'' => {
                let mut look = chars.clone();
                let first = look.next();
                let literal = match first {
                    Some('\\') => true,
                    Some(_) => look.next() == Some('\''),
                    None => false,
                };
                if literal {
                    if first == Some('\\') {
                        // the escaped char may be the quote itself: `'\''`
                        chars.next();
                        chars.next();
                    }
                    for d in chars.by_ref() {
                        if d == '\'' {
                            break;
                        }
                    }
                    out.last_mut().unwrap().push_str("''");
                } else {
                    out.last_mut().unwrap().push(c);
                }
            }
            '/' if chars.peek() == Some(&'/') => while chars.next_if(|&d| d != '\n').is_some() {},
            '/' if chars.peek() == Some(&'*') => {
                chars.next();
                let mut depth = 1;
                while depth > 0 {
                    match chars.next() {
                        None => break,
                        Some('\n') => out.push(String::new()),
                        Some('*') if chars.next_if_eq(&'/').is_some() => depth -= 1,
                        Some('/') if chars.next_if_eq(&'*').is_some() => depth += 1,
                        _ => {}
                    }
                }
                out.last_mut().unwrap().push(' ');
            }
            _ => out.last_mut().unwrap().push(c),
        }
    }
    out
}

/// The braces of a line of code (from [`code_lines`]).
fn braces(code: &str) -> impl Iterator<Item = i64> + '_ {
    code.chars().filter_map(|c| match c {
        '{' => Some(1),
        '}' => Some(-1),
        _ => None,
    })
}

/// What follows a `#[cfg(..)]` attribute at the start of `line` that compiles its item for
/// tests only (`test`, `all(test, ..)`), or None.
fn after_test_cfg(line: &str) -> Option<&str> {
    let rest = line.trim_start().strip_prefix("#[cfg(")?;
    let end = rest.find(")]")?;
    let predicate = rest[..end].trim();
    let test_only = predicate == "test"
        || predicate
            .strip_prefix("all(")
            .is_some_and(|all| all.split([',', ')']).any(|w| w.trim() == "test"));
    test_only.then(|| &rest[end + 2..])
}

/// `text` with its test-only items blanked: each `#[cfg(test)]`, the attributes and doc
/// comments after it, and the item they belong to, through its closing brace or its `;`.
/// Blanked lines stay as empty lines, so the lines reported about the rest stay right. A file's
/// test helpers sit among its production code, which must not go unchecked after them.
fn without_test_items(text: &str) -> String {
    let lines: Vec<&str> = text.lines().collect();
    let code = code_lines(text);
    let mut kept = vec![true; lines.len()];
    let mut i = 0;
    while i < lines.len() {
        let Some(after) = after_test_cfg(&code[i]) else {
            i += 1;
            continue;
        };
        // the item's first line, past attributes (perhaps over several lines) and comments
        let (mut start, mut rest, mut brackets) = (i, after, 0i64);
        loop {
            let t = rest.trim_start();
            if brackets > 0 || t.starts_with("#[") {
                let mut closed = None;
                for (k, c) in t.char_indices() {
                    brackets += match c {
                        '[' => 1,
                        ']' => -1,
                        _ => 0,
                    };
                    if c == ']' && brackets == 0 {
                        closed = Some(k + 1);
                        break;
                    }
                }
                if let Some(k) = closed {
                    rest = &t[k..];
                    continue;
                }
            } else if !t.is_empty() {
                rest = t;
                break;
            }
            start += 1;
            match code.get(start) {
                Some(l) if start < lines.len() => rest = l,
                _ => break,
            }
        }
        // the item, to where its braces close or its `;` ends it outside any brace
        let (mut end, mut depth) = (start, 0i64);
        while end < lines.len() {
            let part = if end == start { rest } else { &code[end] };
            for b in braces(part) {
                depth += b;
                if depth < 0 {
                    break;
                }
            }
            if depth < 0 {
                // a brace of the block around the item (a field's, say), not the item's
                break;
            }
            end += 1;
            let last = part.trim_end();
            if depth == 0 && (last.ends_with(';') || last.ends_with('}')) {
                break;
            }
        }
        for k in &mut kept[i..end] {
            *k = false;
        }
        i = end.max(i + 1);
    }
    lines
        .iter()
        .zip(&kept)
        .map(|(l, &k)| {
            if k {
                format!("{l}\n")
            } else {
                "\n".to_string()
            }
        })
        .collect()
}

/// The modules a text declares for tests only (`#[cfg(test)] mod oracle;`): their files are
/// test code.
fn test_only_modules(text: &str) -> Vec<String> {
    let stripped = without_test_items(text);
    code_lines(text)
        .iter()
        .zip(stripped.lines())
        .filter(|(was, now)| now.is_empty() && !was.is_empty())
        .filter_map(|(was, _)| {
            let t = was.trim();
            let t = t.strip_prefix("pub ").unwrap_or(t);
            let t = match t.strip_prefix("pub(") {
                Some(r) => r.split_once(") ")?.1,
                None => t,
            };
            let name = t.strip_prefix("mod ")?.strip_suffix(';')?.trim();
            Some(name.to_string())
        })
        .collect()
}

/// A path's segments, each with the line it is on.
type Segments = Vec<(String, usize)>;

/// Every path in a text's code that starts at `crate::`, `super::` or `self::`, one for each
/// name it reaches (`use super::{a, b::C}` is two, and `{self, ..}` names the module itself),
/// each segment with its line. Doc comments are left out: a link is no dependency.
fn paths(text: &str) -> Vec<Segments> {
    let code = code_lines(text).join("\n");
    let newlines: Vec<usize> = code.match_indices('\n').map(|(i, _)| i).collect();
    let line_at = |pos: usize| newlines.partition_point(|&n| n < pos) + 1;
    let b = code.as_bytes();
    let ident = |c: u8| c.is_ascii_alphanumeric() || c == b'_';
    let mut out = Vec::new();
    for i in 0..b.len() {
        let at_start = ["crate::", "super::", "self::"]
            .iter()
            .any(|p| b[i..].starts_with(p.as_bytes()));
        let after_path_char = i > 0 && (ident(b[i - 1]) || b[i - 1] == b'$' || b[i - 1] == b':');
        if at_start && !after_path_char {
            use_tree(&code, i, Vec::new(), &line_at, &mut out);
        }
    }
    out
}

/// Reads the path (or `use` tree) at `i` of `code`, its segments so far `base`, into `out`;
/// returns where it ends.
fn use_tree(
    code: &str,
    mut i: usize,
    base: Segments,
    line_at: &dyn Fn(usize) -> usize,
    out: &mut Vec<Segments>,
) -> usize {
    let b = code.as_bytes();
    let ident = |c: u8| c.is_ascii_alphanumeric() || c == b'_';
    let skip_space = |mut i: usize| {
        while b.get(i).is_some_and(|c| c.is_ascii_whitespace()) {
            i += 1;
        }
        i
    };
    i = skip_space(i);
    match b.get(i) {
        Some(b'{') => {
            i += 1;
            loop {
                i = skip_space(i);
                match b.get(i) {
                    None => return i,
                    Some(b'}') => return i + 1,
                    Some(b',') => i += 1,
                    _ => {
                        i = use_tree(code, i, base.clone(), line_at, out);
                        // past an `as name` to the next item
                        while b
                            .get(i)
                            .is_some_and(|&c| c != b',' && c != b'}' && c != b'{')
                        {
                            i += 1;
                        }
                        if b.get(i) == Some(&b'{') {
                            return i;
                        }
                    }
                }
            }
        }
        Some(b'*') => {
            out.push(base);
            i + 1
        }
        Some(&c) if ident(c) => {
            let start = i;
            while b.get(i).is_some_and(|&c| ident(c)) {
                i += 1;
            }
            let name = &code[start..i];
            if name == "self" && !base.is_empty() {
                out.push(base);
                return i;
            }
            let mut path = base;
            path.push((name.to_string(), line_at(start)));
            let next = skip_space(i);
            if b[next..].starts_with(b"::") {
                use_tree(code, next + 2, path, line_at, out)
            } else {
                out.push(path);
                i
            }
        }
        _ => {
            if !base.is_empty() {
                out.push(base);
            }
            i
        }
    }
}

/// Every top-level module a text names through `crate::` (also inside `use crate::{a, b::c}`
/// groups, across lines), with the line it is on.
fn crate_paths(text: &str) -> Vec<(String, usize)> {
    let mut out: Vec<(String, usize)> = Vec::new();
    for p in paths(text) {
        match (p.first(), p.get(1)) {
            (Some((root, _)), Some(m)) if root == "crate" && out.last() != Some(m) => {
                out.push(m.clone());
            }
            _ => {}
        }
    }
    out
}

/// The imports in one file's text, of top-level `module`, that LAYERS or ONLY forbid, each
/// with its line. A file's test-only items may drive the whole pipeline.
fn import_faults(module: &str, text: &str) -> Vec<(usize, String)> {
    let text = without_test_items(text);
    // `super::super::x` from a folder's file is `crate::x` too
    let text = text.replace("super::super::", "crate::");
    let only = ONLY.iter().find(|(m, _)| *m == module).map(|(_, o)| *o);
    let mut out = Vec::new();
    for (to, line) in crate_paths(&text) {
        if to == module {
            continue;
        }
        if !matches!((rank_of(&to), rank_of(module)), (Some(t), Some(f)) if t < f) {
            out.push((
                line,
                format!("`{module}` uses `{to}`, which is not below it in tests/tidy.rs LAYERS"),
            ));
        }
        if let Some(only) = only.filter(|o| !o.contains(&to.as_str())) {
            out.push((
                line,
                format!(
                    "`{module}` uses `{to}`; the {module} may use only [{}] (tests/tidy.rs ONLY)",
                    only.join(", ")
                ),
            ));
        }
    }
    out
}

#[test]
fn imports_go_down_the_pipeline_only() {
    let mut wrong = Vec::new();
    let mut unranked = BTreeMap::new();
    for (root, rel, text) in sources_of(LAYERED_ROOTS) {
        let Some(from) = module_of(&rel) else {
            continue;
        };
        if rank_of(&from).is_none() {
            unranked.insert(from, rel);
            continue;
        }
        for (line, fault) in import_faults(&from, &text) {
            wrong.push(format!("{root}/{}:{line}: {fault}", rel.display()));
        }
    }
    assert!(
        unranked.is_empty(),
        "modules missing from LAYERS in tests/tidy.rs: {unranked:?}"
    );
    let unknown: Vec<&str> = ONLY
        .iter()
        .flat_map(|(m, o)| std::iter::once(m).chain(o.iter()))
        .copied()
        .filter(|m| rank_of(m).is_none())
        .collect();
    assert!(
        unknown.is_empty(),
        "tests/tidy.rs ONLY names modules not in LAYERS: {unknown:?}"
    );
    assert!(
        wrong.is_empty(),
        "{} imports break tests/tidy.rs LAYERS or ONLY:\n{}",
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
    assert_eq!(
        import_faults("cells", text),
        vec![
            (
                2,
                "`cells` uses `export`, which is not below it in tests/tidy.rs LAYERS".to_string()
            ),
            (
                3,
                "`cells` uses `vis`, which is not below it in tests/tidy.rs LAYERS".to_string()
            ),
        ]
    );
}

#[test]
fn the_checker_sees_a_never_rule_broken() {
    // Each use but the floor's is reported as the never rule's, whatever the ranks say.
    let text =
        "use crate::format::Annotated;\nuse crate::scene::Scene;\nuse crate::cells::CellSet;\n";
    let faults = import_faults("runtime", text);
    for (line, module) in [(2, "scene"), (3, "cells")] {
        let never = format!(
            "`runtime` uses `{module}`; the runtime may use only [format] (tests/tidy.rs ONLY)"
        );
        assert!(faults.contains(&(line, never)), "{faults:?}");
    }
    assert!(faults.iter().all(|(line, _)| *line != 1), "{faults:?}");
}

#[test]
fn test_items_are_dropped_and_the_rest_kept() {
    let text = "use crate::geom::Plane;\n\
                fn first() {\n}\n\
                #[cfg(test)]\n/// A helper.\n#[allow(dead_code)]\nfn helper() -> u32 {\n    crate::export::x()\n}\n\
                fn second() {\n    crate::vis::run();\n}\n\
                #[cfg(test)]\nuse crate::{\n    report,\n    buildings,\n};\n\
                #[cfg(test)] const N: [u8; 2] = [1, 2];\n\
                #[cfg(test)]\nmod tests {\n    use crate::buildings::x;\n    #[test]\n    fn t() { let _ = '}'; }\n}\n\
                fn third() {}\n";
    let kept = without_test_items(text);
    assert_eq!(kept.lines().count(), text.lines().count());
    assert_eq!(
        kept.lines()
            .enumerate()
            .filter(|(_, l)| !l.is_empty())
            .map(|(i, _)| i + 1)
            .collect::<Vec<_>>(),
        vec![1, 2, 3, 10, 11, 12, 25]
    );
    assert_eq!(
        crate_paths(&kept),
        vec![("geom".to_string(), 1), ("vis".to_string(), 11)]
    );
    assert_eq!(
        import_faults("cells", text),
        vec![(
            11,
            "`cells` uses `vis`, which is not below it in tests/tidy.rs LAYERS".to_string()
        )]
    );
    assert_eq!(
        function_lengths(text),
        vec![
            ("first".to_string(), 2, 2),
            ("second".to_string(), 10, 3),
            ("third".to_string(), 25, 1)
        ]
    );
    let decl =
        "pub mod a;\n#[cfg(test)]\nmod oracle;\n#[cfg(all(test, unix))]\npub(crate) mod b;\n";
    assert_eq!(test_only_modules(decl), vec!["oracle", "b"]);
}

#[test]
fn the_code_reader_skips_literals_and_comments() {
    let text = "let j = r#\"{\"a\": \"\\\"}\"}\"#; // }\n\
                let s = \"{\n  crate::x }\"; /* {\n */ let c = '\\''; f::<'a>('{');\n\
                let b = br\"}\"; crate::y::z();\n";
    assert_eq!(
        code_lines(text),
        vec![
            "let j = \"\"; ",
            "let s = \"",
            "\"; ",
            "  let c = ''; f::<'a>('');",
            "let b = b\"\"; crate::y::z();",
            ""
        ]
    );
    assert_eq!(crate_paths(text), vec![("y".to_string(), 5)]);
}

/// Longest a production function may be, in lines: beyond it a function holds several jobs
/// (issue 30). Test-only items (`#[cfg(test)]`) are not held to it.
const MAX_FUNCTION_LINES: usize = 120;

/// Each production function of `text` with its first line and length in lines.
fn function_lengths(text: &str) -> Vec<(String, usize, usize)> {
    let lines = code_lines(&without_test_items(text));
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
        let Some(name) = is_fn(&lines[i]) else {
            i += 1;
            continue;
        };
        let (mut depth, mut started, mut j) = (0i64, false, i);
        while j < lines.len() {
            for b in braces(&lines[j]) {
                depth += b;
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
    let mut long = Vec::new();
    for (root, rel, text) in sources_of(SOURCE_ROOTS) {
        for (name, line, len) in function_lengths(&text) {
            if len > MAX_FUNCTION_LINES {
                long.push(format!(
                    "{root}/{}:{line}: `{name}` is {len} lines",
                    rel.display()
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

/// The files of a module that use each other in a circle, each circle with one line per use.
/// A unit is a module's child: a file, or a sub-folder with everything in it. A child using
/// its parent's own items (`super::Item` from `mod.rs`), or a parent re-exporting its
/// children, is no edge: that two-way traffic is how a module is built, so only siblings can
/// form a circle. `files` are relative to `root`, a crate's source folder.
fn file_circles(root: &str, files: &[(PathBuf, String)]) -> Vec<String> {
    let modules: BTreeMap<Vec<String>, &Path> = files
        .iter()
        .map(|(rel, _)| (module_path(rel), rel.as_path()))
        .collect();
    // (parent module, from child, to child) → the first use's file and line
    let mut edges: BTreeMap<(Vec<String>, String, String), (&Path, usize)> = BTreeMap::new();
    for (rel, text) in files {
        let here = module_path(rel);
        if here.is_empty() || rel.starts_with("bin") {
            // the crate roots, whose children are the top-level modules LAYERS holds, and the
            // other binaries, whose paths start at a root of their own
            continue;
        }
        for path in paths(&without_test_items(text)) {
            // the absolute path: `crate::`, `self::` and `super::` (perhaps repeated) resolved
            let (root, line) = (&path[0].0, path[0].1);
            let mut abs: Segments = match root.as_str() {
                "crate" => Vec::new(),
                _ => here.iter().map(|m| (m.clone(), line)).collect(),
            };
            let ups = path.iter().take_while(|s| s.0 == "super").count();
            if ups > abs.len() {
                continue;
            }
            abs.truncate(abs.len() - ups);
            abs.extend(path[ups.max(1)..].iter().cloned());
            // the module whose file holds the item: the longest prefix that is a file's
            let names: Vec<String> = abs.iter().map(|s| s.0.clone()).collect();
            let Some(target) = (1..=names.len())
                .rev()
                .map(|n| &names[..n])
                .find(|p| modules.contains_key(*p))
            else {
                continue;
            };
            let common = here.iter().zip(target).take_while(|(a, b)| a == b).count();
            if common == 0 || common == here.len() || common == target.len() {
                continue;
            }
            let key = (
                here[..common].to_vec(),
                here[common].clone(),
                target[common].clone(),
            );
            edges.entry(key).or_insert((rel, abs[common].1));
        }
    }
    // a child of `parent` shown as its file, or its folder when it has one of its own
    let unit = |parent: &[String], child: &str| -> String {
        let mut p = parent.to_vec();
        p.push(child.to_string());
        match modules.get(&p) {
            Some(f) if f.ends_with("mod.rs") => {
                format!("{root}/{}/", f.parent().unwrap().display())
            }
            Some(f) => format!("{root}/{}", f.display()),
            None => format!("{root}/{}/", p.join("/")),
        }
    };
    let mut out = Vec::new();
    let parents: BTreeSet<&Vec<String>> = edges.keys().map(|(p, _, _)| p).collect();
    for parent in parents {
        let mut next: BTreeMap<&str, BTreeSet<&str>> = BTreeMap::new();
        for (p, from, to) in edges.keys() {
            if p == parent {
                next.entry(from).or_default().insert(to);
            }
        }
        let reach = |from: &str| -> BTreeSet<&str> {
            let mut seen = BTreeSet::new();
            let mut todo = vec![from];
            while let Some(n) = todo.pop() {
                for &m in next.get(n).into_iter().flatten() {
                    if seen.insert(m) {
                        todo.push(m);
                    }
                }
            }
            seen
        };
        let reached: BTreeMap<&str, BTreeSet<&str>> = next.keys().map(|&n| (n, reach(n))).collect();
        let mut circles = BTreeSet::new();
        for (&n, r) in &reached {
            if r.contains(n) {
                let circle: BTreeSet<&str> = r
                    .iter()
                    .copied()
                    .filter(|m| reached.get(m).is_some_and(|rm| rm.contains(n)))
                    .collect();
                circles.insert(circle);
            }
        }
        for circle in circles {
            let names: Vec<String> = circle.iter().map(|c| unit(parent, c)).collect();
            let mut report = format!("a circle of {}:", names.join(", "));
            for ((p, from, to), (file, line)) in &edges {
                if p == parent && circle.contains(from.as_str()) && circle.contains(to.as_str()) {
                    report.push_str(&format!(
                        "\n    {root}/{}:{line}: uses {}",
                        file.display(),
                        unit(parent, to)
                    ));
                }
            }
            out.push(report);
        }
    }
    out
}

#[test]
fn no_file_circle_inside_a_module() {
    let circles: Vec<String> = SOURCE_ROOTS
        .iter()
        .flat_map(|r| file_circles(r, &production_sources(r)))
        .collect();
    assert!(
        circles.is_empty(),
        "{} file circles inside modules (break each: move what both sides need to a file of its \
         own, or to the module's mod.rs):\n{}",
        circles.len(),
        circles.join("\n")
    );
}

#[test]
fn the_circle_finder_sees_two_files_using_each_other() {
    let files = |list: &[(&str, &str)]| -> Vec<(PathBuf, String)> {
        list.iter()
            .map(|(p, t)| (PathBuf::from(p), t.to_string()))
            .collect()
    };
    let circle = files(&[
        ("m/mod.rs", "pub mod a;\npub mod b;\npub use a::Y;\n"),
        ("m/a.rs", "use super::b::X;\npub struct Y;\n"),
        (
            "m/b.rs",
            "pub struct X;\nfn f() -> super::a::Y {\n    todo!()\n}\n",
        ),
    ]);
    assert_eq!(
        file_circles("src", &circle),
        vec![
            "a circle of src/m/a.rs, src/m/b.rs:\n    src/m/a.rs:1: uses src/m/b.rs\n    \
              src/m/b.rs:2: uses src/m/a.rs"
                .to_string()
        ]
    );
    // one way, with the child using its parent's item and a test using its sibling: no circle
    let one_way = files(&[
        ("m/mod.rs", "pub mod a;\npub mod b;\npub struct Z;\n"),
        ("m/a.rs", "use super::b::X;\npub struct Y;\n"),
        (
            "m/b.rs",
            "use super::Z;\npub struct X;\n#[cfg(test)]\nmod tests {\n    use crate::m::a::Y;\n}\n",
        ),
    ]);
    assert_eq!(file_circles("src", &one_way), Vec::<String>::new());
    // through `crate::` into a sub-folder, which is one unit, and `self::` in a mod.rs
    let deep = files(&[
        ("m/mod.rs", "mod a;\nmod c;\nuse self::a::Y;\n"),
        (
            "m/a.rs",
            "pub fn y() -> crate::m::c::d::Z {\n    todo!()\n}\n",
        ),
        ("m/c/mod.rs", "mod d;\n"),
        ("m/c/d.rs", "use crate::{m::a::y, geom::Plane};\n"),
    ]);
    assert_eq!(
        file_circles("src", &deep),
        vec![
            "a circle of src/m/a.rs, src/m/c/:\n    src/m/a.rs:1: uses src/m/c/\n    \
              src/m/c/d.rs:1: uses src/m/a.rs"
                .to_string()
        ]
    );
}

/// ARCHITECTURE.md's text between a heading and the next.
fn architecture_section(heading: &str) -> String {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("ARCHITECTURE.md");
    let text = std::fs::read_to_string(path).unwrap();
    let start = text
        .find(heading)
        .unwrap_or_else(|| panic!("ARCHITECTURE.md has no `{heading}`"));
    let rest = &text[start + heading.len()..];
    rest[..rest.find("\n## ").unwrap_or(rest.len())].to_string()
}

/// The names in backticks on each numbered line of a text, in order.
fn numbered_lists(text: &str) -> Vec<Vec<String>> {
    text.lines()
        .filter(|l| {
            let t = l.trim_start();
            t.split_once(". ")
                .is_some_and(|(n, _)| !n.is_empty() && n.chars().all(|c| c.is_ascii_digit()))
        })
        .map(|l| {
            l.split('`')
                .skip(1)
                .step_by(2)
                .map(str::to_string)
                .collect()
        })
        .collect()
}

#[test]
fn the_architecture_map_lists_the_layers_of_the_code() {
    let listed: Vec<Vec<String>> = numbered_lists(&architecture_section("## Layering"))
        .into_iter()
        .filter(|names| !names.iter().any(|n| n.ends_with(".rs") || n.ends_with('/')))
        .collect();
    let code: Vec<Vec<String>> = LAYERS
        .iter()
        .map(|l| l.iter().map(|m| m.to_string()).collect())
        .collect();
    assert_eq!(
        listed, code,
        "ARCHITECTURE.md's Layering list and tests/tidy.rs LAYERS differ"
    );
}

/// The capitalised words of a text: the type names a diagram draws.
fn type_names(text: &str) -> BTreeSet<String> {
    text.split(|c: char| !c.is_ascii_alphanumeric() && c != '_')
        .filter(|w| {
            let mut c = w.chars();
            c.next().is_some_and(|f| f.is_ascii_uppercase())
                && c.next().is_some_and(|s| s.is_ascii_lowercase())
        })
        .map(str::to_string)
        .collect()
}

#[test]
fn the_architecture_diagram_names_only_types_that_exist() {
    let section = architecture_section("## Bird's eye view");
    let diagram = section
        .split("```")
        .nth(1)
        .expect("ARCHITECTURE.md's bird's eye view has a diagram");
    let names = type_names(diagram);
    assert!(names.len() >= 10, "{names:?}");
    let mut files = Vec::new();
    for root in SOURCE_ROOTS {
        let src = Path::new(env!("CARGO_MANIFEST_DIR")).join(root);
        rust_files(&src, &mut files);
    }
    let text: String = files
        .iter()
        .map(|f| std::fs::read_to_string(f).unwrap())
        .collect();
    let missing: Vec<&String> = names
        .iter()
        .filter(|n| {
            !["struct", "enum", "type", "trait"].iter().any(|k| {
                text.contains(&format!("pub {k} {n} ")) || text.contains(&format!("pub {k} {n}<"))
            })
        })
        .collect();
    assert!(
        missing.is_empty(),
        "ARCHITECTURE.md's diagram names types that do not exist in src/: {missing:?}"
    );
}

#[test]
fn the_map_readers_see_lists_and_type_names() {
    let text =
        "1. leaf helpers: `rng`, `scc`\n2. `geom`\n10. the binaries: `main.rs`\nnot 3. `x`\n";
    assert_eq!(
        numbered_lists(text),
        vec![
            vec!["rng".to_string(), "scc".to_string()],
            vec!["geom".to_string()],
            vec!["main.rs".to_string()]
        ]
    );
    let names = type_names("import ──► Scene ──► CellSet { tagged } .glb HTML Pvs");
    assert_eq!(
        names.into_iter().collect::<Vec<_>>(),
        vec!["CellSet", "Pvs", "Scene"]
    );
}

/// Longest the README may be, in lines: the front page says what the tool is, how to run it
/// and where the rest is; tables and long sections live in docs/ (issue 53).
const README_MAX_LINES: usize = 200;

/// Largest ARCHITECTURE.md may be, in bytes: a map of the code and its invariants, not a diary.
const ARCHITECTURE_MAX_BYTES: usize = 15_000;

#[test]
fn the_readme_and_the_architecture_map_stay_short() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut over = Vec::new();
    let lines = std::fs::read_to_string(root.join("README.md"))
        .unwrap()
        .lines()
        .count();
    if lines > README_MAX_LINES {
        over.push(format!(
            "README.md is {lines} lines, over {README_MAX_LINES}: move detail into docs/ and link it"
        ));
    }
    let bytes = std::fs::metadata(root.join("ARCHITECTURE.md"))
        .unwrap()
        .len() as usize;
    if bytes > ARCHITECTURE_MAX_BYTES {
        over.push(format!(
            "ARCHITECTURE.md is {bytes} bytes, over {ARCHITECTURE_MAX_BYTES}: tighten it"
        ));
    }
    assert!(over.is_empty(), "{}", over.join("\n"));
}

/// Each `pub` function of `text` (not `pub(crate)` or `pub(super)`) whose return type is
/// `Result<_, String>`, with its name and line. The signature is read from `pub` through its
/// body's `{` (or its `;`), across lines, code only.
fn pub_fns_returning_string_errors(text: &str) -> Vec<(String, usize)> {
    let lines = code_lines(&without_test_items(text));
    let mut out = Vec::new();
    for (i, line) in lines.iter().enumerate() {
        let t = line.trim_start();
        let Some(rest) = t.strip_prefix("pub ") else {
            continue;
        };
        let rest = ["const ", "async ", "unsafe ", "extern \"\" "]
            .iter()
            .fold(rest, |r, q| r.strip_prefix(q).unwrap_or(r));
        let Some(rest) = rest.strip_prefix("fn ") else {
            continue;
        };
        let name: String = rest
            .chars()
            .take_while(|c| c.is_alphanumeric() || *c == '_')
            .collect();
        let mut signature = String::new();
        for l in &lines[i..] {
            let end = l.find(['{', ';']);
            signature.push_str(&l[..end.unwrap_or(l.len())]);
            signature.push(' ');
            if end.is_some() {
                break;
            }
        }
        // The return type follows the parameter list's closing parenthesis, after any generics
        // (a parameter or a bound may be a closure with an arrow of its own).
        let signature = signature.replace("->", "→");
        let after_name =
            &signature[signature.find(&format!("fn {name}")).unwrap() + 3 + name.len()..];
        let Some(ret) = after_generics_and_parameters(after_name)
            .and_then(|r| r.trim_start().strip_prefix('→'))
        else {
            continue;
        };
        let ret: String = ret
            .split(" where ")
            .next()
            .unwrap()
            .chars()
            .filter(|c| !c.is_whitespace())
            .collect::<String>()
            .replace(",>", ">");
        let string_error = ret
            .strip_suffix(",String>")
            .or_else(|| ret.strip_suffix(",std::string::String>"))
            .is_some_and(|r| {
                ["Result<", "std::result::Result<", "core::result::Result<"]
                    .iter()
                    .any(|p| r.starts_with(p))
            });
        if string_error {
            out.push((name, i + 1));
        }
    }
    out
}

/// What follows a function's generics (`<..>`, if any) and parameter list (`(..)`), in a
/// signature whose arrows are written `→` (so `>` only closes generics).
fn after_generics_and_parameters(sig: &str) -> Option<&str> {
    let mut depth = 0;
    let mut rest = sig.trim_start();
    if rest.starts_with('<') {
        let end = rest.char_indices().find_map(|(k, c)| {
            match c {
                '<' => depth += 1,
                '>' => depth -= 1,
                _ => return None,
            }
            (depth == 0).then_some(k)
        })?;
        rest = &rest[end + 1..];
    }
    let rest = rest.trim_start();
    if !rest.starts_with('(') {
        return None;
    }
    let end = rest.char_indices().find_map(|(k, c)| {
        match c {
            '(' => depth += 1,
            ')' => depth -= 1,
            _ => return None,
        }
        (depth == 0).then_some(k)
    })?;
    Some(&rest[end + 1..])
}

#[test]
fn no_public_function_returns_a_string_error() {
    let mut found = Vec::new();
    for (root, rel, text) in sources_of(SOURCE_ROOTS) {
        for (name, line) in pub_fns_returning_string_errors(&text) {
            found.push(format!("{root}/{}:{line}: `{name}`", rel.display()));
        }
    }
    assert!(
        found.is_empty(),
        "public functions returning `Result<_, String>` (give the error a type the caller can \
         match on, with Display for the message):\n{}",
        found.join("\n")
    );
}

#[test]
fn the_string_error_finder_reads_signatures_across_lines() {
    let text = "pub fn a(x: &str) -> Result<(), String> {\n}\n\
                pub fn b(\n    x: &str,\n) -> Result<\n    Vec<u8>,\n    String,\n> {\n}\n\
                pub(crate) fn c() -> Result<(), String> {\n}\n\
                fn d() -> Result<(), String> {\n}\n\
                pub fn e() -> Result<String, Error> {\n}\n\
                pub fn f() -> Result<Option<String>, E> {\n}\n\
                pub fn g() -> std::result::Result<u8, String>;\n\
                pub fn h() -> Result<(), String> where T: Copy {\n}\n\
                #[cfg(test)]\npub fn i() -> Result<(), String> {\n}\n\
                pub fn j() -> u8 { let s: Result<(), String> = Ok(()); 0 }\n\
                pub fn k(f: impl Fn() -> u8) -> Result<u8, String> {\n}\n\
                pub fn l(f: impl Fn() -> Result<(), String>) -> u8 {\n}\n\
                pub fn m<F: Fn(u8) -> u8, T: Into<Vec<u8>>>(f: F) -> Result<T, String> {\n}\n";
    assert_eq!(
        pub_fns_returning_string_errors(text),
        vec![
            ("a".to_string(), 1),
            ("b".to_string(), 3),
            ("g".to_string(), 18),
            ("h".to_string(), 19),
            ("k".to_string(), 25),
            ("m".to_string(), 29)
        ]
    );
}

/// How far above a table of measurements (in lines, within its section and not past the table
/// before it) the command that measures it may be named.
const COMMAND_REACH: usize = 12;

/// Units of what a run measures: time, memory, ratios and shares (`0.40 s`, `39 MB`, `2.9×`).
const MEASURED_UNITS: &[&str] = &[
    "s", "ms", "µs", "min", "minutes", "KB", "MB", "GB", "%", "×",
];

/// Header words of a table whose numbers are counted or measured (`cells`, `pairs`, `measured`).
const COUNTED: &[&str] = &[
    "cells",
    "portals",
    "pairs",
    "leafs",
    "points",
    "rays",
    "triangles",
    "brushes",
    "los",
    "sightlines",
    "areas",
    "rooms",
    "seconds",
    "memory",
    "median",
    "measured",
];

/// The pages whose figures must say how to reproduce them: README.md and docs/*.md, but
/// docs/diagnostics.md, which scripts/gen_diagnostics_doc.py writes and which measures nothing.
fn figure_pages(root: &Path) -> Vec<(String, String)> {
    // the engine plugins' pages state what they cost per frame
    let mut names = vec![
        "README.md".to_string(),
        "js/portcullis-three/README.md".to_string(),
        "crates/portcullis-bevy/README.md".to_string(),
    ];
    let mut docs: Vec<String> = std::fs::read_dir(root.join("docs"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".md") && n != "diagnostics.md")
        .map(|n| format!("docs/{n}"))
        .collect();
    docs.sort();
    names.extend(docs);
    names
        .into_iter()
        .map(|n| {
            let text = std::fs::read_to_string(root.join(&n)).unwrap();
            (n, text)
        })
        .collect()
}

/// The numbers of a text, each with the word right after it ("" when none): `0.40 s` is
/// ("0.40", "s"), `2.9×` ("2.9", "×"), `1,078, 5,902` two numbers with no unit. Digits in a
/// word (`E1M1`, `cell3`, `portal_3to5_1`) are no number.
fn numbers(text: &str) -> Vec<(String, String)> {
    let chars: Vec<char> = text.chars().collect();
    let mut out = Vec::new();
    let mut i = 0;
    while i < chars.len() {
        let glued = i > 0 && (chars[i - 1].is_alphanumeric() || chars[i - 1] == '_');
        if !chars[i].is_ascii_digit() || glued {
            i += 1;
            continue;
        }
        let start = i;
        while i < chars.len()
            && (chars[i].is_ascii_digit()
                || ((chars[i] == '.' || chars[i] == ',')
                    && chars.get(i + 1).is_some_and(char::is_ascii_digit)))
        {
            i += 1;
        }
        let number: String = chars[start..i].iter().collect();
        let mut j = i;
        while j < chars.len() && chars[j] == ' ' {
            j += 1;
        }
        let unit_start = j;
        while j < chars.len() && (chars[j].is_alphabetic() || "%×µ".contains(chars[j])) {
            j += 1;
        }
        out.push((number, chars[unit_start..j].iter().collect()));
    }
    out
}

/// Whether a command names a measuring tool of the project: a script, a bench or test target,
/// the binary (after `VAR=value` settings and `/usr/bin/time`).
fn is_command(text: &str) -> bool {
    let rest = without_settings(text);
    [
        "scripts/",
        "cargo bench",
        "cargo test",
        "portcullis ",
        "target/release/portcullis ",
        "/usr/bin/time ",
    ]
    .iter()
    .any(|p| rest.starts_with(p))
}

/// A command without the `VAR=value` settings before it.
fn without_settings(text: &str) -> &str {
    let mut rest = text.trim();
    while let Some((word, after)) = rest.split_once(' ') {
        let setting = word.split_once('=').is_some_and(|(k, _)| {
            !k.is_empty()
                && k.chars()
                    .all(|c| c.is_ascii_uppercase() || c.is_ascii_digit() || c == '_')
        });
        if !setting {
            break;
        }
        rest = after.trim_start();
    }
    rest
}

/// For each line of a Markdown text, the language of the fenced block it is in (`sh`, `text`,
/// "" for a bare fence), or None outside one; fence lines themselves are in none.
fn fences(lines: &[&str]) -> Vec<Option<String>> {
    let mut open: Option<String> = None;
    lines
        .iter()
        .map(|l| match l.trim_start().strip_prefix("```") {
            Some(lang) => {
                open = match open {
                    Some(_) => None,
                    None => Some(lang.trim().to_string()),
                };
                None
            }
            None => open.clone(),
        })
        .collect()
}

/// The commands each line of a page names: the spans in backticks that are commands (a span
/// broken over lines belongs to the line it starts on; a blank line or a fence ends it), and in
/// a shell block the line itself (its `#` comment cut).
fn page_commands(lines: &[&str], fence: &[Option<String>]) -> Vec<Vec<String>> {
    let mut out = vec![Vec::new(); lines.len()];
    // the span open at the end of the line before: the line it started on and its text
    let mut open: Option<(usize, String)> = None;
    for (i, line) in lines.iter().enumerate() {
        match fence[i].as_deref() {
            Some("sh" | "bash" | "") => {
                let code = line.split(" #").next().unwrap_or("").trim();
                if is_command(code) {
                    out[i].push(code.to_string());
                }
                open = None;
                continue;
            }
            Some(_) => {
                open = None;
                continue;
            }
            None if line.trim().is_empty() || line.trim_start().starts_with("```") => {
                open = None;
                continue;
            }
            None => {}
        }
        for (k, part) in line.split('`').enumerate() {
            if k > 0 {
                // a backtick: a span closes or opens here
                open = match open.take() {
                    Some((at, span)) => {
                        if is_command(&span) {
                            out[at].push(span);
                        }
                        None
                    }
                    None => Some((i, String::new())),
                };
            }
            if let Some((_, span)) = &mut open {
                if k == 0 {
                    span.push(' ');
                }
                span.push_str(part);
            }
        }
    }
    out
}

/// Why a command a page names cannot run as written, or None: the script, bench or test
/// target it names does not exist, `scripts/figures.sh` has no such figure, or the binary no
/// such subcommand.
fn command_fault(root: &Path, command: &str) -> Option<String> {
    let words: Vec<&str> = without_settings(command).split_whitespace().collect();
    let after = |flag: &str| -> Vec<&str> {
        words
            .windows(2)
            .filter(|w| w[0] == flag)
            .map(|w| w[1])
            .collect()
    };
    let first = *words.first()?;
    if let Some(script) = first.strip_prefix("scripts/") {
        // `scripts/` alone names the folder
        let path = root.join("scripts").join(script);
        if !script.is_empty() && !path.is_file() {
            return Some(format!("no scripts/{script}"));
        }
        // `scripts/figures.sh` alone lists the figures; with a name, it must be one of them
        if let (true, Some(figure)) = (script == "figures.sh", words.get(1)) {
            let text = std::fs::read_to_string(path).unwrap();
            let known = text
                .lines()
                .any(|l| l.trim_start().starts_with(&format!("{figure})")));
            if !known {
                return Some(format!("scripts/figures.sh has no figure `{figure}`"));
            }
        }
        return None;
    }
    if words.starts_with(&["cargo", "bench"]) {
        let benches = after("--bench");
        if benches.is_empty() {
            return Some("`cargo bench` without `--bench NAME`".into());
        }
        return benches
            .iter()
            .find(|b| !root.join("benches").join(format!("{b}.rs")).is_file())
            .map(|b| format!("no benches/{b}.rs"));
    }
    if words.starts_with(&["cargo", "test"]) {
        return after("--test")
            .iter()
            .find(|t| !root.join("tests").join(format!("{t}.rs")).is_file())
            .map(|t| format!("no tests/{t}.rs"));
    }
    let bin = words
        .iter()
        .position(|w| *w == "portcullis" || w.ends_with("/portcullis"))?;
    let sub = words.get(bin + 1).copied().unwrap_or("");
    let placeholder = sub.starts_with('-') || sub.chars().all(|c| !c.is_ascii_lowercase());
    let real = root.join("src/cli").join(format!("{sub}.rs")).is_file()
        && !["mod", "alloc", "huge_pages"].contains(&sub);
    (!placeholder && !real).then(|| format!("`portcullis {sub}` is no command"))
}

/// What is wrong with a page's figures: each table of measurements with no command that
/// measures it named within [`COMMAND_REACH`] lines above (in its section, after the table
/// before it) nor in each of its measured rows; each command or `scripts/` file named that
/// does not exist. A table measures when a cell of its body has a number in a unit of
/// [`MEASURED_UNITS`], or its header names what is counted ([`COUNTED`]) over a number.
fn figure_faults(root: &Path, page: &str, text: &str) -> Vec<String> {
    let lines: Vec<&str> = text.lines().collect();
    let fence = fences(&lines);
    let commands = page_commands(&lines, &fence);
    let is_row = |i: usize| fence[i].is_none() && lines[i].trim_start().starts_with('|');
    let mut faults = Vec::new();
    for (i, line) in lines.iter().enumerate() {
        for command in &commands[i] {
            if let Some(why) = command_fault(root, command) {
                faults.push(format!("{page}:{}: `{command}`: {why}", i + 1));
            }
        }
        for (k, _) in line.match_indices("scripts/") {
            // `scripts/X` of this project, not `a/scripts/X` of another
            let own = line[..k]
                .chars()
                .next_back()
                .is_none_or(|c| !c.is_alphanumeric() && !"/._-".contains(c));
            let name: String = line[k + 8..]
                .chars()
                .take_while(|c| c.is_ascii_alphanumeric() || "_.-".contains(*c))
                .collect();
            let name = name.trim_end_matches('.');
            if own && !name.is_empty() && !root.join("scripts").join(name).is_file() {
                faults.push(format!("{page}:{}: no scripts/{name}", i + 1));
            }
        }
    }
    let mut i = 0;
    while i < lines.len() {
        if !is_row(i) || (i > 0 && is_row(i - 1)) {
            i += 1;
            continue;
        }
        let start = i;
        while i < lines.len() && is_row(i) {
            i += 1;
        }
        let header: Vec<String> = lines[start]
            .split(|c: char| !c.is_alphanumeric())
            .map(str::to_lowercase)
            .collect();
        let counted = COUNTED.iter().any(|w| header.iter().any(|h| h == w));
        let measures = |row: &str| {
            numbers(row)
                .iter()
                .any(|(_, unit)| counted || MEASURED_UNITS.contains(&unit.as_str()))
        };
        let body = (start + 2).min(i)..i;
        if !body.clone().any(|r| measures(lines[r])) {
            continue;
        }
        // the lines above, up to the table before or the section's heading
        let heading = |k: usize| fence[k].is_none() && lines[k].starts_with('#');
        let named_above = (start.saturating_sub(COMMAND_REACH)..start)
            .rev()
            .take_while(|&k| !is_row(k) && !heading(k))
            .any(|k| !commands[k].is_empty());
        let each_row_names_one = body
            .clone()
            .filter(|&r| measures(lines[r]))
            .all(|r| !commands[r].is_empty());
        if !named_above && !each_row_names_one {
            faults.push(format!(
                "{page}:{}: a table of measurements with no command that reproduces it \
                 (in backticks or a sh block within {COMMAND_REACH} lines above, or in each \
                 measured row)",
                start + 1
            ));
        }
    }
    faults
}

#[test]
fn every_figure_names_the_command_that_measures_it() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let pages = figure_pages(root);
    assert!(pages.len() >= 7, "{} pages", pages.len());
    let faults: Vec<String> = pages
        .iter()
        .flat_map(|(page, text)| figure_faults(root, page, text))
        .collect();
    assert!(
        faults.is_empty(),
        "figures without the command that reproduces them (issue 53, item 13):\n{}",
        faults.join("\n")
    );
    let generated = std::fs::read_to_string(root.join("scripts/gen_diagnostics_doc.py")).unwrap();
    assert!(
        generated.contains("docs/diagnostics.md"),
        "docs/diagnostics.md is left out as generated by scripts/gen_diagnostics_doc.py"
    );
}

#[test]
fn the_figure_checker_sees_a_table_without_its_command() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let table = "| level | time |\n|---|---|\n| a | 0.4 s |\n";
    let faults = |text: &str| figure_faults(root, "p.md", text);
    assert_eq!(faults(table).len(), 1);
    // named above, in a shell block or in backticks
    assert!(faults(&format!("```sh\nscripts/bench.sh\n```\n\n{table}")).is_empty());
    assert!(faults(&format!(
        "Measured with `cargo bench --bench stages -- cull`:\n\n{table}"
    ))
    .is_empty());
    assert!(faults(&format!(
        "A span `cargo bench\n--bench stages` over lines:\n{table}"
    ))
    .is_empty());
    assert_eq!(
        faults(&format!(
            "Not `cargo bench\n\n--bench stages` over a paragraph:\n{table}"
        ))
        .len(),
        1
    );
    // but not across a heading or the table before, nor further than the reach
    assert_eq!(
        faults(&format!("`scripts/bench.sh`\n## Next\n{table}")).len(),
        1
    );
    assert_eq!(
        faults(&format!("`scripts/bench.sh`\n{table}\n{table}")).len(),
        1
    );
    assert_eq!(
        faults(&format!(
            "`scripts/bench.sh`{}\n{table}",
            "\n".repeat(COMMAND_REACH)
        ))
        .len(),
        1
    );
    // or in each measured row
    let rows = "| what | state |\n|---|---|\n| a | 2.9× (`scripts/bench.sh`) |\n| b | done |\n";
    assert!(faults(rows).is_empty());
    // counted things: a number under a header that names them; no unit, no count: no figure
    assert_eq!(
        faults("| map | cells |\n|---|---|\n| a | 1,078 |\n").len(),
        1
    );
    assert!(
        faults("| input | default |\n|---|---|\n| glTF | 8 mm |\n| `cell3`, E1M1 | 2e-5 |\n")
            .is_empty()
    );
    // commands that cannot run as written
    let bad = "`scripts/nope.sh`, `cargo bench --bench nope`, `cargo test --test nope`, \
               `portcullis nope x`, `scripts/figures.sh nope`, scripts/gone.py\n";
    assert_eq!(faults(bad).len(), 7, "{:?}", faults(bad));
    assert!(faults("`QBSP=q cargo bench --bench brush_maps -- grid`, `portcullis --help`, `portcullis vis --report`\n").is_empty());
    assert!(faults("`scripts/`, `scripts/figures.sh`, `scripts/figures.sh stages`\n").is_empty());
    assert_eq!(
        numbers("E1M1 0.40 s, 1,078, 2.9× cell3 85.6%"),
        [("0.40", "s"), ("1,078", ""), ("2.9", "×"), ("85.6", "%")]
            .map(|(a, b)| (a.to_string(), b.to_string()))
    );
}

/// The modules whose distance and angle tests go through the tolerance (ARCHITECTURE.md,
/// "Invariants"): a threshold there is the level's tolerance, a named multiple of it, or a
/// named `const` with its reason, never a bare number, so that one change of policy reaches
/// every test and a reader can tell a tolerance from a budget.
const TOLERANCE_MODULES: &[(&str, &str)] = &[
    ("src", "geom"),
    ("src", "cells"),
    ("src", "portals"),
    ("src", "vis"),
    ("crates/portcullis-runtime/src", "runtime"),
];

/// The smallest float literal allowed bare: 1/100 is a fraction (a hundredth of a width, a
/// percent), anything finer a tolerance that must be named.
const SMALLEST_BARE: f64 = 1e-2;

/// The float literals below [`SMALLEST_BARE`] in `text` outside `const` and `static` items and
/// test items: (line, literal).
fn bare_thresholds(text: &str) -> Vec<(usize, String)> {
    let code = code_lines(&without_test_items(text));
    let mut out = Vec::new();
    let mut in_const = false;
    for (i, line) in code.iter().enumerate() {
        let t = line.trim_start();
        let t = t
            .strip_prefix("pub(crate) ")
            .or_else(|| t.strip_prefix("pub(super) "))
            .or_else(|| t.strip_prefix("pub "))
            .unwrap_or(t);
        if t.starts_with("const ") || t.starts_with("static ") {
            in_const = true;
        }
        if !in_const {
            for lit in float_literals(line) {
                let v: f64 = lit
                    .trim_end_matches("f64")
                    .trim_end_matches("f32")
                    .trim_end_matches('_')
                    .replace('_', "")
                    .parse()
                    .unwrap_or(0.0);
                if v > 0.0 && v < SMALLEST_BARE {
                    out.push((i + 1, lit));
                }
            }
        }
        if in_const && line.contains(';') {
            in_const = false;
        }
    }
    out
}

/// The float literals of one line of code (a `.`, an exponent or an `f32`/`f64` suffix; not a
/// tuple field `x.0`, a range `0..3` or an integer).
fn float_literals(line: &str) -> Vec<String> {
    let b = line.as_bytes();
    let mut out = Vec::new();
    let mut i = 0;
    while i < b.len() {
        let starts = b[i].is_ascii_digit()
            && (i == 0
                || !(b[i - 1].is_ascii_alphanumeric() || b[i - 1] == b'_' || b[i - 1] == b'.'));
        if !starts {
            i += 1;
            continue;
        }
        let from = i;
        let digits = |i: &mut usize| {
            while *i < b.len() && (b[*i].is_ascii_digit() || b[*i] == b'_') {
                *i += 1;
            }
        };
        digits(&mut i);
        let mut float = false;
        if i + 1 < b.len() && b[i] == b'.' && b[i + 1].is_ascii_digit() {
            float = true;
            i += 1;
            digits(&mut i);
        } else if i < b.len()
            && b[i] == b'.'
            && !(i + 1 < b.len()
                && (b[i + 1] == b'.' || b[i + 1].is_ascii_alphabetic() || b[i + 1] == b'_'))
        {
            float = true; // `1.`
            i += 1;
        }
        if i < b.len() && (b[i] == b'e' || b[i] == b'E') {
            let mut j = i + 1;
            if j < b.len() && (b[j] == b'-' || b[j] == b'+') {
                j += 1;
            }
            if j < b.len() && b[j].is_ascii_digit() {
                float = true;
                i = j;
                digits(&mut i);
            }
        }
        let rest = &line[i..];
        if rest.starts_with("f64") || rest.starts_with("f32") {
            float = true;
            i += 3;
        } else if rest.starts_with("_f64") || rest.starts_with("_f32") {
            float = true;
            i += 4;
        }
        if float {
            out.push(line[from..i].to_string());
        }
    }
    out
}

#[test]
fn no_bare_threshold_in_the_geometry_modules() {
    let mut bare = Vec::new();
    for &(root, module) in TOLERANCE_MODULES {
        for (rel, text) in production_sources(root) {
            if module_of(&rel).as_deref() != Some(module) {
                continue;
            }
            for (line, lit) in bare_thresholds(&text) {
                bare.push(format!("{root}/{}:{line}: `{lit}`", rel.display()));
            }
        }
    }
    assert!(
        bare.is_empty(),
        "bare thresholds below {SMALLEST_BARE} (use the tolerance's rules, geom::tolerance, or a named const with its reason):\n{}",
        bare.join("\n")
    );
}

#[test]
fn the_threshold_finder_sees_a_bare_literal_and_passes_a_named_one() {
    let named = "/// Why.\nconst SLIVER: f64 = 1e-9;\npub(crate) const LONG: f64 =\n    0.001;\n\
                 fn f(x: f64, eps: f64) -> bool {\n    x < 2.0 * eps && x.0 > 0.5 && (0..3).len() > 1\n}\n\
                 #[cfg(test)]\nmod tests {\n    fn g() -> f64 { 1e-12 }\n}\n";
    assert_eq!(bare_thresholds(named), vec![]);
    let added = named.replace("x < 2.0 * eps", "x < 1e-9 && y < 0.001_f64 && z < 5e-3");
    assert_eq!(
        bare_thresholds(&added),
        vec![
            (6, "1e-9".to_string()),
            (6, "0.001_f64".to_string()),
            (6, "5e-3".to_string())
        ]
    );
    assert_eq!(
        float_literals("a.0 + 1.5e+3 + 2. + 7u8 + 0..2 + x.max(1.0)"),
        vec!["1.5e+3", "2.", "1.0"]
    );
}
