//! A Bevy app with no window and no renderer that loads a converted level, its scene and the
//! plugin: for tests, tools and CI jobs that check what a level culls (the `cull` example and
//! this crate's tests run on it).

use std::path::Path;

use bevy::app::App;
use bevy::asset::{AssetPlugin, AssetServer, Handle, LoadState, RecursiveDependencyLoadState};
use bevy::camera::visibility::VisibleEntities;
use bevy::camera::{Camera3d, PerspectiveProjection, Projection};
use bevy::ecs::entity::Entity;
use bevy::ecs::world::World;
use bevy::gltf::{GltfAssetLabel, GltfPlugin};
use bevy::math::Vec3;
use bevy::mesh::Mesh3d;
use bevy::transform::components::Transform;
use bevy::world_serialization::{WorldAssetRoot, WorldSerializationPlugin};
use portcullis_runtime::runtime::answer::CameraLine;
use portcullis_runtime::runtime::ViewError;

use crate::{PortalCamera, PortalLevel, PortcullisPlugin};

/// Why a level could not be set up.
#[derive(Debug, thiserror::Error)]
pub enum HeadlessError {
    /// The level's path has no file name or folder.
    #[error("{0}: not a file")]
    NotAFile(String),
    /// Bevy's asset server failed on the level or its scene.
    #[error("{path}: {error}")]
    Load {
        /// The level.
        path: String,
        /// Bevy's message.
        error: String,
    },
}

/// How long [`app_with_level`] waits for the level and its scene.
pub const LOAD_TIMEOUT: std::time::Duration = std::time::Duration::from_secs(300);

/// An app with the plugins a level needs headless: time, transforms, assets (rooted at the
/// level's folder), images and meshes (the glTF loader's sub-assets), scenes, glTF, cameras
/// and visibility, and [`PortcullisPlugin`]; the level at `path` loaded and its first scene
/// spawned. Returns the app, the level and the scene's root entity.
pub fn app_with_level(path: &Path) -> Result<(App, Handle<PortalLevel>, Entity), HeadlessError> {
    let bad = || HeadlessError::NotAFile(path.display().to_string());
    let abs = std::path::absolute(path).map_err(|_| bad())?;
    let (dir, name) = match (abs.parent(), abs.file_name()) {
        (Some(d), Some(n)) => (d.to_path_buf(), n.to_string_lossy().into_owned()),
        _ => return Err(bad()),
    };
    let mut app = App::new();
    app.add_plugins((
        bevy::MinimalPlugins,
        bevy::transform::TransformPlugin,
        AssetPlugin {
            file_path: dir.to_string_lossy().into_owned(),
            ..Default::default()
        },
        bevy::image::ImagePlugin::default(),
        bevy::mesh::MeshPlugin,
        WorldSerializationPlugin,
        GltfPlugin::default(),
        bevy::camera::CameraPlugin,
        PortcullisPlugin,
    ));
    // What `App::run` does before the first frame: the glTF loader is registered in its
    // plugin's `finish`, and a load waits for it until then.
    app.finish();
    app.cleanup();
    let server = app.world().resource::<AssetServer>().clone();
    let level = server.load::<PortalLevel>(name.clone());
    let scene = server.load(GltfAssetLabel::Scene(0).from_asset(name));
    let root = app.world_mut().spawn(WorldAssetRoot(scene.clone())).id();
    // Bevy's message, without the backtrace its error type appends
    let failed = |e: String| HeadlessError::Load {
        path: path.display().to_string(),
        error: e.lines().next().unwrap_or_default().to_string(),
    };
    // Bounded: a file whose scene loads but spawns nothing, or a load that never ends, is an
    // error, not a hang.
    let start = std::time::Instant::now();
    let mut frames_loaded = 0;
    loop {
        app.update();
        for id in [level.id().untyped(), scene.id().untyped()] {
            if let Some(LoadState::Failed(e)) = server.get_load_state(id) {
                return Err(failed(e.to_string()));
            }
        }
        // a texture or buffer the scene needs that failed (a missing file, a format not built in)
        if let Some(RecursiveDependencyLoadState::Failed(e)) =
            server.get_recursive_dependency_load_state(scene.id())
        {
            return Err(failed(e.to_string()));
        }
        let loaded = server.is_loaded_with_dependencies(&level)
            && server.is_loaded_with_dependencies(&scene);
        let spawned = app
            .world()
            .get::<bevy::ecs::hierarchy::Children>(root)
            .is_some();
        if loaded && spawned {
            // one more frame: the scene's transforms and visibility propagate
            app.update();
            return Ok((app, level, root));
        }
        frames_loaded += usize::from(loaded);
        if frames_loaded > 100 {
            return Err(failed("its first scene spawned nothing".to_string()));
        }
        if start.elapsed() > LOAD_TIMEOUT {
            return Err(failed(format!(
                "not loaded after {} s",
                LOAD_TIMEOUT.as_secs()
            )));
        }
        std::thread::sleep(std::time::Duration::from_millis(1));
    }
}

/// A camera culled by `level`, spawned with a perspective projection.
pub fn spawn_camera(world: &mut World, level: Handle<PortalLevel>) -> Entity {
    world
        .spawn((Camera3d::default(), PortalCamera::new(level)))
        .id()
}

/// Puts `camera` where the cameras file's `line` says (its transform in `f32`, its
/// projection) and, with `exact`, has it traced in `f64` as given. `Err` when the line is no
/// usable view (rule 8).
pub fn aim(
    world: &mut World,
    camera: Entity,
    line: &CameraLine,
    exact: bool,
) -> Result<(), ViewError> {
    let view = line.view()?;
    let f = |v: [f64; 3]| Vec3::new(v[0] as f32, v[1] as f32, v[2] as f32);
    let mut e = world.entity_mut(camera);
    let transform = Transform::from_translation(f(line.eye)).looking_to(f(line.look), f(line.up));
    e.insert((
        transform,
        Projection::Perspective(PerspectiveProjection {
            fov: line.fov_y.to_radians() as f32,
            aspect_ratio: line.aspect as f32,
            near: line.near as f32,
            ..Default::default()
        }),
    ));
    if let Some(mut c) = e.get_mut::<PortalCamera>() {
        c.exact = exact.then_some(view);
    }
    Ok(())
}

/// The mesh entities `camera` draws this frame (its `VisibleEntities` of `Mesh3d`), sorted.
pub fn drawn_meshes(world: &World, camera: Entity) -> Vec<Entity> {
    let visible = world.get::<VisibleEntities>(camera);
    let mut v: Vec<Entity> = visible.map_or(Vec::new(), |v| {
        v.get(std::any::TypeId::of::<Mesh3d>()).to_vec()
    });
    v.sort_unstable();
    v
}
