//! Which solid blocks are props: loose objects rendered by the cell around them, never
//! shaping it. Decided for each block from its neighbours alone, so a ground plane, a terrain
//! block, a stack of crates or a shelf elsewhere changes no wall.
//!
//! A node's blocks are structure when one of them lies on two faces of the hull of its room's
//! blocks (a floor, a ceiling, an outer wall: its side and its top in a roofless yard), when
//! they are **mounted** flush on structure beside or above them (a shelf, a panel, a lamp:
//! only what rests on the block below it, along `[cells] up`, or is pushed into another, can
//! be loose), or when they are **held**: pressed between two structural
//! blocks from opposite sides (a wall between floor and ceiling, a jamb between floor and
//! lintel, a lintel between two jambs, a pillar), or spanning two structural blocks that do not
//! touch each other from the same side (a ceiling or a floor across the walls, a beam on two
//! posts). The structure is the largest set of blocks all held by each other, found by taking
//! away, round by round, the blocks nothing holds: a crate on the floor goes first, then the
//! crate it stood on. Blocks that separate air, taken away together with the props they touch
//! (a block plugging a hole in a wall, two blocks plugging it one above the other), are never
//! taken away, so props never open a seal.
//! Contact and its direction come from the separating axes of the blocks' hulls (the face
//! normal along which two blocks overlap least), so the decision turns with the level; blocks
//! a crack apart touch. A node
//! is the designer's object, judged whole: a table's legs holding its top do not make it
//! structure.

use std::collections::{BTreeMap, BTreeSet};

use glam::DVec3;

use super::solids::Solid;
use crate::geom::grid::BoxGrid;
use crate::geom::polyhedron::ConvexPolyhedron;
use crate::geom::tolerance::Tolerance;
use crate::scene::NodeId;

/// Where one node's blocks touch another's: the direction from the first towards the second.
#[derive(Debug, Clone, Copy)]
struct Contact {
    other: NodeId,
    dir: DVec3,
    /// Face to face, a crack apart at most (not one pushed into the other).
    flush: bool,
}

/// The contacts between the blocks of different nodes.
pub(super) struct Contacts {
    by_node: BTreeMap<NodeId, Vec<Contact>>,
    touching: BTreeSet<(NodeId, NodeId)>,
    /// The level's up (`[cells] up`): what a block rests on lies that way down.
    up: DVec3,
}

impl Contacts {
    /// Blocks closer than `gap` (the crack width, or the tolerance if wider) touch: a crack
    /// between two blocks is closed.
    pub fn new(solids: &[Solid], gap: f64, up: DVec3) -> Contacts {
        let eps = gap;
        let grid = BoxGrid::new(solids.iter().map(|s| s.bounds).collect());
        let mut by_node: BTreeMap<NodeId, Vec<Contact>> = BTreeMap::new();
        let mut touching = BTreeSet::new();
        for (i, j) in grid.pairs(Tolerance::touching(eps)) {
            let (a, b) = (&solids[i], &solids[j]);
            if a.node == b.node {
                continue;
            }
            let (Some(ha), Some(hb)) = (&a.hull, &b.hull) else {
                continue;
            };
            if let Some((d, depth)) = contact(ha, hb, eps) {
                let flush = depth <= eps;
                by_node.entry(a.node).or_default().push(Contact {
                    other: b.node,
                    dir: d,
                    flush,
                });
                by_node.entry(b.node).or_default().push(Contact {
                    other: a.node,
                    dir: -d,
                    flush,
                });
                touching.insert((a.node.min(b.node), a.node.max(b.node)));
            }
        }
        Contacts {
            by_node,
            touching,
            up: up.try_normalize().unwrap_or(DVec3::Y),
        }
    }

    fn touch(&self, a: NodeId, b: NodeId) -> bool {
        self.touching.contains(&(a.min(b), a.max(b)))
    }

    /// Whether node `n` is held by the nodes `structure` says are structure.
    fn held(&self, n: NodeId, structure: &dyn Fn(NodeId) -> bool) -> bool {
        let Some(list) = self.by_node.get(&n) else {
            return false;
        };
        let list: Vec<&Contact> = list
            .iter()
            .filter(|c| c.other != n && structure(c.other))
            .collect();
        // Mounted: flush against a block beside or above it (a shelf, a lamp, a panel on a
        // wall); a crate only rests on what is below it, or is pushed into a wall.
        if list.iter().any(|c| c.flush && c.dir.dot(self.up) > -0.7) {
            return true;
        }
        for (k, c) in list.iter().enumerate() {
            for d in &list[k + 1..] {
                let dot = c.dir.dot(d.dir);
                if dot < -0.5 {
                    return true;
                }
                if dot > 0.5 && c.other != d.other && !self.touch(c.other, d.other) {
                    return true;
                }
            }
        }
        false
    }

    /// The props among `candidates` (nodes that may be props; every other node with a block
    /// is structure): the nodes nothing holds once the props are gone, taken away round by
    /// round. A cluster of them (props touching each other) that separates air, taken away
    /// together, stays structure; `separates` answers that for each cluster asked, once.
    pub fn props(
        &self,
        nodes: &[NodeId],
        candidates: &BTreeSet<NodeId>,
        separates: &mut dyn FnMut(&[Vec<NodeId>]) -> Vec<bool>,
    ) -> Vec<NodeId> {
        let mut anchored: BTreeSet<NodeId> = BTreeSet::new();
        let mut asked: BTreeSet<Vec<NodeId>> = BTreeSet::new();
        loop {
            let gone = self.free(nodes, candidates, &anchored);
            let clusters: Vec<Vec<NodeId>> = self
                .clusters(&gone)
                .into_iter()
                .filter(|c| !asked.contains(c))
                .collect();
            if clusters.is_empty() {
                return gone.into_iter().collect();
            }
            let verdicts = separates(&clusters);
            let mut more = false;
            for (c, sep) in clusters.into_iter().zip(verdicts) {
                if sep {
                    anchored.extend(c.iter().copied());
                    more = true;
                }
                asked.insert(c);
            }
            if !more {
                return gone.into_iter().collect();
            }
        }
    }

    /// The candidates nothing holds once they are gone (the largest structure holding itself).
    fn free(
        &self,
        nodes: &[NodeId],
        candidates: &BTreeSet<NodeId>,
        anchored: &BTreeSet<NodeId>,
    ) -> BTreeSet<NodeId> {
        let mut gone: BTreeSet<NodeId> = BTreeSet::new();
        loop {
            let structure = |m: NodeId| !gone.contains(&m);
            let free: Vec<NodeId> = nodes
                .iter()
                .copied()
                .filter(|n| candidates.contains(n) && !anchored.contains(n) && !gone.contains(n))
                .filter(|&n| !self.held(n, &structure))
                .collect();
            if free.is_empty() {
                return gone;
            }
            gone.extend(free);
        }
    }

    /// The nodes of a set grouped by touching, each group in node order.
    fn clusters(&self, set: &BTreeSet<NodeId>) -> Vec<Vec<NodeId>> {
        let list: Vec<NodeId> = set.iter().copied().collect();
        let mut parts = crate::disjoint::DisjointSets::new(list.len());
        for (i, &a) in list.iter().enumerate() {
            for c in self.by_node.get(&a).into_iter().flatten() {
                if let Ok(j) = list.binary_search(&c.other) {
                    parts.union(i, j);
                }
            }
        }
        let mut groups: BTreeMap<usize, Vec<NodeId>> = BTreeMap::new();
        for (i, &n) in list.iter().enumerate() {
            groups.entry(parts.find(i)).or_default().push(n);
        }
        groups.into_values().collect()
    }
}

/// Where `b` touches or overlaps `a`: the unit direction from `a` towards `b` along the face
/// normal (of either hull) on which they overlap least, and how deep they overlap along it;
/// `None` when a face plane separates them.
fn contact(a: &ConvexPolyhedron, b: &ConvexPolyhedron, eps: f64) -> Option<(DVec3, f64)> {
    let reach = |p: &ConvexPolyhedron, n: DVec3| {
        p.faces
            .iter()
            .flat_map(|f| f.points.iter())
            .map(|q| q.dot(n))
            .fold(f64::NEG_INFINITY, f64::max)
    };
    let mut best: Option<(f64, DVec3)> = None;
    for (f, dir) in a
        .faces
        .iter()
        .map(|f| (f, 1.0))
        .chain(b.faces.iter().map(|f| (f, -1.0)))
    {
        // Overlap along the direction from a towards b: how far a reaches past b's start.
        let n = f.plane.normal * dir;
        let overlap = reach(a, n) + reach(b, -n);
        if overlap < -eps {
            return None;
        }
        if best.is_none_or(|(o, _)| overlap < o - eps) {
            best = Some((overlap, n));
        }
    }
    best.map(|(o, n)| (n, o))
}
