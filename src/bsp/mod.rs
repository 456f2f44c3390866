//! Quake-family .bsp files: writing the PVS into them as ericw-tools `vis` does, so
//! `portcullis vis map.bsp` takes its place between `qbsp` and `light`.
//!
//! The PVS itself is computed on the portal file qbsp wrote beside the .bsp (`crate::prt`,
//! `crate::vis`); this module only reads the .bsp, matches the .prt's cells to its leafs or
//! clusters, and puts the rows back where engines read them. Everything vis does not own
//! stays bytes: a .bsp comes back with every lump but visibility byte-identical, and in the
//! leafs lump only `visofs` and the ambient levels changed.
//!
//! The files, each with one job: `read.rs` (header, lump table, leafs and the records
//! ambient sounds read, all checked before use), `visdata.rs` (the zero-run row compression
//! and Quake 2's PVS + PHS lump), `leafmap.rs` (the .prt's cells to leafs or clusters, and
//! refusing a .prt of another compile), `ambient.rs` (water, sky, slime, lava levels),
//! `phs.rs` (Quake 2's hearable set), `write.rs` (the new file), `readback.rs` (decoding a
//! .bsp's visibility to compare), `error.rs` (the `BSP_*` diagnostics).
//!
//! Invariants: no input panics and a count is checked before anything is sized by it; what
//! is written decodes (by any engine's `Mod_DecompressVis`) to the PVS given, expanded from
//! cells to leafs; nothing but the visibility lump, the leafs' `visofs` and ambient bytes
//! changes; the result does not depend on the thread count.

mod ambient;
pub mod error;
pub mod leafmap;
pub mod phs;
pub mod read;
pub mod readback;
pub mod visdata;
pub mod write;

pub use ambient::{noambient_texinfos, Ambient};
pub use leafmap::{match_prt, LeafMap};
pub use read::{parse, read, Bsp, Format};
pub use readback::{stored, Stored};
pub use write::{visited, Options, Stats, Written};

/// The note that `bsp` held visibility already, which the new one replaces; `None` if it
/// held none.
pub fn already_vised(bsp: &Bsp) -> Option<crate::diag::Diagnostic> {
    let n = bsp.lumps[bsp.format.vis_lump()].len;
    (n > 0).then(|| error::already_vised(&bsp.path, n))
}
