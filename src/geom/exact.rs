//! Exact coordinates put back after the 2D booleans.
//!
//! i_overlay works on integers, so every vertex it returns sits on its grid. A vertex that is
//! an input vertex gets that vertex's exact coordinates back; one where two input edges cross
//! (a door's jamb meeting a floor's edge) gets their crossing computed from the edges. Left on
//! the grid, such a vertex moved by up to half a step as the grid's origin or step changed:
//! portal areas then hung on the tolerance and on where the level was (issue 25).

use std::collections::HashMap;

use glam::DVec2;

use super::tolerance::Tolerance;

/// The input vertices (and, if given, edges) the pieces of a boolean are made of.
pub(crate) struct ExactVertices {
    grid: f64,
    map: HashMap<(i64, i64), (usize, DVec2), foldhash::fast::FixedState>,
    /// Input edges, in input order, for vertices that are crossings.
    edges: Vec<(DVec2, DVec2)>,
}

impl ExactVertices {
    /// Remembers `points` by their node on a grid of spacing `grid` (the boolean's), the first
    /// point on a node winning, so a grid vertex gets its exact input coordinates back.
    pub fn new(points: impl Iterator<Item = DVec2>, grid: f64) -> Self {
        let mut map = HashMap::with_hasher(Default::default());
        for (i, p) in points.enumerate() {
            map.entry(Self::key(p, grid)).or_insert((i, p));
        }
        ExactVertices {
            grid,
            map,
            edges: Vec::new(),
        }
    }

    /// Also the edges of these closed rings: a vertex that is no input vertex but lies where
    /// two of them cross is put back on their crossing.
    pub(crate) fn with_rings<'r>(mut self, rings: impl IntoIterator<Item = &'r [DVec2]>) -> Self {
        for r in rings {
            for (i, &a) in r.iter().enumerate() {
                let b = r[(i + 1) % r.len()];
                if a != b {
                    self.edges.push((a, b));
                }
            }
        }
        self
    }

    /// The input order of the vertex at `p` (the earliest input vertex there): of the input
    /// vertices within a grid step of `p`, the earliest, not the nearest. Coincident vertices
    /// of a turned level differ in their last bits and may round to neighbouring grid keys;
    /// the nearest of them is then a coin toss, and so was the order of a room's cells
    /// (tests/cells_props.rs, an L turned by (1.47, -0.52, -0.04) rad).
    pub(crate) fn index_of(&self, p: DVec2) -> Option<usize> {
        let (kx, ky) = Self::key(p, self.grid);
        let mut earliest: Option<usize> = None;
        for dx in -2..=2 {
            for dy in -2..=2 {
                if let Some(&(i, q)) = self.map.get(&(kx + dx, ky + dy)) {
                    if q.distance(p) <= self.grid && earliest.is_none_or(|e| i < e) {
                        earliest = Some(i);
                    }
                }
            }
        }
        earliest.or_else(|| self.nearest(p).map(|(i, _)| i))
    }

    fn nearest(&self, p: DVec2) -> Option<(usize, DVec2)> {
        let (kx, ky) = Self::key(p, self.grid);
        let mut best: Option<(f64, (usize, DVec2))> = None;
        for dx in -2..=2 {
            for dy in -2..=2 {
                if let Some(&(i, q)) = self.map.get(&(kx + dx, ky + dy)) {
                    let d = q.distance_squared(p);
                    if best.is_none_or(|(bd, _)| d < bd) {
                        best = Some((d, (i, q)));
                    }
                }
            }
        }
        best.map(|(_, v)| v)
    }

    /// The crossing of two input edges within two grid steps of `p`, the nearest (ties by
    /// edge order). Snapping moved `p` off the edges by at most a step each.
    fn crossing(&self, p: DVec2) -> Option<DVec2> {
        let reach = 2.0 * self.grid;
        let near: Vec<&(DVec2, DVec2)> = self
            .edges
            .iter()
            .filter(|(a, b)| segment_distance(p, *a, *b) <= reach)
            .collect();
        let mut best: Option<(f64, DVec2)> = None;
        for (i, &&(a, b)) in near.iter().enumerate() {
            for &&(c, d) in &near[i + 1..] {
                let (u, v) = (b - a, d - c);
                // Parallel within the angle tolerance: the same wall twice, no corner.
                if Tolerance::along(u, v) {
                    continue;
                }
                let den = u.perp_dot(v);
                let x = a + u * ((c - a).perp_dot(v) / den);
                let dist = x.distance(p);
                if dist <= reach && best.is_none_or(|(bd, _)| dist < bd) {
                    best = Some((dist, x));
                }
            }
        }
        best.map(|(_, x)| x)
    }

    fn key(p: DVec2, grid: f64) -> (i64, i64) {
        ((p.x / grid).round() as i64, (p.y / grid).round() as i64)
    }

    /// Each vertex put back: the input vertex nearest to it within two grid steps, else the
    /// crossing of two input edges there, else as it is.
    pub(crate) fn restore(&self, piece: Vec<DVec2>) -> Vec<DVec2> {
        piece
            .into_iter()
            .map(|p| {
                self.nearest(p)
                    .map(|(_, q)| q)
                    .or_else(|| self.crossing(p))
                    .unwrap_or(p)
            })
            .collect()
    }
}

/// The distance from `p` to the segment `a`-`b` (to `a` when the segment is a point).
pub(crate) fn segment_distance(p: DVec2, a: DVec2, b: DVec2) -> f64 {
    let d = b - a;
    let len2 = d.length_squared();
    let t = if len2 > 0.0 {
        ((p - a).dot(d) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    p.distance(a + d * t)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::shapes::rect;

    #[test]
    fn a_crossing_comes_back_exact_wherever_the_grid_is() {
        // A door (x 0.3..0.7) cut from a wall whose floor edge is at y = 0.1: the door's
        // lower corners are crossings, on no input vertex.
        let wall = rect(0.0, 0.1, 1.0, 2.0);
        let jambs = [rect(-0.5, -0.5, 0.3, 3.0), rect(0.7, -0.5, 1.5, 3.0)];
        let truth = DVec2::new(0.3, 0.1);
        for grid in [1e-4, 3e-4, 7.77e-5] {
            let exact = ExactVertices::new(wall.iter().copied(), grid).with_rings(
                std::iter::once(wall.as_slice()).chain(jambs.iter().map(|r| r.as_slice())),
            );
            let snapped = DVec2::new(
                (truth.x / grid).round() * grid,
                (truth.y / grid).round() * grid,
            ) + DVec2::splat(0.4 * grid);
            let back = exact.restore(vec![snapped]);
            assert!(back[0].distance(truth) < 1e-15, "{grid}: {}", back[0]);
        }
    }

    #[test]
    fn far_from_any_input_a_vertex_stays() {
        let wall = rect(0.0, 0.0, 1.0, 1.0);
        let exact = ExactVertices::new(wall.iter().copied(), 1e-3).with_rings([wall.as_slice()]);
        let p = DVec2::new(0.5, 0.5);
        assert_eq!(exact.restore(vec![p]), vec![p]);
    }
}
