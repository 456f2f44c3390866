//! The stage usd-core composed, as plain data, turned into a [`Scene`].
//!
//! Kept free of Python so the conversion rules can be tested on their own. USD differs from
//! glTF in ways that silently change a level if ignored: stages are often Z-up and in
//! centimetres (`upAxis`, `metersPerUnit`), faces are n-gons (concave ones included), some faces
//! are holes, and `orientation = "leftHanded"` flips which side a face's front is. All of that is
//! settled here, so every later stage sees glTF conventions: Y-up metres, triangles wound
//! counter-clockwise seen from the front.

use std::collections::{HashMap, HashSet};
use std::path::Path;

use glam::{DMat4, DVec3, DVec4};

use crate::diag::{Code, Diagnostic, Diagnostics, Location};
use crate::geom::triangulate::{triangulate_polygon, NotSimple};
use crate::import::Imported;
use crate::scene::{Format, Material, Mesh, MeshId, Node, Primitive, Scene, SourceRef};

/// The composed stage, as `helper.py` returns it.
#[derive(Debug, Clone, Default)]
pub(crate) struct RawStage {
    /// `upAxis` as composed ("Y" or "Z").
    pub up: String,
    /// `metersPerUnit` as composed (USD's fallback is 0.01).
    pub meters_per_unit: f64,
    /// Kept prims, parents before children.
    pub prims: Vec<RawPrim>,
    /// (prim path, name) of every bound material, indexed by [`RawMesh::face_materials`].
    pub materials: Vec<(String, String)>,
    /// (kind, prim path): things left out that the user should hear about.
    pub notes: Vec<(String, String)>,
}

#[derive(Debug, Clone, Default)]
pub(crate) struct RawPrim {
    pub path: String,
    /// The prim name, or its `displayName` when authored (USD names cannot hold `-` or spaces,
    /// so converters keep the original name there).
    pub name: String,
    /// Index of the nearest kept ancestor in [`RawStage::prims`].
    pub parent: Option<usize>,
    /// Local-to-world in stage units, USD layout (row vectors, row-major), which read
    /// column-major is the same matrix for column vectors.
    pub world: [f64; 16],
    /// Tags from customData and custom attributes, as JSON text.
    pub extras: Option<String>,
    /// Meshes with the same key share data (instance proxies of one prototype).
    pub mesh_key: Option<String>,
    /// The mesh data, sent the first time its key appears.
    pub mesh: Option<RawMesh>,
}

#[derive(Debug, Clone, Default)]
pub(crate) struct RawMesh {
    /// x, y, z per point, mesh-local, stage units.
    pub points: Vec<f32>,
    pub counts: Vec<i32>,
    pub indices: Vec<i32>,
    /// Faces that are holes: not drawn, so they bound nothing and block nothing.
    pub holes: Vec<i32>,
    pub left_handed: bool,
    /// Per face, an index into [`RawStage::materials`] or -1.
    pub face_materials: Option<Vec<i32>>,
}

fn prim_ref(path: &str) -> SourceRef {
    SourceRef {
        prim: Some(path.to_string()),
        ..Default::default()
    }
}

fn at(file: &Path, prim: &str) -> Location {
    Location::file(file).with_source(prim_ref(prim))
}

/// The rotation from the stage's up axis to glTF's +Y (Z-up: x stays, z becomes y, y becomes
/// -z; a proper rotation, so winding is unchanged).
fn up_rotation(up: &str) -> DMat4 {
    if up == "Z" {
        DMat4::from_cols(DVec4::X, DVec4::NEG_Z, DVec4::Y, DVec4::W)
    } else {
        DMat4::IDENTITY
    }
}

/// The node transform in metres, Y-up. The unit scale is put into the positions rather than
/// the matrix (`S·M = M'·S` for a uniform `S`, with `M'` = `M` whose translation is scaled), so
/// coordinates are metres everywhere and the tolerance derived from them means metres too.
fn world_matrix(raw: &[f64; 16], up: &DMat4, mpu: f64) -> DMat4 {
    let mut m = DMat4::from_cols_slice(raw);
    m.w_axis = (m.w_axis.truncate() * mpu).extend(m.w_axis.w);
    *up * m
}

/// Builds the scene; never fails (problems become diagnostics and the item is left out).
pub fn build(path: &Path, raw: RawStage) -> Imported {
    let mut diags = Diagnostics::default();
    let mut scene = Scene::new(path.to_path_buf(), Format::Usd);
    let (up, mpu) = stage_frame(path, &raw, &mut diags);
    for (p, name) in &raw.materials {
        scene.materials.push(Material {
            name: Some(name.clone()),
            extras: None,
            double_sided: true,
            source: prim_ref(p),
        });
    }
    let mut meshes: HashMap<String, Option<MeshId>> = HashMap::new();
    for prim in &raw.prims {
        let world = world_matrix(&prim.world, &up, mpu);
        let extras = prim
            .extras
            .as_deref()
            .and_then(|t| serde_json::from_str(t).ok());
        let id = scene.add_node(Node {
            name: Some(prim.name.clone()),
            parent: prim.parent,
            children: Vec::new(),
            world,
            mesh: None,
            extras,
            source: prim_ref(&prim.path),
        });
        let Some(key) = &prim.mesh_key else { continue };
        if let Some(m) = &prim.mesh {
            let built = build_mesh(m, mpu, scene.materials.len());
            let mesh = match built {
                Ok(b) => {
                    report_faces(path, prim, &scene.node_path(id), &b, &mut diags);
                    scene.meshes.push(Mesh {
                        name: Some(prim.name.clone()),
                        positions: b.positions,
                        triangles: b.triangles,
                        primitives: with_source(b.primitives, &prim.path),
                        extras: None,
                        source: prim_ref(&prim.path),
                    });
                    Some(scene.meshes.len() - 1)
                }
                Err(why) => {
                    diags.push(
                        Diagnostic::new(
                            Code::USD_MESH_INVALID,
                            format!("mesh `{}` was skipped: {why}", prim.path),
                            at(path, &prim.path).with_node(scene.node_path(id)),
                        )
                        .hint("the file is inconsistent; re-export the mesh"),
                    );
                    None
                }
            };
            meshes.insert(key.clone(), mesh);
        }
        let mesh = meshes.get(key).copied().flatten();
        if mesh.is_some() && !world.is_finite() {
            diags.push(
                Diagnostic::new(
                    Code::GEOM_NON_FINITE,
                    format!(
                        "the transform of `{}` is not finite; its mesh was dropped",
                        prim.path
                    ),
                    at(path, &prim.path).with_node(scene.node_path(id)),
                )
                .hint("fix the prim's xformOps (a NaN or infinite value) and re-export"),
            );
            continue;
        }
        scene.nodes[id].mesh = mesh;
    }
    report_notes(path, &raw.notes, &mut diags);
    Imported {
        scene,
        diagnostics: diags,
    }
}

/// The up rotation and metres per unit, falling back (and saying so) where the stage's
/// metadata cannot be used.
fn stage_frame(path: &Path, raw: &RawStage, diags: &mut Diagnostics) -> (DMat4, f64) {
    let mut mpu = raw.meters_per_unit;
    if !(mpu.is_finite() && mpu > 0.0) {
        diags.push(
            Diagnostic::new(
                Code::USD_UNITS_ASSUMED,
                format!("the stage's metersPerUnit is {mpu}, which is not a length; metres were assumed"),
                at(path, "/"),
            )
            .hint("author a positive `metersPerUnit` in the root layer's metadata"),
        );
        mpu = 1.0;
    }
    if raw.up != "Y" && raw.up != "Z" {
        diags.push(
            Diagnostic::new(
                Code::USD_UNITS_ASSUMED,
                format!(
                    "the stage's upAxis is `{}`; USD allows only Y or Z, so Y was assumed",
                    raw.up
                ),
                at(path, "/"),
            )
            .hint("author `upAxis = \"Y\"` or `\"Z\"` in the root layer's metadata"),
        );
    }
    (up_rotation(&raw.up), mpu)
}

fn with_source(mut prims: Vec<Primitive>, path: &str) -> Vec<Primitive> {
    for p in &mut prims {
        p.source = prim_ref(path);
    }
    prims
}

/// A mesh's triangles and what had to be left out of it.
#[derive(Debug, Default)]
pub(crate) struct BuiltMesh {
    pub positions: Vec<DVec3>,
    pub triangles: Vec<[u32; 3]>,
    pub primitives: Vec<Primitive>,
    /// Faces using a NaN or infinite point.
    pub non_finite_faces: usize,
    /// Faces with fewer than three corners.
    pub short_faces: usize,
    /// N-gons that are not simple polygons, fan-triangulated.
    pub not_simple: usize,
}

/// Why a mesh's arrays do not fit together (the mesh is skipped, `USD_MESH_INVALID`).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub(crate) enum StageError {
    /// `points` does not hold whole points.
    #[error("points holds {0} numbers, not a whole number of points")]
    PartialPoint(usize),
    /// More points than a `u32` index reaches.
    #[error("{0} points are more than portcullis indexes")]
    TooManyPoints(usize),
    /// A negative face size.
    #[error("faceVertexCounts holds {0}")]
    NegativeCount(i32),
    /// The face sizes do not add up to the corners given.
    #[error("faceVertexCounts add up to {corners} corners, but faceVertexIndices holds {indices}")]
    CornerCount {
        /// The sum of `faceVertexCounts`.
        corners: usize,
        /// The length of `faceVertexIndices`.
        indices: usize,
    },
    /// A corner names a point that does not exist.
    #[error("faceVertexIndices refers to point {index}, but the mesh has {points} points")]
    PointMissing {
        /// The index given.
        index: i32,
        /// The mesh's points.
        points: usize,
    },
}

/// Checks and triangulates one mesh; `Err` says why its arrays do not fit together.
pub(crate) fn build_mesh(
    m: &RawMesh,
    mpu: f64,
    material_count: usize,
) -> Result<BuiltMesh, StageError> {
    if m.points.len() % 3 != 0 {
        return Err(StageError::PartialPoint(m.points.len()));
    }
    let n_points = m.points.len() / 3;
    if n_points > u32::MAX as usize {
        return Err(StageError::TooManyPoints(n_points));
    }
    let mut corners = 0usize;
    for &c in &m.counts {
        let c = usize::try_from(c).map_err(|_| StageError::NegativeCount(c))?;
        corners = corners.saturating_add(c);
    }
    if corners != m.indices.len() {
        return Err(StageError::CornerCount {
            corners,
            indices: m.indices.len(),
        });
    }
    if let Some(&bad) = m
        .indices
        .iter()
        .find(|&&i| usize::try_from(i).map_or(true, |i| i >= n_points))
    {
        return Err(StageError::PointMissing {
            index: bad,
            points: n_points,
        });
    }
    let positions: Vec<DVec3> = m
        .points
        .chunks_exact(3)
        .map(|p| DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64) * mpu)
        .collect();
    let holes: HashSet<i32> = m.holes.iter().copied().collect();
    let materials = m
        .face_materials
        .as_ref()
        .filter(|f| f.len() == m.counts.len());
    let mut out = BuiltMesh {
        positions,
        ..Default::default()
    };
    let mut start = 0usize;
    let mut pts: Vec<DVec3> = Vec::new();
    for (f, &c) in m.counts.iter().enumerate() {
        let c = c as usize;
        let face: Vec<u32> = m.indices[start..start + c]
            .iter()
            .map(|&i| i as u32)
            .collect();
        start += c;
        if holes.contains(&(f as i32)) {
            continue;
        }
        if c < 3 {
            out.short_faces += 1;
            continue;
        }
        pts.clear();
        pts.extend(face.iter().map(|&i| out.positions[i as usize]));
        if pts.iter().any(|p| !p.is_finite()) {
            out.non_finite_faces += 1;
            continue;
        }
        let tris = if c == 3 {
            vec![[0, 1, 2]]
        } else {
            match triangulate_polygon(&pts) {
                Ok(t) => t,
                Err(e) => {
                    if e != NotSimple::Degenerate {
                        out.not_simple += 1;
                    }
                    (1..c - 1).map(|i| [0, i, i + 1]).collect()
                }
            }
        };
        let material = materials
            .map(|fm| fm[f])
            .and_then(|i| usize::try_from(i).ok())
            .filter(|&i| i < material_count);
        if out.primitives.last().is_none_or(|p| p.material != material) {
            out.primitives.push(Primitive {
                material,
                first_triangle: out.triangles.len(),
                triangle_count: 0,
                source: SourceRef::default(),
                file: None,
            });
        }
        for [a, b, c] in tris {
            let t = if m.left_handed {
                [face[a], face[c], face[b]]
            } else {
                [face[a], face[b], face[c]]
            };
            out.triangles.push(t);
        }
        if let Some(p) = out.primitives.last_mut() {
            p.triangle_count = out.triangles.len() - p.first_triangle;
        }
    }
    Ok(out)
}

fn report_faces(path: &Path, prim: &RawPrim, node: &str, b: &BuiltMesh, diags: &mut Diagnostics) {
    let loc = || at(path, &prim.path).with_node(node.to_string());
    if b.non_finite_faces > 0 {
        diags.push(
            Diagnostic::new(
                Code::GEOM_NON_FINITE,
                format!(
                    "mesh `{}`: {} face(s) use a NaN or infinite point and were dropped",
                    prim.path, b.non_finite_faces
                ),
                loc(),
            )
            .hint("fix or delete the points and re-export"),
        );
    }
    if b.not_simple > 0 {
        diags.push(
            Diagnostic::new(
                Code::USD_POLYGON_NOT_SIMPLE,
                format!(
                    "mesh `{}`: {} polygon face(s) are self-intersecting or far from flat; they \
                     were fan-triangulated, which may cover area outside the face",
                    prim.path, b.not_simple
                ),
                loc(),
            )
            .hint("split such faces into simple, flat polygons or triangulate before export"),
        );
    }
    if b.short_faces > 0 {
        diags.push(
            Diagnostic::new(
                Code::GEOM_DEGENERATE_TRIANGLES,
                format!(
                    "mesh `{}`: {} face(s) have fewer than three corners and were dropped",
                    prim.path, b.short_faces
                ),
                loc(),
            )
            .hint("such faces draw nothing; clean the mesh up in the modelling tool"),
        );
    }
}

/// One diagnostic per portal light, one summary per other kind of note.
fn report_notes(path: &Path, notes: &[(String, String)], diags: &mut Diagnostics) {
    let mut groups: Vec<(&str, Vec<&str>)> = Vec::new();
    for (kind, prim) in notes {
        if kind == "composition" {
            diags.push(
                Diagnostic::new(
                    Code::USD_COMPOSITION_ERROR,
                    format!("USD could not compose part of the stage: {prim}"),
                    Location::file(path),
                )
                .hint(
                    "what the reference, payload or sublayer holds is missing from the level; \
                     fix its path or copy the file next to the stage",
                ),
            );
            continue;
        }
        if kind == "portal_light" {
            diags.push(
                Diagnostic::new(
                    Code::USD_PORTAL_LIGHT_IGNORED,
                    format!(
                        "`{prim}` is a UsdLuxPortalLight, a light that guides dome-light \
                         sampling through an opening; it is not a visibility portal and was \
                         left out"
                    ),
                    at(path, prim),
                )
                .hint(
                    "to author a visibility portal, add a quad Mesh tagged as a portal (a \
                     `portal_` name or a `portcullis:portal` attribute)",
                ),
            );
            continue;
        }
        match groups.iter_mut().find(|(k, _)| *k == kind.as_str()) {
            Some((_, v)) => v.push(prim),
            None => groups.push((kind, vec![prim])),
        }
    }
    for (kind, prims) in groups {
        let first = prims[0];
        let n = prims.len();
        let d = if kind == "hidden" {
            Diagnostic::new(
                Code::USD_PRIMS_HIDDEN,
                format!(
                    "{n} prim(s) are invisible or have guide or proxy purpose and were left out \
                     with what is below them (first: `{first}`)"
                ),
                at(path, first),
            )
            .hint("make them visible with default or render purpose if they are level geometry")
        } else if kind == "units_default" {
            Diagnostic::new(
                Code::USD_UNITS_ASSUMED,
                "the stage does not author metersPerUnit, which USD then takes as centimetres; \
                 coordinates were scaled by 0.01",
                at(path, "/"),
            )
            .hint(
                "author `metersPerUnit = 1` in the root layer's metadata if the level is in metres",
            )
        } else if let Some(ty) = kind.strip_prefix("gprim:") {
            Diagnostic::new(
                Code::USD_GPRIM_UNSUPPORTED,
                format!(
                    "{n} {ty} prim(s) were left out: only Mesh prims are read (first: `{first}`)"
                ),
                at(path, first),
            )
            .hint("convert them to meshes in the modelling tool if they bound or block anything")
        } else {
            continue;
        };
        diags.push(d);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn quad_mesh() -> RawMesh {
        RawMesh {
            points: vec![0., 0., 0., 1., 0., 0., 1., 1., 0., 0., 1., 0.],
            counts: vec![4],
            indices: vec![0, 1, 2, 3],
            ..Default::default()
        }
    }

    fn normal(b: &BuiltMesh, t: usize) -> DVec3 {
        let [a, c, d] = b.triangles[t].map(|i| b.positions[i as usize]);
        (c - a).cross(d - a)
    }

    #[test]
    fn left_handed_flips_winding() {
        let right = build_mesh(&quad_mesh(), 1.0, 0).unwrap();
        let mut m = quad_mesh();
        m.left_handed = true;
        let left = build_mesh(&m, 1.0, 0).unwrap();
        assert_eq!(right.triangles.len(), 2);
        assert!(normal(&right, 0).z > 0.0);
        assert!(normal(&left, 0).z < 0.0);
    }

    #[test]
    fn concave_ngon_is_ear_clipped_and_holes_skipped() {
        // An L: a fan from corner 0 would cover the notch.
        let m = RawMesh {
            points: vec![
                0., 0., 0., 2., 0., 0., 2., 1., 0., 1., 1., 0., 1., 2., 0., 0., 2., 0.,
            ],
            counts: vec![6, 3],
            indices: vec![0, 1, 2, 3, 4, 5, 0, 1, 2],
            holes: vec![1],
            ..Default::default()
        };
        let b = build_mesh(&m, 1.0, 0).unwrap();
        assert_eq!(b.triangles.len(), 4);
        let area: f64 = (0..4).map(|t| normal(&b, t).length() / 2.0).sum();
        assert!((area - 3.0).abs() < 1e-12, "{area}");
    }

    #[test]
    fn inconsistent_arrays_are_refused() {
        let mut m = quad_mesh();
        m.indices.push(0);
        let e = build_mesh(&m, 1.0, 0).unwrap_err();
        assert_eq!(
            e,
            StageError::CornerCount {
                corners: 4,
                indices: 5
            }
        );
        assert!(e.to_string().contains("add up to 4"));
        let mut m = quad_mesh();
        m.indices[3] = 7;
        let e = build_mesh(&m, 1.0, 0).unwrap_err();
        assert!(e.to_string().contains("point 7"), "{e}");
        let mut m = quad_mesh();
        m.counts[0] = -4;
        assert_eq!(
            build_mesh(&m, 1.0, 0).unwrap_err(),
            StageError::NegativeCount(-4)
        );
    }

    #[test]
    fn z_up_centimetres_become_y_up_metres() {
        let up = up_rotation("Z");
        let mut raw = [0.0; 16];
        // identity with a translation of 100 units up (stage z)
        for i in 0..4 {
            raw[i * 5] = 1.0;
        }
        raw[14] = 100.0;
        let w = world_matrix(&raw, &up, 0.01);
        let p = w.transform_point3(DVec3::new(0.0, 0.0, 1.0));
        // Positions are scaled in build_mesh; the translation here.
        assert!((p - DVec3::new(0.0, 2.0, 0.0)).length() < 1e-12, "{p}");
        assert!((w.determinant() - 1.0).abs() < 1e-12);
    }
}
