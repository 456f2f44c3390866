//! The per-view culling: each [`PortalCamera`]'s trace, and its `VisibleEntities` cut to what
//! the visible cells draw.

use std::any::TypeId;
use std::collections::HashSet;

use bevy::asset::{Assets, Handle};
use bevy::camera::visibility::VisibleEntities;
use bevy::camera::Projection;
use bevy::ecs::component::Component;
use bevy::ecs::entity::Entity;
use bevy::ecs::hierarchy::ChildOf;
use bevy::ecs::system::{Local, Query, Res};
use bevy::mesh::Mesh3d;
use bevy::transform::components::GlobalTransform;
use portcullis_runtime::runtime::{DrawList, Level, Trace, TraceOptions, View};

use crate::load::{PortalLevel, PortalNode, PortalPrimitive};

/// Put on a camera (with `Camera3d`) to cull its view by the portals of `level`. After each
/// frame's visibility check it holds that frame's trace and draw list.
#[derive(Component)]
pub struct PortalCamera {
    /// The level whose portals cull this camera.
    pub level: Handle<PortalLevel>,
    /// The entity the level's scene is spawned under, when it is not at the world's origin:
    /// the camera is taken into the level's space by the inverse of its global transform (a
    /// rigid one: the near plane and field of view are not scaled).
    pub level_root: Option<Entity>,
    /// Trace this view instead of the camera's own: for cameras kept in `f64` (large worlds,
    /// replays, the `cull` example), which a `Transform`'s `f32` would round.
    pub exact: Option<View>,
    /// The trace's limits (depths, PVS).
    pub options: TraceOptions,
    /// The last frame's trace: the camera's cell, the visible cells with their screen
    /// rectangles (for scissoring), and the entries seen through mirrors and teleporters.
    pub trace: Trace,
    /// What the last frame's visible cells drew (without those seen through a transform).
    pub draw: DrawList,
    /// Whether the last frame was culled: false while the level is loading, or for a camera
    /// with an orthographic projection and no `exact` view.
    pub culled: bool,
}

impl PortalCamera {
    /// Culls by `level`, with the default limits.
    pub fn new(level: Handle<PortalLevel>) -> PortalCamera {
        PortalCamera {
            level,
            level_root: None,
            exact: None,
            options: TraceOptions::default(),
            trace: Trace::default(),
            draw: DrawList::default(),
            culled: false,
        }
    }
}

/// The camera's view in the level's space, from its transform and perspective projection.
fn camera_view(
    t: &GlobalTransform,
    projection: &Projection,
    root: Option<&GlobalTransform>,
) -> Option<View> {
    let Projection::Perspective(p) = projection else {
        return None;
    };
    let to_level = root.map(|r| r.affine().inverse());
    let point = |v: bevy::math::Vec3| to_level.map_or(v, |m| m.transform_point3(v));
    let vector = |v: bevy::math::Vec3| to_level.map_or(v, |m| m.transform_vector3(v));
    let d = |v: bevy::math::Vec3| [v.x as f64, v.y as f64, v.z as f64];
    View::new(
        d(point(t.translation())),
        d(vector(*t.forward())),
        d(vector(*t.up())),
        (p.fov as f64).to_degrees(),
        p.aspect_ratio as f64,
        p.near as f64,
    )
    .ok()
}

/// What a level's visible cells draw, by node: reused between frames.
#[derive(Default)]
pub struct Drawn {
    /// Per node index: some cell names it (the cells govern its drawing).
    governed: Vec<bool>,
    /// Per node index: a visible cell draws it whole.
    whole: Vec<bool>,
    /// (node, primitive) of which a visible cell draws a range.
    ranges: HashSet<(u32, u32)>,
    /// Per node index: no cell draws it (`PortalLevel::never`).
    never: Vec<bool>,
}

impl Drawn {
    fn fill(&mut self, level: &Level, never: &[u32], list: &DrawList) {
        let named = level.named_nodes();
        let last = named.last().max(never.last());
        let n = last.map_or(0, |&m| m as usize + 1);
        self.never.clear();
        self.never.resize(n, false);
        for &node in never {
            self.never[node as usize] = true;
        }
        self.governed.clear();
        self.governed.resize(n, false);
        for &node in named {
            self.governed[node as usize] = true;
        }
        self.whole.clear();
        self.whole.resize(n, false);
        for &node in &list.nodes {
            self.whole[node] = true;
        }
        self.ranges.clear();
        (self.ranges).extend(
            list.ranges
                .iter()
                .map(|r| (r.node as u32, r.primitive as u32)),
        );
    }

    /// Whether the mesh of `node` drawing `primitive` is kept in the view.
    fn keeps(&self, node: u32, primitive: u32) -> bool {
        let i = node as usize;
        if self.never.get(i).copied().unwrap_or(false) {
            return false;
        }
        if !self.governed.get(i).copied().unwrap_or(false) {
            return true;
        }
        self.whole[i] || self.ranges.contains(&(node, primitive))
    }
}

/// The plugin's system (in `PostUpdate`, after Bevy's `CheckVisibility`): traces each
/// [`PortalCamera`]'s view and takes out of its `VisibleEntities` each of the level's meshes
/// that no visible cell draws. The lists stay sorted, as Bevy's renderer needs them.
#[allow(clippy::type_complexity)]
pub fn cull_views(
    levels: Res<Assets<PortalLevel>>,
    mut cameras: Query<(
        &mut PortalCamera,
        &GlobalTransform,
        &Projection,
        &mut VisibleEntities,
    )>,
    roots: Query<&GlobalTransform>,
    meshes: Query<(&ChildOf, &PortalPrimitive)>,
    nodes: Query<&PortalNode>,
    mut drawn: Local<Drawn>,
) {
    for (mut camera, transform, projection, mut visible) in &mut cameras {
        let camera = &mut *camera;
        camera.culled = false;
        let Some(level) = levels.get(&camera.level) else {
            continue;
        };
        let root = match camera.level_root.map(|r| roots.get(r)) {
            // a level root that is gone: culling in the wrong frame would hide what is seen
            Some(Err(_)) => continue,
            Some(Ok(r)) => Some(r),
            None => None,
        };
        let Some(view) = camera
            .exact
            .or_else(|| camera_view(transform, projection, root))
        else {
            continue;
        };
        level
            .level
            .trace(&view, &level.doors, &camera.options, &mut camera.trace);
        let direct = camera
            .trace
            .visible()
            .iter()
            .filter(|v| v.transform.is_none());
        level
            .level
            .draw_list(direct.filter_map(|v| v.cell), &mut camera.draw);
        drawn.fill(&level.level, &level.never, &camera.draw);
        let keep = |e: &Entity| {
            // Only the glTF loader's mesh entities of this level: a game's own child of a level
            // node (a prop, a light) has no `PortalPrimitive` and is left alone.
            let Ok((parent, primitive)) = meshes.get(*e) else {
                return true;
            };
            match nodes.get(parent.parent()) {
                Ok(n) if n.file == level.file => drawn.keeps(n.node, primitive.primitive),
                _ => true,
            }
        };
        visible.get_mut(TypeId::of::<Mesh3d>()).retain(keep);
        camera.culled = true;
    }
}
