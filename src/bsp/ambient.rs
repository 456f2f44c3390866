//! Quake's ambient sounds: each leaf stores a level (0-255) for water, sky, slime and lava,
//! which the engine fades in while the player stands in the leaf. vis sets them from the
//! textures of the faces of every leaf the leaf can see, as ericw-tools vis does (its
//! `CalcAmbientSounds`, unchanged from id's):
//!
//! - a face is an emitter by its texture name, case-insensitively: `sky...` is sky;
//!   `*water...` and `*04wat...` water; `*slime...` is water too (id's vis wrote slime as
//!   water, and engines play it so); `*lava...` lava. Half-Life's `!` names count as well.
//! - a class any visible leaf has an emitter of is at full level (255), else 0. id's code
//!   measures a distance to each emitter but then overwrites it with 0.25 before comparing,
//!   so in effect the level is all or nothing; ericw kept that, and maps are tuned to it.
//! - a texinfo qbsp flagged `noambient` (in `MAP.texinfo.json`) emits nothing.
//!
//! Unlike ericw's `-noambientslime`, which also silences lava, and `-noambientlava`, which
//! does nothing unless all four are given, each switch here turns off its own class.

use super::read::Bsp;
use crate::diag::Diagnostic;

/// Which classes are written; the others are written 0.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Ambient {
    /// `*water`, `*04wat`.
    pub water: bool,
    /// `sky`.
    pub sky: bool,
    /// `*slime` (written as water).
    pub slime: bool,
    /// `*lava`.
    pub lava: bool,
}

impl Default for Ambient {
    fn default() -> Self {
        Ambient {
            water: true,
            sky: true,
            slime: true,
            lava: true,
        }
    }
}

impl Ambient {
    /// `-noambient`: every level 0.
    pub fn none() -> Ambient {
        Ambient {
            water: false,
            sky: false,
            slime: false,
            lava: false,
        }
    }
    /// Whether any class is on.
    pub fn any(self) -> bool {
        self.water || self.sky || self.slime || self.lava
    }
}

/// Index of each class in a leaf's four levels.
const WATER: u8 = 1 << 0;
const SKY: u8 = 1 << 1;
const LAVA: u8 = 1 << 3;

/// The class a texture name emits (as a bit of the leaf's four levels), if any.
fn class_of(name: &[u8], on: Ambient, half_life: bool) -> u8 {
    let is = |prefix: &[u8]| {
        name.starts_with(prefix)
            || (half_life
                && prefix[0] == b'*'
                && name.first() == Some(&b'!')
                && name[1..].starts_with(&prefix[1..]))
    };
    // Slime is written as water, as id's vis did.
    let water = (on.water && (is(b"*water") || is(b"*04wat"))) || (on.slime && is(b"*slime"));
    if on.sky && name.starts_with(b"sky") {
        SKY
    } else if water {
        WATER
    } else if on.lava && is(b"*lava") {
        LAVA
    } else {
        0
    }
}

/// For each visible leaf (index j is leaf j + 1): the classes its faces emit.
pub(crate) fn emitters(bsp: &Bsp, on: Ambient, noambient: &[bool]) -> Result<Vec<u8>, Diagnostic> {
    let mut out = vec![0u8; bsp.vis_units];
    if !on.any() {
        return Ok(out);
    }
    let names = bsp.texinfo_names()?;
    let faces = bsp.faces()?;
    let half_life = bsp.format == super::read::Format::HalfLife;
    let class: Vec<u8> = names
        .iter()
        .enumerate()
        .map(|(t, n)| match n {
            Some(n) if !noambient.get(t).copied().unwrap_or(false) => class_of(n, on, half_life),
            _ => 0,
        })
        .collect();
    for (j, mask) in out.iter_mut().enumerate() {
        for f in bsp.leaf_faces(j + 1)? {
            if f >= faces {
                return Err(super::error::bad_index(
                    &bsp.path,
                    "leafs",
                    j + 1,
                    format!("lists face {f}; the faces lump holds {faces}"),
                ));
            }
            *mask |= class[bsp.face_texinfo(f)?];
        }
    }
    Ok(out)
}

/// The four levels of a leaf that sees emitters of the classes in `mask`.
pub(crate) fn levels(mask: u8) -> [u8; 4] {
    [0, 1, 2, 3].map(|k| if mask >> k & 1 == 1 { 255 } else { 0 })
}

/// The texinfos `MAP.texinfo.json` (qbsp's extended surface flags) marks `noambient`.
/// `None` when the file does not fit the .bsp (an index past its texinfos): ericw ignores
/// the whole file then, and so does this.
pub fn noambient_texinfos(json: &str, texinfos: usize) -> Option<Vec<bool>> {
    let v: serde_json::Value = serde_json::from_str(json).ok()?;
    let mut out = vec![false; texinfos];
    for (k, flags) in v.as_object()? {
        let i: usize = k.parse().ok()?;
        *out.get_mut(i)? = flags
            .get("noambient")
            .and_then(|b| b.as_bool())
            .unwrap_or(false);
    }
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn texture_names_pick_their_class() {
        let on = Ambient::default();
        assert_eq!(class_of(b"sky4", on, false), SKY);
        assert_eq!(class_of(b"*water1", on, false), WATER);
        assert_eq!(class_of(b"*04water2", on, false), WATER);
        assert_eq!(class_of(b"*slime0", on, false), WATER);
        assert_eq!(class_of(b"*lava1", on, false), LAVA);
        assert_eq!(class_of(b"*teleport", on, false), 0);
        assert_eq!(class_of(b"!water", on, false), 0);
        assert_eq!(class_of(b"!water", on, true), WATER);
        let no_lava = Ambient { lava: false, ..on };
        assert_eq!(class_of(b"*lava1", no_lava, false), 0);
        assert_eq!(levels(WATER | LAVA), [255, 0, 0, 255]);
        assert_eq!(
            noambient_texinfos(r#"{"1": {"noambient": true}}"#, 3),
            Some(vec![false, true, false])
        );
        assert_eq!(noambient_texinfos(r#"{"5": {}}"#, 3), None);
    }
}
