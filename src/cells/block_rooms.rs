//! The rooms of solid blocks, gathered from the scene for the level-wide reading (`blocks.rs`)
//! and its findings turned into each room's cells, props and diagnostics.
//!
//! A room is read as blocks when its structure has closed, outward-facing parts (`solids.rs`),
//! unless that is one solid and nothing else (a room modelled as its own volume) and the
//! solid is not tagged `solid`. A room whose blocks enclose no air keeps to the surface
//! reading (a shell of quads around a pillar block), unless its blocks are tagged `solid`.
//!
//! This is the block-room half of [`RoomBuilder`]'s impl (the rest is in `rooms.rs`): what
//! happens here happens once for the whole level, before any room is built, and hands each
//! room its [`BlockCells`]; the builder only takes them.

use std::collections::BTreeMap;

use glam::DVec3;
use rayon::prelude::*;

use super::blocks::{self, BlockRoom};
use super::gather::{canonical_node_triangles, node_triangles};
use super::rooms::{detect_props, extras_flag, BlockCells, RoomBuilder};
use super::solids::{self, Solid};
use super::{CellSource, Gate, GateKind, Prop, PropReason};
use crate::diag::{Code, Diagnostic, Diagnostics};
use crate::geom::crack::ClosedGaps;
use crate::geom::polyhedron::ConvexPolyhedron;
use crate::scene::NodeId;
use crate::tags::{Room, Tagging};

/// A room's blocks and the rest of its structure, before the reading.
struct Prep {
    solids: Vec<Solid>,
    surfaces: Vec<[DVec3; 3]>,
    /// Nodes with surfaces taken for props by the box rule.
    boxed: Vec<Prop>,
    candidates: Vec<NodeId>,
    tagged: bool,
    gates: Vec<(Gate, ConvexPolyhedron)>,
    /// Meshes that look meant as blocks but are open, with their open edges (recentred).
    open: Vec<(NodeId, Vec<[DVec3; 2]>)>,
}

impl RoomBuilder<'_> {
    /// Every block room's cells (`None` for rooms read otherwise), the occupants standing
    /// inside a solid, and the gaps among the blocks the crack width closed (recentred).
    pub(super) fn read_blocks(
        &self,
        tagging: &Tagging,
        diags: &mut Diagnostics,
    ) -> (Vec<Option<BlockCells>>, Vec<NodeId>, ClosedGaps) {
        let preps: Vec<Option<Prep>> = tagging
            .rooms
            .par_iter()
            .enumerate()
            // Generated rooms are read together as one room (`super::generated`).
            .map(
                |(ri, room)| match tagging.generated.as_deref().and_then(|g| g.boxes_of(ri)) {
                    Some(_) => None,
                    None => self.prep(room),
                },
            )
            .collect();
        let read: Vec<usize> = (0..preps.len()).filter(|&r| preps[r].is_some()).collect();
        let mut by_name: Vec<usize> = read.clone();
        by_name.sort_by(|&a, &b| tagging.rooms[a].name.cmp(&tagging.rooms[b].name));
        let mut gates: Vec<(Gate, ConvexPolyhedron)> = Vec::new();
        let mut rooms: Vec<BlockRoom> = Vec::new();
        for &r in &read {
            let Some(p) = &preps[r] else { continue };
            gates.extend(p.gates.iter().cloned());
            rooms.push(BlockRoom {
                rank: by_name.iter().position(|&x| x == r).unwrap_or(0),
                solids: p.solids.clone(),
                surfaces: p.surfaces.clone(),
                prop_candidates: p.candidates.clone(),
            });
        }
        if rooms.is_empty() {
            return (
                (0..preps.len()).map(|_| None).collect(),
                Vec::new(),
                ClosedGaps::default(),
            );
        }
        let near = rooms
            .iter()
            .flat_map(|r| r.solids.iter().map(|s| s.bounds))
            .fold(crate::geom::aabb::Aabb::EMPTY, |a, b| a.union(&b));
        let others = self.unassigned_solids(tagging, &near);
        let occupants: Vec<(NodeId, DVec3)> = tagging
            .all_occupants()
            .map(|o| {
                let at = self.scene.place(o.node) - self.origin;
                (o.node, at)
            })
            .collect();
        let points: Vec<DVec3> = occupants.iter().map(|(_, p)| *p).collect();
        let rules = blocks::BlockRules {
            loose: self.cfg.detect_props,
            crack: self.crack,
            max_width: self.cfg.max_cell_width,
            eps: self.eps,
            up: self.frame.up,
        };
        let reading = blocks::read(&rooms, &others, &gates, &points, &rules);
        let mut out: Vec<Option<BlockCells>> = (0..preps.len()).map(|_| None).collect();
        for (k, &r) in read.iter().enumerate() {
            let Some(p) = &preps[r] else { continue };
            let cells = &reading.cells[k];
            if cells.is_empty() && !p.tagged {
                continue; // no air in its blocks: the surface reading
            }
            let room = &tagging.rooms[r];
            let mut props = p.boxed.clone();
            props.extend(reading.props[k].iter().map(|&node| Prop {
                node,
                reason: PropReason::LooseBlock,
            }));
            props.sort_unstable_by_key(|p| p.node);
            let mut d: Vec<Diagnostic> =
                p.open.iter().map(|(n, g)| self.open_block(*n, g)).collect();
            if let Some((count, volume, at)) = reading.pockets[k] {
                d.push(self.pockets(room, count, volume, at));
            }
            if !reading.unsure[k].is_empty() {
                d.push(self.unsure(room, &reading.unsure[k]));
            }
            out[r] = Some(BlockCells {
                polys: cells
                    .iter()
                    .map(|(c, g)| (c.clone(), g.iter().map(|&i| gates[i].0).collect()))
                    .collect(),
                source: CellSource::Split,
                props,
                diags: d,
            });
        }
        let buried: Vec<NodeId> = reading.buried.iter().map(|&k| occupants[k].0).collect();
        for &n in &buried {
            diags.push(
                Diagnostic::new(
                    Code::CELL_OCCUPANT_IN_SOLID,
                    format!(
                        "occupant `{}` stands inside a solid block: it marks no air and seeds no leak search",
                        self.scene.node_label(n)
                    ),
                    self.loc(n).with_position(self.scene.place(n).to_array()),
                )
                .hint("move it into the room's air if it should mark it (qbsp skips such entities too)"),
            );
        }
        (out, buried, reading.closed)
    }

    /// A room's blocks, or `None` when it is read otherwise (see the module docs).
    fn prep(&self, room: &Room) -> Option<Prep> {
        let (scene, eps) = (self.scene, self.eps);
        if !room.bounds.is_empty()
            || !room.footprints.is_empty()
            || room.volume == crate::tags::rules::VolumeHint::Footprint
        {
            return None;
        }
        let mut solids = Vec::new();
        let mut surfaces: Vec<(NodeId, [DVec3; 3])> = Vec::new();
        let mut open = Vec::new();
        for (n, tris) in canonical_node_triangles(scene, &room.structure, self.origin) {
            let (s, rest, gaps) = solids::split_node_open(n, &tris, eps);
            solids.extend(s);
            surfaces.extend(rest.into_iter().map(|t| (n, t)));
            open.extend(gaps.into_iter().map(|g| (n, g)));
        }
        if solids.is_empty() {
            return None;
        }
        let with_surface: std::collections::HashSet<NodeId> =
            surfaces.iter().map(|(m, _)| *m).collect();
        let has_surface = |n: NodeId| with_surface.contains(&n);
        let detect = self.cfg.detect_props && room.structure.len() >= 2;
        let mut boxed: Vec<Prop> = Vec::new();
        if detect {
            boxed = detect_props(
                scene,
                &room.structure,
                self.origin,
                self.extent,
                &self.frame,
            )
            .into_iter()
            .filter(|&n| has_surface(n) && !extras_flag(scene, n, "structure"))
            .map(|node| Prop {
                node,
                reason: PropReason::LooseInRoom,
            })
            .collect();
        }
        let candidates: Vec<NodeId> = if detect {
            // A block on two faces of the hull of the room's blocks bounds the room (a wall
            // of a roofless yard: its side and its top); nothing else makes it structure.
            let pts: Vec<DVec3> = solids
                .iter()
                .flat_map(|s| s.tris.iter().flatten())
                .copied()
                .collect();
            let hull = crate::geom::hull::hull(&pts, eps).ok();
            // Nodes with a solid on two faces of the hull (each solid looked at once).
            let bounding: std::collections::HashSet<NodeId> = hull
                .as_ref()
                .map(|h| {
                    (solids.iter())
                        .filter(|s| solids::on_hull_faces(s, h, eps) >= 2)
                        .map(|s| s.node)
                        .collect()
                })
                .unwrap_or_default();
            let mut c: Vec<NodeId> = solids
                .iter()
                .map(|s| s.node)
                .filter(|&n| !has_surface(n) && !extras_flag(scene, n, "structure"))
                .filter(|n| !bounding.contains(n))
                .collect();
            c.dedup();
            c
        } else {
            Vec::new()
        };
        let boxed_set: std::collections::HashSet<NodeId> = boxed.iter().map(|p| p.node).collect();
        let boxed_out = |n: &NodeId| boxed_set.contains(n);
        surfaces.retain(|(n, _)| !boxed_out(n));
        solids.retain(|s| !boxed_out(&s.node));
        let tagged = solids.iter().any(|s| extras_flag(scene, s.node, "solid"));
        if solids.is_empty() || (!tagged && solids.len() == 1 && surfaces.is_empty()) {
            return None;
        }
        Some(Prep {
            solids,
            surfaces: surfaces.into_iter().map(|(_, t)| t).collect(),
            boxed,
            candidates,
            tagged,
            gates: {
                let (g, h) = self.gates(room);
                g.into_iter().zip(h).collect()
            },
            open,
        })
    }

    /// A block room's gates: its detail and the nodes under it flagged `door` or `area_portal`
    /// in extras, each with its convex hull (recentred), in node order.
    fn gates(&self, room: &Room) -> (Vec<Gate>, Vec<ConvexPolyhedron>) {
        let scene = self.scene;
        let mut nodes: Vec<NodeId> = room.detail.clone();
        nodes.extend((0..scene.nodes.len()).filter(|&n| scene.nodes[n].parent == Some(room.node)));
        nodes.sort_unstable();
        nodes.dedup();
        let mut out = (Vec::new(), Vec::new());
        // The first node of each entity (extras `entity`, a brush map's entity number).
        let mut first: BTreeMap<String, NodeId> = BTreeMap::new();
        for n in nodes {
            let kind = if extras_flag(scene, n, "door") {
                GateKind::Door
            } else if extras_flag(scene, n, "area_portal") {
                GateKind::AreaPortal
            } else {
                continue;
            };
            let pts: Vec<DVec3> = node_triangles(scene, &[n], self.origin)
                .into_iter()
                .flatten()
                .collect();
            if let Ok(h) = crate::geom::hull::hull(&pts, self.eps) {
                let entity = scene.nodes[n].extras.as_ref().and_then(|e| e.get("entity"));
                let node = match entity {
                    Some(e) => *first.entry(format!("{kind:?} {e}")).or_insert(n),
                    None => n,
                };
                out.0.push(Gate { node, kind });
                out.1.push(h);
            }
        }
        out
    }

    /// The closed parts of structure in no room whose box meets `near` (the rooms' blocks):
    /// they carve the rooms around them too.
    fn unassigned_solids(&self, tagging: &Tagging, near: &crate::geom::aabb::Aabb) -> Vec<Solid> {
        let nodes: Vec<NodeId> = tagging
            .unassigned
            .iter()
            .map(|u| u.node)
            .filter(|&n| {
                let mut b = crate::geom::aabb::Aabb::EMPTY;
                for p in self.scene.world_positions_used_iter(n) {
                    b.add(p - self.origin);
                }
                b.meets(&near.grown(self.eps))
            })
            .collect();
        canonical_node_triangles(self.scene, &nodes, self.origin)
            .into_iter()
            .flat_map(|(n, tris)| solids::split_node(n, &tris, self.eps).0)
            .collect()
    }

    /// `CELL_BLOCK_OPEN` for node `n`, whose part with open edges `gaps` looks meant as a
    /// closed block: read as a surface, it seals nothing, and the leak it leaves would
    /// otherwise blame only its room.
    fn open_block(&self, n: NodeId, gaps: &[[DVec3; 2]]) -> Diagnostic {
        let at = |p: DVec3| {
            let q = p + self.origin;
            format!("({:.3}, {:.3}, {:.3})", q.x, q.y, q.z)
        };
        let list: Vec<String> = gaps
            .iter()
            .map(|[a, b]| format!("{} - {}", at(*a), at(*b)))
            .collect();
        let mid = gaps.iter().map(|[a, b]| (*a + *b) * 0.5).sum::<DVec3>() / gaps.len() as f64;
        Diagnostic::new(
            Code::CELL_BLOCK_OPEN,
            format!(
                "mesh `{}` is a block with {} open edge(s), so it is read as a surface and seals nothing: {}",
                self.scene.node_label(n),
                gaps.len(),
                list.join(", ")
            ),
            self.loc(n).with_position((mid + self.origin).to_array()),
        )
        .hint("close the mesh: fill the hole, or weld the vertices along those edges so that each edge is shared by two triangles")
    }

    fn pockets(&self, room: &Room, count: usize, volume: f64, at: DVec3) -> Diagnostic {
        Diagnostic::new(
            Code::CELL_POCKETS_FILLED,
            format!(
                "room `{}`: {count} sealed pocket(s) of air that no occupant reaches were filled, {volume:.3} m³ in all (the largest here)",
                room.name
            ),
            self.loc(room.node).with_position((at + self.origin).to_array()),
        )
        .hint("a pocket is air the blocks seal off (inside a hollow block or a wall); if it is a room, put an occupant in it or open it to the rest")
    }

    fn unsure(&self, room: &Room, parts: &[(f64, DVec3)]) -> Diagnostic {
        let list: Vec<String> = parts
            .iter()
            .map(|(v, p)| {
                let q = *p + self.origin;
                format!("{v:.3} m³ at ({:.2}, {:.2}, {:.2})", q.x, q.y, q.z)
            })
            .collect();
        Diagnostic::new(
            Code::CELL_ROOM_NO_OCCUPANT,
            format!(
                "room `{}` has no occupant and its blocks enclose {} separate regions of air ({}); all were kept as its air",
                room.name,
                parts.len(),
                list.join(", ")
            ),
            self.loc(room.node).with_position((parts[0].1 + self.origin).to_array()),
        )
        .hint("if some are pockets (a hollow block, the inside of a wall), put a player start or an occupant (extras `\"occupant\": true`, a `-occupant` node) in the room's air: regions no occupant reaches are then filled")
    }
}
