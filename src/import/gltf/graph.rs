//! The glTF node hierarchy to scene nodes with f64 world transforms.
//!
//! Transforms are read as f64 straight from the JSON numbers (gltf-json would round them to
//! f32), because levels are often kilometres wide and f32 loses millimetres there. The hierarchy
//! is validated up front (one parent per node, no cycles) and walked with an explicit stack, so
//! a hostile file can neither loop forever nor overflow the call stack.

use glam::{DMat4, DQuat, DVec3};

use super::mesh::{Builder, Tally};
use super::schema::{index, Doc, Node as GNode};
use super::Ctx;
use crate::diag::{Code, Diagnostic, Diagnostics};
use crate::scene::{MeshId, Node, NodeId, Scene, SourceRef};

pub fn build(
    ctx: &Ctx,
    doc: &Doc,
    scene: &mut Scene,
    meshes: &Builder<'_>,
    tally: &mut Tally,
    diagnostics: &mut Diagnostics,
) -> Result<(), Diagnostic> {
    let parents = parents(ctx, doc)?;
    let roots = scene_roots(ctx, doc, &parents, diagnostics)?;
    // Meshes are numbered where a node first uses them, and built on every thread while this
    // one walks the nodes (a big level has tens of thousands of each). A mesh that fails is
    // reported before whatever stops the walk after its first use, as building meshes one by
    // one during the walk would: the walk says how far it got (`walked` meshes), and a failed
    // mesh counts only if it is among those.
    let order = mesh_order(doc, &roots);
    let (walked, built) = rayon::join(
        || {
            let mut walked = Vec::new();
            let r = walk(ctx, doc, scene, &roots, &mut walked, diagnostics);
            debug_assert_eq!(walked[..], order[..walked.len()]);
            (walked.len(), r)
        },
        || meshes.build_all(&order, tally),
    );
    let (walked, result) = walked;
    match built {
        Ok(built) => scene.meshes = built,
        Err((k, e)) if k < walked => return Err(e),
        Err(_) => {}
    }
    result
}

/// The glTF meshes in the order the walk first meets them (the nodes depth first from the
/// roots, children in order), each once; a node's mesh that does not exist is passed over
/// (the walk stops there).
fn mesh_order(doc: &Doc, roots: &[usize]) -> Vec<usize> {
    let mut seen = vec![false; doc.meshes.len()];
    let mut visited = vec![false; doc.nodes.len()];
    let mut order = Vec::new();
    let mut stack: Vec<usize> = roots.iter().rev().copied().collect();
    while let Some(n) = stack.pop() {
        let (Some(node), Some(v)) = (doc.nodes.get(n), visited.get_mut(n)) else {
            continue;
        };
        if std::mem::replace(v, true) {
            continue;
        }
        if let Some(mi) = node.mesh.and_then(|m| index(m, doc.meshes.len())) {
            if !std::mem::replace(&mut seen[mi], true) {
                order.push(mi);
            }
        }
        stack.extend(
            node.children
                .iter()
                .rev()
                .filter_map(|&c| index(c, doc.nodes.len())),
        );
    }
    order
}

/// The nodes, with mesh ids given in order of first use (`order` gets the glTF mesh of each).
fn walk(
    ctx: &Ctx,
    doc: &Doc,
    scene: &mut Scene,
    roots: &[usize],
    order: &mut Vec<usize>,
    diagnostics: &mut Diagnostics,
) -> Result<(), Diagnostic> {
    let mut mesh_ids: Vec<Option<MeshId>> = vec![None; doc.meshes.len()];
    let mut gpu_instanced = 0usize;
    let mut first_gpu_instanced = None;
    // (glTF node, scene parent, parent's world transform)
    let mut stack: Vec<(usize, Option<NodeId>, DMat4)> = roots
        .iter()
        .rev()
        .map(|&r| (r, None, DMat4::IDENTITY))
        .collect();
    let mut visited = vec![false; doc.nodes.len()];
    // Exact room: a big level has tens of thousands of each.
    scene.nodes.reserve_exact(doc.nodes.len());
    while let Some((n, parent, parent_world)) = stack.pop() {
        let (Some(node), Some(seen)) = (doc.nodes.get(n), visited.get_mut(n)) else {
            continue;
        };
        if std::mem::replace(seen, true) {
            // Cannot happen after the checks in `parents`/`scene_roots`; never import twice.
            continue;
        }
        let np = format!("/nodes/{n}");
        let world = parent_world * local_transform(ctx, node, &np)?;
        if !world.is_finite() {
            return Err(ctx
                .diag(
                    Code::GLTF_TRANSFORM_INVALID,
                    np,
                    format!(
                        "the world transform of node {n}{} is not finite (its transforms multiply to overflow)",
                        name_suffix(node)
                    ),
                )
                .hint("apply (freeze) the transforms in the modelling tool and export again"));
        }
        let mesh = match node.mesh {
            None => None,
            Some(m) => {
                let Some(mi) = index(m, doc.meshes.len()) else {
                    return Err(ctx
                        .diag(
                            Code::GLTF_BAD_INDEX,
                            format!("{np}/mesh"),
                            format!(
                                "node {n}{} uses mesh {m}, which does not exist (the file has {})",
                                name_suffix(node),
                                doc.meshes.len()
                            ),
                        )
                        .hint(super::VALIDATOR_HINT));
                };
                match mesh_ids.get(mi).copied().flatten() {
                    Some(id) => Some(id),
                    None => {
                        let id = order.len();
                        order.push(mi);
                        if let Some(slot) = mesh_ids.get_mut(mi) {
                            *slot = Some(id);
                        }
                        Some(id)
                    }
                }
            }
        };
        if node
            .extensions
            .as_ref()
            .is_some_and(|e| e.contains_key("EXT_mesh_gpu_instancing"))
        {
            gpu_instanced += 1;
            first_gpu_instanced.get_or_insert_with(|| np.clone());
        }
        let id = scene.add_node(Node {
            name: node.name.clone(),
            parent,
            children: Vec::new(),
            world,
            mesh,
            extras: node.extras.clone(),
            source: SourceRef::pointer(np),
        });
        for &c in node.children.iter().rev() {
            // Indices were checked in `parents`.
            if let Some(c) = index(c, doc.nodes.len()) {
                stack.push((c, Some(id), world));
            }
        }
    }
    if let Some(first) = first_gpu_instanced {
        diagnostics.push(
            ctx.diag(
                Code::GLTF_EXTENSION_IGNORED,
                first,
                format!(
                    "{gpu_instanced} node(s) use EXT_mesh_gpu_instancing (first shown); only each node's own mesh was imported, not its GPU instances"
                ),
            )
            .hint("realise the instances as separate nodes before export if they matter to the level"),
        );
    }
    Ok(())
}

/// Each node's parent, after checking that child indices exist, no node has two parents and the
/// parent links form no cycle.
fn parents(ctx: &Ctx, doc: &Doc) -> Result<Vec<Option<usize>>, Diagnostic> {
    const HINT: &str =
        "the node hierarchy must be a tree; the exporter is buggy or the file was edited by hand";
    let n = doc.nodes.len();
    let mut parent: Vec<Option<usize>> = vec![None; n];
    for (i, node) in doc.nodes.iter().enumerate() {
        for (k, &c) in node.children.iter().enumerate() {
            // Only a problem needs the pointer (a big level has tens of thousands of children).
            let cp = || format!("/nodes/{i}/children/{k}");
            let Some(ci) = index(c, n) else {
                return Err(ctx
                    .diag(
                        Code::GLTF_BAD_INDEX,
                        cp(),
                        format!("node {i} lists child {c}, which does not exist (the file has {n} nodes)"),
                    )
                    .hint(super::VALIDATOR_HINT));
            };
            if ci == i {
                return Err(ctx
                    .diag(
                        Code::GLTF_NODE_CYCLE,
                        cp(),
                        format!("node {i} lists itself as its child"),
                    )
                    .hint(HINT));
            }
            let Some(slot) = parent.get_mut(ci) else {
                continue;
            };
            if let Some(p) = *slot {
                let msg = if p == i {
                    format!("node {i} lists child {ci} twice")
                } else {
                    format!("node {ci} has two parents, nodes {p} and {i}")
                };
                return Err(ctx.diag(Code::GLTF_NODE_CYCLE, cp(), msg).hint(HINT));
            }
            *slot = Some(i);
        }
    }
    // With one parent per node, a cycle is a parent chain that returns to a node on it.
    const NEW: u8 = 0;
    const ON_PATH: u8 = 1;
    const DONE: u8 = 2;
    let mut state = vec![NEW; n];
    let mut path = Vec::new();
    for start in 0..n {
        let mut cur = start;
        path.clear();
        let cycle = loop {
            match state.get(cur).copied() {
                Some(NEW) => {}
                Some(ON_PATH) => break Some(cur),
                _ => break None,
            }
            if let Some(s) = state.get_mut(cur) {
                *s = ON_PATH;
            }
            path.push(cur);
            match parent.get(cur).copied().flatten() {
                Some(p) => cur = p,
                None => break None,
            }
        };
        for &p in &path {
            if let Some(s) = state.get_mut(p) {
                *s = DONE;
            }
        }
        if let Some(c) = cycle {
            return Err(ctx
                .diag(
                    Code::GLTF_NODE_CYCLE,
                    format!("/nodes/{c}/children"),
                    format!("node {c} is its own ancestor: the hierarchy has a cycle"),
                )
                .hint(HINT));
        }
    }
    Ok(parent)
}

/// The root nodes to import: the default scene's, the first scene's, or (no scenes at all)
/// every node without a parent.
fn scene_roots(
    ctx: &Ctx,
    doc: &Doc,
    parents: &[Option<usize>],
    diagnostics: &mut Diagnostics,
) -> Result<Vec<usize>, Diagnostic> {
    let (s, scene) = match doc.scene {
        Some(s) => match index(s, doc.scenes.len()).and_then(|i| Some((i, doc.scenes.get(i)?))) {
            Some(found) => found,
            None => {
                return Err(ctx
                    .diag(
                        Code::GLTF_BAD_INDEX,
                        "/scene",
                        format!(
                            "the default scene {s} does not exist (the file has {})",
                            doc.scenes.len()
                        ),
                    )
                    .hint(super::VALIDATOR_HINT));
            }
        },
        None => match doc.scenes.first() {
            Some(scene) => (0, scene),
            None => {
                let roots: Vec<usize> = (0..doc.nodes.len())
                    .filter(|&i| parents.get(i).copied().flatten().is_none())
                    .filter(|i| doc.parts.binary_search(i).is_err())
                    .collect();
                if !roots.is_empty() {
                    diagnostics.push(
                        ctx.file_diag(
                            Code::GLTF_NO_SCENE,
                            format!(
                                "the file defines no scene; all {} root node(s) were imported",
                                roots.len()
                            ),
                        )
                        .hint("export with a scene so it is clear which nodes make up the level"),
                    );
                }
                return Ok(roots);
            }
        },
    };
    let mut roots = Vec::with_capacity(scene.nodes.len());
    let mut listed = vec![false; doc.nodes.len()];
    for (k, &r) in scene.nodes.iter().enumerate() {
        let rp = format!("/scenes/{s}/nodes/{k}");
        let Some(ri) = index(r, doc.nodes.len()) else {
            return Err(ctx
                .diag(
                    Code::GLTF_BAD_INDEX,
                    rp,
                    format!(
                        "scene {s} lists node {r}, which does not exist (the file has {} nodes)",
                        doc.nodes.len()
                    ),
                )
                .hint(super::VALIDATOR_HINT));
        };
        if let Some(p) = parents.get(ri).copied().flatten() {
            return Err(ctx
                .diag(
                    Code::GLTF_NODE_CYCLE,
                    rp,
                    format!("scene {s} lists node {ri} as a root, but it is a child of node {p}"),
                )
                .hint(super::VALIDATOR_HINT));
        }
        if listed.get(ri).copied().unwrap_or(false) {
            return Err(ctx
                .diag(
                    Code::GLTF_NODE_CYCLE,
                    rp,
                    format!("scene {s} lists node {ri} twice"),
                )
                .hint(super::VALIDATOR_HINT));
        }
        if let Some(l) = listed.get_mut(ri) {
            *l = true;
        }
        roots.push(ri);
    }
    Ok(roots)
}

fn name_suffix(node: &GNode) -> String {
    match &node.name {
        Some(n) => format!(" `{n}`"),
        None => String::new(),
    }
}

/// The node's local transform: `matrix` if given, else translation * rotation * scale.
fn local_transform<'n>(ctx: &Ctx, node: &'n GNode, np: &str) -> Result<DMat4, Diagnostic> {
    let invalid = |field: &str, msg: String| {
        ctx.diag(Code::GLTF_TRANSFORM_INVALID, format!("{np}/{field}"), msg)
            .hint("fix the node's transform in the modelling tool (apply/freeze transforms) and export again")
    };
    let array = |field: &str,
                 v: &'n Option<Vec<f64>>,
                 len: usize|
     -> Result<Option<&'n [f64]>, Diagnostic> {
        match v {
            None => Ok(None),
            Some(v) if v.len() != len => Err(ctx
                .diag(
                    Code::GLTF_INVALID_JSON,
                    format!("{np}/{field}"),
                    format!(
                        "`{field}` of node {np} has {} numbers; it must have {len}",
                        v.len()
                    ),
                )
                .hint(super::VALIDATOR_HINT)),
            Some(v) if v.iter().any(|x| !x.is_finite()) => Err(invalid(
                field,
                format!("`{field}` of node {np}{} is not finite", name_suffix(node)),
            )),
            Some(v) => Ok(Some(v.as_slice())),
        }
    };
    if let Some(m) = array("matrix", &node.matrix, 16)? {
        let cols: [f64; 16] = m
            .try_into()
            .map_err(|_| invalid("matrix", "matrix must have 16 numbers".into()))?;
        return Ok(DMat4::from_cols_array(&cols));
    }
    let v3 = |v: Option<&[f64]>, default: DVec3| match v {
        Some(&[x, y, z]) => DVec3::new(x, y, z),
        _ => default,
    };
    let t = v3(array("translation", &node.translation, 3)?, DVec3::ZERO);
    let s = v3(array("scale", &node.scale, 3)?, DVec3::ONE);
    let r = match array("rotation", &node.rotation, 4)? {
        Some(&[x, y, z, w]) => {
            let q = DQuat::from_xyzw(x, y, z, w);
            let len = q.length();
            // Exporters write quaternions rounded to f32; renormalising keeps them a pure
            // rotation instead of a slight scale.
            if !(len.is_finite() && len > 1e-12) {
                return Err(invalid(
                    "rotation",
                    format!(
                        "the rotation of node {np}{} is a zero quaternion",
                        name_suffix(node)
                    ),
                ));
            }
            q / len
        }
        _ => DQuat::IDENTITY,
    };
    Ok(DMat4::from_scale_rotation_translation(s, r, t))
}
