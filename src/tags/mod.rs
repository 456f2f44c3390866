//! Tags: turn the designer's names, materials and extras into rooms, authored portals, bound
//! volumes, footprints and ignored/detail geometry.
//!
//! Precedence for one node is extras, then node name, then material name: the first source
//! with a matching rule decides the node's kind; lower sources of the same kind may still fill
//! in details the first left open (the Panda3D portals say "portal" in extras and carry their
//! source and target cells in the name).
//!
//! Invariants of [`Tagging`]:
//! - room names are unique (a duplicate is reported and merged into the first);
//! - every mesh node is in exactly one of: a room's `structure`, a room's `detail`,
//!   `portals`, `bounds`, `footprints`, `ignored`, `unassigned`;
//! - a portal's `target_room`/`source_room` is set only when its name resolved to a room.

use serde::Serialize;

use crate::diag::{Code, Diagnostic, Diagnostics, Location};
use crate::scene::{NodeId, Scene};

pub(crate) mod extras;
mod generated;
pub(crate) mod near_miss;
pub use generated::Generated;
pub mod presets;
pub mod rules;
mod suggest;

use extras::ExtrasValue;
use rules::{MatchOn, PortalKind, RuleMatch, RuleSet, TagKind, VolumeHint};

/// Index into [`Tagging::rooms`].
pub type RoomId = usize;

/// A node a tag put in a list, with the path reports show for it.
#[derive(Debug, Clone, Serialize)]
pub struct NodeRef {
    /// Index into the scene's nodes.
    pub node: NodeId,
    /// Slash-separated names from the root, as in the designer's outliner.
    pub path: String,
}

/// A room: what the designer declared, and the nodes that make it up.
#[derive(Debug, Clone, Serialize)]
pub struct Room {
    /// As the designer wrote it (after the rule's template); portals and reports name it so.
    pub name: String,
    /// The node that declared the room.
    pub node: NodeId,
    /// The declaring node's path, for reports.
    pub path: String,
    /// The rule that recognised it.
    pub rule: String,
    /// The room group it belongs to (index into [`Tagging::room_groups`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub group: Option<usize>,
    /// Where the room's volume comes from, as far as tags can tell.
    pub volume: VolumeHint,
    /// Higher wins where rooms nest (extras `priority`).
    pub priority: i64,
    /// Mesh nodes that bound the room and block sight.
    pub structure: Vec<NodeId>,
    /// Mesh nodes rendered by the room that bound nothing (props).
    pub detail: Vec<NodeId>,
    /// Bound-volume nodes of this room.
    pub bounds: Vec<NodeId>,
    /// Footprint nodes of this room.
    pub footprints: Vec<NodeId>,
    /// An area split off room `area_of` by its area portals (id Tech 4's areas): made by the
    /// cells stage, not declared, so it owns no nodes and is not part of the input hash.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub area_of: Option<RoomId>,
}

/// A group of rooms (Godot's RoomGroup): it names them together, no volume of its own.
#[derive(Debug, Clone, Serialize)]
pub struct RoomGroup {
    /// The group's name, from its rule's template or else its node's name.
    pub name: String,
    /// The node that declared the group.
    pub node: NodeId,
    /// The rooms whose nodes are children of the group's node.
    pub rooms: Vec<RoomId>,
}

/// A portal the designer placed as a mesh: its polygon and what it says about its rooms.
#[derive(Debug, Clone, Serialize)]
pub struct AuthoredPortal {
    /// The portal's node; its mesh is the portal polygon.
    pub node: NodeId,
    /// The node's path, for reports.
    pub path: String,
    /// The id of the rule that recognised it.
    pub rule: String,
    /// The source room as named (extras `source_room` or the rule's template), if named.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub source_name: Option<String>,
    /// The source room: named, else the room the node sits in; `None` if neither.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub source_room: Option<RoomId>,
    /// The target room as the name or extras gave it, if given.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub target_name: Option<String>,
    /// The named target, resolved; `None`: unnamed or unknown (linked by position).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub target_room: Option<RoomId>,
    /// Plain, mirror or teleporter (extras `portal_kind`, else the rule's).
    pub kind: PortalKind,
    /// Sight passes from source to target only (extras `one_way`, else the rule's).
    pub one_way: bool,
    /// Starts closed, like a shut door (extras `closed`, else the rule's).
    pub closed: bool,
    /// A teleporter's exit portal node (extras `teleport_exit`), once resolved.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub teleport_exit: Option<NodeId>,
    /// Which way the quad's front faces by its convention (out of its source room, or in).
    pub faces: rules::Facing,
}

/// A bound or footprint node and the room it gives a volume to.
#[derive(Debug, Clone, Serialize)]
pub struct VolumeNode {
    /// The bound's or footprint's node.
    pub node: NodeId,
    /// The node's path, for reports.
    pub path: String,
    /// The id of the rule that recognised it (or its room's rule).
    pub rule: String,
    /// The room it shapes; `None` when it is in no room and names none (reported).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub room: Option<RoomId>,
}

/// A name that looks like a tag but matches no rule, and the spelling that would.
#[derive(Debug, Clone, Serialize)]
pub struct NearMiss {
    /// The node so named.
    pub node: NodeId,
    /// The node's path, for reports.
    pub path: String,
    /// The name as written.
    pub name: String,
    /// What the almost-matching rule recognises.
    pub kind: TagKind,
    /// The id of the almost-matching rule.
    pub rule: String,
    /// The corrected name, which that rule accepts.
    pub suggestion: String,
    /// What was wrong, in words (`letter case`, `a misspelt tag word`).
    pub slip: String,
}

/// Everything the tags said about a scene.
#[derive(Debug, Clone, Serialize)]
pub struct Tagging {
    /// The rule set's name (a preset such as `godot`, or the config's own).
    pub preset: String,
    /// Every room, in scene order; a [`RoomId`] indexes it.
    pub rooms: Vec<Room>,
    /// Room groups, in scene order.
    pub room_groups: Vec<RoomGroup>,
    /// Authored portals, in scene order.
    pub portals: Vec<AuthoredPortal>,
    /// Bound-volume nodes.
    pub bounds: Vec<VolumeNode>,
    /// Footprint nodes.
    pub footprints: Vec<VolumeNode>,
    /// Nodes the rules say to ignore: no cell is bounded or rendered by them.
    pub ignored: Vec<NodeRef>,
    /// Detail nodes (props) in no room, or without a mesh.
    pub detail: Vec<NodeRef>,
    /// Where leak searches start.
    pub player_starts: Vec<NodeRef>,
    /// Other occupants (a brush map's point entities, nodes tagged `occupant`): they tell a
    /// block room's air from the void and seed leak searches, as the player starts do.
    pub occupants: Vec<NodeRef>,
    /// Structural mesh nodes in no room (the cells stage places or reports them).
    pub unassigned: Vec<NodeRef>,
    /// Names that look like tags but match no rule (each also reported).
    pub near_misses: Vec<NearMiss>,
    /// The effective settings that shape the cells and portals (the tag rules, `[cells]`,
    /// `[portals]`), as the bytes the input hash covers; set by `pipeline::tag`.
    #[serde(skip)]
    pub settings: Vec<u8>,
    /// What the tags stage reported.
    #[serde(skip)]
    pub diagnostics: Diagnostics,
    /// The rooms `--tags auto` generated, with its settings (`None`: none were asked for).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub generated: Option<Box<Generated>>,
    /// Per material of the scene (its index), whether it is the open sky (the rules' `sky`):
    /// its triangles bound rooms and are drawn but block no sight. Empty when none is.
    #[serde(skip)]
    pub sky: Vec<bool>,
    /// Rooms by name as the rules compare names (lower case unless case-sensitive), so a level
    /// of many rooms resolves names in constant time. Kept by `add_room`.
    #[serde(skip)]
    room_index: std::collections::HashMap<String, RoomId>,
}

impl Tagging {
    /// Per triangle of `mesh`, whether it is of a sky material (see [`Tagging::sky`]); `None`
    /// when the level has no sky.
    pub fn sky_triangles(&self, mesh: &crate::scene::Mesh) -> Option<Vec<bool>> {
        if self.sky.is_empty() {
            return None;
        }
        let mut out = vec![false; mesh.triangles.len()];
        for p in &mesh.primitives {
            if p.material
                .is_some_and(|m| self.sky.get(m).copied().unwrap_or(false))
            {
                let end = (p.first_triangle + p.triangle_count).min(out.len());
                out[p.first_triangle.min(end)..end].fill(true);
            }
        }
        Some(out)
    }

    /// Every occupant: the player starts first (in scene order), then the other occupants.
    pub fn all_occupants(&self) -> impl Iterator<Item = &NodeRef> {
        self.player_starts.iter().chain(self.occupants.iter())
    }

    /// Appends a room the generator found (`--tags auto`), findable by name like any other.
    pub(crate) fn push_generated(&mut self, room: Room) -> RoomId {
        let id = self.rooms.len();
        self.room_index.insert(room.name.to_lowercase(), id);
        self.rooms.push(room);
        id
    }

    /// A room for an area of room `of` that its area portals cut off, called `name`: declared
    /// by the same node, owning no nodes (`of`'s geometry renders in its cells).
    pub(crate) fn add_area(&mut self, of: RoomId, name: String) -> RoomId {
        let r = &self.rooms[of];
        let area = Room {
            name,
            node: r.node,
            path: r.path.clone(),
            rule: format!("area of `{}`", r.name),
            group: r.group,
            volume: r.volume,
            priority: r.priority,
            structure: Vec::new(),
            detail: Vec::new(),
            bounds: Vec::new(),
            footprints: Vec::new(),
            area_of: Some(of),
        };
        let id = self.rooms.len();
        if let Some(g) = area.group {
            self.room_groups[g].rooms.push(id);
        }
        self.rooms.push(area);
        id
    }

    /// The room called `name` as `rules` compare names (case, wildcard).
    pub fn room_by_name(&self, rules: &RuleSet, name: &str) -> Option<RoomId> {
        match self.room_index.get(&rules.name_key(name)) {
            Some(&r) => Some(r),
            // Rooms added without the index (a Tagging built by hand) are still found.
            None if self.room_index.len() < self.rooms.len() => self
                .rooms
                .iter()
                .position(|r| rules.same_name(&r.name, name)),
            None => None,
        }
    }
}

/// How one node was classified.
#[derive(Debug, Clone)]
struct Class {
    kind: TagKind,
    rule: usize,
    m: RuleMatch,
    /// Details from lower-precedence rules of the same kind.
    extra: Vec<RuleMatch>,
}

impl Class {
    fn first<T>(&self, f: impl Fn(&RuleMatch) -> Option<T>) -> Option<T> {
        f(&self.m).or_else(|| self.extra.iter().find_map(&f))
    }
}

/// Applies `rules` to `scene`.
pub fn recognise(scene: &Scene, rules: &RuleSet) -> Tagging {
    let mut r = Recognition::new(scene, rules);
    r.collect_rooms();
    r.declare_volume_rooms();
    r.assign_members();
    r.finish()
}

/// What `recognise` carries from pass to pass: every node's classification, which room each
/// node belongs to so far, and the tagging and diagnostics being built, so that each pass is
/// one function over the same facts and the diagnostics keep the order the passes make them.
/// Per material of the scene (its index), whether the rules' `sky` pattern names it; empty
/// when none does, so a level without sky pays nothing per triangle.
fn sky_materials(scene: &Scene, rules: &RuleSet) -> Vec<bool> {
    let Some(sky) = &rules.sky else {
        return Vec::new();
    };
    let marks: Vec<bool> = (scene.materials.iter())
        .map(|m| m.name.as_deref().is_some_and(|n| sky.is_match(n)))
        .collect();
    if marks.contains(&true) {
        marks
    } else {
        Vec::new()
    }
}

/// Per material of the scene (its index), the near miss of a material rule, when no rule
/// accepts the material: found once per material, not per node using it.
fn material_misses(scene: &Scene, rules: &RuleSet) -> Vec<Option<near_miss::Miss>> {
    scene
        .materials
        .iter()
        .map(|m| {
            let name = m.name.as_deref()?;
            if rules.match_text(MatchOn::Material, name).is_some() {
                return None;
            }
            near_miss::check_material(rules, name)
        })
        .collect()
}

/// The first material of node `n`'s mesh that no rule accepts but a material rule narrowly
/// misses (`misses` from [`material_misses`]).
fn material_miss(
    scene: &Scene,
    misses: &[Option<near_miss::Miss>],
    n: NodeId,
) -> Option<near_miss::Miss> {
    let mesh = scene.nodes[n].mesh?;
    scene.meshes[mesh]
        .primitives
        .iter()
        .find_map(|p| misses.get(p.material?)?.clone())
}

struct Recognition<'a> {
    scene: &'a Scene,
    rules: &'a RuleSet,
    order: Vec<NodeId>,
    classes: Vec<Option<Class>>,
    misses: Vec<Option<near_miss::Miss>>,
    room_of_node: Vec<Option<RoomId>>,
    t: Tagging,
    diags: Diagnostics,
}

impl<'a> Recognition<'a> {
    /// Classifies every node before any is placed, because placing needs rooms that may be
    /// declared after the nodes that name them.
    fn new(scene: &'a Scene, rules: &'a RuleSet) -> Self {
        let mut diags = Diagnostics::default();
        let order = scene.walk();
        // Each node is classified on its own (on every thread: a big level has tens of thousands),
        // what that reports kept in node order; so are the near misses of unclassified names.
        use rayon::prelude::*;
        let by_material = material_misses(scene, rules);
        let classified: Vec<(Option<Class>, Option<near_miss::Miss>, Diagnostics)> =
            (0..scene.nodes.len())
                .into_par_iter()
                .map(|n| {
                    let mut d = Diagnostics::default();
                    let class = classify(scene, rules, n, &mut d);
                    let miss = match (&class, scene.nodes[n].name.as_deref()) {
                        (None, Some(name)) => near_miss::check(rules, name),
                        _ => None,
                    }
                    .or_else(|| {
                        class
                            .is_none()
                            .then(|| material_miss(scene, &by_material, n))?
                    });
                    (class, miss, d)
                })
                .collect();
        let mut classes: Vec<Option<Class>> = Vec::with_capacity(classified.len());
        let mut misses: Vec<Option<near_miss::Miss>> = Vec::with_capacity(classified.len());
        for (class, miss, d) in classified {
            classes.push(class);
            misses.push(miss);
            diags.extend(d.0);
        }
        let t = Tagging {
            preset: rules.name.clone(),
            rooms: Vec::new(),
            room_groups: Vec::new(),
            portals: Vec::new(),
            bounds: Vec::new(),
            footprints: Vec::new(),
            ignored: Vec::new(),
            detail: Vec::new(),
            player_starts: Vec::new(),
            occupants: Vec::new(),
            unassigned: Vec::new(),
            near_misses: Vec::new(),
            settings: Vec::new(),
            diagnostics: Diagnostics::default(),
            generated: None,
            sky: sky_materials(scene, rules),
            room_index: Default::default(),
        };
        Recognition {
            scene,
            rules,
            order,
            classes,
            misses,
            room_of_node: vec![None; scene.nodes.len()],
            t,
            diags,
        }
    }

    /// Pass 1: rooms and groups, so later references by name can resolve in any order.
    fn collect_rooms(&mut self) {
        let (scene, rules) = (self.scene, self.rules);
        for i in 0..self.order.len() {
            let n = self.order[i];
            let Some(c) = &self.classes[n] else { continue };
            match c.kind {
                TagKind::Room => {
                    let name = c
                        .first(|m| m.room.clone())
                        .unwrap_or_else(|| scene.node_label(n));
                    let volume = rules.rules[c.rule].spec.volume.unwrap_or_default();
                    let id = self.declare_room(n, name, volume);
                    let r = &mut self.t.rooms[id];
                    if let Some(p) = extras::read_number(scene.nodes[n].extras.as_ref(), "priority")
                    {
                        r.priority = p as i64;
                    }
                }
                TagKind::Roomgroup => {
                    let name = c
                        .first(|m| m.room.clone())
                        .unwrap_or_else(|| scene.node_label(n));
                    self.t.room_groups.push(RoomGroup {
                        name,
                        node: n,
                        rooms: Vec::new(),
                    });
                }
                _ => {}
            }
        }
    }

    /// Standalone footprints and `-cell` bounds that name a room nobody declared declare it.
    fn declare_volume_rooms(&mut self) {
        let (scene, rules) = (self.scene, self.rules);
        for i in 0..self.order.len() {
            let n = self.order[i];
            let Some(c) = &self.classes[n] else { continue };
            if !matches!(c.kind, TagKind::Footprint | TagKind::Bound) {
                continue;
            }
            let named = c.first(|m| m.room.clone());
            let ancestor = ancestor_room(scene, &self.room_of_node, n);
            if ancestor.is_some() {
                continue;
            }
            let name = match (&named, c.kind) {
                (Some(name), _) => name.clone(),
                (None, TagKind::Footprint) => scene.node_label(n),
                _ => continue,
            };
            if self.t.room_by_name(rules, &name).is_none() {
                let volume = if c.kind == TagKind::Footprint {
                    VolumeHint::Footprint
                } else {
                    VolumeHint::Bound
                };
                self.declare_room(n, name, volume);
            }
        }
    }

    /// Declares room `name` at node `n`, by the rule that classed the node.
    fn declare_room(&mut self, n: NodeId, name: String, volume: VolumeHint) -> usize {
        let (scene, rules) = (self.scene, self.rules);
        let rule = self.classes[n].as_ref().map(|c| rule_id(rules, c));
        let id = add_room(
            scene,
            rules,
            &mut self.t,
            &mut self.diags,
            name,
            n,
            rule.unwrap_or_default(),
            volume,
        );
        self.room_of_node[n] = Some(id);
        id
    }

    /// Pass 2: membership, in pre-order so the nearest room ancestor is known.
    fn assign_members(&mut self) {
        let scene = self.scene;
        let mut group_of_node: Vec<Option<usize>> = vec![None; scene.nodes.len()];
        for (gi, g) in self.t.room_groups.iter().enumerate() {
            group_of_node[g.node] = Some(gi);
        }
        for i in 0..self.order.len() {
            let n = self.order[i];
            let parent = scene.nodes[n].parent;
            if self.room_of_node[n].is_none() {
                self.room_of_node[n] = parent.and_then(|p| self.room_of_node[p]);
            }
            if group_of_node[n].is_none() {
                group_of_node[n] = parent.and_then(|p| group_of_node[p]);
            }
            let has_mesh = scene.nodes[n].mesh.is_some();
            let nref = || NodeRef {
                node: n,
                path: scene.node_path(n),
            };
            match self.classes[n].as_ref().map(|c| c.kind) {
                Some(TagKind::Room) => {
                    let group = parent.and_then(|p| group_of_node[p]);
                    self.place_room_node(n, group, has_mesh);
                }
                Some(kind @ (TagKind::Bound | TagKind::Footprint)) => {
                    self.place_volume(n, kind, has_mesh)
                }
                Some(TagKind::Portal) => {
                    let Some(c) = &self.classes[n] else { continue };
                    let p = make_portal(
                        scene,
                        self.rules,
                        &self.t,
                        c,
                        n,
                        rule_id(self.rules, c),
                        &self.room_of_node,
                        &mut self.diags,
                    );
                    self.t.portals.push(p);
                }
                Some(TagKind::Ignore) => self.t.ignored.push(nref()),
                Some(TagKind::Detail) => match self.room_of_node[n] {
                    Some(r) if has_mesh => self.t.rooms[r].detail.push(n),
                    _ => self.t.detail.push(nref()),
                },
                Some(TagKind::PlayerStart) => self.t.player_starts.push(nref()),
                Some(TagKind::Occupant) => self.t.occupants.push(nref()),
                Some(TagKind::Roomgroup) => {}
                None => self.place_untagged(n, has_mesh),
            }
        }
    }

    /// A room's own node: it joins the group it sits in, and its mesh is the room's footprint,
    /// bound or structure as the room's volume hint says.
    fn place_room_node(&mut self, n: NodeId, group: Option<usize>, has_mesh: bool) {
        let scene = self.scene;
        let t = &mut self.t;
        let id = self.room_of_node[n].unwrap_or(0);
        if let Some(g) = group {
            t.rooms[id].group = Some(g);
            if !t.room_groups[g].rooms.contains(&id) {
                t.room_groups[g].rooms.push(id);
            }
        }
        let own = VolumeNode {
            node: n,
            path: scene.node_path(n),
            rule: t.rooms[id].rule.clone(),
            room: Some(id),
        };
        match t.rooms[id].volume {
            VolumeHint::Footprint if t.rooms[id].node == n && has_mesh => {
                t.rooms[id].footprints.push(n);
                t.footprints.push(own);
            }
            VolumeHint::Bound if t.rooms[id].node == n && has_mesh => {
                t.rooms[id].bounds.push(n);
                t.bounds.push(own);
            }
            _ if has_mesh => t.rooms[id].structure.push(n),
            _ => {}
        }
    }

    /// A bound or footprint node: it shapes the room it names or sits in, and turns a room
    /// that had only its geometry into one bounded by it.
    fn place_volume(&mut self, n: NodeId, kind: TagKind, has_mesh: bool) {
        let (scene, rules) = (self.scene, self.rules);
        let t = &mut self.t;
        let Some(c) = &self.classes[n] else { return };
        let room = c
            .first(|m| m.room.clone())
            .and_then(|name| t.room_by_name(rules, &name))
            .or(self.room_of_node[n]);
        if !has_mesh {
            self.diags.push(
                Diagnostic::new(
                    Code::TAG_BOUND_NO_MESH,
                    format!(
                        "`{}` is tagged as a {} but has no mesh",
                        scene.node_label(n),
                        kind.as_str()
                    ),
                    node_location(scene, n),
                )
                .hint("give the node a mesh, or remove the tag"),
            );
            // Nothing to bound with: the room keeps its own geometry's volume.
            return;
        }
        if room.is_none() {
            self.diags.push(
                Diagnostic::new(
                    Code::TAG_BOUND_NO_ROOM,
                    format!(
                        "{} `{}` is in no room and names none",
                        kind.as_str(),
                        scene.node_label(n)
                    ),
                    node_location(scene, n),
                )
                .hint("make it a child of its room, or name the room (`kitchen-cell`, extras `\"bound\": \"kitchen\"`)"),
            );
        }
        let v = VolumeNode {
            node: n,
            path: scene.node_path(n),
            rule: rule_id(rules, c),
            room,
        };
        if let Some(r) = room {
            if kind == TagKind::Bound {
                t.rooms[r].bounds.push(n);
                if t.rooms[r].volume == VolumeHint::Geometry {
                    t.rooms[r].volume = VolumeHint::Bound;
                }
            } else {
                t.rooms[r].footprints.push(n);
                if t.rooms[r].volume == VolumeHint::Geometry {
                    t.rooms[r].volume = VolumeHint::Footprint;
                }
            }
        }
        if kind == TagKind::Bound {
            t.bounds.push(v);
        } else {
            t.footprints.push(v);
        }
    }

    /// A node no rule tagged: its mesh is structure of the room it sits in (or unassigned),
    /// and a name that nearly matched a rule is reported, since that is usually a typo.
    fn place_untagged(&mut self, n: NodeId, has_mesh: bool) {
        let scene = self.scene;
        if has_mesh {
            // A door's or an area portal's block (extras `door`, `area_portal`) is air that
            // something closes: the room's detail, rendered and never sealing, as a brush
            // map's door is; the cell stage makes its volume a gate.
            let flag = |k: &str| extras::read_bool(scene.nodes[n].extras.as_ref(), k) == Some(true);
            match self.room_of_node[n] {
                Some(r) if flag("door") || flag("area_portal") => self.t.rooms[r].detail.push(n),
                Some(r) => self.t.rooms[r].structure.push(n),
                None => self.t.unassigned.push(NodeRef {
                    node: n,
                    path: scene.node_path(n),
                }),
            }
        }
        let Some(miss) = self.misses[n].take() else {
            return;
        };
        let rule = &self.rules.rules[miss.rule].spec;
        let example = rule.example.as_deref().unwrap_or(rule.id.as_str());
        let (what, name, hint) = match &miss.material {
            Some(m) => (
                format!("material `{m}` of `{}`", scene.node_label(n)),
                m.clone(),
                format!(
                    "rename the material to `{}`, or add a rule for this spelling in portcullis.toml",
                    miss.suggestion
                ),
            ),
            None => {
                let name = scene.nodes[n].name.clone().unwrap_or_default();
                (
                    format!("`{name}`"),
                    name,
                    format!(
                        "rename it to `{}`, or add a rule for this spelling in portcullis.toml",
                        miss.suggestion
                    ),
                )
            }
        };
        let named = if miss.material.is_some() {
            "materials"
        } else {
            "names"
        };
        self.diags.push(
            Diagnostic::new(
                Code::TAG_NEAR_MISS,
                format!(
                    "{what} looks like a {} tag but matches no rule ({}: rule `{}` accepts {named} like `{example}`)",
                    rule.kind.as_str(),
                    miss.slip,
                    rule.id
                ),
                node_location(scene, n),
            )
            .hint(hint),
        );
        self.t.near_misses.push(NearMiss {
            node: n,
            path: scene.node_path(n),
            name,
            kind: rule.kind,
            rule: rule.id.clone(),
            suggestion: miss.suggestion,
            slip: miss.slip.to_string(),
        });
    }

    /// Reports a level in which no room was found, then hands the tagging over with every
    /// diagnostic the passes made.
    fn finish(self) -> Tagging {
        let Recognition {
            scene,
            rules,
            order,
            classes,
            mut t,
            mut diags,
            ..
        } = self;
        // An empty scene is reported by the importer; "no rooms" would only repeat it.
        let has_triangles = scene.meshes.iter().any(|m| !m.triangles.is_empty());
        let tagged = order.iter().filter(|&&n| classes[n].is_some()).count();
        // Only when the active rules find no room: that is how a wrong preset shows, and asking
        // every other preset about every node cost a big level's tagging a third again.
        let suggested = if t.rooms.is_empty() {
            suggest::suggest_preset(scene, rules, &order, tagged)
        } else {
            None
        };
        // A suggested preset says more than "no room": it says which rules find them.
        if t.rooms.is_empty() && has_triangles && suggested.is_none() {
            diags.push(
                Diagnostic::new(
                    Code::TAG_NO_ROOMS,
                    format!("no room was recognised with the `{}` tag rules", rules.name),
                    Location::file(&scene.path),
                )
                .hint("tag rooms (e.g. `kitchen-room`, `room_kitchen`, extras `\"room\": \"kitchen\"`) or choose a preset with --tags"),
            );
        }
        diags.extend(suggested);
        t.diagnostics = diags;
        t
    }
}

/// The id of the rule that classified a node, as rooms, portals and volumes record it.
fn rule_id(rules: &RuleSet, c: &Class) -> String {
    rules.rules[c.rule].spec.id.clone()
}

/// Where a diagnostic about node `n` points: the file, the node's source and its path.
fn node_location(scene: &Scene, n: NodeId) -> Location {
    Location::file(&scene.path)
        .with_source(scene.nodes[n].source.clone())
        .with_node(scene.node_path(n))
}

#[allow(clippy::too_many_arguments)]
fn add_room(
    scene: &Scene,
    rules: &RuleSet,
    t: &mut Tagging,
    diags: &mut Diagnostics,
    name: String,
    node: NodeId,
    rule: String,
    volume: VolumeHint,
) -> RoomId {
    if let Some(existing) = t.room_by_name(rules, &name) {
        diags.push(
            Diagnostic::new(
                Code::TAG_DUPLICATE_ROOM,
                format!(
                    "room `{name}` is declared twice: by `{}` and by `{}`",
                    t.rooms[existing].path,
                    scene.node_path(node)
                ),
                Location::file(&scene.path)
                    .with_source(scene.nodes[node].source.clone())
                    .with_node(scene.node_path(node)),
            )
            .hint(
                "give every room a unique name; the second declaration was merged into the first",
            ),
        );
        return existing;
    }
    t.room_index.insert(rules.name_key(&name), t.rooms.len());
    t.rooms.push(Room {
        name,
        node,
        path: scene.node_path(node),
        rule,
        group: None,
        volume,
        priority: 0,
        structure: Vec::new(),
        detail: Vec::new(),
        bounds: Vec::new(),
        footprints: Vec::new(),
        area_of: None,
    });
    t.rooms.len() - 1
}

fn ancestor_room(scene: &Scene, room_of_node: &[Option<RoomId>], n: NodeId) -> Option<RoomId> {
    let mut cur = scene.nodes[n].parent;
    let mut guard = 0;
    while let Some(p) = cur {
        if let Some(r) = room_of_node[p] {
            return Some(r);
        }
        cur = scene.nodes[p].parent;
        guard += 1;
        if guard > scene.nodes.len() {
            break;
        }
    }
    None
}

/// `TAG_EXTRAS_INVALID` for extras key `key` of node `n`, saying `why`.
fn extras_invalid(scene: &Scene, n: NodeId, key: &str, why: &str) -> Diagnostic {
    Diagnostic::new(
        Code::TAG_EXTRAS_INVALID,
        format!("extras key `{key}` of `{}`: {why}", scene.node_label(n)),
        Location::file(&scene.path)
            .with_source(scene.nodes[n].source.clone())
            .with_node(scene.node_path(n)),
    )
}

fn classify(scene: &Scene, rules: &RuleSet, n: NodeId, diags: &mut Diagnostics) -> Option<Class> {
    let node = &scene.nodes[n];
    let mut found: Vec<(TagKind, RuleMatch)> = Vec::new();
    // Extras first.
    for (i, r) in rules.rules.iter().enumerate() {
        if r.spec.on != MatchOn::Extras {
            continue;
        }
        let key = r.spec.key.as_deref().unwrap_or_default();
        // A rule with a room template reads its key as an identifier for the template.
        let value = match &r.spec.room {
            Some(template) => match extras::read_id(node.extras.as_ref(), key) {
                Ok(None) => ExtrasValue::Off,
                Ok(Some(id)) => ExtrasValue::Named(template.replace("${value}", &id)),
                Err(why) => ExtrasValue::Invalid(why),
            },
            None => extras::read(node.extras.as_ref(), key),
        };
        let named = match value {
            ExtrasValue::Off => continue,
            ExtrasValue::On => None,
            ExtrasValue::Named(s) => Some(s),
            ExtrasValue::Invalid(why) => {
                diags.push(
                    extras_invalid(scene, n, key, &why.to_string())
                        .hint("write a name in quotes (`\"kitchen\"`), or true for a flag"),
                );
                continue;
            }
        };
        let mut m = RuleMatch {
            rule: i,
            ..Default::default()
        };
        if r.spec.kind == TagKind::Portal {
            m.target = named;
        } else {
            m.room = named;
        }
        found.push((r.spec.kind, m));
    }
    for (key, why) in extras::attribute_problems(node.extras.as_ref()) {
        diags.push(
            extras_invalid(scene, n, key, &why)
                .hint("see schemas/tags.schema.json for each key's type"),
        );
    }
    if let Some(name) = node.name.as_deref() {
        if let Some(m) = rules.match_text(MatchOn::Name, name) {
            found.push((rules.rules[m.rule].spec.kind, m));
        }
    }
    if let Some(mesh) = node.mesh {
        let names = scene.mesh_material_names(mesh);
        let mut all: Option<RuleMatch> = None;
        for name in &names {
            match name.and_then(|s| rules.match_text(MatchOn::Material, s)) {
                Some(m) if all.as_ref().is_none_or(|a| a.rule == m.rule) => all = Some(m),
                _ => {
                    all = None;
                    break;
                }
            }
        }
        if let Some(m) = all {
            found.push((rules.rules[m.rule].spec.kind, m));
        }
    }
    let mut it = found.into_iter();
    let (kind, m) = it.next()?;
    let extra = it.filter(|(k, _)| *k == kind).map(|(_, m)| m).collect();
    Some(Class {
        kind,
        rule: m.rule,
        m,
        extra,
    })
}

#[allow(clippy::too_many_arguments)]
fn make_portal(
    scene: &Scene,
    rules: &RuleSet,
    t: &Tagging,
    c: &Class,
    n: NodeId,
    rule: String,
    room_of_node: &[Option<RoomId>],
    diags: &mut Diagnostics,
) -> AuthoredPortal {
    let node = &scene.nodes[n];
    let ex = node.extras.as_ref();
    let spec_flags = |f: fn(&rules::RuleSpec) -> bool| {
        f(&rules.rules[c.rule].spec) || c.extra.iter().any(|m| f(&rules.rules[m.rule].spec))
    };
    let source_name =
        extras::read_string(ex, "source_room").or_else(|| c.first(|m| m.source.clone()));
    let target_name = c.first(|m| m.target.clone());
    let source_room = match &source_name {
        Some(name) => resolve_portal_room(scene, rules, t, n, name, "source", diags),
        None => ancestor_room(scene, room_of_node, n).or(room_of_node[n]),
    };
    let target_room = target_name
        .as_ref()
        .and_then(|name| resolve_portal_room(scene, rules, t, n, name, "target", diags));
    report_unplaced_portal(
        scene,
        n,
        source_room.is_none() && source_name.is_none(),
        diags,
    );
    let kind = portal_kind(scene, rules, c, n, diags);
    let teleport_exit = teleport_exit(scene, n, diags);
    AuthoredPortal {
        node: n,
        path: scene.node_path(n),
        rule,
        source_name,
        source_room,
        target_name,
        target_room,
        kind,
        one_way: extras::read_bool(ex, "one_way").unwrap_or_else(|| spec_flags(|s| s.one_way)),
        closed: extras::read_bool(ex, "closed").unwrap_or_else(|| spec_flags(|s| s.closed)),
        teleport_exit,
        faces: std::iter::once(c.rule)
            .chain(c.extra.iter().map(|m| m.rule))
            .find_map(|r| rules.rules[r].spec.faces)
            .unwrap_or_default(),
    }
}

/// The room portal `n` names as its `what` (source or target) end. A name that matches no
/// room, or several, links nothing rather than a guess; the portal is then linked by position.
fn resolve_portal_room(
    scene: &Scene,
    rules: &RuleSet,
    t: &Tagging,
    n: NodeId,
    name: &str,
    what: &str,
    diags: &mut Diagnostics,
) -> Option<RoomId> {
    let hits: Vec<RoomId> = t.room_by_name(rules, name).into_iter().collect();
    match hits.as_slice() {
        [one] => Some(*one),
        [] => {
            let hint = match closest(t.rooms.iter().map(|r| r.name.as_str()), name) {
                Some(s) => {
                    format!("did you mean `{s}`? Rename the portal or the room so they agree")
                }
                None => "name an existing room, or remove the name to link the portal by position"
                    .to_string(),
            };
            diags.push(
                Diagnostic::new(
                    Code::TAG_UNKNOWN_TARGET,
                    format!(
                        "portal `{}` names {what} room `{name}`, and no room has that name",
                        scene.node_label(n)
                    ),
                    node_location(scene, n),
                )
                .hint(hint),
            );
            None
        }
        _ => {
            diags.push(
                Diagnostic::new(
                    Code::TAG_AMBIGUOUS_TARGET,
                    format!(
                        "portal `{}` names {what} room `{name}`, which {} rooms match",
                        scene.node_label(n),
                        hits.len()
                    ),
                    node_location(scene, n),
                )
                .hint("give the rooms distinct names"),
            );
            None
        }
    }
}

/// Warns of a portal without a polygon (no mesh) and of one with no source room
/// (`no_source`), which the portal stage can then only link by position.
fn report_unplaced_portal(scene: &Scene, n: NodeId, no_source: bool, diags: &mut Diagnostics) {
    if scene.nodes[n].mesh.is_none() {
        diags.push(
            Diagnostic::new(
                Code::TAG_PORTAL_NO_MESH,
                format!(
                    "portal `{}` has no mesh, so it has no polygon",
                    scene.node_label(n)
                ),
                node_location(scene, n),
            )
            .hint("give the portal node a planar convex mesh (a quad), or remove the portal tag"),
        );
    }
    if no_source {
        diags.push(
            Diagnostic::new(
                Code::TAG_PORTAL_NO_SOURCE,
                format!(
                    "portal `{}` is in no room and names no source room; it will be linked by position",
                    scene.node_label(n)
                ),
                node_location(scene, n),
            )
            .hint("put the portal under the room it leads out of, or set extras `source_room`"),
        );
    }
}

/// The portal's kind: extras `portal_kind` overrides the rule's; an unknown kind is reported
/// and read as plain, so a typo never makes a mirror or teleporter.
fn portal_kind(
    scene: &Scene,
    rules: &RuleSet,
    c: &Class,
    n: NodeId,
    diags: &mut Diagnostics,
) -> PortalKind {
    match extras::read_string(scene.nodes[n].extras.as_ref(), "portal_kind") {
        Some(k) => PortalKind::parse(&k).unwrap_or_else(|| {
            diags.push(
                Diagnostic::new(
                    Code::TAG_EXTRAS_INVALID,
                    format!("extras `portal_kind` of `{}` is `{k}`", scene.node_label(n)),
                    node_location(scene, n),
                )
                .hint("use `plain`, `mirror` or `teleporter`"),
            );
            PortalKind::Plain
        }),
        None => rules.rules[c.rule].spec.portal_kind.unwrap_or_default(),
    }
}

/// The node a teleporter's extras `teleport_exit` names, by name or path; a name that finds
/// no node is reported, and the teleporter keeps no exit.
fn teleport_exit(scene: &Scene, n: NodeId, diags: &mut Diagnostics) -> Option<NodeId> {
    extras::read_string(scene.nodes[n].extras.as_ref(), "teleport_exit").and_then(|exit| {
        let found = scene.walk().into_iter().find(|&m| {
            scene.nodes[m].name.as_deref() == Some(exit.as_str()) || scene.node_path(m) == exit
        });
        if found.is_none() {
            diags.push(
                Diagnostic::new(
                    Code::TAG_TELEPORT_EXIT_UNKNOWN,
                    format!(
                        "teleporter `{}` names exit node `{exit}`, which does not exist",
                        scene.node_label(n)
                    ),
                    node_location(scene, n),
                )
                .hint("set extras `teleport_exit` to the name or path of the exit portal's node"),
            );
        }
        found
    })
}

/// The candidate closest to `name` by edit distance, if reasonably close.
fn closest<'a>(candidates: impl Iterator<Item = &'a str>, name: &str) -> Option<&'a str> {
    let lname = name.to_lowercase();
    candidates
        .map(|c| (strsim::levenshtein(&c.to_lowercase(), &lname), c))
        .filter(|(d, c)| *d <= (c.len().max(name.len()) / 3).max(2))
        .min_by_key(|(d, _)| *d)
        .map(|(_, c)| c)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn closest_names() {
        assert_eq!(
            closest(["lounge", "kitchen"].into_iter(), "lounges"),
            Some("lounge")
        );
        assert_eq!(closest(["lounge", "kitchen"].into_iter(), "attic"), None);
    }
}
