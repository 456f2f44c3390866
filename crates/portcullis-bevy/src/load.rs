//! The level's culling data as a Bevy asset, and the tags that tie the glTF loader's entities
//! to its nodes.

use std::hash::{Hash, Hasher};

use bevy::asset::io::Reader;
use bevy::asset::{Asset, AssetLoader, AssetPath, LoadContext};
use bevy::ecs::component::Component;
use bevy::ecs::reflect::ReflectComponent;
use bevy::ecs::world::EntityWorldMut;
use bevy::gltf::extensions::{ErasedGltfExtensionHandler, GltfExtensionHandler};
use bevy::gltf::GltfLoaderSettings;
use bevy::reflect::{Reflect, TypePath};
use portcullis_runtime::format::NAME;
use portcullis_runtime::runtime::{Doors, Level, LevelError};

/// A converted level's cells, portals and PVS (`portcullis_runtime`'s [`Level`]) and its door
/// state, loaded from the same .glb (or .gltf) as its scene:
/// `assets.load::<PortalLevel>("level.glb")`.
#[derive(Asset, TypePath)]
pub struct PortalLevel {
    /// The runtime's level: locate, trace, draw lists.
    pub level: Level,
    /// Which portals are closed: open or close doors here (`Doors::set` closes a portal and its
    /// partner alike); every camera's next trace sees it.
    pub doors: Doors,
    /// Which file it came from, as [`PortalNode::file`] says it of an entity.
    pub file: u64,
    /// The level's nodes no cell draws, ascending: authored portal meshes (`portals[].node`)
    /// and `--split-by-cell` parts no cell names. Hidden in every culled view.
    pub never: Vec<u32>,
}

/// The nodes of a converted file that are the level's but no cell draws: authored portals'
/// meshes and split parts no cell lists (a `[no cell]` part), as the three.js plugin hides.
fn never_drawn(bytes: &[u8], level: &Level) -> Vec<u32> {
    use portcullis_runtime::format::glb;
    let json = if glb::is_glb(bytes) {
        glb::split(bytes).map(|g| g.json).unwrap_or(&[])
    } else {
        bytes
    };
    let Ok(doc) = serde_json::from_slice::<serde_json::Value>(json) else {
        return Vec::new();
    };
    let index = |v: &serde_json::Value| v.as_u64().map(|n| n as u32);
    let ext = &doc["extensions"][NAME];
    let portals = ext["portals"].as_array().into_iter().flatten();
    let mut never: Vec<u32> = portals.filter_map(|p| index(&p["node"])).collect();
    for node in doc["nodes"].as_array().into_iter().flatten() {
        let parts = node["extensions"][NAME]["parts"]
            .as_array()
            .into_iter()
            .flatten();
        never.extend(parts.filter_map(index));
    }
    let named = level.named_nodes();
    never.retain(|n| named.binary_search(n).is_err());
    never.sort_unstable();
    never.dedup();
    never
}

/// Why a [`PortalLevel`] could not be loaded.
#[derive(Debug, thiserror::Error)]
pub enum PortalLoadError {
    /// The asset's bytes could not be read.
    #[error("cannot read the level: {0}")]
    Io(#[from] std::io::Error),
    /// The file has no usable `PORTCULLIS_portals` extension.
    #[error("{error}; run `portcullis convert` on the level and load the file it writes")]
    Level {
        /// What is wrong with the file or one of its records.
        #[from]
        error: LevelError,
    },
}

/// Loads a [`PortalLevel`] from a .glb or .gltf written by `portcullis convert` (a .gltf's
/// buffers embedded; `convert` writes a .glb by default).
#[derive(Default, TypePath)]
pub struct PortalLevelLoader;

impl AssetLoader for PortalLevelLoader {
    type Asset = PortalLevel;
    type Settings = ();
    type Error = PortalLoadError;

    async fn load(
        &self,
        reader: &mut dyn Reader,
        _settings: &(),
        load_context: &mut LoadContext<'_>,
    ) -> Result<PortalLevel, PortalLoadError> {
        let mut bytes = Vec::new();
        reader.read_to_end(&mut bytes).await?;
        let level = Level::from_bytes(&bytes, None)?;
        Ok(PortalLevel {
            doors: Doors::new(&level),
            never: never_drawn(&bytes, &level),
            level,
            file: file_id(load_context.path()),
        })
    }

    /// None: a level is loaded by its type (`assets.load::<PortalLevel>("level.glb")`), so
    /// the file's extensions stay Bevy's glTF loader's, which loads its scenes (a labeled path
    /// such as `level.glb#Scene0` picks its loader by extension alone, the last registered).
    fn extensions(&self) -> &[&str] {
        &[]
    }
}

/// The glTF node an entity was spawned for, on every node entity of a converted level.
#[derive(Component, Reflect, Clone, Copy, Debug, PartialEq, Eq)]
#[reflect(Component)]
pub struct PortalNode {
    /// The node's index in the file's `nodes`.
    pub node: u32,
    /// The file's [`PortalLevel::file`].
    pub file: u64,
}

/// The primitive of its node's mesh a mesh entity draws (its parent has the [`PortalNode`]).
#[derive(Component, Reflect, Clone, Copy, Debug, PartialEq, Eq)]
#[reflect(Component)]
pub struct PortalPrimitive {
    /// The primitive's index in its mesh.
    pub primitive: u32,
}

/// A file's identity: a hash of its asset path without the label, the same for the scene
/// (`level.glb#Scene0`) and the level (`level.glb`).
pub(crate) fn file_id(path: &AssetPath) -> u64 {
    let mut h = std::hash::DefaultHasher::new();
    path.without_label().hash(&mut h);
    h.finish()
}

/// The glTF loader's hooks: tags the entities of files that carry the extension, and only those.
#[derive(Default, Clone)]
pub(crate) struct NodeTags {
    file: Option<u64>,
}

impl GltfExtensionHandler for NodeTags {
    fn dyn_clone(&self) -> Box<dyn ErasedGltfExtensionHandler> {
        Box::new(self.clone())
    }

    fn on_root(
        &mut self,
        load_context: &mut LoadContext<'_>,
        gltf: &bevy::gltf::gltf::Gltf,
        _settings: &GltfLoaderSettings,
    ) {
        let converted = gltf.document.extensions_used().any(|e| e == NAME);
        self.file = converted.then(|| file_id(load_context.path()));
    }

    fn on_spawn_mesh_and_material(
        &mut self,
        _load_context: &mut LoadContext<'_>,
        primitive: &bevy::gltf::gltf::Primitive,
        _mesh: &bevy::gltf::gltf::Mesh,
        _material: &bevy::gltf::gltf::Material,
        entity: &mut EntityWorldMut,
        _material_label: &str,
    ) {
        if self.file.is_some() {
            entity.insert(PortalPrimitive {
                primitive: primitive.index() as u32,
            });
        }
    }

    fn on_gltf_node(
        &mut self,
        _load_context: &mut LoadContext<'_>,
        gltf_node: &gltf::Node,
        entity: &mut EntityWorldMut,
    ) {
        if let Some(file) = self.file {
            entity.insert(PortalNode {
                node: gltf_node.index() as u32,
                file,
            });
        }
    }
}
