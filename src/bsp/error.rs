//! The `BSP_*` diagnostics, made in one place so every message names the file, the lump (or
//! leaf, or byte) and what to do, the same way wherever the problem is found.

use std::path::Path;

use crate::diag::{Code, Diagnostic, Location};

/// Where in a .bsp: `lump` (`leafs`, `models`, ...) and optionally a record in it, written as
/// a pointer-like place (`map.bsp#/lumps/leafs/12`) so a report points at one record.
pub(crate) fn place(path: &Path, lump: &str, record: Option<usize>) -> Location {
    let p = match record {
        Some(r) => format!("/lumps/{lump}/{r}"),
        None => format!("/lumps/{lump}"),
    };
    Location::file(path).with_pointer(p)
}

/// The file ends before what its header promises.
pub(crate) fn truncated(path: &Path, what: String, len: usize) -> Diagnostic {
    Diagnostic::new(
        Code::BSP_TRUNCATED,
        format!(
            "{}: {what}, but the file ends at {len} bytes",
            path.display()
        ),
        Location::file(path),
    )
    .hint("the .bsp is cut short (an interrupted copy or compile); run qbsp again")
}

/// A magic or version portcullis does not write visibility into.
pub(crate) fn unsupported(path: &Path, what: String) -> Diagnostic {
    Diagnostic::new(
        Code::BSP_UNSUPPORTED,
        format!("{}: {what}", path.display()),
        Location::file(path),
    )
    .hint("portcullis vis writes Quake (BSP29, BSP2, 2PSB), Hexen II, Half-Life (BSP30) and Quake 2 (IBSP 38, Qbism) files; use the vis of the game's own tools for others")
}

/// A lump whose bytes lie outside the file or that is not a whole number of records.
pub(crate) fn lump_range(path: &Path, lump: &str, what: String) -> Diagnostic {
    Diagnostic::new(
        Code::BSP_LUMP_OUT_OF_RANGE,
        format!("{}: lump `{lump}` {what}", path.display()),
        place(path, lump, None),
    )
    .hint("the header's lump table is damaged; run qbsp again")
}

/// A record naming a record that does not exist.
pub(crate) fn bad_index(path: &Path, lump: &str, record: usize, what: String) -> Diagnostic {
    let noun = match lump {
        "leafs" => "leaf",
        "models" => "model",
        "faces" => "face",
        "textures" => "texture",
        other => other,
    };
    Diagnostic::new(
        Code::BSP_BAD_INDEX,
        format!("{}: {noun} {record} {what}", path.display()),
        place(path, lump, Some(record)),
    )
    .hint("the .bsp is damaged or was written by a tool that broke it; run qbsp again")
}

/// A .prt that does not describe this .bsp's leafs or clusters.
pub(crate) fn prt_mismatch(bsp: &Path, prt: &Path, what: String) -> Diagnostic {
    Diagnostic::new(
        Code::BSP_PRT_MISMATCH,
        format!("{} does not belong to {}: {what}", prt.display(), bsp.display()),
        Location::file(prt),
    )
    .hint("run qbsp again so the .bsp and the .prt come from one compile, or name the right portal file with --prt")
}

/// No portal file where vis looks. qbsp writes none when the map leaks, and a leak file
/// (`.pts`, or `.lin` for Quake 2 tools) instead, so that is named when it is there.
pub fn prt_missing(bsp: &Path, prt: &Path) -> Diagnostic {
    let leak = ["pts", "lin"]
        .iter()
        .map(|e| bsp.with_extension(e))
        .find(|p| p.is_file());
    let what = match &leak {
        Some(l) => format!(
            "qbsp wrote no .prt, so the map leaks; {} holds the path from an entity to the void",
            l.display()
        ),
        None => "qbsp writes none when the map leaks (it writes a .pts or .lin file beside the map instead) or when it did not finish".to_string(),
    };
    Diagnostic::new(
        Code::BSP_PRT_MISSING,
        format!("{}: there is no `{}`: {what}", bsp.display(), prt.display()),
        Location::file(prt),
    )
    .hint("load the leak file in your editor (TrenchBroom: File > Load Point File), seal the hole it runs through and run qbsp again; or name the portal file with --prt")
}

/// The input already held visibility (vis ran before, or light after it): it is replaced.
pub(crate) fn already_vised(path: &Path, bytes: usize) -> Diagnostic {
    Diagnostic::new(
        Code::BSP_ALREADY_VISED,
        format!(
            "{} already had visibility data ({bytes} bytes); it was replaced",
            path.display()
        ),
        place(path, "visibility", None),
    )
    .hint("nothing to do: running vis again is safe (run light after vis, as usual)")
}
