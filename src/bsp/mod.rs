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

#[cfg(test)]
mod tests {
    use super::read::{Format, Tail};
    use super::*;
    use std::path::Path;

    fn le(v: i32) -> [u8; 4] {
        v.to_le_bytes()
    }

    /// A map of two air leafs side by side (x 0..64 and 64..128) behind the solid leaf 0,
    /// each with one face, textured `tex[0]` and `tex[1]`; `bspx` appends a BSPX block.
    fn tiny(format: Format, hexen2: bool, tex: [&str; 2], bspx: bool) -> Vec<u8> {
        let q2 = format.has_clusters();
        let wide = matches!(format, Format::Bsp2 | Format::Bsp2Rmq);
        let n = if q2 { 19 } else { 15 };
        let mut lumps = vec![Vec::new(); n];
        lumps[0] = b"{\n\"classname\" \"worldspawn\"\n}\n\0".to_vec();
        let boxes = [
            ([0i16; 3], [0i16; 3]),
            ([0, 0, 0], [64, 64, 64]),
            ([64, 0, 0], [128, 64, 64]),
        ];
        let mut leafs = Vec::new();
        for (i, (lo, hi)) in boxes.iter().enumerate() {
            let mut r = Vec::new();
            let contents = if i == 0 { -2 } else { -1 };
            r.extend(le(contents));
            let short =
                |r: &mut Vec<u8>, v: &[i16; 3]| v.iter().for_each(|c| r.extend(c.to_le_bytes()));
            let float = |r: &mut Vec<u8>, v: &[i16; 3]| {
                v.iter().for_each(|&c| r.extend(f32::from(c).to_le_bytes()))
            };
            let (mark, marks) = (i.saturating_sub(1) as u32, u32::from(i > 0));
            match format {
                Format::Quake2 => {
                    r.extend((i as i16 - 1).to_le_bytes());
                    r.extend(0i16.to_le_bytes());
                    short(&mut r, lo);
                    short(&mut r, hi);
                    r.resize(28, 0);
                }
                Format::Qbism => {
                    r.extend(le(i as i32 - 1));
                    r.extend(le(0));
                    float(&mut r, lo);
                    float(&mut r, hi);
                    r.resize(52, 0);
                }
                Format::Bsp2 => {
                    r.extend(le(0));
                    float(&mut r, lo);
                    float(&mut r, hi);
                    r.extend(mark.to_le_bytes());
                    r.extend(marks.to_le_bytes());
                    r.extend([0; 4]);
                }
                _ => {
                    r.extend(le(0));
                    short(&mut r, lo);
                    short(&mut r, hi);
                    if wide {
                        r.extend(mark.to_le_bytes());
                        r.extend(marks.to_le_bytes());
                    } else {
                        r.extend((mark as u16).to_le_bytes());
                        r.extend((marks as u16).to_le_bytes());
                    }
                    r.extend([0; 4]);
                }
            }
            assert_eq!(r.len(), format.leaf_size());
            leafs.extend(r);
        }
        lumps[format.leafs_lump()] = leafs;
        if !q2 {
            let mut t = Vec::new();
            t.extend(le(2));
            t.extend(le(12));
            t.extend(le(52));
            for name in tex {
                let mut m = name.as_bytes().to_vec();
                m.resize(40, 0);
                t.extend(m);
            }
            lumps[2] = t;
            lumps[6] = (0..2)
                .flat_map(|k| [vec![0; 32], le(k).to_vec(), le(0).to_vec()].concat())
                .collect();
            lumps[7] = (0..2i32)
                .flat_map(|k| {
                    let mut f = if wide { vec![0; 28] } else { vec![0; 20] };
                    if wide {
                        f[16..20].copy_from_slice(&le(k));
                    } else {
                        f[10..12].copy_from_slice(&(k as i16).to_le_bytes());
                    }
                    f
                })
                .collect();
            lumps[11] = if wide {
                [le(0), le(1)].concat()
            } else {
                vec![0, 0, 1, 0]
            };
            let mut model = vec![0u8; if hexen2 { 80 } else { 64 }];
            let at = if hexen2 { 68 } else { 52 };
            model[at..at + 4].copy_from_slice(&le(2));
            lumps[14] = model;
        }
        let header = if q2 { 8 + 8 * n } else { 4 + 8 * n };
        let mut out = vec![0u8; header];
        match format {
            Format::Bsp29 => out[..4].copy_from_slice(&le(29)),
            Format::HalfLife => out[..4].copy_from_slice(&le(30)),
            Format::Bsp2 => out[..4].copy_from_slice(b"BSP2"),
            Format::Bsp2Rmq => out[..4].copy_from_slice(b"2PSB"),
            Format::Quake2 => out[..8].copy_from_slice(&[*b"IBSP", le(38)].concat()),
            Format::Qbism => out[..8].copy_from_slice(&[*b"QBSP", le(38)].concat()),
        }
        let first = if q2 { 8 } else { 4 };
        for (i, data) in lumps.iter().enumerate() {
            out.resize(out.len().div_ceil(4) * 4, 0);
            let at = first + 8 * i;
            let ofs = out.len() as i32;
            out[at..at + 4].copy_from_slice(&le(ofs));
            out[at + 4..at + 8].copy_from_slice(&le(data.len() as i32));
            out.extend(data);
        }
        if bspx {
            out.resize(out.len().div_ceil(4) * 4, 0);
            let start = out.len();
            out.extend(b"BSPX");
            out.extend(le(1));
            let mut name = [0u8; 24];
            name[..7].copy_from_slice(b"LMSHIFT");
            out.extend(name);
            out.extend(le((start + 40) as i32));
            out.extend(le(3));
            out.extend([7, 8, 9, 0]);
        }
        out
    }

    const PRT: &str = "PRT1\n2\n1\n4 0 1 (64 0 0) (64 64 0) (64 64 64) (64 0 64)\n";

    fn vised(bytes: Vec<u8>, ambient: Ambient) -> (Bsp, Bsp) {
        let path = Path::new("tiny.bsp");
        let bsp = parse(bytes, path).unwrap();
        let (prt, _) = crate::prt::parse(PRT, Path::new("tiny.prt")).unwrap();
        let map = match_prt(&bsp, &prt, Path::new("tiny.prt")).unwrap();
        let pvs = crate::vis::compute(&prt.graph(None), &Default::default());
        let opts = Options {
            ambient,
            noambient: Vec::new(),
        };
        let w = visited(&bsp, &map, &pvs, &opts).unwrap();
        let after = parse(w.bytes, path).unwrap();
        (bsp, after)
    }

    #[test]
    fn every_dialect_gets_its_rows_and_keeps_the_rest() {
        for (format, hexen2) in [
            (Format::Bsp29, false),
            (Format::Bsp29, true),
            (Format::HalfLife, false),
            (Format::Bsp2, false),
            (Format::Bsp2Rmq, false),
            (Format::Quake2, false),
            (Format::Qbism, false),
        ] {
            let water = if format == Format::HalfLife {
                "!water"
            } else {
                "*water1"
            };
            let (before, after) = vised(
                tiny(format, hexen2, [water, "sky4"], true),
                Ambient::default(),
            );
            let what = format!("{} (hexen2 {hexen2})", format.name());
            assert_eq!((after.format, after.hexen2), (format, hexen2), "{what}");
            assert_eq!(after.tail, before.tail, "{what}: the BSPX lumps");
            assert!(matches!(after.tail, Tail::Bspx(_)));
            let (vi, li) = (format.vis_lump(), format.leafs_lump());
            for i in (0..before.lumps.len()).filter(|&i| i != vi && i != li) {
                assert_eq!(before.lump(i), after.lump(i), "{what}: lump {i}");
            }
            let stored = stored(&after).unwrap();
            assert_eq!(stored.pairs(), 4, "{what}: both leafs see both");
            assert!(stored.broken.is_empty() && stored.without == 0);
            if format.has_clusters() {
                assert_eq!(
                    before.lump(li),
                    after.lump(li),
                    "{what}: Quake 2 leafs untouched"
                );
                assert_eq!(stored.hearable, Some(4));
                continue;
            }
            assert_eq!(after.leafs[0].visofs, -1, "{what}");
            for l in &after.leafs[1..] {
                assert_eq!(l.ambient, [255, 255, 0, 0], "{what}: water and sky heard");
            }
            let size = format.leaf_size();
            let amb = format.ambient_offset();
            for (k, (a, b)) in before.lump(li).iter().zip(after.lump(li)).enumerate() {
                let f = k % size;
                assert!(
                    a == b || (4..8).contains(&f) || (amb..amb + 4).contains(&f),
                    "{what}: leaf byte {k}"
                );
            }
        }
    }

    #[test]
    fn ambient_switches_and_names() {
        let t = |tex: [&str; 2], on: Ambient| {
            vised(tiny(Format::Bsp29, false, tex, false), on).1.leafs[1].ambient
        };
        assert_eq!(
            t(["*slime", "*lava1"], Ambient::default()),
            [255, 0, 0, 255]
        );
        assert_eq!(t(["*slime", "*lava1"], Ambient::none()), [0; 4]);
        let no_lava = Ambient {
            lava: false,
            ..Default::default()
        };
        assert_eq!(t(["*slime", "*lava1"], no_lava), [255, 0, 0, 0]);
        // Quake reads no `!` names, and matches case-insensitively.
        assert_eq!(t(["!water", "SKY1"], Ambient::default()), [0, 255, 0, 0]);
    }

    #[test]
    fn damaged_files_are_diagnostics_never_panics() {
        let good = tiny(Format::Bsp2, false, ["*water", "sky"], true);
        for len in 0..good.len() {
            let _ = parse(good[..len].to_vec(), Path::new("cut.bsp"));
        }
        // Every byte of the header and of the leafs set to 0xff, one at a time.
        for at in 0..good.len().min(400) {
            let mut b = good.clone();
            b[at] = 0xff;
            if let Ok(bsp) = parse(b, Path::new("x.bsp")) {
                let (prt, _) = crate::prt::parse(PRT, Path::new("x.prt")).unwrap();
                if let Ok(map) = match_prt(&bsp, &prt, Path::new("x.prt")) {
                    let pvs = crate::vis::Pvs::identity(2);
                    if let Ok(w) = visited(&bsp, &map, &pvs, &Options::default()) {
                        let again = parse(w.bytes, Path::new("x.bsp")).unwrap();
                        assert_eq!(stored(&again).unwrap().pairs(), 2, "byte {at}");
                    }
                }
                let _ = stored(&bsp);
            }
        }
    }
}
