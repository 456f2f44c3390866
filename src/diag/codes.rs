//! The registry of diagnostic codes. A code, once released, keeps its meaning forever; add new
//! codes rather than repurposing old ones. `docs/diagnostics.md` is checked against this list
//! by a test, so every code is documented.

use std::fmt;

use serde::{Serialize, Serializer};

use super::Severity;

macro_rules! codes {
    ($( $(#[$doc:meta])* $name:ident = $sev:ident, $summary:literal; )*) => {
        /// A stable diagnostic code.
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
        #[allow(non_camel_case_types)]
        // The summaries are plain text: `[cells]` there is a config section, not a link.
        #[allow(rustdoc::broken_intra_doc_links)]
        pub enum Code { $( #[doc = $summary] $(#[$doc])* $name, )* }

        impl Code {
            /// Every code, in registry order.
            pub const ALL: &'static [Code] = &[ $( Code::$name, )* ];

            /// The code as written in reports and configs (`TAG_NEAR_MISS`).
            pub fn as_str(self) -> &'static str {
                match self { $( Code::$name => stringify!($name), )* }
            }
            /// The severity before any policy changes it.
            pub fn default_severity(self) -> Severity {
                match self { $( Code::$name => Severity::$sev, )* }
            }
            /// One line saying what the code means, for `--list-codes` and the docs.
            pub fn summary(self) -> &'static str {
                match self { $( Code::$name => $summary, )* }
            }
            /// The code spelt `s` exactly (upper case), `None` if the registry has none.
            pub fn parse(s: &str) -> Option<Code> {
                match s { $( stringify!($name) => Some(Code::$name), )* _ => None }
            }
        }
    };
}

codes! {
    // --- input: the file could not be read as a level (exit 2) ---
    IO_READ_FAILED = Error, "the input file could not be read";
    INPUT_FORMAT_UNKNOWN = Error, "the file extension names no supported format";
    INPUT_EMPTY = Error, "the input file is empty";
    USD_UNSUPPORTED_BUILD = Error, "USD input needs a build with the `usd` feature";
    GLB_INVALID = Error, "the GLB container is malformed or truncated";
    GLTF_INVALID_JSON = Error, "the glTF JSON does not parse or does not follow the glTF schema";
    GLTF_UNSUPPORTED_VERSION = Error, "the asset version is not glTF 2.x";
    GLTF_REQUIRED_EXTENSION_UNSUPPORTED = Error, "the file requires an extension portcullis cannot read";
    GLTF_BUFFER_MISSING = Error, "a buffer's data could not be loaded (missing file, bad data: URI)";
    GLTF_BUFFER_TOO_SHORT = Error, "a buffer holds fewer bytes than its byteLength";
    GLTF_BAD_INDEX = Error, "an index refers to an object that does not exist";
    GLTF_ACCESSOR_OUT_OF_BOUNDS = Error, "an accessor reads past the end of its buffer view or buffer";
    GLTF_ACCESSOR_INVALID = Error, "an accessor has a type or component type that cannot be used here";
    GLTF_NODE_CYCLE = Error, "the node hierarchy contains a cycle or a node with two parents";
    MESH_INDEX_OUT_OF_RANGE = Error, "a triangle index is not below the vertex count";
    OBJ_NOT_TEXT = Error, "the .obj file is not a text file";
    OBJ_BAD_STATEMENT = Error, "an OBJ statement cannot be parsed";
    OBJ_BAD_INDEX = Error, "an OBJ face refers to a vertex that does not exist";
    MAP_SYNTAX = Error, "the brush map's text cannot be parsed";
    MAP_BRUSH_INVALID = Error, "a brush of the map is no closed solid (collinear face points, fewer than four planes, open, flat, or beyond ±1,048,576 units)";
    CONFIG_INVALID = Error, "the configuration file does not parse or does not follow its schema";
    CONFIG_NOT_FOUND = Error, "the configuration file given with --config does not exist";
    TAGS_PRESET_UNKNOWN = Error, "the tag preset named does not exist";
    TAGS_RULE_INVALID = Error, "a tag rule has an invalid pattern";
    OUTPUT_FAILED = Error, "the output file could not be written";
    OUTPUT_WOULD_OVERWRITE_INPUT = Error, "the output path is the input file (use --in-place to allow it)";
    OUTPUT_FORMAT_UNKNOWN = Error, "the output file extension names no format portcullis writes";
    CONVERT_SPLIT_INPUT = Error, "the glTF input was written by convert --split-by-cell; convert its source instead";

    // --- input: read, but with problems in the level (exit 1 for errors) ---
    GEOM_NON_FINITE = Error, "a position is NaN or infinite; its triangles were dropped";
    GEOM_DEGENERATE_TRIANGLES = Info, "zero-area triangles were dropped";
    GLTF_NON_TRIANGLES_SKIPPED = Info, "point or line primitives were skipped (they bound nothing)";
    GLTF_NO_SCENE = Warning, "the file has no scene; every root node was used";
    GLTF_TRANSFORM_INVALID = Error, "a node transform is not finite or not invertible";
    GLTF_EXTENSION_IGNORED = Warning, "an optional extension that adds geometry (EXT_mesh_gpu_instancing) was not applied";
    OBJ_MTL_MISSING = Warning, "a material library named by mtllib was not found";
    OBJ_POLYGON_SELF_INTERSECTING = Warning, "a polygon face is self-intersecting; it was fan-triangulated";
    OBJ_UNSUPPORTED_STATEMENT = Info, "OBJ statements that carry no level geometry were skipped";
    MAP_PATCHES_SKIPPED = Info, "patches and other non-brush primitives of a brush map were skipped";
    EMPTY_SCENE = Warning, "the scene holds no triangles";

    // --- tags ---
    TAG_NEAR_MISS = Warning, "a name looks like a tag but does not match any rule";
    TAG_UNKNOWN_TARGET = Error, "a portal names a target room that does not exist";
    TAG_AMBIGUOUS_TARGET = Error, "a portal target matches more than one room";
    TAG_DUPLICATE_ROOM = Error, "two rooms have the same name";
    TAG_PORTAL_NO_SOURCE = Warning, "an authored portal is in no room and names no source room";
    TAG_PORTAL_NO_MESH = Error, "a node tagged as a portal has no mesh to give its polygon";
    TAG_BOUND_NO_ROOM = Error, "a bound volume is not inside a room and names none";
    TAG_BOUND_NO_MESH = Error, "a node tagged as a bound volume has no mesh";
    TAG_EXTRAS_INVALID = Warning, "a tag key in extras has a value of the wrong type";
    TAG_TELEPORT_EXIT_UNKNOWN = Error, "a teleporter portal names an exit node that does not exist";
    TAG_NO_ROOMS = Info, "no room was recognised; the whole level is one space";
    TAGS_PRESET_SUGGESTED = Warning, "most nodes follow the conventions of a built-in tag preset that is not active";

    // --- cells ---
    TOLERANCE_CAPPED = Warning, "the input's precision is coarser than the largest tolerance allowed";
    CELL_ROOM_FROM_FLOOR = Info, "a room made only of floor was extruded upward like a footprint";
    CELL_ROOM_ZERO_HEIGHT = Info, "a room of floor whose walls have no height (a closed door or lift, floor and ceiling at one height) has no air, so no cell";
    CELL_ROOM_EMPTY = Error, "a room has no geometry, bound or footprint to give it a volume";
    CELL_ROOM_DEGENERATE = Error, "a room's geometry has no volume (flat, a line or a point)";
    CELL_BOUND_NOT_CONVEX = Warning, "a bound mesh is not convex; its convex hull was used";
    CELL_TOO_MANY_PLANES = Warning, "a cell has more planes than configured";
    CELL_OVERLAP = Warning, "cells of two rooms of equal priority overlap (one keeps the space, the other is cut around it)";
    CELL_GEOMETRY_OUTSIDE = Warning, "a mesh lies in no cell, so no cell renders it";
    CELL_POCKETS_FILLED = Info, "sealed pockets of air among solid blocks that no occupant reaches were filled, as qbsp fills them";
    CELL_ROOM_NO_OCCUPANT = Warning, "a room of solid blocks with no occupant encloses several separate regions of air; all were kept";
    CELL_BLOCK_OPEN = Warning, "a mesh of a room of blocks is closed but for a few edges, so it is read as a surface and seals nothing";
    CELL_OCCUPANT_IN_SOLID = Info, "an occupant stands inside a solid block, so it marks no air";
    CRACKS_CLOSED = Info, "gaps narrower than the crack width were closed (no cell, no leak, no portal through them); the widest is shown, so a level at the wrong scale shows";

    // --- annotated files ---
    ANNOTATION_INVALID = Error, "the file's PORTCULLIS_portals extension breaks its schema or refers to things that do not exist";
    ANNOTATION_STALE = Warning, "the file's PORTCULLIS_portals extension was computed from a different level or settings (geometry, names, extras, materials, tag rules, [cells] or [portals])";

    // --- portals ---
    PORTAL_AUTHORED_UNMATCHED = Warning, "an authored portal covers no opening between its cells";
    PORTAL_AUTHORED_WRONG_WAY = Warning, "an authored portal faces the wrong way for its tag convention";
    PORTAL_AUTHORED_AMBIGUOUS = Warning, "an authored portal covers openings between several pairs of rooms";
    PORTAL_NOT_PLANAR = Warning, "an authored portal's vertices are not on one plane";
    PORTAL_TOO_FEW_POINTS = Error, "a portal has fewer than 3 distinct points, so it has no area";
    PORTAL_NOT_CONVEX = Warning, "a portal's outline is not convex; its convex hull was used";
    PORTAL_NOT_ON_BOUNDARY = Error, "a portal does not lie on the boundary of its cell";
    PORTAL_SEPARATES_NOTHING = Warning, "a portal has the same cell on both sides, so it separates nothing";
    PORTAL_UNPAIRED = Error, "a two-way portal has no partner going back";
    PORTAL_PARTNER_MISMATCH = Error, "a portal and its partner do not share one polygon between the same cells";
    PORTAL_DUPLICATE = Warning, "two portals between the same cells overlap";

    // --- transforms (mirrors, teleporters) ---
    TRANSFORM_NON_FINITE = Error, "a portal transform has NaN or infinite entries";
    TRANSFORM_NOT_RIGID = Error, "a teleporter's transform scales, shears or mirrors";
    TRANSFORM_PARTNER_NOT_INVERSE = Error, "a transformed portal's partner does not carry the inverse transform";
    TRANSFORM_EXIT_MISMATCH = Warning, "a teleporter's exit polygon is not the image of its entry polygon";
    TRANSFORM_MIRROR_PLANE = Error, "a mirror's reflection plane is not its portal's plane";

    // --- the cell graph ---
    GRAPH_UNREACHABLE = Warning, "cells that no portal path joins to the rest of the level";
    GRAPH_ONE_WAY_DEAD_END = Warning, "one-way portals lead into cells with no way back out";
    GRAPH_TRANSFORM_LOOP = Warning, "sightlines loop through mirrors or teleporters without bound";
    PLAYER_START_OUTSIDE = Warning, "a player start lies in no cell";
    OCCUPANT_OUTSIDE = Warning, "an occupant (not a player start) lies in no cell";

    // --- leaks ---
    EXTERIOR_OPENINGS = Info, "cells open to the exterior (an error when the level is declared sealed)";
    LEAK = Error, "a level declared sealed opens to the exterior";

    // --- sightlines (check --sightlines N) ---
    PVS_MISSES_SIGHTLINE = Error, "a ray through the level's geometry joins two cells that the PVS says cannot see each other";
    SIGHTLINES_CONFIRMED = Info, "the share of the PVS's pairs that rays through the level's geometry confirmed";
    SIGHTLINES_THROUGH_CRACKS = Info, "pairs of cells the PVS leaves out are joined only by rays through gaps narrower than the crack width, which the level's reading closes";

    // --- usd ---
    USD_CORE_MISSING = Error, "USD input needs Pixar's usd-core Python package, which the embedded Python cannot import";
    USD_OPEN_FAILED = Error, "USD could not open the stage (syntax error, missing layer, unknown format)";
    USD_PYTHON_FAILED = Error, "reading the stage through usd-core failed unexpectedly";
    USD_MESH_INVALID = Error, "a USD mesh's points, faceVertexCounts and faceVertexIndices do not fit together; the mesh was skipped";
    USD_POLYGON_NOT_SIMPLE = Warning, "a USD polygon face is self-intersecting; it was fan-triangulated";
    USD_UNITS_ASSUMED = Info, "the stage's metersPerUnit or upAxis is unset or unusable; a fallback was used";
    USD_PRIMS_HIDDEN = Info, "invisible prims and prims with guide or proxy purpose were left out";
    USD_GPRIM_UNSUPPORTED = Info, "geometry prims other than Mesh (Cube, Sphere, ...) were left out";
    USD_PORTAL_LIGHT_IGNORED = Info, "a UsdLuxPortalLight is a light, not a visibility portal; it was left out";
    USD_COMPOSITION_ERROR = Warning, "a reference, payload or sublayer of the stage could not be opened; what it holds is missing";

    // --- visibility ---
    VIS_TRANSFORM_DEPTH = Info, "sightlines through mirrors and teleporters were followed only up to the depth bound";
    VIS_FLOW_BUDGET = Info, "the full PVS reached its work budget: some portals' flow stopped early, so the PVS is looser (still conservative)";

    // --- prt ---
    PRT_UNKNOWN_FORMAT = Error, "the .prt file's first line names no portal file format portcullis reads";
    PRT_SYNTAX = Error, "a line of the .prt file cannot be parsed or the file ends early";
    PRT_BAD_INDEX = Error, "a .prt portal or cluster names a cell, cluster or leaf that does not exist";
    PRT_TRAILING_DATA = Warning, "the .prt file has text after its last record";
    PRT_PORTAL_DEGENERATE = Warning, "a .prt portal has no area or joins a cell to itself; it was skipped";
    PRT_EXPORT_DROPPED = Warning, "one-way, closed, mirror or teleporter portals cannot be written to a .prt file";

    // --- bsp (`vis MAP.bsp`) ---
    BSP_TRUNCATED = Error, "the .bsp ends before its header or before a lump its header lists";
    BSP_UNSUPPORTED = Error, "the file's magic or version is no .bsp portcullis writes visibility into";
    BSP_LUMP_OUT_OF_RANGE = Error, "a lump of the .bsp lies outside the file, overlaps its header or is not a whole number of records";
    BSP_BAD_INDEX = Error, "a record of the .bsp names a leaf, face, texinfo or texture that does not exist";
    BSP_PRT_MISMATCH = Error, "the .prt does not belong to the .bsp: its leaf or cluster count differs, or its portals lie outside the leafs they join";
    BSP_PRT_MISSING = Error, "there is no .prt beside the .bsp: qbsp writes none when the map leaks";
    BSP_ALREADY_VISED = Info, "the .bsp already had visibility data, which was replaced";

    // --- runtime (`cull`) ---
    CULL_NOT_CONVERTED = Error, "the level given to `cull` has no usable PORTCULLIS_portals extension";
    CULL_CAMERA_INVALID = Error, "a line of the cameras file is not a usable camera";
    CULL_PORTAL_UNKNOWN = Error, "a portal given with --closed or --open does not exist in the level";
}

impl fmt::Display for Code {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

impl Serialize for Code {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.as_str())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_code_is_documented_and_round_trips() {
        let doc = include_str!("../../docs/diagnostics.md");
        for c in Code::ALL {
            // Each code has its section with an example (or the reason there is none).
            assert!(
                doc.contains(&format!("### `{c}`")),
                "docs/diagnostics.md lacks a section for {c}; run scripts/gen_diagnostics_doc.py"
            );
            assert_eq!(Code::parse(c.as_str()), Some(*c));
            assert!(!c.summary().is_empty());
        }
    }
}
