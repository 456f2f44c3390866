//! Accessor reading, written here rather than taken from the gltf crate so that quantized
//! positions (KHR_mesh_quantization), sparse accessors and hostile sizes are all handled, and so
//! that every failure names the accessor.
//!
//! Every byte range is checked against the buffer view and the buffer *before* the output is
//! allocated, so the largest allocation is bounded by the bytes actually present in the file
//! (times a small factor), whatever count the JSON claims.

use std::fmt::{self, Display};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

use glam::DVec3;

use super::schema::{index, Accessor, Doc};
use super::Ctx;
use crate::diag::{Code, Diagnostic};

/// Accessors without a buffer view are all zeros (plus sparse values) and so are backed by no
/// bytes at all; their count needs a limit of its own.
const MAX_UNBACKED_ELEMENTS: u64 = 1 << 22;

/// Elements read per buffer byte across the whole file; reading every accessor once stays
/// below 1, so 8 leaves room for accessors shared between meshes.
const READ_BUDGET_PER_BYTE: u64 = 8;

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Component {
    I8,
    U8,
    I16,
    U16,
    U32,
    F32,
}

impl Component {
    fn from_gl(v: u64) -> Option<Component> {
        Some(match v {
            5120 => Component::I8,
            5121 => Component::U8,
            5122 => Component::I16,
            5123 => Component::U16,
            5125 => Component::U32,
            5126 => Component::F32,
            _ => return None,
        })
    }

    fn size(self) -> usize {
        match self {
            Component::I8 | Component::U8 => 1,
            Component::I16 | Component::U16 => 2,
            Component::U32 | Component::F32 => 4,
        }
    }

    fn name(self) -> &'static str {
        match self {
            Component::I8 => "BYTE",
            Component::U8 => "UNSIGNED_BYTE",
            Component::I16 => "SHORT",
            Component::U16 => "UNSIGNED_SHORT",
            Component::U32 => "UNSIGNED_INT",
            Component::F32 => "FLOAT",
        }
    }

    fn read(self, bytes: &[u8], at: usize) -> Option<f64> {
        let b = bytes.get(at..at.checked_add(self.size())?)?;
        Some(match self {
            Component::I8 => f64::from(i8::from_le_bytes(b.try_into().ok()?)),
            Component::U8 => f64::from(u8::from_le_bytes(b.try_into().ok()?)),
            Component::I16 => f64::from(i16::from_le_bytes(b.try_into().ok()?)),
            Component::U16 => f64::from(u16::from_le_bytes(b.try_into().ok()?)),
            Component::U32 => f64::from(u32::from_le_bytes(b.try_into().ok()?)),
            Component::F32 => f64::from(f32::from_le_bytes(b.try_into().ok()?)),
        })
    }

    /// The value a normalized integer stands for (glTF 2.0 §3.11, "Animations" and
    /// KHR_mesh_quantization use the same rule).
    fn normalize(self, v: f64) -> f64 {
        match self {
            Component::I8 => (v / 127.0).max(-1.0),
            Component::U8 => v / 255.0,
            Component::I16 => (v / 32767.0).max(-1.0),
            Component::U16 => v / 65535.0,
            Component::U32 => v / 4_294_967_295.0,
            Component::F32 => v,
        }
    }
}

/// A JSON pointer to an element of a root array (`/accessors/3`), written out only when a
/// diagnostic needs it: a big level reads a hundred thousand accessors without a problem.
struct Pointer(&'static str, usize);

impl Display for Pointer {
    fn fmt(&self, f: &mut fmt::Formatter) -> fmt::Result {
        write!(f, "{}/{}", self.0, self.1)
    }
}

/// An accessor's elements: in a buffer view, or zeros (no view).
enum Span<'b> {
    Backed(Run<'b>),
    Zeros(usize),
}

/// `count` elements of a buffer view's bytes, `stride` apart from `offset`.
struct Run<'b> {
    bytes: &'b [u8],
    offset: usize,
    stride: usize,
    count: usize,
}

struct View<'b> {
    bytes: &'b [u8],
    stride: Option<usize>,
    index: usize,
}

pub(crate) struct Reader<'a> {
    ctx: &'a Ctx,
    doc: &'a Doc,
    buffers: &'a [Vec<u8>],
    /// Elements still allowed to be read. Each read is bounded by its bytes, but one accessor
    /// can be referenced by thousands of meshes for a few bytes of JSON each; this keeps the
    /// total proportional to the file's size. Shared by the threads building meshes.
    budget: AtomicU64,
    initial: u64,
    /// Set once a read was refused for want of budget.
    exhausted: AtomicBool,
}

impl<'a> Reader<'a> {
    pub fn new(ctx: &'a Ctx, doc: &'a Doc, buffers: &'a [Vec<u8>]) -> Self {
        let bytes: u64 = buffers.iter().map(|b| b.len() as u64).sum();
        let budget = bytes
            .saturating_mul(READ_BUDGET_PER_BYTE)
            .saturating_add(MAX_UNBACKED_ELEMENTS);
        Reader {
            ctx,
            doc,
            buffers,
            budget: AtomicU64::new(budget),
            initial: budget,
            exhausted: AtomicBool::new(false),
        }
    }

    /// Whether a read was refused for want of budget since the last [`Reader::reset`].
    pub(crate) fn exhausted(&self) -> bool {
        self.exhausted.load(Ordering::Relaxed)
    }

    /// The whole budget back, for reading everything again in one order.
    pub(crate) fn reset(&self) {
        self.budget.store(self.initial, Ordering::Relaxed);
        self.exhausted.store(false, Ordering::Relaxed);
    }

    fn charge(&self, count: u64, pointer: &dyn Display) -> Result<(), Diagnostic> {
        let charged = self
            .budget
            .fetch_update(Ordering::Relaxed, Ordering::Relaxed, |b| {
                b.checked_sub(count)
            });
        match charged {
            Ok(_) => Ok(()),
            Err(_) => Err({
                self.exhausted.store(true, Ordering::Relaxed);
                self.oob(
                pointer,
                "the file's accessors, counted every time a mesh uses them, hold far more elements than its buffers could; refusing to read more",
            )
            }),
        }
    }

    /// Positions of a POSITION accessor, dequantized when normalized. `from` is the pointer of
    /// the reference to the accessor, blamed if the index is out of range.
    pub fn positions(&self, accessor: u64, from: &dyn Display) -> Result<Vec<DVec3>, Diagnostic> {
        let (i, acc) = self.accessor(accessor, from)?;
        let pointer = &Pointer("/accessors", i);
        let (kind, ct) = self.kind(acc, &pointer)?;
        if kind != "VEC3" {
            return Err(self.invalid(
                &pointer,
                format!("POSITION accessor {i} has type {kind}; it must be VEC3"),
            ));
        }
        if ct == Component::U32 {
            return Err(self.invalid(
                &pointer,
                format!("POSITION accessor {i} has component type UNSIGNED_INT, which glTF does not allow for positions"),
            ));
        }
        let span = self.span(acc, &pointer, 3, ct)?;
        // Plain positions in a view (nearly all) go straight to points, without a list of
        // components in between.
        if let (Span::Backed(run), None, false) = (&span, &acc.sparse, acc.normalized) {
            let at = |e, c| self.component(run, e, c, ct, &pointer);
            // Exact room: the list becomes the mesh's (a collect into a `Result` grows it by
            // doubling, up to twice the room).
            let mut out = Vec::with_capacity(run.count);
            for e in 0..run.count {
                out.push(DVec3::new(at(e, 0)?, at(e, 1)?, at(e, 2)?));
            }
            return Ok(out);
        }
        let mut raw = self.decode(span, acc, &pointer, 3, ct)?;
        if acc.normalized {
            for v in &mut raw {
                *v = ct.normalize(*v);
            }
        }
        Ok(raw
            .chunks_exact(3)
            .map(|c| DVec3::new(c[0], c[1], c[2]))
            .collect())
    }

    /// Vertex indices of an `indices` accessor.
    pub(crate) fn indices(
        &self,
        accessor: u64,
        from: &dyn Display,
    ) -> Result<Vec<u32>, Diagnostic> {
        let (i, acc) = self.accessor(accessor, from)?;
        let pointer = &Pointer("/accessors", i);
        let (kind, ct) = self.kind(acc, &pointer)?;
        if kind != "SCALAR" || !matches!(ct, Component::U8 | Component::U16 | Component::U32) {
            return Err(self.invalid(
                &pointer,
                format!(
                    "index accessor {i} is {kind} of {}; indices must be SCALAR of UNSIGNED_BYTE, UNSIGNED_SHORT or UNSIGNED_INT",
                    ct.name()
                ),
            ));
        }
        let span = self.span(acc, &pointer, 1, ct)?;
        if let (Span::Backed(run), None) = (&span, &acc.sparse) {
            let mut out = Vec::with_capacity(run.count);
            for e in 0..run.count {
                out.push(self.component(run, e, 0, ct, &pointer)? as u32);
            }
            return Ok(out);
        }
        let raw = self.decode(span, acc, &pointer, 1, ct)?;
        // The values were read from u8/u16/u32, so the conversion back is exact.
        Ok(raw.into_iter().map(|v| v as u32).collect())
    }

    fn accessor(
        &self,
        accessor: u64,
        from: &dyn Display,
    ) -> Result<(usize, &'a Accessor), Diagnostic> {
        index(accessor, self.doc.accessors.len())
            .and_then(|i| Some((i, self.doc.accessors.get(i)?)))
            .ok_or_else(|| {
                self.ctx
                    .diag(
                        Code::GLTF_BAD_INDEX,
                        from.to_string(),
                        format!(
                            "accessor {accessor} does not exist (the file has {})",
                            self.doc.accessors.len()
                        ),
                    )
                    .hint(super::VALIDATOR_HINT)
            })
    }

    fn kind(
        &self,
        acc: &'a Accessor,
        pointer: &dyn Display,
    ) -> Result<(&'a str, Component), Diagnostic> {
        let kind = acc.kind.as_deref().ok_or_else(|| {
            self.missing(&format!("{pointer}/type"), "the required `type` is missing")
        })?;
        let ct = acc.component_type.ok_or_else(|| {
            self.missing(
                &format!("{pointer}/componentType"),
                "the required `componentType` is missing",
            )
        })?;
        let ct = Component::from_gl(ct).ok_or_else(|| {
            self.invalid(
                pointer,
                format!("componentType {ct} is not a glTF component type"),
            )
        })?;
        Ok((kind, ct))
    }

    /// Where an accessor's `count * comps` components lie, checked against its buffer view
    /// and charged to the budget.
    fn span(
        &self,
        acc: &Accessor,
        pointer: &dyn Display,
        comps: usize,
        ct: Component,
    ) -> Result<Span<'a>, Diagnostic> {
        let Some(count) = acc.count else {
            return Err(self.missing(
                &format!("{pointer}/count"),
                "the required `count` is missing",
            ));
        };
        let elem = comps * ct.size();
        Ok(match acc.buffer_view {
            Some(bv) => {
                let view = self.view(bv, &format_args!("{pointer}/bufferView"))?;
                let stride = match view.stride {
                    None | Some(0) => elem,
                    Some(s) if s < elem => {
                        return Err(self.invalid(
                            &format!("/bufferViews/{}/byteStride", view.index),
                            format!(
                                "byteStride {s} of buffer view {} is smaller than the {elem}-byte elements of accessor {pointer}",
                                view.index
                            ),
                        ));
                    }
                    Some(s) => s,
                };
                // Last byte read: byteOffset + stride * (count - 1) + elem, all in u64.
                let end = match count.checked_sub(1) {
                    None => Some(acc.byte_offset),
                    Some(last) => (stride as u64)
                        .checked_mul(last)
                        .and_then(|v| v.checked_add(acc.byte_offset))
                        .and_then(|v| v.checked_add(elem as u64)),
                };
                let view_len = view.bytes.len() as u64;
                if end.is_none_or(|e| e > view_len) {
                    return Err(self.oob(
                        pointer,
                        format!(
                            "{count} elements of {elem} bytes (stride {stride}) from byteOffset {} need more than the {view_len} bytes of buffer view {}",
                            acc.byte_offset, view.index
                        ),
                    ));
                }
                // Bounded by the view length checked above.
                let count = count as usize;
                let offset = acc.byte_offset as usize;
                self.charge(count as u64, pointer)?;
                Span::Backed(Run {
                    bytes: view.bytes,
                    offset,
                    stride,
                    count,
                })
            }
            None => {
                if count > MAX_UNBACKED_ELEMENTS {
                    return Err(self.oob(
                        pointer,
                        format!(
                            "accessor has no bufferView yet claims {count} elements; at most {MAX_UNBACKED_ELEMENTS} zero-filled elements are read"
                        ),
                    ));
                }
                self.charge(count, pointer)?;
                Span::Zeros(count as usize)
            }
        })
    }

    /// The components of a checked span (zeros when there is no buffer view), with sparse
    /// substitution applied.
    fn decode(
        &self,
        span: Span,
        acc: &Accessor,
        pointer: &dyn Display,
        comps: usize,
        ct: Component,
    ) -> Result<Vec<f64>, Diagnostic> {
        let mut out = match span {
            Span::Backed(run) => {
                let mut out = Vec::with_capacity(run.count * comps);
                for e in 0..run.count {
                    for c in 0..comps {
                        out.push(self.component(&run, e, c, ct, pointer)?);
                    }
                }
                out
            }
            Span::Zeros(n) => vec![0.0; n * comps],
        };
        if let Some(sparse) = &acc.sparse {
            let count = acc.count.unwrap_or(0);
            self.apply_sparse(sparse, pointer, count, comps, ct, &mut out)?;
        }
        Ok(out)
    }

    /// Component `c` of element `e` of a run (checked against the view when the run was made;
    /// a read past it is still a diagnostic, not a panic).
    fn component(
        &self,
        run: &Run,
        e: usize,
        c: usize,
        ct: Component,
        pointer: &dyn Display,
    ) -> Result<f64, Diagnostic> {
        ct.read(run.bytes, run.offset + e * run.stride + c * ct.size())
            .ok_or_else(|| self.oob(pointer, "element read past its buffer view"))
    }

    fn apply_sparse(
        &self,
        sparse: &super::schema::Sparse,
        pointer: &dyn Display,
        count: u64,
        comps: usize,
        ct: Component,
        out: &mut [f64],
    ) -> Result<(), Diagnostic> {
        let sp = format!("{pointer}/sparse");
        let n = sparse.count.ok_or_else(|| {
            self.missing(
                &format!("{sp}/count"),
                "the required sparse `count` is missing",
            )
        })?;
        if n > count {
            return Err(self.oob(
                &sp,
                format!("sparse count {n} exceeds the accessor's count {count}"),
            ));
        }
        let (Some(ind), Some(vals)) = (&sparse.indices, &sparse.values) else {
            return Err(self.missing(&sp, "sparse `indices` or `values` is missing"));
        };
        let ind_ptr = format!("{sp}/indices");
        let val_ptr = format!("{sp}/values");
        let ict = ind
            .component_type
            .and_then(Component::from_gl)
            .filter(|c| matches!(c, Component::U8 | Component::U16 | Component::U32))
            .ok_or_else(|| {
                self.invalid(
                    &format!("{ind_ptr}/componentType"),
                    "sparse indices must be UNSIGNED_BYTE, UNSIGNED_SHORT or UNSIGNED_INT",
                )
            })?;
        let ibv = ind.buffer_view.ok_or_else(|| {
            self.missing(
                &format!("{ind_ptr}/bufferView"),
                "sparse indices need a bufferView",
            )
        })?;
        let vbv = vals.buffer_view.ok_or_else(|| {
            self.missing(
                &format!("{val_ptr}/bufferView"),
                "sparse values need a bufferView",
            )
        })?;
        let iview = self.view(ibv, &format!("{ind_ptr}/bufferView"))?;
        let vview = self.view(vbv, &format!("{val_ptr}/bufferView"))?;
        let elem = (comps * ct.size()) as u64;
        let fits = |offset: u64, size: u64, len: usize| {
            n.checked_mul(size)
                .and_then(|v| v.checked_add(offset))
                .is_some_and(|end| end <= len as u64)
        };
        if !fits(ind.byte_offset, ict.size() as u64, iview.bytes.len()) {
            return Err(self.oob(
                &ind_ptr,
                format!(
                    "{n} sparse indices do not fit in buffer view {}",
                    iview.index
                ),
            ));
        }
        if !fits(vals.byte_offset, elem, vview.bytes.len()) {
            return Err(self.oob(
                &val_ptr,
                format!(
                    "{n} sparse values do not fit in buffer view {}",
                    vview.index
                ),
            ));
        }
        // Both ranges were checked above, so `n` is bounded by the bytes present.
        let (ioff, voff) = (ind.byte_offset as usize, vals.byte_offset as usize);
        for k in 0..n as usize {
            let target = ict
                .read(iview.bytes, ioff + k * ict.size())
                .ok_or_else(|| self.oob(&ind_ptr, "sparse index read past its buffer view"))?;
            if target >= count as f64 {
                return Err(self.oob(
                    &ind_ptr,
                    format!("sparse index {target} is not below the accessor's count {count}"),
                ));
            }
            let target = target as usize;
            for c in 0..comps {
                let v = ct
                    .read(vview.bytes, voff + k * elem as usize + c * ct.size())
                    .ok_or_else(|| self.oob(&val_ptr, "sparse value read past its buffer view"))?;
                let slot = out
                    .get_mut(target * comps + c)
                    .ok_or_else(|| self.oob(&ind_ptr, "sparse index outside the accessor"))?;
                *slot = v;
            }
        }
        Ok(())
    }

    fn view(&self, bv: u64, from: &dyn Display) -> Result<View<'a>, Diagnostic> {
        let Some(vi) = index(bv, self.doc.buffer_views.len()) else {
            return Err(self
                .ctx
                .diag(
                    Code::GLTF_BAD_INDEX,
                    from.to_string(),
                    format!(
                        "buffer view {bv} does not exist (the file has {})",
                        self.doc.buffer_views.len()
                    ),
                )
                .hint(super::VALIDATOR_HINT));
        };
        let vp = &Pointer("/bufferViews", vi);
        let Some(view) = self.doc.buffer_views.get(vi) else {
            return Err(self.missing(&vp, "buffer view missing"));
        };
        let b = view.buffer.ok_or_else(|| {
            self.missing(&format!("{vp}/buffer"), "the required `buffer` is missing")
        })?;
        let len = view.byte_length.ok_or_else(|| {
            self.missing(
                &format!("{vp}/byteLength"),
                "the required `byteLength` is missing",
            )
        })?;
        let (Some(bi), Some(data)) = (
            index(b, self.doc.buffers.len()),
            index(b, self.buffers.len()).and_then(|i| self.buffers.get(i)),
        ) else {
            return Err(self
                .ctx
                .diag(
                    Code::GLTF_BAD_INDEX,
                    format!("{vp}/buffer"),
                    format!(
                        "buffer {b} does not exist (the file has {})",
                        self.doc.buffers.len()
                    ),
                )
                .hint(super::VALIDATOR_HINT));
        };
        // Only the declared byteLength counts: a GLB BIN chunk may carry padding after it.
        let declared = self
            .doc
            .buffers
            .get(bi)
            .and_then(|b| b.byte_length)
            .unwrap_or(0)
            .min(data.len() as u64);
        let bytes = view
            .byte_offset
            .checked_add(len)
            .filter(|&end| end <= declared)
            .and_then(|end| data.get(view.byte_offset as usize..end as usize));
        let Some(bytes) = bytes else {
            return Err(self.oob(
                &vp,
                format!(
                    "buffer view {vi} covers bytes {}..{} of buffer {bi}, which holds {declared}",
                    view.byte_offset,
                    view.byte_offset.saturating_add(len)
                ),
            ));
        };
        Ok(View {
            bytes,
            stride: view.byte_stride.and_then(|s| usize::try_from(s).ok()),
            index: vi,
        })
    }

    fn oob(&self, pointer: &dyn Display, msg: impl AsRef<str>) -> Diagnostic {
        self.ctx
            .diag(Code::GLTF_ACCESSOR_OUT_OF_BOUNDS, pointer.to_string(), format!("{pointer}: {}", msg.as_ref()))
            .hint("the file claims more data than it holds; it is damaged or the exporter is buggy, export it again")
    }

    fn invalid(&self, pointer: &dyn Display, msg: impl AsRef<str>) -> Diagnostic {
        self.ctx
            .diag(Code::GLTF_ACCESSOR_INVALID, pointer.to_string(), msg)
            .hint(super::VALIDATOR_HINT)
    }

    fn missing(&self, pointer: &dyn Display, msg: impl AsRef<str>) -> Diagnostic {
        self.ctx
            .diag(
                Code::GLTF_INVALID_JSON,
                pointer.to_string(),
                format!("{pointer}: {}", msg.as_ref()),
            )
            .hint(super::VALIDATOR_HINT)
    }
}
