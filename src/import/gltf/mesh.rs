//! glTF meshes to scene meshes: every triangle primitive's positions concatenated, its triangles
//! listed in a [`Primitive`] run.
//!
//! Problems in the geometry itself (non-finite positions, degenerate triangles, point and line
//! primitives) do not stop the import: the level is still worth checking, so the offending
//! triangles are dropped and reported. Structural problems (an index past the vertex count)
//! mean the file cannot be trusted and are fatal.

use super::accessor::Reader;
use super::schema::{index, Doc};
use super::Ctx;
use crate::diag::{Code, Diagnostic, Diagnostics};
use crate::scene::{FileTriangles, Mesh, Primitive, SourceRef};

/// One POSITION accessor's vertices as stored in the mesh: glTF vertex index to mesh index,
/// `None` for a dropped non-finite vertex.
struct Vertices {
    remap: Remap,
    bad: usize,
    first_bad: Option<(usize, glam::DVec3)>,
}

/// glTF vertex index to mesh index.
enum Remap {
    /// The accessor's vertices are the mesh's, all finite (nearly every mesh): no table.
    Same(usize),
    /// `None` for a dropped vertex.
    Table(Vec<Option<u32>>),
}

impl Remap {
    fn len(&self) -> usize {
        match self {
            Remap::Same(n) => *n,
            Remap::Table(t) => t.len(),
        }
    }

    fn get(&self, i: u32) -> Option<u32> {
        match self {
            Remap::Same(n) => ((i as usize) < *n).then_some(i),
            Remap::Table(t) => t.get(i as usize).copied().flatten(),
        }
    }
}

/// How a diagnostic names a mesh (written out only for one).
struct Label<'a>(Option<&'a str>, &'a str);

impl std::fmt::Display for Label<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        match self.0 {
            Some(n) => write!(f, "mesh `{n}` ({})", self.1),
            None => write!(f, "mesh {}", self.1),
        }
    }
}

/// Builds scene meshes; shared by the threads that build them (see [`Builder::build_all`]).
pub struct Builder<'a> {
    ctx: &'a Ctx,
    doc: &'a Doc,
    reader: Reader<'a>,
}

/// What building meshes dropped and found, added up in mesh order so the report does not depend
/// on which thread built which mesh.
#[derive(Default)]
pub struct Tally {
    found: Vec<Diagnostic>,
    non_triangles: usize,
    first_non_triangles: Option<String>,
    degenerate: usize,
    first_degenerate: Option<String>,
}

impl Tally {
    fn add(&mut self, o: Tally) {
        self.found.extend(o.found);
        self.non_triangles += o.non_triangles;
        if let Some(f) = o.first_non_triangles {
            self.first_non_triangles.get_or_insert(f);
        }
        self.degenerate += o.degenerate;
        if let Some(f) = o.first_degenerate {
            self.first_degenerate.get_or_insert(f);
        }
    }
}

impl<'a> Builder<'a> {
    pub fn new(ctx: &'a Ctx, doc: &'a Doc, reader: Reader<'a>) -> Self {
        Builder { ctx, doc, reader }
    }

    /// The scene meshes of glTF meshes `order` (which the caller has checked exist), built on
    /// every thread, with what they dropped added to `tally` in that order; or the error the
    /// first of them to fail gives, and its place in `order`, as building them one by one in
    /// that order would.
    pub(crate) fn build_all(
        &self,
        order: &[usize],
        tally: &mut Tally,
    ) -> Result<Vec<Mesh>, (usize, Diagnostic)> {
        use rayon::prelude::*;
        // Each mesh is built into its slot, in runs on every thread, each run stopping at its
        // first failure (so the first run that failed holds the first failure in order). The
        // slots become the list in place, so a big level's meshes are never held twice.
        const RUN: usize = 512;
        let mut slots: Vec<Option<Mesh>> = Vec::with_capacity(order.len());
        slots.resize_with(order.len(), || None);
        let runs: Vec<(Option<(usize, Diagnostic)>, Tally)> = slots
            .par_chunks_mut(RUN)
            .zip(order.par_chunks(RUN))
            .enumerate()
            .map(|(r, (slots, run))| {
                let mut t = Tally::default();
                for (k, (slot, &m)) in slots.iter_mut().zip(run).enumerate() {
                    match self.build(m, &mut t) {
                        Ok(mesh) => *slot = Some(mesh),
                        Err(e) => return (Some((r * RUN + k, e)), t),
                    }
                }
                (None, t)
            })
            .collect();
        if self.reader.exhausted() {
            // Which mesh runs out of the read budget depends on the order of the reads:
            // read again one by one, in order, so the same mesh is blamed every time.
            drop(slots);
            self.reader.reset();
            return order
                .iter()
                .enumerate()
                .map(|(k, &m)| self.build(m, tally).map_err(|e| (k, e)))
                .collect();
        }
        for (failed, t) in runs {
            tally.add(t);
            if let Some(e) = failed {
                return Err(e);
            }
        }
        // `filter_map` collects in place (`flatten` would allocate the list a second time).
        #[allow(clippy::filter_map_identity)]
        let out: Vec<Mesh> = slots.into_iter().filter_map(|m| m).collect();
        Ok(out)
    }

    /// Builds the scene mesh of glTF mesh `m`, which the caller has checked exists.
    fn build(&self, m: usize, tally: &mut Tally) -> Result<Mesh, Diagnostic> {
        let mp = format!("/meshes/{m}");
        let Some(mesh) = self.doc.meshes.get(m) else {
            return Err(self.ctx.diag(
                Code::GLTF_BAD_INDEX,
                mp,
                format!("mesh {m} does not exist"),
            ));
        };
        let label = Label(mesh.name.as_deref(), &mp);
        let Some(prims) = &mesh.primitives else {
            return Err(self
                .ctx
                .diag(
                    Code::GLTF_INVALID_JSON,
                    format!("{mp}/primitives"),
                    format!("{label} has no `primitives`"),
                )
                .hint(super::VALIDATOR_HINT));
        };
        let mut b = MeshBuild {
            label,
            shared: Vec::new(),
            out: Mesh {
                name: mesh.name.clone(),
                positions: Vec::new(),
                triangles: Vec::new(),
                primitives: Vec::with_capacity(prims.len()),
                extras: mesh.extras.clone(),
                source: SourceRef::pointer(mp.clone()),
            },
        };
        for (p, prim) in prims.iter().enumerate() {
            self.primitive(p, prim, &mut b, tally)?;
        }
        Ok(b.out)
    }

    /// Adds primitive `p` of the mesh being built: its vertices (once per POSITION accessor)
    /// and its triangles, as one [`Primitive`] run. Points, lines and primitives without
    /// POSITION add nothing.
    fn primitive(
        &self,
        p: usize,
        prim: &super::schema::Primitive,
        b: &mut MeshBuild,
        tally: &mut Tally,
    ) -> Result<(), Diagnostic> {
        let label = &b.label;
        let pp = format!("{}/primitives/{p}", label.1);
        let mode = prim.mode.unwrap_or(4);
        match mode {
            0..=3 => {
                tally.non_triangles += 1;
                tally.first_non_triangles.get_or_insert(pp);
                return Ok(());
            }
            4..=6 => {}
            _ => {
                return Err(self
                    .ctx
                    .diag(
                        Code::GLTF_INVALID_JSON,
                        format!("{pp}/mode"),
                        format!("primitive {p} of {label} has mode {mode}, which is not a glTF primitive mode (0-6)"),
                    )
                    .hint(super::VALIDATOR_HINT));
            }
        }
        let material = match prim.material {
            None => None,
            Some(x) => Some(index(x, self.doc.materials.len()).ok_or_else(|| {
                self.ctx
                    .diag(
                        Code::GLTF_BAD_INDEX,
                        format!("{pp}/material"),
                        format!(
                            "material {x} does not exist (the file has {})",
                            self.doc.materials.len()
                        ),
                    )
                    .hint(super::VALIDATOR_HINT)
            })?),
        };
        let Some(attributes) = &prim.attributes else {
            return Err(self
                .ctx
                .diag(
                    Code::GLTF_INVALID_JSON,
                    format!("{pp}/attributes"),
                    format!("primitive {p} of {label} has no `attributes`"),
                )
                .hint(super::VALIDATOR_HINT));
        };
        // glTF lets a primitive omit POSITION (an extension may supply it); without it there
        // is nothing to bound space with, so it is passed over like a renderer would.
        let Some(pos_acc) = attributes.position else {
            return Ok(());
        };
        // Primitives of one mesh often share their POSITION accessor (one per material);
        // its vertices are stored once and each primitive indexes into them.
        if !b.shared.iter().any(|(a, _)| *a == pos_acc) {
            let vertices = self.vertices(pos_acc, &pp, &mut b.out)?;
            b.shared.push((pos_acc, vertices));
        }
        let Some((_, vertices)) = b.shared.iter().find(|(a, _)| *a == pos_acc) else {
            return Ok(());
        };
        let indices = self.indices(prim, p, &pp, label, vertices.remap.len())?;
        let out = &mut b.out;
        let first_triangle = out.triangles.len();
        let (dropped, degenerate, file) = add_triangles(mode, &indices, vertices, out);
        if degenerate > 0 {
            tally.degenerate += degenerate;
            tally.first_degenerate.get_or_insert_with(|| pp.clone());
        }
        if let Some((i, v)) = vertices.first_bad {
            let bad = vertices.bad;
            tally.found.push(
                self.ctx
                    .diag(
                        Code::GEOM_NON_FINITE,
                        format!("/accessors/{pos_acc}"),
                        format!(
                            "{bad} POSITION value(s) of accessor /accessors/{pos_acc} used by primitive {p} of {label} are NaN or infinite (first: vertex {i} = {v}); the {dropped} triangle(s) using them were dropped"
                        ),
                    )
                    .hint("fix or delete those vertices in the modelling tool and export again"),
            );
        }
        out.primitives.push(Primitive {
            material,
            first_triangle,
            triangle_count: out.triangles.len() - first_triangle,
            source: SourceRef::pointer(pp),
            file: Some(Box::new(file)),
        });
        Ok(())
    }

    /// Reads POSITION accessor `pos_acc` (for primitive pointer `pp`) into `out`'s positions,
    /// and says where each of its vertices went.
    fn vertices(&self, pos_acc: u64, pp: &str, out: &mut Mesh) -> Result<Vertices, Diagnostic> {
        let positions = self
            .reader
            .positions(pos_acc, &format_args!("{pp}/attributes/POSITION"))?;
        let whole = out.positions.is_empty()
            && u32::try_from(positions.len()).is_ok()
            && positions.iter().all(|v| v.is_finite());
        if whole {
            // The mesh's first accessor, all finite: its list becomes the mesh's.
            let n = positions.len();
            out.positions = positions;
            return Ok(Vertices {
                remap: Remap::Same(n),
                bad: 0,
                first_bad: None,
            });
        }
        // Non-finite vertices are left out of the mesh so every stored position
        // is finite. Exact room (not doubling growth): on a big level these are
        // most of the scene.
        out.positions.reserve_exact(positions.len());
        let mut remap = Vec::with_capacity(positions.len());
        let (mut bad, mut first_bad) = (0, None);
        for (i, v) in positions.iter().enumerate() {
            if v.is_finite() {
                let id = u32::try_from(out.positions.len()).map_err(|_| self.too_many(pp))?;
                remap.push(Some(id));
                out.positions.push(*v);
            } else {
                remap.push(None);
                bad += 1;
                first_bad.get_or_insert((i, *v));
            }
        }
        Ok(Vertices {
            remap: Remap::Table(remap),
            bad,
            first_bad,
        })
    }

    /// The primitive's vertex indices (all `n` vertices in order when it has none); an index
    /// past the vertex count means the file is damaged, which is fatal.
    fn indices(
        &self,
        prim: &super::schema::Primitive,
        p: usize,
        pp: &str,
        label: &Label,
        n: usize,
    ) -> Result<Vec<u32>, Diagnostic> {
        match prim.indices {
            Some(a) => {
                let idx = self.reader.indices(a, &format_args!("{pp}/indices"))?;
                if let Some((k, &v)) = idx.iter().enumerate().find(|(_, &v)| v as usize >= n) {
                    return Err(self
                        .ctx
                        .diag(
                            Code::MESH_INDEX_OUT_OF_RANGE,
                            pp,
                            format!("primitive {p} of {label}: index {v} (element {k} of accessor /accessors/{a}) is not below its vertex count {n}"),
                        )
                        .hint("the file is damaged or the exporter is buggy; export it again"));
                }
                Ok(idx)
            }
            None => {
                let n = u32::try_from(n).map_err(|_| self.too_many(pp))?;
                Ok((0..n).collect())
            }
        }
    }

    fn too_many(&self, pp: &str) -> Diagnostic {
        self.ctx.diag(
            Code::GLTF_ACCESSOR_INVALID,
            pp,
            "the mesh has more than 2^32 vertices, more than a glTF index can address",
        )
    }

    /// Reports what was dropped across the whole file, once per kind, so a level with thousands
    /// of line primitives does not drown the other findings.
    pub fn finish(&self, tally: Tally, diagnostics: &mut Diagnostics) {
        diagnostics.extend(tally.found);
        if let Some(first) = tally.first_non_triangles {
            diagnostics.push(
                self.ctx
                    .diag(
                        Code::GLTF_NON_TRIANGLES_SKIPPED,
                        first,
                        format!(
                            "{} point or line primitive(s) were skipped (first shown); they bound no space",
                            tally.non_triangles
                        ),
                    )
                    .hint("nothing to do unless those primitives were meant to be surfaces"),
            );
        }
        if let Some(first) = tally.first_degenerate {
            diagnostics.push(
                self.ctx
                    .diag(
                        Code::GEOM_DEGENERATE_TRIANGLES,
                        first,
                        format!(
                            "{} degenerate triangle(s) (a vertex index repeated) were dropped (first primitive shown)",
                            tally.degenerate
                        ),
                    )
                    .hint("harmless; Blender's Mesh > Clean Up > Delete Loose/Degenerate removes them at the source"),
            );
        }
    }
}

/// The mesh being built from a glTF mesh's primitives, with what it needs between them.
struct MeshBuild<'m> {
    label: Label<'m>,
    /// The POSITION accessors read so far and where their vertices went.
    shared: Vec<(u64, Vertices)>,
    out: Mesh,
}

/// Adds the triangles `mode` makes of `indices` to `out`, through the vertices' remap;
/// returns how many were dropped for a non-finite vertex and how many were degenerate
/// (a corner repeated), which are reported, not stored.
fn add_triangles(
    mode: u64,
    indices: &[u32],
    vertices: &Vertices,
    out: &mut Mesh,
) -> (usize, usize, FileTriangles) {
    let count = match mode {
        4 => indices.len() / 3,
        _ => indices.len().saturating_sub(2),
    };
    out.triangles.reserve_exact(count);
    let mut file = FileTriangles {
        triangles: Vec::with_capacity(count),
        scene: Vec::with_capacity(count),
    };
    let mut dropped = 0usize;
    let mut degenerate = 0usize;
    for [a, b, c] in assemble(mode, indices) {
        file.triangles.push([a, b, c]);
        if a == b || b == c || a == c {
            degenerate += 1;
            file.scene.push(u32::MAX);
            continue;
        }
        let r = |i: u32| vertices.remap.get(i);
        match (r(a), r(b), r(c)) {
            (Some(a), Some(b), Some(c)) => {
                file.scene.push(out.triangles.len() as u32);
                out.triangles.push([a, b, c]);
            }
            _ => {
                dropped += 1;
                file.scene.push(u32::MAX);
            }
        }
    }
    (dropped, degenerate, file)
}

/// Triangles of an index list in `mode` 4 (list), 5 (strip) or 6 (fan), following the vertex
/// order the glTF 2.0 specification gives (§3.7.2.1), so every triangle keeps its facing.
pub(crate) fn assemble(mode: u64, idx: &[u32]) -> impl Iterator<Item = [u32; 3]> + '_ {
    let (list, strip, fan) = match mode {
        5 => (None, Some(idx), None),
        6 => (None, None, idx.split_first()),
        _ => (Some(idx), None, None),
    };
    let list = list.into_iter().flat_map(|idx| {
        idx.chunks_exact(3).filter_map(|c| match *c {
            [a, b, c] => Some([a, b, c]),
            _ => None,
        })
    });
    let strip = strip.into_iter().flat_map(|idx| {
        idx.windows(3).enumerate().filter_map(|(i, w)| match *w {
            [a, b, c] if i % 2 == 0 => Some([a, b, c]),
            [a, b, c] => Some([a, c, b]),
            _ => None,
        })
    });
    let fan = fan.into_iter().flat_map(|(&v0, rest)| {
        rest.windows(2).filter_map(move |w| match *w {
            [b, c] => Some([b, c, v0]),
            _ => None,
        })
    });
    list.chain(strip).chain(fan)
}

#[cfg(test)]
mod tests {
    use super::assemble;

    #[test]
    fn strip_alternates_winding() {
        assert_eq!(
            assemble(5, &[0, 1, 2, 3, 4]).collect::<Vec<_>>(),
            vec![[0, 1, 2], [1, 3, 2], [2, 3, 4]]
        );
    }

    #[test]
    fn fan_keeps_first_vertex() {
        assert_eq!(
            assemble(6, &[0, 1, 2, 3]).collect::<Vec<_>>(),
            vec![[1, 2, 0], [2, 3, 0]]
        );
        assert_eq!(assemble(6, &[]).count(), 0);
    }

    #[test]
    fn list_ignores_trailing_indices() {
        assert_eq!(
            assemble(4, &[0, 1, 2, 3]).collect::<Vec<_>>(),
            vec![[0, 1, 2]]
        );
    }
}
