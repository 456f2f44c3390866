//! The portal graph every method runs on, whatever the level came from (a [`PortalSet`] or a
//! .prt file): cells, and directed portals with their polygon and plane. Only portals light
//! can pass are in it: closed portals are left out here, one-way portals are present only in
//! their own direction (the set has no partner for them), so the methods never need to know
//! about those flags.
//!
//! A level's openings to the exterior all lead into one more cell, the outside, after the
//! level's own (each opening a portal both ways): a sightline may leave through one opening
//! and come back through any other. The outside is not convex and nothing in it is known to
//! block, so the conservative methods treat it as open space (sight through it is still
//! clipped by the openings themselves, as through any cell), and [`super::compute`] drops its
//! row and column from the result. An opening on the convex hull of every portal, facing out
//! of it, leads nowhere: a sightline can come back into a cell only through a portal or an
//! opening, and a straight line that left the hull never meets it again. Such openings (the
//! open sky over a level with no sky modelled) are left out, exactly: the outside's fan of
//! thousands of openings was most of the PVS's work on such levels.

use glam::{DMat4, DVec3};

use crate::geom::plane::Plane;
use crate::portals::PortalSet;

/// One directed portal of the graph the PVS flows through.
#[derive(Debug, Clone)]
pub struct VisPortal {
    /// The cell a sightline leaves.
    pub from: usize,
    /// The cell it enters.
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

/// Cells and directed portals: what the vis stage needs of a level or a `.prt`.
#[derive(Debug, Clone, Default)]
pub struct VisGraph {
    /// How many cells, the outside included when there is one.
    pub cells: usize,
    /// The directed portals; see `leaving` for each cell's.
    pub portals: Vec<VisPortal>,
    /// Per cell, the portals leaving it, ascending.
    pub leaving: Vec<Vec<usize>>,
    /// Points this close to a plane are on it (the flow keeps them on both sides).
    pub epsilon: f64,
    /// Per portal, the portal through the same polygon the other way, when there is one and
    /// neither carries a transform: a sightline through one passes through the other the
    /// other way, so what one sees tells what the other is seen by.
    pub reverse: Vec<Option<usize>>,
    /// Per portal, its place in an order that does not follow the portals' numbers where the
    /// level says more (its cells' rank by room name, then the portal's number): the flow's
    /// waves break their ties by it, so the same level with its rooms listed in another
    /// order gets the same PVS. Plainly the portals' numbers otherwise.
    pub order: Vec<u32>,
    /// The outside's cell (the last), when the level has openings to the exterior.
    pub outside: Option<usize>,
}

impl VisGraph {
    /// A graph of `cells` cells; `epsilon` is the distance tolerance (m).
    pub fn new(cells: usize, portals: Vec<VisPortal>, epsilon: f64) -> VisGraph {
        let mut leaving = vec![Vec::new(); cells];
        for (i, p) in portals.iter().enumerate() {
            leaving[p.from].push(i);
        }
        let reverse = reverses(&portals, &leaving, epsilon);
        let order = (0..portals.len() as u32).collect();
        VisGraph {
            cells,
            portals,
            leaving,
            epsilon,
            reverse,
            order,
            outside: None,
        }
    }

    /// The level's own cells: every cell but the outside.
    pub fn level_cells(&self) -> usize {
        self.cells - usize::from(self.outside.is_some())
    }

    /// The open portals of a level. `epsilon`: the level's distance tolerance.
    pub fn from_portal_set(cells: usize, set: &PortalSet, epsilon: f64) -> VisGraph {
        let open = |p: &&crate::portals::Portal| !p.closed && p.polygon.len() >= 3;
        let onto_hull = onto_hull(set, epsilon);
        let exterior =
            |p: &crate::portals::Portal| p.to.is_none() && p.transform.is_none() && !onto_hull(p);
        let outside = set
            .portals
            .iter()
            .filter(open)
            .any(|p| exterior(p) && p.from < cells)
            .then_some(cells);
        let plane_of = |normal: DVec3, polygon: &[DVec3]| Plane {
            normal,
            d: normal.dot(polygon.iter().copied().sum::<DVec3>()) / polygon.len() as f64,
        };
        let mut portals = Vec::new();
        for (i, p) in set.portals.iter().enumerate().filter(|(_, p)| open(p)) {
            match (p.to, outside) {
                (Some(to), _) => portals.push(VisPortal {
                    from: p.from,
                    to,
                    winding: p.polygon.clone(),
                    plane: plane_of(p.normal, &p.polygon),
                    transform: p.transform,
                    origin: i,
                }),
                // Out through the opening (its normal faces away from its cell), and back in.
                (None, Some(o)) if exterior(p) && p.from < cells => {
                    portals.push(VisPortal {
                        from: p.from,
                        to: o,
                        winding: p.polygon.clone(),
                        plane: plane_of(p.normal, &p.polygon),
                        transform: None,
                        origin: i,
                    });
                    let back: Vec<DVec3> = p.polygon.iter().rev().copied().collect();
                    portals.push(VisPortal {
                        from: o,
                        to: p.from,
                        plane: plane_of(-p.normal, &back),
                        winding: back,
                        transform: None,
                        origin: i,
                    });
                }
                _ => {}
            }
        }
        let all = cells + usize::from(outside.is_some());
        let mut g = VisGraph::new(all, portals, epsilon);
        g.outside = outside;
        // The outside ranks after every cell.
        let mut rank = set.cell_rank.clone();
        if rank.len() == cells && outside.is_some() {
            rank.push(cells as u32);
        }
        if rank.len() == all && g.portals.iter().all(|p| p.from < all && p.to < all) {
            let mut by: Vec<usize> = (0..g.portals.len()).collect();
            by.sort_by_key(|&k| {
                let p = &g.portals[k];
                (rank[p.from], rank[p.to], k)
            });
            for (place, k) in by.into_iter().enumerate() {
                g.order[k] = place as u32;
            }
        }
        g
    }

    /// Whether any portal is a mirror or teleporter.
    pub fn has_transforms(&self) -> bool {
        self.portals.iter().any(|p| p.transform.is_some())
    }
}

/// Whether an opening lies on the convex hull of every portal's corners and faces out of it:
/// no corner in front of its plane (see the module docs). Asked of the hull's faces, or of
/// the corners themselves when they are flat (a hull needs volume).
fn onto_hull(set: &PortalSet, eps: f64) -> impl Fn(&crate::portals::Portal) -> bool {
    let corners: Vec<DVec3> = (set.portals.iter())
        .flat_map(|p| p.polygon.iter().copied())
        .collect();
    let hull = crate::geom::hull::hull(&corners, eps).ok();
    move |p| {
        let Some(&at) = p.polygon.first() else {
            return false;
        };
        match &hull {
            Some(h) => h.faces.iter().any(|f| {
                f.plane.normal.dot(p.normal) > 0.0
                    && p.polygon.iter().all(|q| f.plane.distance(*q).abs() <= eps)
            }),
            None => corners.iter().all(|q| p.normal.dot(*q - at) <= eps),
        }
    }
}

/// Pairs each portal with one leaving its target into its source whose corners are its own
/// (each within `eps` of one of the other's), neither transformed.
fn reverses(portals: &[VisPortal], leaving: &[Vec<usize>], eps: f64) -> Vec<Option<usize>> {
    let covers =
        |a: &[DVec3], b: &[DVec3]| a.iter().all(|v| b.iter().any(|w| v.distance(*w) <= eps));
    portals
        .iter()
        .map(|p| {
            if p.transform.is_some() {
                return None;
            }
            leaving[p.to].iter().copied().find(|&q| {
                let r = &portals[q];
                r.to == p.from
                    && r.transform.is_none()
                    && covers(&p.winding, &r.winding)
                    && covers(&r.winding, &p.winding)
            })
        })
        .collect()
}

/// A rigid motion or reflection applied to a plane (normals by the linear part, which is
/// orthogonal for every transform a portal carries).
pub(crate) fn transform_plane(m: &DMat4, p: &Plane) -> Plane {
    let n = m.transform_vector3(p.normal).normalize_or_zero();
    let on = m.transform_point3(p.normal * p.d);
    Plane {
        normal: n,
        d: n.dot(on),
    }
}
