//! Why an annotation, its stored PVS or a PVS text cannot be read: one variant per problem, each
//! rendering the message `inspect`, `check` and the runtime's loader show.

/// What is wrong with a stored annotation or PVS. Its text names the problem in the user's
/// terms, with a JSON pointer into the extension where there is one.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FormatError {
    /// The extension object does not deserialize into the records (serde's message).
    #[error("{0}")]
    Parse(String),

    // What the schema cannot check (`read::consistency`).
    /// A room lists a cell that does not exist.
    #[error("/rooms/{room}: cell {cell} does not exist ({cells} cells)")]
    RoomCellMissing {
        /// The room's index.
        room: usize,
        /// The cell it names.
        cell: usize,
        /// The cells there are.
        cells: usize,
    },
    /// A cell lists a node that does not exist.
    #[error("/cells/{cell}: node {node} does not exist ({nodes} nodes)")]
    CellNodeMissing {
        /// The cell's index.
        cell: usize,
        /// The node it names.
        node: usize,
        /// The nodes there are.
        nodes: usize,
    },
    /// A portal joins a cell that does not exist.
    #[error("/portals/{portal}: cell {cell} does not exist ({cells} cells)")]
    PortalCellMissing {
        /// The portal's index.
        portal: usize,
        /// The cell it names.
        cell: usize,
        /// The cells there are.
        cells: usize,
    },
    /// A portal's partner does not exist.
    #[error("/portals/{portal}: partner {partner} does not exist")]
    PartnerMissing {
        /// The portal's index.
        portal: usize,
        /// The partner it names.
        partner: usize,
    },
    /// A portal's partner names another portal (or none) as its own partner.
    #[error("/portals/{portal}: partner {partner} does not name it back")]
    PartnerNotMutual {
        /// The portal's index.
        portal: usize,
        /// The partner it names.
        partner: usize,
    },
    /// A portal's partner does not join its cells the other way round.
    #[error("/portals/{portal}: partner {partner} does not join the same cells the other way")]
    PartnerCellsDiffer {
        /// The portal's index.
        portal: usize,
        /// The partner it names.
        partner: usize,
    },
    /// A portal was authored as a node that does not exist.
    #[error("/portals/{portal}: node {node} does not exist")]
    PortalNodeMissing {
        /// The portal's index.
        portal: usize,
        /// The node it names.
        node: usize,
    },
    /// An occupant buried in solid is a node that does not exist.
    #[error("/buriedOccupants: node {node} does not exist")]
    BuriedNodeMissing {
        /// The node it names.
        node: usize,
    },
    /// The inline `lists` of the stored visibility do not decode.
    #[error("/visibility: {0}")]
    StoredLists(Box<FormatError>),

    // The `visibility` encodings (`visibility::decode`).
    /// A `lists` encoding without its `lists`.
    #[error("`lists` is missing")]
    ListsMissing,
    /// Not one list per cell.
    #[error("{lists} lists for {cells} cells")]
    ListCount {
        /// The lists stored.
        lists: usize,
        /// The level's cells.
        cells: usize,
    },
    /// A list that is not a JSON array.
    #[error("a list is not an array")]
    ListNotArray,
    /// A list entry that is not a whole number.
    #[error("a list holds a non-index")]
    ListNonIndex,
    /// A list names a cell that does not exist.
    #[error("/lists/{row}: cell {cell} does not exist")]
    ListCellMissing {
        /// The list (the seeing cell).
        row: usize,
        /// The cell it names.
        cell: usize,
    },
    /// `rowBytes` does not fit the level's cells.
    #[error("rowBytes must be {row_bytes} for {cells} cells")]
    RowBytes {
        /// What it must be.
        row_bytes: usize,
        /// The level's cells.
        cells: usize,
    },
    /// A bit encoding whose buffer view was not given.
    #[error("the buffer view cannot be read")]
    NoBlob,
    /// The rows of a bit encoding are cut short.
    #[error("the buffer view holds fewer rows than cells")]
    FewerRows,
    /// An `encoding` other than `lists`, `bits` and `bitsZeroRun`.
    #[error("unknown visibility encoding `{0}`")]
    UnknownEncoding(String),
    /// The buffer view of the stored visibility is missing or out of its buffer's range
    /// (`read::visibility`).
    #[error("visibility: buffer view {0} cannot be read")]
    ViewUnreadable(u64),

    // The `c: v1 v2 ...` text of a PVS (`Pvs::parse_text`); lines count from 1.
    /// A line without a `:`.
    #[error("line {0}: no `:`")]
    TextNoColon(usize),
    /// A line whose cell is not a whole number.
    #[error("line {0}: bad cell index")]
    TextBadCell(usize),
    /// A line whose cell does not exist.
    #[error("line {0}: cell index out of range")]
    TextCellOutOfRange(usize),
    /// A line with a visible cell that is not a whole number.
    #[error("line {0}: bad visible cell")]
    TextBadVisible(usize),
    /// A line with a visible cell that does not exist.
    #[error("line {0}: visible cell out of range")]
    TextVisibleOutOfRange(usize),
}
