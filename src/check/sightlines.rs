//! The PVS against the level's real geometry (`check --sightlines N`): rays from random points
//! inside every cell, half in random directions and half aimed at random points of the level's
//! portals, traced against every blocking triangle through a
//! BVH (parry's `TriMesh`), through open portals and the outside as the straight line goes,
//! stopped by closed portals and by one-way portals crossed against their way, and carried on
//! through mirrors and teleporters with their transform, at most `depth` of them. Every cell a
//! ray passes through is really visible from the cell it started in: a pair the PVS lacks is
//! an error, and the pairs the rays confirm tell how tight the PVS is.
//!
//! A gap narrower than the crack width (`[cells] crack_width`) is closed for the cells and the
//! portals alike (DESIGN, Cells), so a ray that finds a pair the PVS lacks is traced again as
//! thick as a crack: eight rays beside it, parallel, half a crack width out. A pair only the thin
//! ray reaches is seen through a closed crack, which is reported apart
//! (`SIGHTLINES_THROUGH_CRACKS`), not as a miss.
//!
//! It shares nothing with the visibility methods but the cells and portals: the rays know
//! triangles and planes, not portal flow. Each cell's rays come from a generator seeded by the
//! cell's number, so the result is the same for any thread count.

use std::collections::BTreeMap;

use glam::{DMat4, DVec3};
use parry3d_f64::partitioning::{Bvh, BvhBuildStrategy};
use parry3d_f64::query::{Ray, RayCast};
use parry3d_f64::shape::TriMesh;
use rayon::prelude::*;

use super::Subject;
use crate::diag::{Code, Diagnostic, Diagnostics, Location};
use crate::geom::aabb::Aabb;
use crate::geom::polyhedron::ConvexPolyhedron;
use crate::rng::SplitMix64 as Rng;
use crate::vis::Pvs;

/// What the audit found.
#[derive(Debug, Clone)]
pub struct Audit {
    /// Missed pairs (sightlines the PVS does not have), as `VIS_MISSED_PAIR` findings.
    pub diagnostics: Diagnostics,
    /// One polyline per missed pair: the ray that found it, for debug output.
    pub lines: Vec<Vec<DVec3>>,
    /// PVS pairs between different cells that some ray confirmed, and all of them.
    pub confirmed: usize,
    /// All PVS pairs between different cells, confirmed or not.
    pub pairs: usize,
    /// Every pair some ray joined (each cell with itself): a lower bound of the real PVS from
    /// the level's own geometry.
    pub seen: Pvs,
    /// Pairs the PVS lacks that only rays through closed cracks joined.
    pub through_cracks: usize,
}

/// Rays beside a ray that make it as thick as a crack: the octagon they stand on holds the
/// crack's circle, so a gap narrower than a crack stops one of them however it lies.
const SIDES: usize = 8;

/// How a portal changes a ray that crosses it.
enum Rule {
    Block,
    /// Passes only along the portal's normal (into its target).
    OneWay,
    Transform(DMat4),
}

struct Gate {
    polygon: Vec<DVec3>,
    normal: DVec3,
    d: f64,
    rule: Rule,
}

/// The portals that do more than let a straight ray through.
fn gates(s: &Subject) -> Vec<Gate> {
    s.portals
        .portals
        .iter()
        .filter(|p| p.polygon.len() >= 3)
        .filter_map(|p| {
            let rule = if p.closed {
                Rule::Block
            } else if let Some(m) = p.transform {
                Rule::Transform(m)
            } else if p.one_way && p.to.is_some() {
                Rule::OneWay
            } else {
                return None;
            };
            let c = p.polygon.iter().copied().sum::<DVec3>() / p.polygon.len() as f64;
            Some(Gate {
                polygon: p.polygon.clone(),
                normal: p.normal,
                d: p.normal.dot(c),
                rule,
            })
        })
        .collect()
}

/// Where the ray `o + t d` crosses the gate's polygon (either winding), if it does.
fn crossing(g: &Gate, o: DVec3, d: DVec3) -> Option<f64> {
    let nd = g.normal.dot(d);
    if nd == 0.0 {
        return None;
    }
    let t = (g.d - g.normal.dot(o)) / nd;
    let x = o + d * t;
    let w = &g.polygon;
    let mut sign = 0.0;
    for k in 0..w.len() {
        let s = (w[(k + 1) % w.len()] - w[k]).cross(x - w[k]).dot(g.normal);
        if s != 0.0 {
            if sign != 0.0 && s.signum() != sign {
                return None;
            }
            sign = s.signum();
        }
    }
    Some(t)
}

/// The part of the segment `o + t d`, `t` in `[0, len]`, at least `inset` inside every face
/// of a convex cell, as `(t0, t1)`.
fn clip(poly: &ConvexPolyhedron, o: DVec3, d: DVec3, len: f64, inset: f64) -> Option<(f64, f64)> {
    let (mut t0, mut t1) = (0.0f64, len);
    for f in &poly.faces {
        let dn = f.plane.normal.dot(d);
        let dist = f.plane.distance(o) + inset;
        if dn == 0.0 {
            if dist > 0.0 {
                return None;
            }
            continue;
        }
        let t = -dist / dn;
        if dn > 0.0 {
            t1 = t1.min(t);
        } else {
            t0 = t0.max(t);
        }
        if t0 >= t1 {
            return None;
        }
    }
    Some((t0, t1))
}

/// `PVS_MISSES_SIGHTLINE` for the ray `line` from cell `c` into cell `x`; the hint names the
/// overlap the ray passes through, if any.
fn missed(s: &Subject, c: usize, x: usize, line: &[DVec3]) -> Diagnostic {
    let (from, to) = (line[0], line[line.len() - 1]);
    let hint = match through_overlap(&s.overlaps, line) {
        Some([a, b]) => format!(
            "the ray passes where the cells of rooms `{a}` and `{b}` overlapped (CELL_OVERLAP): move the geometry of one out of the other, or give the nested one a higher `priority`; with `[check] sightlines = N` in portcullis.toml, `convert --debug` draws the ray and the overlap"
        ),
        None => "if the geometry should block this ray, close the gap it passes through; if not, the PVS is wrong: convert the level again (a stored PVS may be stale), and report it if a fresh one misses the pair too; with `[check] sightlines = N` in portcullis.toml, `convert --debug` draws the ray".to_string(),
    };
    Diagnostic::new(
        Code::PVS_MISSES_SIGHTLINE,
        format!(
            "a sightline from {} reaches {}, which its PVS leaves out: the ray from ({:.4}, {:.4}, {:.4}) to ({:.4}, {:.4}, {:.4})",
            s.cell(c),
            s.cell(x),
            from.x, from.y, from.z, to.x, to.y, to.z
        ),
        s.cells[c].at.clone().with_position(from.to_array()),
    )
    .hint(hint)
}

/// `SIGHTLINES_THROUGH_CRACKS`: `count` pairs only rays through closed cracks join, with the
/// first one's ray.
fn through_cracks(s: &Subject, count: usize, c: usize, x: usize, line: &[DVec3]) -> Diagnostic {
    let (from, to) = (line[0], line[line.len() - 1]);
    Diagnostic::new(
        Code::SIGHTLINES_THROUGH_CRACKS,
        format!(
            "{count} pairs of cells the PVS leaves out are joined only by rays through gaps narrower than the crack width ({} m), which the cells and portals close: the first, from {} to {}, by the ray from ({:.4}, {:.4}, {:.4}) to ({:.4}, {:.4}, {:.4})",
            s.crack,
            s.cell(c),
            s.cell(x),
            from.x, from.y, from.z, to.x, to.y, to.z
        ),
        s.cells[c].at.clone().with_position(from.to_array()),
    )
    .hint("if such a gap is an opening, make it wider than the crack width or lower `[cells] crack_width` in portcullis.toml; if it is a modelling crack, close it, or leave it: nothing sees through it")
}

/// The rooms of the first overlap (see [`Subject::overlaps`]) a polyline passes through.
fn through_overlap<'a>(
    overlaps: &'a [(ConvexPolyhedron, [String; 2])],
    line: &[DVec3],
) -> Option<&'a [String; 2]> {
    overlaps.iter().find_map(|(region, rooms)| {
        line.windows(2)
            .any(|w| {
                let len = w[0].distance(w[1]);
                len > 0.0 && clip(region, w[0], (w[1] - w[0]) / len, len, 0.0).is_some()
            })
            .then_some(rooms)
    })
}

/// Whether the segment from `o` along `d` for `len` meets the box.
fn meets_box(b: &Aabb, o: DVec3, d: DVec3, len: f64) -> bool {
    let (mut t0, mut t1) = (0.0f64, len);
    for k in 0..3 {
        if d[k] == 0.0 {
            if o[k] < b.min[k] || o[k] > b.max[k] {
                return false;
            }
            continue;
        }
        let (a, c) = ((b.min[k] - o[k]) / d[k], (b.max[k] - o[k]) / d[k]);
        t0 = t0.max(a.min(c));
        t1 = t1.min(a.max(c));
        if t0 > t1 {
            return false;
        }
    }
    true
}

/// A uniformly random point strictly inside the cell (rejection in its box), if one is found
/// in a few tries.
fn point_in(poly: &ConvexPolyhedron, b: &Aabb, eps: f64, r: &mut Rng) -> Option<DVec3> {
    (0..64).find_map(|_| {
        let q = b.min + (b.max - b.min) * DVec3::new(r.unit(), r.unit(), r.unit());
        poly.contains_strictly(q, eps).then_some(q)
    })
}

/// A random point of a convex polygon (a fan triangle picked by area, then a point in it).
fn point_on(poly: &[DVec3], r: &mut Rng) -> DVec3 {
    let o = poly[0];
    let area = |k: usize| (poly[k] - o).cross(poly[k + 1] - o).length();
    let total: f64 = (1..poly.len() - 1).map(area).sum();
    let mut pick = r.unit() * total;
    let mut k = 1;
    while k + 2 < poly.len() && pick > area(k) {
        pick -= area(k);
        k += 1;
    }
    let (mut u, mut v) = (r.unit(), r.unit());
    if u + v > 1.0 {
        (u, v) = (1.0 - u, 1.0 - v);
    }
    o + (poly[k] - o) * u + (poly[k + 1] - o) * v
}

fn direction(r: &mut Rng) -> DVec3 {
    let z = 2.0 * r.unit() - 1.0;
    let phi = std::f64::consts::TAU * r.unit();
    let s = (1.0 - z * z).max(0.0).sqrt();
    DVec3::new(s * phi.cos(), s * phi.sin(), z)
}

struct Tracer<'a> {
    mesh: Option<TriMesh>,
    gates: Vec<Gate>,
    cells: Vec<Option<(&'a ConvexPolyhedron, Aabb)>>,
    /// The cells' boxes in a BVH: a ray asks for the cells whose boxes it meets, not every
    /// cell (2,000 rays from each of 10,000 cells would be 2·10^11 box tests).
    index: Bvh,
    /// Rays stop this far out (past the level).
    far: f64,
    /// A ray must run this far inside a cell to see into it (grazing a face or an edge is not
    /// seeing in).
    within: f64,
    /// How deep inside a cell a ray must run to see into it: the distance tolerance, within
    /// which a point is on a face.
    inset: f64,
    depth: usize,
    /// How far beside a ray its side rays run (0: rays are thin).
    radius: f64,
}

/// Which way a ray goes through a line of a rule: first a thin ray, then, for a pair the PVS
/// lacks, as thick as a crack.
#[derive(Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
enum Reach {
    /// Only the thin ray joins the pair: through a closed crack.
    ThroughCrack,
    Clear,
}

impl Tracer<'_> {
    /// The straight pieces of one ray, `(origin, direction, length)`.
    fn trace(&self, mut o: DVec3, mut d: DVec3) -> Vec<(DVec3, DVec3, f64)> {
        let mut out = Vec::new();
        let mut left = self.depth;
        for _ in 0..=self.depth {
            let hit = self
                .mesh
                .as_ref()
                .and_then(|m| m.cast_local_ray(&Ray::new(o, d), self.far, false))
                .unwrap_or(self.far);
            // A portal lying on a wall (a mirror) is met at the wall's distance: it wins.
            let mut best: Option<(f64, usize)> = None;
            for (k, g) in self.gates.iter().enumerate() {
                let Some(t) = crossing(g, o, d) else { continue };
                if t <= self.within || t > hit + self.within {
                    continue;
                }
                let along = g.normal.dot(d) > 0.0;
                let counts = match g.rule {
                    Rule::Block => true,
                    Rule::OneWay => !along,
                    Rule::Transform(_) => along,
                };
                if counts && best.is_none_or(|(bt, _)| t < bt) {
                    best = Some((t, k));
                }
            }
            let Some((t, k)) = best else {
                out.push((o, d, hit));
                break;
            };
            out.push((o, d, t));
            match self.gates[k].rule {
                Rule::Transform(m) if left > 0 => {
                    left -= 1;
                    o = m.transform_point3(o + d * t);
                    d = m.transform_vector3(d).normalize_or_zero();
                    if d == DVec3::ZERO {
                        break;
                    }
                }
                _ => break,
            }
        }
        out
    }

    /// The pieces of a ray as thick as a crack: the thin ray's pieces, cut where one of its side
    /// rays (parallel, `radius` out, or half way to a wall nearer the eye than that) meets a
    /// triangle first. A piece that ends on a gate (a mirror
    /// on a wall) lets its side rays meet that wall up to `radius / cos` sooner.
    fn thicken(&self, pieces: &[(DVec3, DVec3, f64)]) -> Vec<(DVec3, DVec3, f64)> {
        let Some(mesh) = self.mesh.as_ref().filter(|_| self.radius > 0.0) else {
            return pieces.to_vec();
        };
        let mut out = Vec::new();
        for (i, &(o, d, len)) in pieces.iter().enumerate() {
            let slack = if i + 1 < pieces.len() {
                let gate = self.gates.iter().find(|g| crossing(g, o, d) == Some(len));
                gate.map_or(0.0, |g| self.radius / g.normal.dot(d).abs().max(1e-3))
            } else {
                0.0
            };
            let (u, v) = d.any_orthonormal_pair();
            let cut = (0..SIDES)
                .filter_map(|k| {
                    let a = std::f64::consts::TAU * k as f64 / SIDES as f64;
                    let w = u * a.cos() + v * a.sin();
                    // A side ray starts on the eye's side of a wall beside it: from behind
                    // the wall it would meet the wall's back, not a crack ahead.
                    let r = (mesh.cast_local_ray(&Ray::new(o, w), self.radius, false))
                        .map_or(self.radius, |h| 0.5 * h);
                    let side = o + w * r;
                    let hit = mesh.cast_local_ray_and_get_normal(&Ray::new(side, d), len, false)?;
                    // The axis stops where it meets the plane the side ray hit (a slat
                    // beside a slit the axis passes stands on the wall's plane), no more
                    // than two radii sooner (a wall met at a grazing angle).
                    let (t, n) = (hit.time_of_impact, hit.normal);
                    let nd = n.dot(d);
                    let on_plane = if nd != 0.0 {
                        n.dot(side + d * t - o) / nd
                    } else {
                        t
                    };
                    Some(on_plane.clamp(t - 2.0 * self.radius, t))
                })
                .fold(f64::INFINITY, f64::min);
            if cut < len - slack {
                out.push((o, d, cut));
                break;
            }
            out.push((o, d, len));
        }
        out
    }

    /// What `rays` rays from cell `c` reached: each cell with the first ray that reached it
    /// the clearest way (a pair the PVS lacks is traced again as thick as a crack).
    fn rays_from(
        &self,
        c: usize,
        s: &Subject,
        pvs: &Pvs,
        rays: usize,
        targets: &[&[DVec3]],
    ) -> BTreeMap<usize, (Reach, Vec<DVec3>)> {
        let mut found = BTreeMap::new();
        let Some((poly, b)) = self.cells[c] else {
            return found;
        };
        let mut r = Rng::new(0x5167_4711_u64 ^ (c as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15));
        for k in 0..rays {
            let Some(p) = point_in(poly, &b, s.eps, &mut r) else {
                continue;
            };
            // Every other ray aimed at a random point of a random portal (of the level,
            // not only this cell's): uniform directions rarely thread a narrow opening.
            let aim = (k % 2 == 1 && !targets.is_empty())
                .then(|| {
                    let t = &targets[(r.unit() * targets.len() as f64) as usize % targets.len()];
                    (point_on(t, &mut r) - p).try_normalize()
                })
                .flatten();
            let pieces = self.trace(p, aim.unwrap_or_else(|| direction(&mut r)));
            let mut thick: Option<Vec<usize>> = None;
            for x in self.cells_met(&pieces) {
                if x == c {
                    continue;
                }
                let reach = if x >= pvs.cells() || pvs.sees(c, x) {
                    Reach::Clear
                } else {
                    let thick = thick.get_or_insert_with(|| self.cells_met(&self.thicken(&pieces)));
                    if thick.contains(&x) {
                        Reach::Clear
                    } else {
                        Reach::ThroughCrack
                    }
                };
                if found.get(&x).is_none_or(|(had, _)| *had < reach) {
                    let mut line = vec![p];
                    line.extend(pieces.iter().map(|&(o, d, l)| o + d * l));
                    found.insert(x, (reach, line));
                }
            }
        }
        found
    }

    /// The cells a ray's pieces run through, each once, in the order met.
    fn cells_met(&self, pieces: &[(DVec3, DVec3, f64)]) -> Vec<usize> {
        let mut out: Vec<usize> = Vec::new();
        for &(o, d, len) in pieces {
            let near = self.index.leaves(|node| {
                let a = node.aabb();
                let b = Aabb {
                    min: a.mins,
                    max: a.maxs,
                };
                meets_box(&b, o, d, len)
            });
            let mut here: Vec<(f64, usize)> = near
                .filter_map(|c| {
                    let c = c as usize;
                    let (poly, b) = self.cells[c].as_ref()?;
                    if !meets_box(b, o, d, len) {
                        return None;
                    }
                    // Deeper than the tolerance, and along the ray more than `within`: a
                    // ray grazing a face at a shallow angle runs far along it while never
                    // more than a tolerance inside (a wall a hair off the cell's face).
                    let (t0, t1) = clip(poly, o, d, len, self.inset)?;
                    (t1 - t0 > self.within).then_some((t0, c))
                })
                .collect();
            here.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
            for (_, c) in here {
                if !out.contains(&c) {
                    out.push(c);
                }
            }
        }
        out
    }
}

/// Audits `pvs` (rows for the subject's cells) with `rays` rays per cell; `triangles`: the
/// level's blocking triangles in world space; `depth`: transformed portals one ray passes.
pub fn audit(s: &Subject, triangles: &[[DVec3; 3]], pvs: &Pvs, rays: usize, depth: usize) -> Audit {
    let mesh = crate::geom::ray_mesh::ray_mesh(triangles);
    let cells: Vec<Option<(&ConvexPolyhedron, Aabb)>> = s
        .cells
        .iter()
        .map(|c| {
            let p = c.poly.as_ref()?;
            let b = Aabb::from_points(p.faces.iter().flat_map(|f| f.points.iter()));
            (!b.is_empty()).then_some((p, b))
        })
        .collect();
    let index = Bvh::from_iter(
        BvhBuildStrategy::default(),
        (cells.iter().enumerate()).filter_map(|(c, cell)| {
            let b = cell.as_ref()?.1;
            Some((c, parry3d_f64::bounding_volume::Aabb::new(b.min, b.max)))
        }),
    );
    let tracer = Tracer {
        mesh,
        gates: gates(s),
        cells,
        index,
        far: 4.0 * s.extent.max(s.eps),
        within: 10.0 * s.eps,
        inset: s.eps,
        depth,
        radius: 0.5 * s.crack / (std::f64::consts::PI / SIDES as f64).cos(),
    };
    let n = s.cells.len().min(pvs.cells());
    let targets: Vec<&[DVec3]> = s
        .portals
        .portals
        .iter()
        .filter(|p| !p.closed && p.polygon.len() >= 3)
        .map(|p| p.polygon.as_slice())
        .collect();
    // Per cell: the cells its rays reached, each with the first ray that reached it the
    // clearest way.
    let reached: Vec<BTreeMap<usize, (Reach, Vec<DVec3>)>> = (0..n)
        .into_par_iter()
        .map(|c| tracer.rays_from(c, s, pvs, rays, &targets))
        .collect();
    let mut out = Audit {
        diagnostics: Diagnostics::default(),
        lines: Vec::new(),
        confirmed: 0,
        pairs: 0,
        seen: Pvs::identity(n),
        through_cracks: 0,
    };
    let mut crack_example = None;
    for (c, found) in reached.iter().enumerate() {
        out.pairs += pvs.visible(c).filter(|&v| v != c).count();
        for (&x, (reach, line)) in found {
            if x >= n {
                continue;
            }
            if *reach == Reach::ThroughCrack {
                out.through_cracks += 1;
                crack_example.get_or_insert((c, x, line));
                continue;
            }
            out.seen.bits.set(c, x);
            if pvs.sees(c, x) {
                out.confirmed += 1;
                continue;
            }
            out.diagnostics.push(missed(s, c, x, line));
            out.lines.push(line.clone());
        }
    }
    if let Some((c, x, line)) = crack_example {
        out.diagnostics
            .push(through_cracks(s, out.through_cracks, c, x, line));
    }
    let share = if out.pairs > 0 {
        100.0 * out.confirmed as f64 / out.pairs as f64
    } else {
        100.0
    };
    out.diagnostics.push(Diagnostic::new(
        Code::SIGHTLINES_CONFIRMED,
        format!(
            "{rays} sightlines from each of {n} cells confirmed {} of the PVS's {} pairs of different cells ({share:.1}%); the rest are seen from points or directions no ray took, or are the PVS's over-estimate",
            out.confirmed, out.pairs
        ),
        Location::file(&s.file),
    ));
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::aabb::Aabb;

    /// A ray running a long way along a face, less than the tolerance inside, does not see
    /// into the cell; one a little deeper does.
    #[test]
    fn a_ray_grazing_a_face_does_not_see_in() {
        let cell = ConvexPolyhedron::from_aabb(&Aabb {
            min: DVec3::ZERO,
            max: DVec3::new(4.0, 3.0, 2.0),
        });
        let eps = 1e-3;
        let along = |depth: f64| {
            let o = DVec3::new(-1.0, 1.0, 2.0 - depth);
            clip(&cell, o, DVec3::X, 6.0, eps)
        };
        assert_eq!(along(0.5 * eps), None);
        let (t0, t1) = along(2.0 * eps).expect("two tolerances deep is inside");
        assert!((t0 - 1.0 - eps).abs() < 1e-12 && (t1 - 5.0 + eps).abs() < 1e-12);
        // Without an inset the grazing ray runs 4 m inside: what the audit used to count.
        let o = DVec3::new(-1.0, 1.0, 2.0 - 0.5 * eps);
        assert_eq!(clip(&cell, o, DVec3::X, 6.0, 0.0), Some((1.0, 5.0)));
    }

    #[test]
    fn a_ray_through_an_overlap_is_told_by_its_rooms() {
        let region = ConvexPolyhedron::from_aabb(&Aabb {
            min: DVec3::new(4.0, 0.0, 0.0),
            max: DVec3::new(5.0, 3.0, 4.0),
        });
        let overlaps = vec![(region, ["east".to_string(), "west".to_string()])];
        let through = [DVec3::new(1.0, 1.0, 2.0), DVec3::new(7.0, 1.0, 2.0)];
        assert_eq!(
            through_overlap(&overlaps, &through),
            Some(&["east".to_string(), "west".to_string()])
        );
        // A polyline whose second leg (after a teleporter) crosses it.
        let bent = [
            DVec3::new(1.0, 1.0, 6.0),
            DVec3::new(3.0, 1.0, 6.0),
            DVec3::new(4.5, 1.0, 1.0),
        ];
        assert!(through_overlap(&overlaps, &bent).is_some());
        let beside = [DVec3::new(1.0, 1.0, 6.0), DVec3::new(7.0, 1.0, 6.0)];
        assert_eq!(through_overlap(&overlaps, &beside), None);
    }
}
