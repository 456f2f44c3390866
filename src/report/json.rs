//! The JSON report: one document with every file's diagnostics and the totals; the shape is
//! stable for scripts (fields are only ever added).

use serde_json::{json, Value};

use super::file::FileReport;
use super::Totals;

/// The `--format json` report: every file's findings and the totals.
pub fn report(files: &[FileReport], totals: &Totals) -> Value {
    json!({
        "tool": { "name": "portcullis", "version": env!("CARGO_PKG_VERSION") },
        "files": files.iter().map(|f| {
            let mut v = serde_json::to_value(f).unwrap_or(Value::Null);
            if let Some(o) = v.as_object_mut() {
                o.insert("status".into(), json!(f.status()));
                if let Some(bytes) = crate::diag::raw_path_bytes(&f.file) {
                    o.insert("file_bytes".into(), json!(bytes));
                }
            }
            v
        }).collect::<Vec<_>>(),
        "summary": totals,
    })
}
