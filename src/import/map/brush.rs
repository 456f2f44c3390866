//! A brush's planes to a closed convex solid: the intersection of the half-spaces behind its
//! faces (f64, clipped by `geom`'s polyhedron), its corners welded so that the faces meeting
//! at one share it bit for bit (the cells stage tells a solid by its closed edges), each face
//! wound counter-clockwise seen from outside and carrying the texture of the plane it lies on.

use glam::DVec3;

use super::parse::Face;
use crate::geom::aabb::Aabb;
use crate::geom::plane::Plane;
use crate::geom::polyhedron::ConvexPolyhedron;

use super::WORLD;

/// Map units within which two corners of one brush are one point (qbsp welds at 1e-4 and
/// ignores planes nearer than that).
const WELD: f64 = 1e-5;

/// The most faces a brush may have. Building a brush clips a box by each plane, which costs
/// the planes times the faces so far (quadratic): 1,024 planes take about 0.3 s, 8,000 would
/// take 20. Editors write a few dozen at most; ericw-tools' test maps at most 362.
pub(super) const MAX_BRUSH_FACES: usize = 1024;

/// Why a brush's planes make no closed solid: each says what the mapper sees in the editor.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum NotSolid {
    /// Fewer than four distinct planes (the count).
    FewPlanes(usize),
    /// A plane lies beyond `WORLD`, where no engine of the family reaches.
    Beyond,
    /// Nothing lies behind every plane (inverted or contradictory faces, or a flat brush).
    Empty,
    /// The planes leave it open on some side.
    Open,
}

impl NotSolid {
    /// What is wrong, to follow "brush N of entity M (`class`)".
    pub fn message(self) -> String {
        match self {
            NotSolid::FewPlanes(n) => format!(
                "has {n} distinct plane(s): a closed brush needs at least four"
            ),
            NotSolid::Beyond => format!(
                "lies beyond ±{WORLD} units of the map's origin, farther than any engine of the Quake family reaches (±32768)"
            ),
            NotSolid::Empty => {
                "encloses no volume: no point lies behind all its planes (it is flat, or a face points inwards)".into()
            }
            NotSolid::Open => "is open: its planes do not close it on every side".into(),
        }
    }
}

/// A brush as polygons (map units), each with the index of its face, or why its planes make
/// no closed solid.
pub(super) fn polygons(faces: &[Face]) -> Result<Vec<(Vec<DVec3>, usize)>, NotSolid> {
    let mut planes: Vec<(Plane, usize)> = Vec::new();
    for (k, f) in faces.iter().enumerate() {
        let p = Plane {
            normal: DVec3::from_array(f.normal),
            d: f.dist,
        };
        // A plane written twice counts once.
        if !planes.iter().any(|(q, _)| q.same_as(&p, 1e-4, 1e-6)) {
            planes.push((p, k));
        }
    }
    if planes.len() < 4 {
        return Err(NotSolid::FewPlanes(planes.len()));
    }
    // Past the box a brush is clipped out of, it is empty or open there for that reason.
    let beyond = |e: NotSolid| match planes
        .iter()
        .any(|(p, _)| p.d.is_nan() || p.d.abs() >= WORLD)
    {
        true => NotSolid::Beyond,
        false => e,
    };
    let bounds = Aabb {
        min: DVec3::splat(-WORLD),
        max: DVec3::splat(WORLD),
    };
    let mut poly = ConvexPolyhedron::from_aabb(&bounds);
    for (p, _) in &planes {
        poly = poly.clip(p, WELD).ok_or_else(|| beyond(NotSolid::Empty))?;
    }
    // A face of the starting box that survived: the planes do not close the brush.
    let mut out = Vec::new();
    for f in &poly.faces {
        let (_, k) = planes
            .iter()
            .find(|(p, _)| p.same_as(&f.plane, 1e-3, 1e-6))
            .ok_or_else(|| beyond(NotSolid::Open))?;
        out.push((f.points.clone(), *k));
    }
    weld(&mut out);
    for (ring, k) in &mut out {
        let n = DVec3::from_array(faces[*k].normal);
        if ring_normal(ring).dot(n) < 0.0 {
            ring.reverse();
        }
    }
    out.retain(|(ring, _)| ring.len() >= 3);
    match out.len() >= 4 {
        true => Ok(out),
        false => Err(NotSolid::Empty),
    }
}

/// Corners closer than `WELD` become the first of them, and a ring drops a corner that
/// repeats its neighbour.
fn weld(rings: &mut [(Vec<DVec3>, usize)]) {
    let mut seen: Vec<DVec3> = Vec::new();
    for (ring, _) in rings.iter_mut() {
        for p in ring.iter_mut() {
            match seen.iter().find(|q| q.distance(*p) <= WELD) {
                Some(q) => *p = *q,
                None => seen.push(*p),
            }
        }
        ring.dedup();
        while ring.len() > 1 && ring.first() == ring.last() {
            ring.pop();
        }
    }
}

/// Twice the ring's vector area.
fn ring_normal(ring: &[DVec3]) -> DVec3 {
    let o = ring[0];
    ring.windows(2)
        .skip(1)
        .fold(DVec3::ZERO, |n, w| n + (w[0] - o).cross(w[1] - o))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn face(n: [f64; 3], d: f64) -> Face {
        Face {
            normal: n,
            dist: d,
            texture: "t".into(),
            contents: None,
        }
    }

    #[test]
    fn a_box_is_six_outward_quads_sharing_corners() {
        let faces = [
            face([1.0, 0.0, 0.0], 64.0),
            face([-1.0, 0.0, 0.0], 0.0),
            face([0.0, 1.0, 0.0], 32.0),
            face([0.0, -1.0, 0.0], 0.0),
            face([0.0, 0.0, 1.0], 16.0),
            face([0.0, 0.0, -1.0], 0.0),
        ];
        let rings = polygons(&faces).unwrap();
        assert_eq!(rings.len(), 6);
        let mut volume = 0.0;
        for (ring, k) in &rings {
            assert_eq!(ring.len(), 4);
            let n = ring_normal(ring);
            assert!(n.dot(DVec3::from_array(faces[*k].normal)) > 0.0);
            for w in ring[1..].windows(2) {
                volume += ring[0].dot(w[0].cross(w[1])) / 6.0;
            }
        }
        assert!((volume - 64.0 * 32.0 * 16.0).abs() < 1e-6);
    }

    #[test]
    fn three_planes_or_an_open_brush_is_no_solid() {
        let open = [
            face([1.0, 0.0, 0.0], 64.0),
            face([-1.0, 0.0, 0.0], 0.0),
            face([0.0, 1.0, 0.0], 32.0),
            face([0.0, -1.0, 0.0], 0.0),
            face([0.0, 0.0, 1.0], 16.0),
        ];
        assert_eq!(polygons(&open), Err(NotSolid::Open));
        assert_eq!(polygons(&open[..3]), Err(NotSolid::FewPlanes(3)));
    }
}
