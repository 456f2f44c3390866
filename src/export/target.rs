//! The one place that decides what a path is written as (and, for `.prt`, read as): by its
//! extension, in any case. Every command and the library ask here, so `-o level.GLB`,
//! `--prt` and `vis level.prt` agree.

use std::path::Path;

use super::gltf_out::OutFormat;

/// What a file is written as.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Target {
    /// Binary glTF: the JSON and one BIN chunk.
    Glb,
    /// Text glTF, buffers as data: URIs (or the input's external files).
    Gltf,
    /// A USD text layer with cells and portals as `portcullis:` attributes.
    Usda,
    /// A Quake portal file (PRT1): the cell graph only.
    Prt,
}

impl Target {
    /// The target a path names, or `None` for an extension portcullis does not write.
    pub fn from_path(path: &Path) -> Option<Target> {
        let ext = path.extension()?.to_str()?.to_ascii_lowercase();
        match ext.as_str() {
            "glb" => Some(Target::Glb),
            "gltf" => Some(Target::Gltf),
            "usda" => Some(Target::Usda),
            "prt" => Some(Target::Prt),
            _ => None,
        }
    }

    /// The glTF container, for the glTF targets.
    pub fn gltf(self) -> Option<OutFormat> {
        match self {
            Target::Glb => Some(OutFormat::Glb),
            Target::Gltf => Some(OutFormat::Gltf),
            Target::Usda | Target::Prt => None,
        }
    }

    /// Whether `path` names a portal file.
    pub fn is_prt(path: &Path) -> bool {
        Target::from_path(path) == Some(Target::Prt)
    }
}
