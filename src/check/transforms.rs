//! Transforms of mirrors and teleporters: finite; a teleporter's rigid (a rotation and a
//! translation, no scale, shear or reflection); a mirror's the reflection in its own plane;
//! a partner's the inverse; and a teleporter's exit polygon the image of its entry polygon,
//! so what is seen through it lines up with where the player comes out.

use glam::{DMat3, DMat4, DVec3};

use super::{centroid, Subject};
use crate::diag::{Code, Diagnostic, Diagnostics};
use crate::geom::plane::Plane;
use crate::tags::rules::PortalKind;

/// Tolerance on the unitless (rotation) part of a transform.
const LINEAR_TOL: f64 = 1e-6;

/// Whether two affine transforms agree: the linear parts within [`LINEAR_TOL`], the
/// translations within `dist`.
fn close(a: &DMat4, b: &DMat4, dist: f64) -> bool {
    let (la, lb) = (DMat3::from_mat4(*a), DMat3::from_mat4(*b));
    la.abs_diff_eq(lb, LINEAR_TOL) && (a.w_axis.truncate() - b.w_axis.truncate()).length() <= dist
}

pub(super) fn check(s: &Subject, out: &mut Diagnostics) {
    let ps = &s.portals.portals;
    // Translations are compared relative to where the level is.
    let dist = 10.0 * s.eps + 1e-9 * s.extent;
    for (i, p) in ps.iter().enumerate() {
        let Some(m) = p.transform else { continue };
        let c = centroid(&p.polygon);
        let diag = |code: Code, msg: String, hint: &str| {
            Diagnostic::new(code, format!("{} {msg}", s.portal(i)), s.at(i, c)).hint(hint)
        };
        if !m.to_cols_array().iter().all(|x| x.is_finite()) {
            out.push(diag(
                Code::TRANSFORM_NON_FINITE,
                "has a transform with NaN or infinite entries".into(),
                "recompute the annotation with `portcullis convert`; check the exit node's transform",
            ));
            continue;
        }
        let lin = DMat3::from_mat4(m);
        if p.kind == PortalKind::Mirror {
            if let Some(plane) = Plane::from_polygon(&p.polygon) {
                if !close(&m, &plane.reflection(), dist) {
                    out.push(diag(
                        Code::TRANSFORM_MIRROR_PLANE,
                        "reflects in a plane other than its own".into(),
                        "a mirror's transform must be the reflection in the mirror's plane; recompute it with `portcullis convert`",
                    ));
                }
            }
        } else {
            let gram = lin.transpose() * lin;
            let det = lin.determinant();
            if !gram.abs_diff_eq(DMat3::IDENTITY, LINEAR_TOL) || det < 0.0 {
                let scale = DVec3::new(
                    lin.x_axis.length(),
                    lin.y_axis.length(),
                    lin.z_axis.length(),
                );
                let what = if det < 0.0 {
                    "mirrors (its determinant is negative)".to_string()
                } else {
                    format!(
                        "scales or shears (axis lengths {:.4}, {:.4}, {:.4})",
                        scale.x, scale.y, scale.z
                    )
                };
                out.push(diag(
                    Code::TRANSFORM_NOT_RIGID,
                    format!("has a transform that {what}; a teleporter must only turn and move"),
                    "make the entry and exit the same size and give neither a scaled or mirrored transform",
                ));
            }
        }
        let Some(j) = p.partner.filter(|&j| j != i) else {
            continue;
        };
        let Some(q) = ps.get(j) else { continue };
        let Some(back) = q.transform else {
            if i < j {
                out.push(diag(
                    Code::TRANSFORM_PARTNER_NOT_INVERSE,
                    format!("has a transform but its partner, portal {j}, has none"),
                    "give the partner the inverse transform (recompute with `portcullis convert`)",
                ));
            }
            continue;
        };
        if i < j && !close(&(back * m), &DMat4::IDENTITY, dist) {
            out.push(diag(
                Code::TRANSFORM_PARTNER_NOT_INVERSE,
                format!("and its partner, portal {j}, have transforms that are not inverses"),
                "the way back must undo the way in; recompute with `portcullis convert`",
            ));
        }
        if i < j && p.kind == PortalKind::Teleporter {
            let image: Vec<DVec3> = p.polygon.iter().map(|v| m.transform_point3(*v)).collect();
            let gap = image
                .iter()
                .map(|v| {
                    q.polygon
                        .iter()
                        .map(|w| w.distance(*v))
                        .fold(f64::INFINITY, f64::min)
                })
                .chain(q.polygon.iter().map(|w| {
                    image
                        .iter()
                        .map(|v| v.distance(*w))
                        .fold(f64::INFINITY, f64::min)
                }))
                .fold(0.0, f64::max);
            if gap > dist.max(1e-4) {
                out.push(diag(
                    Code::TRANSFORM_EXIT_MISMATCH,
                    format!(
                        "does not map onto its exit, portal {j}: the entry's image misses it by up to {gap:.4} m"
                    ),
                    "make the entry and exit quads the same size and shape (the exit may be turned, not resized)",
                ));
            }
        }
    }
}
