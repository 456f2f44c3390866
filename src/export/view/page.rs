//! The HTML page: the payload, three.js and the viewer inlined into one file.

use serde_json::Value;

/// three.js r158 (npm `three@0.158.0`, `build/three.min.js`), see assets/README.md.
const THREE: &str = include_str!("assets/three.min.js");
const THREE_LICENSE: &str = include_str!("assets/three.LICENSE");
const VIEWER: &str = include_str!("assets/viewer.js");
const STYLE: &str = include_str!("assets/viewer.css");

/// Text safe inside a `<script>` element: `</` would end it early.
fn in_script(text: &str) -> String {
    text.replace("</", "<\\/")
}

fn escape_html(text: &str) -> String {
    text.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// The whole page for `data` (from [`super::payload`]).
pub fn page(data: &Value) -> String {
    let title = data["title"].as_str().unwrap_or("level");
    let json = in_script(&data.to_string());
    let mut out = String::with_capacity(THREE.len() + VIEWER.len() + json.len() + 4096);
    out.push_str("<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n");
    out.push_str(&format!(
        "<title>{} — portcullis view</title>\n",
        escape_html(title)
    ));
    out.push_str("<style>\n");
    out.push_str(STYLE);
    out.push_str("</style>\n</head>\n<body>\n");
    out.push_str("<div id=\"view\"></div>\n<div id=\"panel\"></div>\n");
    out.push_str("<script id=\"portcullis-data\" type=\"application/json\">");
    out.push_str(&json);
    out.push_str("</script>\n<script>\n/*\nthree.js r158\n");
    out.push_str(&THREE_LICENSE.replace("*/", "* /"));
    out.push_str("*/\n");
    out.push_str(&in_script(THREE));
    out.push_str("\n</script>\n<script>\n");
    out.push_str(&in_script(VIEWER));
    out.push_str("\n</script>\n</body>\n</html>\n");
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn data_cannot_close_its_script_element() {
        let p = page(&serde_json::json!({"title": "a</script><b>", "x": "</script>"}));
        let start = p.find("id=\"portcullis-data\"").unwrap();
        let end = start + p[start..].find("</script>").unwrap();
        assert!(p[start..end].contains("<\\/script>"));
        assert!(p.contains("<title>a&lt;/script&gt;&lt;b&gt; — portcullis view</title>"));
    }
}
