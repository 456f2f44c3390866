#![warn(missing_docs)]
#![deny(unsafe_code)]
//! Portal culling for Bevy, from a level written by `portcullis convert`.
//!
//! ```no_run
//! use bevy::prelude::*;
//! use portcullis_bevy::{PortalCamera, PortalLevel, PortcullisPlugin};
//!
//! fn setup(mut commands: Commands, assets: Res<AssetServer>) {
//!     commands.spawn(WorldAssetRoot(assets.load(GltfAssetLabel::Scene(0).from_asset("level.glb"))));
//!     let level: Handle<PortalLevel> = assets.load("level.glb");
//!     commands.spawn((Camera3d::default(), PortalCamera::new(level)));
//! }
//! # fn main() {
//! App::new().add_plugins((DefaultPlugins, PortcullisPlugin)).add_systems(Startup, setup).run();
//! # }
//! ```
//!
//! [`PortcullisPlugin`] does three things:
//! - it loads a [`PortalLevel`] asset from the same file as the glTF (the extension and the PVS,
//!   by the engine-side crate `portcullis-runtime`; never the meshes, which Bevy's glTF loader
//!   reads);
//! - it tags, through Bevy's glTF extension hooks, each entity the glTF loader spawns for a
//!   node with [`PortalNode`] (the glTF node index: the loader's own association, not names)
//!   and each mesh entity with [`PortalPrimitive`];
//! - each frame, after Bevy's own visibility check (frustum culling), for each camera with a
//!   [`PortalCamera`] it traces the camera's view through the portals
//!   ([`portcullis_runtime::runtime::Level::trace`]) and takes out of that camera's
//!   `VisibleEntities` every mesh of the level that no visible cell draws. That is the list the
//!   renderer draws the view from, so several cameras (split screen, a minimap) each cull for
//!   themselves.
//!
//! What is governed: the glTF loader's mesh entities of nodes some cell names (the level's
//! geometry); authored portal meshes and split parts no cell names are hidden. Other meshes
//! (props spawned by the game, meshes in no room) are left as Bevy's frustum culling left them.
//! One spawned instance per level file; the README lists the other limits.
//! A node drawn whole by a visible cell is drawn; a split node (the extension's `split`: one
//! primitive shared by several cells, drawn by ranges of an index accessor) is drawn whole when
//! any visible cell draws a range of it, since a Bevy mesh entity is one draw. Convert with
//! `--split-by-cell` to give each cell meshes of its own. Cells seen through a mirror or a
//! teleporter are not drawn into the view (they need a pass of their own with the entry's
//! transform): the trace in [`PortalCamera::trace`] lists them with their transforms.

mod cull;
pub mod headless;
mod load;

pub use cull::{cull_views, PortalCamera};
pub use load::{PortalLevel, PortalLevelLoader, PortalLoadError, PortalNode, PortalPrimitive};
pub use portcullis_runtime;

use bevy::app::{App, Plugin, PostUpdate};
use bevy::asset::AssetApp;
use bevy::camera::visibility::VisibilitySystems;
use bevy::ecs::schedule::IntoScheduleConfigs;
use bevy::gltf::extensions::GltfExtensionHandlers;

/// Loads [`PortalLevel`]s, tags the glTF's entities and culls each [`PortalCamera`]'s view.
/// Add it before or after Bevy's `GltfPlugin` (in `DefaultPlugins`), as long as both are
/// added before the app runs.
pub struct PortcullisPlugin;

impl Plugin for PortcullisPlugin {
    fn build(&self, app: &mut App) {
        // Registered for reflection: scenes are spawned by copying their components by it.
        app.init_asset::<PortalLevel>()
            .register_type::<PortalNode>()
            .register_type::<PortalPrimitive>()
            .register_asset_loader(PortalLevelLoader)
            .init_resource::<GltfExtensionHandlers>()
            .add_systems(
                PostUpdate,
                cull_views
                    .after(VisibilitySystems::CheckVisibility)
                    .before(VisibilitySystems::MarkNewlyHiddenEntitiesInvisible),
            );
        // The glTF loader clones the handlers' list when it is registered (GltfPlugin's
        // `finish`); the list is shared, so a handler added here is seen either way.
        let handlers = app.world().resource::<GltfExtensionHandlers>();
        handlers
            .0
            .write_blocking()
            .push(Box::new(load::NodeTags::default()));
    }
}
