//! The portal graph every method runs on, whatever the level came from (a [`PortalSet`] or a
//! .prt file): cells, and directed portals with their polygon and plane. Only portals light
//! can pass are in it: closed portals and openings to the exterior are left out here, one-way
//! portals are present only in their own direction (the set has no partner for them), so the
//! methods never need to know about those flags.

use glam::{DMat4, DVec3};

use crate::geom::plane::Plane;
use crate::portals::PortalSet;

#[derive(Debug, Clone)]
pub struct VisPortal {
    pub from: usize,
    pub to: usize,
    /// Convex polygon; either winding order.
    pub winding: Vec<DVec3>,
    /// Facing the target cell: the side a sightline is on after passing the portal.
    pub plane: Plane,
    /// Maps the source side's space to the target side's (mirrors, teleporters).
    pub transform: Option<DMat4>,
    /// The index of the portal in the set or file it came from.
    pub origin: usize,
}

#[derive(Debug, Clone, Default)]
pub struct VisGraph {
    pub cells: usize,
    pub portals: Vec<VisPortal>,
    /// Per cell, the portals leaving it, ascending.
    pub leaving: Vec<Vec<usize>>,
    /// Points this close to a plane are on it (the flow keeps them on both sides).
    pub epsilon: f64,
}

impl VisGraph {
    pub fn new(cells: usize, portals: Vec<VisPortal>, epsilon: f64) -> VisGraph {
        let mut leaving = vec![Vec::new(); cells];
        for (i, p) in portals.iter().enumerate() {
            leaving[p.from].push(i);
        }
        VisGraph {
            cells,
            portals,
            leaving,
            epsilon,
        }
    }

    /// The open portals of a level. `epsilon`: the level's distance tolerance.
    pub fn from_portal_set(cells: usize, set: &PortalSet, epsilon: f64) -> VisGraph {
        let portals = set
            .portals
            .iter()
            .enumerate()
            .filter(|(_, p)| !p.closed && p.polygon.len() >= 3)
            .filter_map(|(i, p)| {
                let to = p.to?;
                let d =
                    p.normal.dot(p.polygon.iter().copied().sum::<DVec3>()) / p.polygon.len() as f64;
                Some(VisPortal {
                    from: p.from,
                    to,
                    winding: p.polygon.clone(),
                    plane: Plane {
                        normal: p.normal,
                        d,
                    },
                    transform: p.transform,
                    origin: i,
                })
            })
            .collect();
        VisGraph::new(cells, portals, epsilon)
    }

    pub fn has_transforms(&self) -> bool {
        self.portals.iter().any(|p| p.transform.is_some())
    }
}

/// A rigid motion or reflection applied to a plane (normals by the linear part, which is
/// orthogonal for every transform a portal carries).
pub fn transform_plane(m: &DMat4, p: &Plane) -> Plane {
    let n = m.transform_vector3(p.normal).normalize_or_zero();
    let on = m.transform_point3(p.normal * p.d);
    Plane {
        normal: n,
        d: n.dot(on),
    }
}
