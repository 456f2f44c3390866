//! Writing .prt (PRT1: one cell per portcullis cell). Only what the format can say is
//! written: two-way, open portals between two cells. One-way, closed and transformed portals
//! are left out and reported, since Quake's vis would take them as open both ways.

use std::fmt::Write as _;

use crate::diag::{Code, Diagnostic, Location};
use crate::portals::PortalSet;

/// The PRT1 text of a level and what was left out. `path`: for messages.
pub fn write(cells: usize, set: &PortalSet, path: &std::path::Path) -> (String, Vec<Diagnostic>) {
    let mut lines = Vec::new();
    let mut dropped = 0;
    for (i, p) in set.portals.iter().enumerate() {
        let Some(to) = p.to else { continue };
        let two_way = p.partner.is_some_and(|j| j != i);
        if !two_way || p.closed || p.one_way || p.transform.is_some() {
            if p.partner.is_none_or(|j| i < j) {
                dropped += 1;
            }
            continue;
        }
        if p.partner.is_some_and(|j| j < i) {
            continue;
        }
        // The polygon is counter-clockwise seen from `from`; reversed, the file's three-point
        // normal faces into `from`, which is therefore the first cell.
        let mut s = format!("{} {} {}", p.polygon.len(), p.from, to);
        for v in p.polygon.iter().rev() {
            let _ = write!(s, " ({} {} {})", v.x, v.y, v.z);
        }
        lines.push(s);
    }
    let mut out = format!("PRT1\n{cells}\n{}\n", lines.len());
    for l in lines {
        out.push_str(&l);
        out.push('\n');
    }
    let mut diags = Vec::new();
    if dropped > 0 {
        diags.push(
            Diagnostic::new(
                Code::PRT_EXPORT_DROPPED,
                format!("{dropped} one-way, closed, mirror or teleporter portals cannot be written to `{}`", path.display()),
                Location::file(path),
            )
            .hint("PRT portals are open both ways; Quake's vis sees through them as if they were"),
        );
    }
    (out, diags)
}
