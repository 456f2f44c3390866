//! SARIF 2.1.0, for code-scanning services (GitHub, Azure DevOps): one run, every code as a
//! rule (with its default level and a link to its documentation), one result per diagnostic.
//! glTF places are JSON pointers and node paths, which SARIF has no region for, so they are
//! logical locations; OBJ lines are regions; the 3D point and the hint are properties.

use std::path::Path;

use serde_json::{json, Map, Value};

use super::file::FileReport;
use crate::diag::{Code, Diagnostic, Severity};

const DOCS: &str = "https://github.com/portcullis-dev/portcullis/blob/main/docs/diagnostics.md";

fn level(s: Severity) -> &'static str {
    match s {
        Severity::Error => "error",
        Severity::Warning => "warning",
        Severity::Info => "note",
    }
}

/// A path as a URI reference: relative paths stay relative (resolved against the working
/// folder, `%SRCROOT%`), absolute ones become `file://` URIs; anything outside the unreserved
/// characters is percent-encoded.
pub fn uri(path: &Path) -> String {
    let s = path.to_string_lossy().replace('\\', "/");
    let mut out = String::new();
    if path.is_absolute() {
        out.push_str("file://");
        if !s.starts_with('/') {
            out.push('/');
        }
    }
    for b in s.bytes() {
        match b {
            b'A'..=b'Z' | b'a'..=b'z' | b'0'..=b'9' | b'-' | b'.' | b'_' | b'~' | b'/' => {
                out.push(b as char)
            }
            b':' if path.is_absolute() => out.push(':'),
            _ => out.push_str(&format!("%{b:02X}")),
        }
    }
    out
}

fn rule(c: Code) -> Value {
    json!({
        "id": c.as_str(),
        "shortDescription": { "text": c.summary() },
        "defaultConfiguration": { "level": level(c.default_severity()) },
        "helpUri": format!("{DOCS}#{}", c.as_str().to_ascii_lowercase()),
    })
}

fn result(d: &Diagnostic, artifact: usize, file: &Path) -> Value {
    let rule_index = Code::ALL.iter().position(|c| *c == d.code).unwrap_or(0);
    let mut physical = Map::new();
    let artifact_uri = d.location.file.as_deref().unwrap_or(file);
    let mut art = json!({ "uri": uri(artifact_uri) });
    if artifact_uri == file {
        art["index"] = json!(artifact);
    }
    physical.insert("artifactLocation".into(), art);
    if let Some(line) = d.location.source.line {
        physical.insert("region".into(), json!({ "startLine": line.max(1) }));
    }
    let mut location = json!({ "physicalLocation": physical });
    let logical: Vec<Value> = [
        d.location.source.pointer.as_ref().map(|p| (p, "element")),
        d.location.source.prim.as_ref().map(|p| (p, "element")),
        d.location.node.as_ref().map(|n| (n, "member")),
    ]
    .into_iter()
    .flatten()
    .map(|(name, kind)| json!({ "fullyQualifiedName": name, "kind": kind }))
    .collect();
    if !logical.is_empty() {
        location["logicalLocations"] = json!(logical);
    }
    let mut text = d.message.clone();
    if let Some(h) = &d.hint {
        text.push_str(&format!(" Hint: {h}."));
    }
    let mut props = Map::new();
    if let Some(p) = d.location.position {
        props.insert("position".into(), json!(p));
    }
    if let Some(h) = &d.hint {
        props.insert("hint".into(), json!(h));
    }
    let mut r = json!({
        "ruleId": d.code.as_str(),
        "ruleIndex": rule_index,
        "level": level(d.severity),
        "message": { "text": text },
        "locations": [location],
    });
    if !props.is_empty() {
        r["properties"] = Value::Object(props);
    }
    r
}

/// The `--format sarif` report (SARIF 2.1.0), for code-scanning services.
pub fn report(files: &[FileReport]) -> Value {
    let artifacts: Vec<Value> = files
        .iter()
        .map(|f| json!({ "location": { "uri": uri(&f.file) } }))
        .collect();
    let results: Vec<Value> = files
        .iter()
        .enumerate()
        .flat_map(|(k, f)| f.diagnostics.iter().map(move |d| result(d, k, &f.file)))
        .collect();
    json!({
        "$schema": "https://json.schemastore.org/sarif-2.1.0.json",
        "version": "2.1.0",
        "runs": [{
            "tool": { "driver": {
                "name": "portcullis",
                "version": env!("CARGO_PKG_VERSION"),
                "informationUri": DOCS,
                "rules": Code::ALL.iter().map(|c| rule(*c)).collect::<Vec<_>>(),
            }},
            "artifacts": artifacts,
            "results": results,
            "columnKind": "unicodeCodePoints",
        }],
    })
}

#[cfg(test)]
mod tests {
    use super::uri;
    use std::path::Path;

    #[test]
    fn paths_become_uri_references() {
        assert_eq!(uri(Path::new("levels/a b.glb")), "levels/a%20b.glb");
        assert_eq!(uri(Path::new("/tmp/x#1.gltf")), "file:///tmp/x%231.gltf");
    }
}
