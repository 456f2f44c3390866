//! The air of the rooms built of solid blocks, for the whole level at once: every solid carves
//! every room, so a wall listed once bounds both rooms it separates, and the air of the level
//! is one space in which occupants are followed from room to room.
//!
//! 1. **Props** (`props.rs`): blocks nothing holds and that separate no air are set aside.
//! 2. **Leaves** (`bsp.rs`): the hull of every room's solids (the world) is cut by the planes
//!    of the solids' faces, the rooms' surfaces and the rooms' hulls.
//! 3. **Air** (`air.rs`): the leaves in no solid, joined through faces wider than the crack
//!    width; whose they are and which are air, by the occupants and the rules there.
//! 4. **Cells**: each room's air leaves, cut by the gates that close them, are merged into
//!    maximal convex unions within the gates they lie in only, and halved while wider than
//!    `[cells] max_cell_width`.
//!
//! **Gates** (a door's brush, an area portal's or visportal's brush) are volumes of air that
//! something can close. A gate cuts a leaf only where its blocks, made solid, would part the
//! leaf's air (a door in its doorway, not bars with gaps or a lift standing in a room), and
//! only that leaf: the BSP never sees a gate's planes (qbsp keeps doors out of the world BSP
//! too). Each gate's air is then cells of its own whose portals the gate can close; a gate
//! that parts nothing closes nothing, and the PVS sees through it as through open air.

use std::collections::{BTreeMap, BTreeSet};

use glam::DVec3;
use rayon::prelude::*;

use super::air::{least_width, shared_faces, touching, Air};
use super::bsp::{Faces, Frag, Leaf, Owner, Space};
use super::interior::{merge, thickness};
use super::props::Contacts;
use super::solids::Solid;
use super::Gate;
use crate::disjoint::DisjointSets;
use crate::geom::aabb::Aabb;
use crate::geom::grid::BoxGrid;
use crate::geom::hull::hull;
use crate::geom::plane::Plane;
use crate::geom::polyhedron::{clip_polygon, polygon_area, ConvexPolyhedron};
use crate::geom::tolerance::Tolerance;
use crate::scene::NodeId;

/// One room of solid blocks, as the cells stage found it (recentred coordinates).
pub(super) struct BlockRoom {
    /// Its rank by name: ties of ownership go to the lower.
    pub rank: usize,
    pub solids: Vec<Solid>,
    /// Its other structural triangles, which bound its air as they face.
    pub surfaces: Vec<[DVec3; 3]>,
    /// Nodes whose blocks may be props (prop detection on, not tagged `structure`).
    pub prop_candidates: Vec<NodeId>,
}

/// The settings the block reading follows: whether `others` may be props, the crack width,
/// the widest cell, the tolerance and up.
#[derive(Clone, Copy)]
pub(super) struct BlockRules {
    pub loose: bool,
    pub crack: f64,
    /// No cell is wider than this across any of its faces' directions (`[cells]
    /// max_cell_width`).
    pub max_width: f64,
    pub eps: f64,
    pub up: DVec3,
}

/// What [`read`] found, room by room (in the order of the rooms given).
#[derive(Default)]
pub(super) struct BlockReading {
    /// Each room's cells, each with the indices of the gates it lies in.
    pub cells: Vec<Vec<(ConvexPolyhedron, Vec<usize>)>>,
    /// Nodes whose blocks are props, by room.
    pub props: Vec<Vec<NodeId>>,
    /// Sealed pockets no occupant reaches, filled: per room, their count, volume and a point.
    pub pockets: Vec<Option<(usize, f64, DVec3)>>,
    /// Rooms no occupant reaches that keep several separate regions: their volumes and points.
    pub unsure: Vec<Vec<(f64, DVec3)>>,
    /// The occupants that stand inside a solid (they seed nothing).
    pub buried: Vec<usize>,
    /// The gaps among the blocks the crack width closed (recentred).
    pub closed: crate::geom::crack::ClosedGaps,
}

/// Reads the air of the block rooms (see the module docs). `others` are solids of the level
/// outside these rooms, which carve them too unless they are props (`rules.loose`: they may
/// be); `gates` the level's gates (convex volumes); `occupants` where the occupants stand;
/// gaps narrower than `rules.crack` are closed.
pub(super) fn read(
    rooms: &[BlockRoom],
    others: &[Solid],
    gates: &[(Gate, ConvexPolyhedron)],
    occupants: &[DVec3],
    rules: &BlockRules,
) -> BlockReading {
    let BlockRules {
        loose, crack, eps, ..
    } = *rules;
    let mut out = BlockReading {
        cells: vec![Vec::new(); rooms.len()],
        props: vec![Vec::new(); rooms.len()],
        pockets: vec![None; rooms.len()],
        unsure: vec![Vec::new(); rooms.len()],
        buried: Vec::new(),
        closed: Default::default(),
    };
    // All solids, each with its room (none for `others`).
    let mut solids: Vec<Solid> = Vec::new();
    let mut room_of: Vec<Option<usize>> = Vec::new();
    for (r, room) in rooms.iter().enumerate() {
        solids.extend(room.solids.iter().cloned());
        room_of.extend(std::iter::repeat_n(Some(r), room.solids.len()));
    }
    solids.extend(others.iter().cloned());
    room_of.extend(std::iter::repeat_n(None, others.len()));
    let mut candidates: BTreeSet<NodeId> = rooms
        .iter()
        .flat_map(|r| r.prop_candidates.iter().copied())
        .collect();
    if loose {
        candidates.extend(others.iter().map(|s| s.node));
    }
    let gone = find_props(rooms, &solids, &room_of, &candidates, rules);
    for (r, room) in rooms.iter().enumerate() {
        let mut p: Vec<NodeId> = room
            .prop_candidates
            .iter()
            .copied()
            .filter(|n| gone.contains(n))
            .collect();
        p.sort_unstable();
        p.dedup();
        // Never call all of a room's blocks props.
        if room.solids.iter().all(|s| p.contains(&s.node)) {
            p.clear();
        }
        out.props[r] = p;
    }
    let keep: Vec<bool> = solids
        .iter()
        .zip(&room_of)
        .map(|(s, r)| match r {
            Some(r) => !out.props[*r].contains(&s.node),
            None => !gone.contains(&s.node),
        })
        .collect();
    let (solids, room_of): (Vec<Solid>, Vec<Option<usize>>) = solids
        .into_iter()
        .zip(room_of)
        .zip(keep)
        .filter(|(_, k)| *k)
        .map(|(x, _)| x)
        .unzip();
    let Some(cut) = CutWorld::new(rooms, &solids, &room_of, crack, eps) else {
        return out;
    };
    let air = &cut.air;
    out.closed = air.closed;
    // Occupants, and what they reach.
    let mut seeds = Vec::new();
    for (k, &p) in occupants.iter().enumerate() {
        // On a block's face counts as in it, as qbsp prefers the sealing side.
        if cut.space.held(p) {
            out.buried.push(k);
            continue;
        }
        match air.leaf_at(p) {
            Some(i) if !air.thin[i] => seeds.push(i),
            Some(_) => out.buried.push(k),
            None => {}
        }
    }
    let reached = air.flood(&seeds);
    let open = &cut.open;
    let owners = cut.owners(&solids, &room_of);
    let mut owned: Vec<Vec<usize>> = vec![Vec::new(); rooms.len()];
    for (i, o) in owners.iter().enumerate() {
        if let Some(r) = o {
            owned[*r as usize].push(i);
        }
    }
    let gate_index = GateIndex::new(gates);
    for (r, leaves) in owned.iter().enumerate() {
        let kept = decide(air, leaves, &reached, open, r, &mut out);
        out.cells[r] = cut.cells(&kept, gates, &gate_index, rules);
    }
    out
}

/// What the rules keep of a room's leaves (see `air.rs`, steps 3 and 4).
fn decide(
    air: &Air,
    leaves: &[usize],
    reached: &[bool],
    open: &[bool],
    r: usize,
    out: &mut BlockReading,
) -> Vec<usize> {
    if leaves.iter().any(|&i| reached[i]) {
        let (kept, rest): (Vec<usize>, Vec<usize>) = leaves.iter().partition(|&&i| reached[i]);
        let pockets: Vec<Vec<usize>> = air
            .components(&rest)
            .into_iter()
            .filter(|part| part.iter().all(|&i| !open[i]))
            .collect();
        if !pockets.is_empty() {
            let all: Vec<usize> = pockets.iter().flatten().copied().collect();
            let largest = pockets
                .iter()
                .max_by(|a, b| air.volume(a).total_cmp(&air.volume(b)))
                .map_or(DVec3::ZERO, |p| air.point(p));
            out.pockets[r] = Some((pockets.len(), air.volume(&all), largest));
        }
        return kept;
    }
    let mut kept = Vec::new();
    let mut parts = Vec::new();
    for part in air.components(leaves) {
        let (held, opens) = air.held_and_open(&part);
        if opens <= 0.0 || held > opens {
            parts.push((air.volume(&part), air.point(&part)));
            kept.extend(part);
        }
    }
    if parts.len() >= 2 {
        out.unsure[r] = parts;
    }
    kept.sort_unstable();
    kept
}

/// The props among the rooms' candidates (see `props.rs`): a block's regions of air are
/// read with every block in place, and only when some candidate is free.
fn find_props(
    rooms: &[BlockRoom],
    solids: &[Solid],
    room_of: &[Option<usize>],
    candidates: &BTreeSet<NodeId>,
    rules: &BlockRules,
) -> BTreeSet<NodeId> {
    let (crack, eps, up) = (rules.crack, rules.eps, rules.up);
    if candidates.is_empty() {
        return BTreeSet::new();
    }
    let contacts = Contacts::new(solids, crack.max(Tolerance::touching(eps)), up);
    let mut nodes: Vec<NodeId> = solids.iter().map(|s| s.node).collect();
    nodes.sort_unstable();
    nodes.dedup();
    let mut cut: Option<Option<CutWorld>> = None;
    let mut separates = |clusters: &[Vec<NodeId>]| -> Vec<bool> {
        let cut = cut.get_or_insert_with(|| CutWorld::new(rooms, solids, room_of, crack, eps));
        match cut {
            Some(cut) => clusters
                .iter()
                .map(|c| separating(cut, solids, c, crack, eps))
                .collect(),
            None => vec![false; clusters.len()],
        }
    };
    contacts
        .props(&nodes, candidates, &mut separates)
        .into_iter()
        .collect()
}

/// Whether a cluster of nodes' blocks, taken away together, would join air: the space they
/// fill, less every other block, has a connected piece that touches two regions of air (or
/// one and the void around the world, or one and a crack), as a block plugging a hole in a
/// wall does. A crate
/// pushed through a wall touches the room and the void, but the wall parts its two pieces.
fn separating(cut: &CutWorld, solids: &[Solid], cluster: &[NodeId], crack: f64, eps: f64) -> bool {
    let air = &cut.air;
    // Every region that reaches the world's boundary is the one void around it.
    let region = |i: usize| if cut.open[i] { VOID } else { air.region[i] };
    let mine: Vec<usize> = (0..solids.len())
        .filter(|&s| cluster.contains(&solids[s].node))
        .collect();
    // A quick look first: the regions the blocks' faces touch.
    let mut touched: BTreeSet<usize> = BTreeSet::new();
    for &s in &mine {
        for i in cut
            .leaf_grid
            .query(&solids[s].bounds, Tolerance::touching(eps))
        {
            let leaf = &air.leaves[i];
            if !touching(leaf, solids, std::iter::once(s), eps).is_empty() {
                touched.insert(region(i));
            }
        }
    }
    if mine
        .iter()
        .any(|&s| solids[s].hull.as_ref().is_some_and(|h| cut.on_world(h)))
    {
        touched.insert(VOID);
    }
    if touched.len() < 2 {
        return false;
    }
    let all = BoxGrid::new(solids.iter().map(|s| s.bounds).collect());
    let wide = |p: &ConvexPolyhedron, q: &ConvexPolyhedron| {
        shared_faces(p, q, eps).any(|(c, n)| least_width(&c, n) > crack)
    };
    let mut pieces: Vec<ConvexPolyhedron> = Vec::new();
    for &si in &mine {
        let s = &solids[si];
        let Some(h) = &s.hull else { continue };
        let local: Vec<Solid> = all
            .query(&s.bounds, Tolerance::touching(eps))
            .into_iter()
            .filter(|&o| !cluster.contains(&solids[o].node))
            .map(|o| solids[o].clone())
            .collect();
        let mut faces = Faces::new(h, eps);
        for (k, o) in local.iter().enumerate() {
            for t in &o.tris {
                faces.face(t, Owner::Solid(k as u32));
            }
        }
        let Faces { planes, frags, .. } = faces;
        let space = Space::new(planes, &local, eps);
        pieces.extend(
            space
                .leaves(h.clone(), frags)
                .into_iter()
                .map(|l| l.region)
                .filter(|r| {
                    thickness(r) > Tolerance::touching(eps)
                        && space.in_solid(r.interior_point()).is_none()
                }),
        );
    }
    let mut parts = DisjointSets::new(pieces.len());
    let pgrid = BoxGrid::new(pieces.iter().map(|p| p.bounds()).collect());
    for (i, j) in pgrid.pairs(Tolerance::touching(eps)) {
        if wide(&pieces[i], &pieces[j]) {
            parts.union(i, j);
        }
    }
    let mut regions: BTreeMap<usize, BTreeSet<usize>> = BTreeMap::new();
    for (k, p) in pieces.iter().enumerate() {
        if cut.on_world(p) {
            regions.entry(parts.find(k)).or_default().insert(VOID);
        }
        for i in cut.leaf_grid.query(&p.bounds(), Tolerance::touching(eps)) {
            // A crack counts as a region of its own: its mouth, which the block covered, may
            // be wide where its depth is not, and the portal stage would see it open.
            let meets = if air.thin[i] {
                shared_faces(p, &air.leaves[i].region, eps)
                    .any(|(c, n)| polygon_area(&c, n) > eps * eps)
            } else {
                wide(p, &air.leaves[i].region)
            };
            if meets {
                regions.entry(parts.find(k)).or_default().insert(region(i));
            }
        }
    }
    regions.values().any(|r| r.len() >= 2)
}

/// The gates' blocks by box, and each block's gate as its first block's index (a door of
/// several blocks is one gate), built once for every room.
struct GateIndex {
    grid: BoxGrid,
    first: Vec<usize>,
}

impl GateIndex {
    fn new(gates: &[(Gate, ConvexPolyhedron)]) -> GateIndex {
        let mut seen: std::collections::HashMap<Gate, usize> = std::collections::HashMap::new();
        GateIndex {
            grid: BoxGrid::new(gates.iter().map(|(_, g)| g.bounds()).collect()),
            first: (0..gates.len())
                .map(|g| *seen.entry(gates[g].0).or_insert(g))
                .collect(),
        }
    }
}

/// The region id the world's boundary stands for (the void around it).
const VOID: usize = usize::MAX;

/// The world (the hull of every room's solids) cut into leaves by the BSP, and their air:
/// the level's space of solids, read once for the props and again for the cells.
struct CutWorld<'a> {
    /// The hull of every room's solids: outside it is the void.
    world: ConvexPolyhedron,
    space: Space<'a>,
    /// The air leaves by box.
    leaf_grid: BoxGrid,
    /// Per air leaf, whether its region reaches the world's boundary.
    open: Vec<bool>,
    air: Air<'a>,
    hulls: Vec<Option<ConvexPolyhedron>>,
    ranks: Vec<usize>,
    eps: f64,
}

impl<'a> CutWorld<'a> {
    /// The leaves of the world (the hull of every room's solids) and their air; `None` when
    /// no room has a hull.
    fn new(
        rooms: &[BlockRoom],
        solids: &'a [Solid],
        room_of: &[Option<usize>],
        crack: f64,
        eps: f64,
    ) -> Option<CutWorld<'a>> {
        // Each room's solids' vertices, gathered in one pass (not one pass per room).
        let mut points: Vec<Vec<DVec3>> = vec![Vec::new(); rooms.len()];
        for (s, o) in solids.iter().zip(room_of) {
            if let Some(r) = *o {
                points[r].extend(s.tris.iter().flatten().copied());
            }
        }
        let hulls: Vec<Option<ConvexPolyhedron>> =
            points.par_iter().map(|pts| hull(pts, eps).ok()).collect();
        // The hull of the rooms' blocks' own vertices (as each room's hull is taken), not of
        // the rooms' hulls' corners, which carry the rounding of their clipping.
        let corners: Vec<DVec3> = solids
            .iter()
            .zip(room_of)
            .filter(|(_, r)| r.is_some_and(|r| hulls[r].is_some()))
            .flat_map(|(s, _)| s.tris.iter().flatten().copied())
            .collect();
        // Should the hull fail on points that near-coincide, the rooms' box does as well: the
        // world only needs to hold every room's hull.
        let world = hull(&corners, eps).ok().or_else(|| {
            let b = hulls
                .iter()
                .flatten()
                .fold(crate::geom::aabb::Aabb::EMPTY, |a, h| a.union(&h.bounds()));
            (!b.is_empty()).then(|| ConvexPolyhedron::from_aabb(&b.grown(eps)))
        })?;
        let world_box = world.bounds();
        let mut faces = Faces::new(&world, eps);
        let mut world_surfaces: Vec<Frag> = Vec::new();
        for (i, s) in solids.iter().enumerate() {
            if s.bounds.meets(&world_box.grown(eps)) {
                for t in &s.tris {
                    faces.face(t, Owner::Solid(i as u32));
                }
            }
        }
        for (r, room) in rooms.iter().enumerate() {
            let Some(h) = &hulls[r] else { continue };
            for t in &room.surfaces {
                let mut pts = t.to_vec();
                for f in &h.faces {
                    pts = clip_polygon(&pts, f.plane.normal, f.plane.d + eps);
                }
                if let Some(frag) = faces.face(&pts, Owner::Surface(r as u32)) {
                    world_surfaces.push(frag);
                }
            }
            for f in &h.faces {
                faces.cut(&f.points, f.plane.normal);
            }
        }
        let Faces { planes, frags, .. } = faces;
        let space = Space::new(planes, solids, eps);
        let leaves: Vec<Leaf> = space
            .leaves(world.clone(), frags)
            .into_iter()
            .filter(|l| {
                thickness(&l.region) > Tolerance::touching(eps)
                    && space.in_solid(l.region.interior_point()).is_none()
            })
            .collect();
        let air = Air::new(leaves, &world, &world_surfaces, crack, eps);
        Some(CutWorld {
            world,
            leaf_grid: BoxGrid::new(air.leaves.iter().map(|l| l.region.bounds()).collect()),
            open: air.open_regions(),
            space,
            air,
            hulls,
            ranks: rooms.iter().map(|r| r.rank).collect(),
            eps,
        })
    }

    /// Whether a convex region has a face on the world's boundary (it touches the void).
    fn on_world(&self, p: &ConvexPolyhedron) -> bool {
        p.faces.iter().any(|f| {
            self.world
                .faces
                .iter()
                .any(|w| Tolerance::coplanar(&w.plane, &f.plane, Tolerance::touching(self.eps)))
        })
    }

    /// One owner per air leaf, or none (see `air.rs`, step 2).
    fn owners(&self, solids: &[Solid], room_of: &[Option<usize>]) -> Vec<Option<u32>> {
        let hulls: Vec<Option<&ConvexPolyhedron>> = self.hulls.iter().map(Option::as_ref).collect();
        let candidates = self.air.candidates(&hulls);
        let size: Vec<f64> = self
            .hulls
            .iter()
            .map(|h| h.as_ref().map_or(0.0, |h| h.volume()))
            .collect();
        let grid = BoxGrid::new(solids.iter().map(|s| s.bounds).collect());
        let eps = self.eps;
        let frame = |i: usize, r: u32| -> f64 {
            let leaf = &self.air.leaves[i];
            let near = grid
                .query(&leaf.region.bounds(), Tolerance::touching(eps))
                .into_iter();
            let blocks: f64 = touching(leaf, solids, near, eps)
                .into_iter()
                .filter(|(s, _)| room_of[*s] == Some(r as usize))
                .map(|(_, a)| a)
                .sum();
            let surfaces: f64 = leaf
                .surfaces
                .iter()
                .filter(|f| f.owner == Owner::Surface(r))
                .map(|f| polygon_area(&f.pts, f.air))
                .sum();
            blocks + surfaces
        };
        self.air.owners(&candidates, &size, &self.ranks, &frame)
    }

    /// Some leaves as cells: merged within the gates they lie in.
    fn cells(
        &self,
        kept: &[usize],
        gates: &[(Gate, ConvexPolyhedron)],
        index: &GateIndex,
        rules: &BlockRules,
    ) -> Vec<(ConvexPolyhedron, Vec<usize>)> {
        let GateIndex {
            grid: gate_grid,
            first,
        } = index;
        let eps = rules.eps;
        let mut groups: BTreeMap<Vec<usize>, Vec<ConvexPolyhedron>> = BTreeMap::new();
        for &i in kept {
            for region in carve(&self.air.leaves[i].region, gates, gate_grid, rules) {
                let p = region.interior_point();
                // One index per gate (a door of several blocks is one gate: its first block's).
                let mut inside: Vec<usize> = gate_grid
                    .query(&Aabb { min: p, max: p }, eps)
                    .into_iter()
                    .filter(|&g| gates[g].1.contains(p, eps))
                    .map(|g| first[g])
                    .collect();
                inside.sort_unstable();
                inside.dedup();
                groups.entry(inside).or_default().push(region);
            }
        }
        let merged: Vec<(ConvexPolyhedron, Vec<usize>)> = groups
            .into_iter()
            .flat_map(|(g, leaves)| merge(leaves, eps).into_iter().map(move |c| (c, g.clone())))
            .collect();
        let mut out = halved(merged, rules.max_width, eps);
        // The room's largest cell first (its main space before its door reveals), volumes
        // compared in millionths of the room's so near-equal ones keep the leaves' order.
        let total: f64 = out.iter().map(|(c, _)| c.volume()).sum();
        let key = |v: f64| (v / total.max(f64::MIN_POSITIVE) * 1e6).round() as i64;
        out.sort_by_key(|(c, _)| std::cmp::Reverse(key(c.volume())));
        out
    }
}

/// A leaf cut by the gates that close it: by each gate (a door of several blocks is one
/// gate) whose blocks, made solid, would cut the leaf's air in two. A gate that does not
/// (bars with gaps, a lift standing in a room, a door narrower than its hole) closes nothing
/// here and leaves the leaf whole. Cutting only there, and only the leaf, keeps a door's planes
/// out of the rest of the level: cut through the whole BSP, they split leaves far from any door
/// and made a brush map's cells over half as many again for the same air.
fn carve(
    leaf: &ConvexPolyhedron,
    gates: &[(Gate, ConvexPolyhedron)],
    grid: &BoxGrid,
    rules: &BlockRules,
) -> Vec<ConvexPolyhedron> {
    let (crack, eps) = (rules.crack, rules.eps);
    let mut near = grid.query(&leaf.bounds(), eps);
    near.sort_unstable();
    // The gates near, each as its blocks (in gate order).
    let mut groups: Vec<Vec<usize>> = Vec::new();
    for g in near {
        match groups.iter_mut().find(|k| gates[k[0]].0 == gates[g].0) {
            Some(k) => k.push(g),
            None => groups.push(vec![g]),
        }
    }
    let mut pieces = vec![leaf.clone()];
    for group in groups {
        let blocks: Vec<&ConvexPolyhedron> = group.iter().map(|&g| &gates[g].1).collect();
        pieces = pieces
            .into_iter()
            .flat_map(|piece| closed_by(piece, &blocks, crack, eps))
            .collect();
    }
    pieces
}

/// A convex region cut by the blocks of one gate when, made solid, they would part its air;
/// else the region whole.
fn closed_by(
    region: ConvexPolyhedron,
    blocks: &[&ConvexPolyhedron],
    crack: f64,
    eps: f64,
) -> Vec<ConvexPolyhedron> {
    let mut parts = vec![region.clone()];
    for b in blocks {
        parts = parts
            .into_iter()
            .flat_map(|p| carve_one(p, b, eps))
            .collect();
    }
    if parts.len() == 1 {
        return parts;
    }
    let (inside, outside): (Vec<_>, Vec<_>) = parts.into_iter().partition(|p| {
        let c = p.interior_point();
        blocks.iter().any(|b| b.contains(c, eps))
    });
    // The air left around the gate, joined through faces wider than a crack.
    let mut sets = DisjointSets::new(outside.len());
    for i in 0..outside.len() {
        for k in i + 1..outside.len() {
            if shared_faces(&outside[i], &outside[k], eps)
                .any(|(pts, n)| least_width(&pts, n) > crack)
            {
                sets.union(i, k);
            }
        }
    }
    let parted = (0..outside.len())
        .map(|i| sets.find(i))
        .collect::<BTreeSet<_>>()
        .len()
        != 1;
    if inside.is_empty() || !parted {
        return vec![region];
    }
    inside.into_iter().chain(outside).collect()
}

/// A convex region cut by one convex block: the part inside it last, the parts outside it one
/// face plane at a time before; the region whole unless they share a volume thicker than the
/// tolerance.
fn carve_one(region: ConvexPolyhedron, gate: &ConvexPolyhedron, eps: f64) -> Vec<ConvexPolyhedron> {
    let solid = |p: &ConvexPolyhedron| thickness(p) > Tolerance::touching(eps);
    let mut inside = Some(region.clone());
    for f in &gate.faces {
        inside = inside.and_then(|r| r.clip(&f.plane, eps));
    }
    if !inside.as_ref().is_some_and(solid) {
        return vec![region];
    }
    let mut out = Vec::new();
    let mut rest = region;
    for f in &gate.faces {
        if let Some(outside) = rest.clip(&f.plane.flipped(), eps) {
            if solid(&outside) {
                out.push(outside);
            }
        }
        match rest.clip(&f.plane, eps) {
            Some(r) => rest = r,
            None => return out,
        }
    }
    out.push(rest);
    out
}

/// The cells, the widest halved across its widest direction (of its faces') first, again
/// until none is wider than `max` or they are half as many again as they were: a from-region
/// PVS is as loose as its widest cells (qbsp caps its leafs the same way, `-maxnodesize`), but
/// in open terrain, where every cell sees every other, narrower cells buy nothing and each
/// costs the PVS (halved without that budget, an open terrain map's cells grew twentyfold and
/// its full PVS ran for minutes).
fn halved<T: Clone>(
    cells: Vec<(ConvexPolyhedron, T)>,
    max: f64,
    eps: f64,
) -> Vec<(ConvexPolyhedron, T)> {
    let budget = cells.len() + cells.len() / 2;
    // The widest direction of a cell: its width, quantized to the tolerance, and the plane
    // across its middle (ties to the first face).
    let widest = |c: &ConvexPolyhedron| -> (i64, Plane) {
        let corners: Vec<DVec3> = c
            .faces
            .iter()
            .flat_map(|f| f.points.iter().copied())
            .collect();
        let mut best = (
            i64::MIN,
            Plane {
                normal: DVec3::X,
                d: 0.0,
            },
        );
        for f in &c.faces {
            let (lo, hi) = super::bsp::extent(&f.plane, &corners);
            let w = ((hi - lo) / eps).round() as i64;
            if w > best.0 {
                let mid = Plane {
                    normal: f.plane.normal,
                    d: f.plane.d + (lo + hi) / 2.0,
                };
                best = (w, mid);
            }
        }
        best
    };
    let limit = (max / eps).round() as i64;
    let mut slots: Vec<Option<(ConvexPolyhedron, T)>> = Vec::new();
    let mut heap = std::collections::BinaryHeap::new();
    for c in cells {
        heap.push((widest(&c.0).0, std::cmp::Reverse(slots.len())));
        slots.push(Some(c));
    }
    let mut count = slots.len();
    while let Some((w, std::cmp::Reverse(i))) = heap.pop() {
        if w <= limit || count >= budget {
            break;
        }
        let (c, tag) = slots[i].take().expect("each cell is popped once");
        let mid = widest(&c).1;
        match (c.clip(&mid, eps), c.clip(&mid.flipped(), eps)) {
            (Some(a), Some(b)) => {
                for half in [a, b] {
                    heap.push((widest(&half).0, std::cmp::Reverse(slots.len())));
                    slots.push(Some((half, tag.clone())));
                }
                count += 1;
            }
            _ => slots[i] = Some((c, tag)),
        }
    }
    slots.into_iter().flatten().collect()
}
