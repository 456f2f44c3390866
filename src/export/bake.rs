//! A scene whose nodes carry transforms (USD), made into the form the new-glTF writer expects
//! (world-space meshes under identity nodes, as OBJ gives them).
//!
//! The writer places each mesh node at its mesh's centre and ignores node transforms, which is
//! right for OBJ only. Baking is simpler than writing each transform relative to its parent:
//! a relative transform of a scaled parent and a rotated child can shear, and glTF node
//! matrices must decompose into translation, rotation and scale. The price is that a mesh used
//! by several nodes is written once per node.

use std::borrow::Cow;

use glam::DMat4;

use crate::scene::Scene;

/// `scene` itself when every node transform is the identity, else a copy with each mesh node's
/// mesh in world space (winding kept facing the same way under a mirroring transform); a node
/// without a mesh keeps its transform, of which the writer takes the place.
pub(crate) fn world_space(scene: &Scene) -> Cow<'_, Scene> {
    if scene.nodes.iter().all(|n| n.world == DMat4::IDENTITY) {
        return Cow::Borrowed(scene);
    }
    let mut out = scene.clone();
    let mut meshes = Vec::new();
    for n in &mut out.nodes {
        if let Some(m) = n.mesh {
            let mut mesh = scene.meshes[m].clone();
            for p in &mut mesh.positions {
                *p = n.world.transform_point3(*p);
            }
            if n.world.determinant() < 0.0 {
                for t in &mut mesh.triangles {
                    t.swap(1, 2);
                }
            }
            n.mesh = Some(meshes.len());
            meshes.push(mesh);
            n.world = DMat4::IDENTITY;
        }
        // A node without a mesh (a player start, an occupant) keeps its place.
    }
    out.meshes = meshes;
    Cow::Owned(out)
}
