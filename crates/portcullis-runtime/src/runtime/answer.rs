//! `cull`'s JSON both ways: a camera line in, one answer out (schemas/PORTCULLIS_portals.md,
//! rules 8 and 16). The CLI and the engine plugins print through this one module, so a plugin's
//! answers are the CLI's byte for byte, and the test vectors judge them all alike.

use serde::Deserialize;
use serde_json::{json, Value};

use super::{DrawList, Level, Location, Trace, View, ViewError};

/// One line of a cameras file: `{"eye", "look", "up", "fov_y", "aspect", "near"}`, the last
/// four optional (rule 8's defaults).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraLine {
    /// The eye, in the level's units.
    pub eye: [f64; 3],
    /// Where it looks (need not be of unit length).
    pub look: [f64; 3],
    /// Up, default +Y.
    #[serde(default = "default_up")]
    pub up: [f64; 3],
    /// The vertical field of view in degrees, default 60.
    #[serde(default = "default_fov")]
    pub fov_y: f64,
    /// Width over height, default 16:9.
    #[serde(default = "default_aspect")]
    pub aspect: f64,
    /// The near plane's distance, default 0.05.
    #[serde(default = "default_near")]
    pub near: f64,
}

fn default_up() -> [f64; 3] {
    [0.0, 1.0, 0.0]
}
fn default_fov() -> f64 {
    60.0
}
fn default_aspect() -> f64 {
    16.0 / 9.0
}
fn default_near() -> f64 {
    0.05
}

impl CameraLine {
    /// The camera of one line of JSON, `None` for a blank line.
    pub fn parse(line: &str) -> Result<Option<CameraLine>, serde_json::Error> {
        if line.trim().is_empty() {
            return Ok(None);
        }
        serde_json::from_str(line).map(Some)
    }

    /// The view this camera traces, or why it cannot be one (a zero look, up along look...).
    pub fn view(&self) -> Result<View, ViewError> {
        View::new(
            self.eye,
            self.look,
            self.up,
            self.fov_y,
            self.aspect,
            self.near,
        )
    }
}

/// One camera's answer as `cull --format json` prints it (rule 16); with `draws`
/// (`--draw-lists`), what it draws: the list of the cells seen without a transform, and on each
/// entry seen through one, its own cell's.
pub fn answer(t: &Trace, mut draws: Option<(&Level, &mut DrawList)>) -> Value {
    let mut visible: Vec<Value> = Vec::with_capacity(t.visible().len());
    for v in t.visible() {
        let mut o = json!({
            "cell": v.cell,
            "rect": v.rect.map(round),
            "depth": v.depth,
            "via": t.via(v),
        });
        if let Some(m) = &v.transform {
            o["transform"] = json!(m.to_cols_array().map(round));
        }
        o["mirrored"] = json!(v.mirrored);
        if let (Some((level, list)), Some(_)) = (draws.as_mut(), v.transform) {
            // As `Level::cost` prices it: the cell's own list, moved (the outside draws none).
            level.draw_list(v.cell, list);
            o["draw"] = draw_json(list);
        }
        visible.push(o);
    }
    let mut o = json!({
        "cell": t.location.cell(),
        "location": t.location.name(),
    });
    if let Location::Outside { nearest } = t.location {
        o["nearest"] = json!(nearest);
    }
    o["visible"] = json!(visible);
    if let Some((level, list)) = draws {
        let direct = t.visible().iter().filter(|v| v.transform.is_none());
        level.draw_list(direct.filter_map(|v| v.cell), list);
        o["draw"] = draw_json(list);
    }
    o["stats"] = json!(t.stats);
    o
}

/// A draw list as `--draw-lists` prints it.
fn draw_json(list: &DrawList) -> Value {
    let ranges: Vec<[usize; 4]> = (list.ranges.iter())
        .map(|r| [r.node, r.primitive, r.first, r.count])
        .collect();
    json!({"nodes": list.nodes, "ranges": ranges})
}

/// Rectangles and transforms to 1e-9, halves away from zero, -0 as 0: two right answers
/// differ in the last bits of their arithmetic, not in what they print.
fn round(x: f64) -> f64 {
    let r = (x * 1e9).round() / 1e9;
    if r == 0.0 {
        0.0
    } else {
        r
    }
}
