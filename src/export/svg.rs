//! A plan of cells and portals as a standalone SVG, for reviewing a partition (or one cell's
//! potentially visible set) at a glance, in a browser or a pull request, without a 3D viewer.
//!
//! Convention: the view from above, looking down −Y (the up axis). World x goes to the right
//! and world z goes down the page, so SVG coordinates are `(x, z)` unchanged: SVG's y axis
//! already points down, and with x to the right that is exactly what a right-handed Y-up world
//! looks like from above (−Z, "north", at the top). No axis is flipped.
//!
//! Every number is written with at most three decimals (millimetres), so the text does not
//! change with the last bits of a computation and can be diffed.

use crate::level::Level;
use std::fmt::Write;

use glam::DVec2;

use crate::cells::CellSet;
use crate::export::debug::{room_rgb, PortalStyle};
use crate::geom::aabb::Aabb;
use crate::portals::PortalSet;
use crate::tags::Tagging;

const TITLE: &str =
    "portcullis plan: seen from above (looking down -Y), x to the right, z down the page";

/// Fill of the cell whose visible set is shown.
pub const PVS_SOURCE_FILL: &str = "#1f5fbf";
/// Fill of the cells it can see.
pub const PVS_VISIBLE_FILL: &str = "#ffd24d";
/// Fill of every other cell.
pub const PVS_HIDDEN_FILL: &str = "#d9d9d9";

/// Fixed-point text with at most three decimals, without trailing zeros or a negative zero,
/// so equal drawings give equal bytes.
fn num(v: f64) -> String {
    let s = format!("{v:.3}");
    let s = if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    };
    if s == "-0" {
        "0".into()
    } else {
        s
    }
}

fn escape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&apos;"),
            // Control characters are not allowed in XML 1.0 at all.
            c if (c as u32) < 0x20 && !matches!(c, '\t' | '\n' | '\r') => out.push('?'),
            c => out.push(c),
        }
    }
    out
}

fn hex(c: [f64; 3]) -> String {
    let b = |x: f64| (x.clamp(0.0, 1.0) * 255.0).round() as u8;
    format!("#{:02x}{:02x}{:02x}", b(c[0]), b(c[1]), b(c[2]))
}

/// Room colours washed out towards white so labels and portals stay readable on top.
fn pale(c: [f64; 3]) -> [f64; 3] {
    c.map(|x| 0.55 + 0.45 * x)
}

/// Rounded to the precision we write, so the hull (and so the output) does not depend on
/// float noise below a millimetre.
fn plan_point(p: glam::DVec3) -> DVec2 {
    let r = |v: f64| (v * 1000.0).round() / 1000.0;
    DVec2::new(r(p.x), r(p.z))
}

/// Convex hull (monotone chain), counter-clockwise in (x, z).
fn hull2(mut pts: Vec<DVec2>) -> Vec<DVec2> {
    pts.sort_by(|a, b| a.x.total_cmp(&b.x).then(a.y.total_cmp(&b.y)));
    pts.dedup();
    if pts.len() < 3 {
        return pts;
    }
    let cross = |o: DVec2, a: DVec2, b: DVec2| (a - o).perp_dot(b - o);
    let mut lower: Vec<DVec2> = Vec::new();
    for &p in &pts {
        while lower.len() >= 2 && cross(lower[lower.len() - 2], lower[lower.len() - 1], p) <= 0.0 {
            lower.pop();
        }
        lower.push(p);
    }
    let mut upper: Vec<DVec2> = Vec::new();
    for &p in pts.iter().rev() {
        while upper.len() >= 2 && cross(upper[upper.len() - 2], upper[upper.len() - 1], p) <= 0.0 {
            upper.pop();
        }
        upper.push(p);
    }
    lower.pop();
    upper.pop();
    lower.extend(upper);
    lower
}

/// Area centroid, falling back to the vertex mean for degenerate outlines (a cell seen exactly
/// edge-on has none).
fn centroid(poly: &[DVec2]) -> DVec2 {
    let mean = poly.iter().copied().sum::<DVec2>() / poly.len().max(1) as f64;
    let (mut a, mut c) = (0.0, DVec2::ZERO);
    for (i, p) in poly.iter().enumerate() {
        let q = poly[(i + 1) % poly.len()];
        let w = (*p - mean).perp_dot(q - mean);
        a += w;
        c += (*p - mean + q - mean) * w;
    }
    if a.abs() < 1e-12 {
        mean
    } else {
        mean + c / (3.0 * a)
    }
}

/// The plan (see the module documentation for the axes). Cells are `<polygon id="cell-N">`
/// outlines of their projection, pale by room, labelled `N room` at their centroid; portals
/// are line segments along their projection's longest extent, coloured as in the debug GLB,
/// each pair drawn once (a one-way portal gets a tick pointing the way it can be crossed).
///
/// With `pvs_of = Some((cell, visible))` the fills show that cell's visible set instead of
/// rooms: the cell [`PVS_SOURCE_FILL`], the visible cells [`PVS_VISIBLE_FILL`], the rest
/// [`PVS_HIDDEN_FILL`]. A legend below the plan explains the colours in use.
pub fn svg_map(level: &Level, pvs_of: Option<(usize, &[usize])>) -> String {
    let (tagging, cells, portals) = (level.tagging(), &level.cells, &level.portals);
    let page = Page::of(cells, pvs_of);
    let u = page.u;
    let mut s = String::new();
    write_header(&mut s, &page, cells, portals);

    let outlines: Vec<Vec<DVec2>> = cells
        .cells
        .iter()
        .map(|c| {
            hull2(
                c.poly
                    .faces
                    .iter()
                    .flat_map(|f| f.points.iter().map(|p| plan_point(*p)))
                    .collect(),
            )
        })
        .collect();

    write_cells(&mut s, cells, &outlines, pvs_of, u);
    write_portals(&mut s, portals, u);
    write_labels(&mut s, tagging, cells, &outlines, u);
    write_legend(&mut s, &page, pvs_of);
    let _ = writeln!(s, "</svg>");
    s
}

/// Where the plan sits on the page: the cells' box in (x, z), the drawing unit and the
/// margin, and the band below for the legend.
struct Page {
    x0: f64,
    z0: f64,
    w: f64,
    h: f64,
    /// One drawing unit: text and strokes scale with the level, so a 5 m room and a 5 km
    /// terrain look alike.
    u: f64,
    margin: f64,
    /// The height of one legend row.
    row: f64,
    legend_h: f64,
}

impl Page {
    fn of(cells: &CellSet, pvs_of: Option<(usize, &[usize])>) -> Page {
        let mut bounds = Aabb::EMPTY;
        for c in &cells.cells {
            bounds = bounds.union(&c.poly.bounds());
        }
        let (x0, z0, w, h) = if bounds.is_empty() {
            (0.0, 0.0, 1.0, 1.0)
        } else {
            (
                bounds.min.x,
                bounds.min.z,
                bounds.max.x - bounds.min.x,
                bounds.max.z - bounds.min.z,
            )
        };
        let u = (w.max(h) / 100.0).max(0.01);
        let margin = 5.0 * u;
        let legend_rows = PortalStyle::ALL.len() + if pvs_of.is_some() { 3 } else { 0 };
        let row = 3.0 * u;
        let legend_h = row * legend_rows as f64 + u;
        Page {
            x0,
            z0,
            w,
            h,
            u,
            margin,
            row,
            legend_h,
        }
    }
}

/// The XML prolog, the `<svg>` element sized to the page, its title and description, and the
/// white background.
fn write_header(s: &mut String, page: &Page, cells: &CellSet, portals: &PortalSet) {
    let Page {
        x0,
        z0,
        w,
        h,
        u,
        margin,
        legend_h,
        ..
    } = *page;
    let (vx, vy) = (x0 - margin, z0 - margin);
    let (vw, vh) = (w + 2.0 * margin, h + 2.0 * margin + legend_h);
    let _ = writeln!(s, r#"<?xml version="1.0" encoding="UTF-8"?>"#);
    let _ = writeln!(
        s,
        r#"<svg xmlns="http://www.w3.org/2000/svg" version="1.1" viewBox="{} {} {} {}" width="{}mm" height="{}mm">"#,
        num(vx),
        num(vy),
        num(vw),
        num(vh),
        num((vw / u * 2.0).round()),
        num((vh / u * 2.0).round()),
    );
    let _ = writeln!(s, "<title>{}</title>", escape(TITLE));
    let _ = writeln!(
        s,
        "<desc>{} cells, {} portals; world units, x right, z down</desc>",
        cells.cells.len(),
        portals.portals.len()
    );
    let _ = writeln!(
        s,
        r##"<rect x="{}" y="{}" width="{}" height="{}" fill="#ffffff"/>"##,
        num(vx),
        num(vy),
        num(vw),
        num(vh)
    );
}

/// The cells' outlines, filled by room or by the visible set shown.
fn write_cells(
    s: &mut String,
    cells: &CellSet,
    outlines: &[Vec<DVec2>],
    pvs_of: Option<(usize, &[usize])>,
    u: f64,
) {
    let _ = writeln!(
        s,
        r##"<g id="cells" stroke="#404040" stroke-width="{}" stroke-linejoin="round">"##,
        num(0.15 * u)
    );
    for (i, (cell, outline)) in cells.cells.iter().zip(outlines).enumerate() {
        let fill = match pvs_of {
            Some((src, _)) if src == i => PVS_SOURCE_FILL.to_string(),
            Some((_, vis)) if vis.contains(&i) => PVS_VISIBLE_FILL.to_string(),
            Some(_) => PVS_HIDDEN_FILL.to_string(),
            None => hex(pale(room_rgb(cell.room))),
        };
        let points: Vec<String> = outline
            .iter()
            .map(|p| format!("{},{}", num(p.x), num(p.y)))
            .collect();
        let _ = writeln!(
            s,
            r#"<polygon id="cell-{i}" class="cell" fill="{fill}" points="{}"/>"#,
            points.join(" ")
        );
    }
    let _ = writeln!(s, "</g>");
}

/// The portals that show from above, one line per pair, with a tick for one-way ones.
fn write_portals(s: &mut String, portals: &PortalSet, u: f64) {
    let _ = writeln!(s, r#"<g id="portals" stroke-linecap="round">"#);
    for (i, p) in portals.portals.iter().enumerate() {
        // A pair is one opening on the plan; its first portal stands for both.
        if p.partner.is_some_and(|j| j < i) {
            continue;
        }
        // Openings in floors and ceilings (open tops, stairwells) face up or down: seen from
        // above they are areas, not lines, and drawing their diagonal would only mislead.
        if p.normal.y.abs() > 0.7 {
            continue;
        }
        let pts: Vec<DVec2> = p.polygon.iter().map(|q| plan_point(*q)).collect();
        let Some((a, b)) = longest_extent(&pts) else {
            continue;
        };
        let style = PortalStyle::of(p);
        let width = if style == PortalStyle::Exterior {
            0.2 * u
        } else {
            0.6 * u
        };
        let to = p.to.map_or("exterior".to_string(), |t| format!("cell {t}"));
        let _ = writeln!(
            s,
            r#"<line id="portal-{i}" x1="{}" y1="{}" x2="{}" y2="{}" stroke="{}" stroke-width="{}"><title>portal {i}: cell {} -&gt; {}</title></line>"#,
            num(a.x),
            num(a.y),
            num(b.x),
            num(b.y),
            hex(style.rgb()),
            num(width),
            p.from,
            escape(&to),
        );
        if style == PortalStyle::OneWay {
            let mid = (a + b) * 0.5;
            let dir = DVec2::new(p.normal.x, p.normal.z);
            if let Some(dir) = dir.try_normalize() {
                let tip = mid + dir * 2.0 * u;
                let _ = writeln!(
                    s,
                    r#"<line x1="{}" y1="{}" x2="{}" y2="{}" stroke="{}" stroke-width="{}"/>"#,
                    num(mid.x),
                    num(mid.y),
                    num(tip.x),
                    num(tip.y),
                    hex(style.rgb()),
                    num(0.3 * u),
                );
            }
        }
    }
    let _ = writeln!(s, "</g>");
}

/// Each cell's label at its centroid: its number and room, or the number alone where that
/// would not fit.
fn write_labels(
    s: &mut String,
    tagging: &Tagging,
    cells: &CellSet,
    outlines: &[Vec<DVec2>],
    u: f64,
) {
    let room_name = |r: usize| tagging.rooms.get(r).map_or("?", |room| room.name.as_str());
    let _ = writeln!(
        s,
        r##"<g id="labels" font-family="sans-serif" font-size="{}" text-anchor="middle" fill="#000000">"##,
        num(2.0 * u)
    );
    for (i, (cell, outline)) in cells.cells.iter().zip(outlines).enumerate() {
        let c = centroid(outline);
        // A narrow cell (a door reveal) gets its number alone, where `N room` would spill over
        // its neighbours (a glyph is about 1.1 units wide at this size).
        let full = format!("{i} {}", room_name(cell.room));
        let width = outline
            .iter()
            .map(|p| p.x)
            .fold(f64::NEG_INFINITY, f64::max)
            - outline.iter().map(|p| p.x).fold(f64::INFINITY, f64::min);
        let label = if 1.1 * u * full.chars().count() as f64 <= width {
            full
        } else {
            i.to_string()
        };
        let _ = writeln!(
            s,
            r#"<text x="{}" y="{}">{}</text>"#,
            num(c.x),
            num(c.y + 0.7 * u),
            escape(&label)
        );
    }
    let _ = writeln!(s, "</g>");
}

/// Legend: swatches in the band below the plan.
fn write_legend(s: &mut String, page: &Page, pvs_of: Option<(usize, &[usize])>) {
    let (u, row) = (page.u, page.row);
    let _ = writeln!(
        s,
        r##"<g id="legend" font-family="sans-serif" font-size="{}" fill="#000000">"##,
        num(1.8 * u)
    );
    let mut y = page.z0 + page.h + page.margin;
    let lx = page.x0;
    if let Some((src, vis)) = pvs_of {
        let entries = [
            (PVS_SOURCE_FILL, format!("cell {src}")),
            (
                PVS_VISIBLE_FILL,
                format!("visible from cell {src} ({})", vis.len()),
            ),
            (PVS_HIDDEN_FILL, "not visible".to_string()),
        ];
        for (fill, text) in entries {
            let _ = writeln!(
                s,
                r##"<rect x="{}" y="{}" width="{}" height="{}" fill="{fill}" stroke="#404040" stroke-width="{}"/><text x="{}" y="{}">{}</text>"##,
                num(lx),
                num(y),
                num(2.0 * u),
                num(2.0 * u),
                num(0.1 * u),
                num(lx + 3.0 * u),
                num(y + 1.6 * u),
                escape(&text)
            );
            y += row;
        }
    }
    for style in PortalStyle::ALL {
        let _ = writeln!(
            s,
            r#"<line x1="{}" y1="{}" x2="{}" y2="{}" stroke="{}" stroke-width="{}"/><text x="{}" y="{}">portal: {}</text>"#,
            num(lx),
            num(y + u),
            num(lx + 2.0 * u),
            num(y + u),
            hex(style.rgb()),
            num(0.6 * u),
            num(lx + 3.0 * u),
            num(y + 1.6 * u),
            style.label()
        );
        y += row;
    }
    let _ = writeln!(s, "</g>");
}

/// The two points farthest apart: a door seen from above is a segment between its jambs, and
/// a floor hatch is drawn along its diagonal rather than vanishing.
fn longest_extent(pts: &[DVec2]) -> Option<(DVec2, DVec2)> {
    let mut best: Option<(f64, DVec2, DVec2)> = None;
    for (i, a) in pts.iter().enumerate() {
        for b in &pts[i + 1..] {
            let d = a.distance_squared(*b);
            if best.is_none_or(|(bd, _, _)| d > bd) {
                best = Some((d, *a, *b));
            }
        }
    }
    best.filter(|(d, _, _)| *d > 0.0).map(|(_, a, b)| (a, b))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_are_short_and_stable() {
        assert_eq!(num(1.0), "1");
        assert_eq!(num(-0.0001), "0");
        assert_eq!(num(2.5), "2.5");
        assert_eq!(num(1.23456), "1.235");
        assert_eq!(num(-3.1), "-3.1");
    }

    #[test]
    fn escapes_markup() {
        assert_eq!(escape("a<b&\"c\""), "a&lt;b&amp;&quot;c&quot;");
    }
}
