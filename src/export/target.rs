//! The one place that decides what a path is written as (and, for `.prt`, read as): by its
//! extension, in any case. Every command and the library ask here, so `-o level.GLB`,
//! `--prt` and `vis level.prt` agree; [`super::output`] writes each.

use std::path::Path;

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
    /// A plain glTF (.glb) of the cells and portals, for looking at them (`--debug`; never
    /// decided by a path, which would read as an annotated .glb).
    Debug,
    /// A top-down SVG map of the cells and portals.
    Svg,
    /// The self-contained HTML viewer page.
    Html,
    /// A Quake-family .bsp, which `vis` writes its PVS into (never a level's own output).
    Bsp,
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
            "svg" => Some(Target::Svg),
            "html" | "htm" => Some(Target::Html),
            "bsp" => Some(Target::Bsp),
            _ => None,
        }
    }

    /// What the level itself can be written as (`convert -o`): the annotated glTF, a USD
    /// layer, or its portal file; the rest show it.
    pub fn is_level(self) -> bool {
        matches!(
            self,
            Target::Glb | Target::Gltf | Target::Usda | Target::Prt
        )
    }

    /// How a message names it.
    pub fn name(self) -> &'static str {
        match self {
            Target::Glb => ".glb",
            Target::Gltf => ".gltf",
            Target::Usda => ".usda",
            Target::Prt => "a portal file (.prt)",
            Target::Debug => "a debug glTF",
            Target::Svg => "an SVG map",
            Target::Html => "an HTML page",
            Target::Bsp => "a Quake .bsp",
        }
    }

    /// The glTF container, for the glTF targets.
    pub fn gltf(self) -> Option<OutFormat> {
        match self {
            Target::Glb => Some(OutFormat::Glb),
            Target::Gltf => Some(OutFormat::Gltf),
            _ => None,
        }
    }

    /// Whether `path` names a portal file.
    pub fn is_prt(path: &Path) -> bool {
        Target::from_path(path) == Some(Target::Prt)
    }

    /// Whether `path` names a Quake-family .bsp.
    pub fn is_bsp(path: &Path) -> bool {
        Target::from_path(path) == Some(Target::Bsp)
    }
}

/// The glTF container written (a path's is decided by [`Target::from_path`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OutFormat {
    /// JSON text; the input's BIN chunk and the PVS blob become data: URIs.
    Gltf,
    /// Binary: the JSON and every buffer joined into one BIN chunk.
    Glb,
}
