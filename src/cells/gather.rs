//! The triangles of a set of nodes, in world space about the level's centre, and in an order
//! the file's listing does not decide: every reading (footprints, prisms, the 3D interior, the
//! solid blocks) takes its input here, so a level shuffled, mirrored or moved breaks its ties
//! the same way.

use glam::DVec3;

use crate::scene::{NodeId, Scene};

/// World-space triangles of a set of nodes, recentred by `-origin`.
pub(crate) fn node_triangles(scene: &Scene, nodes: &[NodeId], origin: DVec3) -> Vec<[DVec3; 3]> {
    let mut out = Vec::new();
    for &n in nodes {
        let node = &scene.nodes[n];
        let Some(m) = node.mesh else { continue };
        let mesh = &scene.meshes[m];
        let world: Vec<DVec3> = mesh
            .positions
            .iter()
            .map(|p| node.world.transform_point3(*p) - origin)
            .collect();
        let winding = scene.winding(n);
        for &t in &mesh.triangles {
            let t = winding.order(t);
            if let (Some(a), Some(b), Some(c)) = (
                world.get(t[0] as usize),
                world.get(t[1] as usize),
                world.get(t[2] as usize),
            ) {
                out.push([*a, *b, *c]);
            }
        }
    }
    out
}

/// A room's triangles in an order that does not depend on how the file lists them: nodes by
/// path (then mesh), each triangle started at its lowest vertex index, triangles by their
/// indices. Shuffling nodes or triangles, or rotating a triangle's corners, changes nothing
/// here, so the 3D decomposition breaks its ties the same way (tests/metamorphic.rs).
pub(crate) fn canonical_triangles(
    scene: &Scene,
    nodes: &[NodeId],
    origin: DVec3,
) -> Vec<[DVec3; 3]> {
    canonical_node_triangles(scene, nodes, origin)
        .into_iter()
        .flat_map(|(_, t)| t)
        .collect()
}

/// [`canonical_triangles`] node by node, nodes in the same canonical order.
pub(crate) fn canonical_node_triangles(
    scene: &Scene,
    nodes: &[NodeId],
    origin: DVec3,
) -> Vec<(NodeId, Vec<[DVec3; 3]>)> {
    let mut order: Vec<(String, usize, NodeId)> = nodes
        .iter()
        .map(|&n| {
            (
                scene.node_path(n),
                scene.nodes[n].mesh.unwrap_or(usize::MAX),
                n,
            )
        })
        .collect();
    order.sort();
    let mut out = Vec::new();
    for (_, _, n) in order {
        let node = &scene.nodes[n];
        let Some(m) = node.mesh else { continue };
        let mesh = &scene.meshes[m];
        let mut tris: Vec<[u32; 3]> = mesh
            .triangles
            .iter()
            .filter(|t| t.iter().all(|&i| (i as usize) < mesh.positions.len()))
            .map(|t| {
                let k = (0..3).min_by_key(|&k| t[k]).unwrap_or(0);
                [t[k], t[(k + 1) % 3], t[(k + 2) % 3]]
            })
            .collect();
        // Sorted as stored, then turned for a mirroring node: a mirrored instance lists its
        // triangles in the same order as the original, so its cells are the mirror image.
        tris.sort_unstable();
        let winding = scene.winding(n);
        out.push((
            n,
            tris.into_iter()
                .map(|t| winding.order(t))
                .map(|t| {
                    t.map(|i| node.world.transform_point3(mesh.positions[i as usize]) - origin)
                })
                .collect(),
        ));
    }
    out
}
