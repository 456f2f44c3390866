//! Why a level cannot be loaded: [`LoadError`], the file and what to do, around a
//! [`LevelError`], what is wrong with it.

use std::path::PathBuf;

use crate::format::glb::GlbError;
use crate::format::FormatError;

/// Why a level cannot be loaded: what, where, and what to do.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{}: {kind} ({hint})", .path.display())]
pub struct LoadError {
    /// The file that could not be loaded.
    pub path: PathBuf,
    /// What is wrong, for the player-facing log; its text follows the file's name
    /// (`… has no PORTCULLIS_portals extension`).
    pub kind: LevelError,
    /// What to do about it (reconvert the level, check the path).
    pub hint: &'static str,
    /// The file itself could not be read (as opposed to read and found unusable): `kind` is
    /// [`LevelError::Unreadable`].
    pub unreadable: bool,
}

/// What is wrong with a level's file or its annotation. The texts of the file's problems read
/// after its name; those of the annotation's records start with the record's JSON pointer.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LevelError {
    // The file.
    /// The file cannot be read (the I/O error's message).
    #[error("cannot be read: {0}")]
    Unreadable(String),
    /// It starts like a .glb but is not one.
    #[error("is not a readable .glb: {0}")]
    NotGlb(GlbError),
    /// Its JSON is not a glTF document (serde's message).
    #[error("is not a glTF document: {0}")]
    NotGltf(String),
    /// It was not converted.
    #[error("has no PORTCULLIS_portals extension")]
    NoExtension,

    // The buffer view of the stored visibility.
    /// The view does not exist.
    #[error("visibility: buffer view {0} does not exist")]
    ViewMissing(usize),
    /// The view names no buffer.
    #[error("visibility: buffer view {0} names no buffer")]
    ViewNoBuffer(usize),
    /// The view has no length.
    #[error("visibility: buffer view {0} has no byteLength")]
    ViewNoLength(usize),
    /// The view's buffer does not exist.
    #[error("visibility: buffer view {0} names a buffer that does not exist")]
    ViewBufferMissing(usize),
    /// The view's offset and length overflow.
    #[error("visibility: buffer view {0} is out of range")]
    ViewOutOfRange(usize),
    /// The view ends after its buffer.
    #[error("visibility: buffer view {0} lies beyond its buffer")]
    ViewBeyondBuffer(usize),
    /// The view's buffer is the BIN chunk of a file without one.
    #[error("visibility: buffer view {0} lies in a BIN chunk the file does not have")]
    ViewNoBin(usize),
    /// The view's buffer is a data URI that does not decode.
    #[error("visibility: buffer view {0} lies in a data URI that is not base64")]
    ViewBadDataUri(usize),
    /// The view's buffer is a file that cannot be opened.
    #[error("visibility: buffer view {view} lies in {} which cannot be read: {error}", .file.display())]
    ViewFileUnreadable {
        /// The view's index.
        view: usize,
        /// The buffer's file.
        file: PathBuf,
        /// The I/O error's message.
        error: String,
    },
    /// The view's buffer is a file that ends before the view does.
    #[error("visibility: buffer view {view} lies beyond the end of {}: {error}", .file.display())]
    ViewFileShort {
        /// The view's index.
        view: usize,
        /// The buffer's file.
        file: PathBuf,
        /// The I/O error's message.
        error: String,
    },
    /// The stored visibility does not decode.
    #[error("visibility: {0}")]
    Visibility(FormatError),

    // The annotation's records.
    /// What the schema cannot check: an index out of range, partners not mutual.
    #[error(transparent)]
    Inconsistent(FormatError),
    /// The level's tolerance.
    #[error("tolerance {0} is not a positive number")]
    Tolerance(f64),
    /// A cell's plane without a unit normal.
    #[error("/cells/{cell}: plane {plane:?} has no unit normal")]
    PlaneNotUnit {
        /// The cell's index.
        cell: usize,
        /// The plane, `[nx, ny, nz, d]`.
        plane: [f64; 4],
    },
    /// A cell's bounds are not finite, or min exceeds max.
    #[error("/cells/{0}: bounds are not a box")]
    BoundsNotBox(usize),
    /// A cell's planes leave no face.
    #[error("/cells/{0}: its planes enclose nothing")]
    EnclosesNothing(usize),
    /// A portal of fewer than three finite corners.
    #[error("/portals/{0}: the polygon is not a polygon")]
    NotPolygon(usize),
    /// A portal polygon without area.
    #[error("/portals/{0}: the polygon has no area")]
    NoArea(usize),
    /// A portal transform that cannot be inverted.
    #[error("/portals/{0}: the transform cannot be inverted")]
    Singular(usize),
    /// A cell's draw range outside its split primitive, or naming none.
    #[error(
        "/cells/{cell}/draws/{draw}: the range is not within split primitive {primitive}'s indices"
    )]
    DrawOutOfRange {
        /// The cell's index.
        cell: usize,
        /// The range's index in the cell's `draws`.
        draw: usize,
        /// The split primitive it names.
        primitive: usize,
    },
    /// `visibility.outside` names something that is no cell.
    #[error("visibility: outside names {0}, which is no cell")]
    OutsideCell(String),
    /// The PVS given does not have one row per cell.
    #[error("the visibility does not have one row per cell")]
    PvsRows,
}
