//! The GLB container (binary glTF 2.0): a 12-byte header, a JSON chunk, an optional BIN chunk.
//! One framing for everything that reads or writes one (the importer, the runtime's loader,
//! the annotated, plain and debug writers), so a file one side writes the other reads.

/// The first four bytes of every GLB.
pub const MAGIC: &[u8; 4] = b"glTF";
/// The container version written and read (glTF 2.0).
pub const VERSION: u32 = 2;
/// The type of the JSON chunk, as it appears in the file.
pub const JSON_CHUNK: &[u8; 4] = b"JSON";
/// The type of the BIN chunk, as it appears in the file.
pub const BIN_CHUNK: &[u8; 4] = b"BIN\0";
/// Bytes of the file header (magic, version, total length).
pub const HEADER_LEN: usize = 12;
/// Where the JSON chunk's text starts: the header and the chunk's own 8-byte header.
pub const JSON_START: usize = HEADER_LEN + 8;

/// Why bytes that start like a GLB are not one; each says what is wrong in the user's terms.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum GlbError {
    /// Fewer bytes than the header.
    #[error("truncated GLB: {len} bytes, shorter than the 12-byte header")]
    ShortHeader {
        /// The file's length.
        len: usize,
    },
    /// A container version other than 2.
    #[error("GLB container version {0}; only version 2 (glTF 2.0) is read")]
    Version(u32),
    /// A total length too short for a JSON chunk.
    #[error("the GLB header claims a total length of {0} bytes, too short to hold a JSON chunk")]
    TooShort(usize),
    /// A total length beyond the end of the file.
    #[error("truncated GLB: the header says {claimed} bytes but the file has {has}")]
    Truncated {
        /// The length the header claims.
        claimed: usize,
        /// The bytes present.
        has: usize,
    },
    /// The chunks themselves are malformed (lengths, types).
    #[error("{0}")]
    Chunks(String),
}

/// A GLB's chunks, borrowed from its bytes.
#[derive(Debug, Clone, Copy)]
pub struct Glb<'a> {
    /// The JSON chunk's text, padding included.
    pub json: &'a [u8],
    /// The BIN chunk, if any.
    pub bin: Option<&'a [u8]>,
}

/// Whether `bytes` are a GLB (else a .gltf's text, or something else).
pub fn is_glb(bytes: &[u8]) -> bool {
    bytes.starts_with(MAGIC)
}

/// Splits a GLB into its chunks. The header is checked here first because
/// `gltf::binary::Glb::from_slice` subtracts the header size from the claimed length without
/// checking, which would overflow on a hostile header.
pub fn split(bytes: &[u8]) -> Result<Glb<'_>, GlbError> {
    let word = |at: usize| -> Option<u32> {
        let b: [u8; 4] = bytes.get(at..at + 4)?.try_into().ok()?;
        Some(u32::from_le_bytes(b))
    };
    let (Some(version), Some(length)) = (word(4), word(8)) else {
        return Err(GlbError::ShortHeader { len: bytes.len() });
    };
    if version != VERSION {
        return Err(GlbError::Version(version));
    }
    let length = length as usize;
    if length < JSON_START {
        return Err(GlbError::TooShort(length));
    }
    let Some(data) = bytes.get(..length) else {
        return Err(GlbError::Truncated {
            claimed: length,
            has: bytes.len(),
        });
    };
    let glb = gltf::binary::Glb::from_slice(data).map_err(|e| GlbError::Chunks(chunk_error(e)))?;
    // `from_slice` borrows from `data`, so the chunks can be re-sliced without copying.
    let json_len = glb.json.len();
    let json = data
        .get(JSON_START..JSON_START + json_len)
        .unwrap_or_default();
    let bin = match &glb.bin {
        Some(b) => {
            let start = (JSON_START + json_len + 8).min(data.len());
            data.get(start..start + b.len())
        }
        None => None,
    };
    Ok(Glb { json, bin })
}

fn chunk_error(e: gltf::Error) -> String {
    use gltf::binary::Error as B;
    match e {
        gltf::Error::Binary(B::ChunkLength {
            ty,
            length,
            length_read,
        }) => format!(
            "truncated GLB: the {ty:?} chunk claims {length} bytes but only {length_read} follow"
        ),
        gltf::Error::Binary(B::Io(_)) => "truncated GLB: a chunk header is cut off".to_string(),
        gltf::Error::Binary(B::ChunkType(ty)) => {
            format!("unexpected {ty:?} chunk (the first chunk must be JSON, the second BIN)")
        }
        gltf::Error::Binary(B::UnknownChunkType(t)) => {
            format!("unknown GLB chunk type {:?}", String::from_utf8_lossy(&t))
        }
        other => format!("malformed GLB container: {other}"),
    }
}

/// The file header with its total length.
pub fn header(total: u32) -> [u8; HEADER_LEN] {
    let mut h = [0; HEADER_LEN];
    h[..4].copy_from_slice(MAGIC);
    h[4..8].copy_from_slice(&VERSION.to_le_bytes());
    h[8..].copy_from_slice(&total.to_le_bytes());
    h
}

/// A chunk's header: its length (padded) and type.
pub fn chunk_header(len: u32, kind: &[u8; 4]) -> [u8; 8] {
    let mut h = [0; 8];
    h[..4].copy_from_slice(&len.to_le_bytes());
    h[4..].copy_from_slice(kind);
    h
}

/// A whole GLB from a JSON text and a BIN chunk: the JSON padded with spaces, the BIN with
/// zeros, to 4 bytes, as the container requires.
pub fn frame(json: &[u8], bin: Option<&[u8]>) -> Vec<u8> {
    let padded = |n: usize| n.next_multiple_of(4);
    let json_len = padded(json.len());
    let chunks = 8 + json_len + bin.map_or(0, |b| 8 + padded(b.len()));
    let mut out = Vec::with_capacity(HEADER_LEN + chunks);
    out.extend_from_slice(&header((HEADER_LEN + chunks) as u32));
    out.extend_from_slice(&chunk_header(json_len as u32, JSON_CHUNK));
    out.extend_from_slice(json);
    out.resize(JSON_START + json_len, b' ');
    if let Some(b) = bin {
        out.extend_from_slice(&chunk_header(padded(b.len()) as u32, BIN_CHUNK));
        out.extend_from_slice(b);
        out.resize(HEADER_LEN + chunks, 0);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_framed_glb_splits_back_into_its_padded_chunks() {
        let bytes = frame(b"{\"a\":1}", Some(&[1, 2, 3]));
        assert_eq!(bytes.len() % 4, 0);
        let g = split(&bytes).unwrap();
        assert_eq!(g.json, b"{\"a\":1} ");
        assert_eq!(g.bin, Some(&[1u8, 2, 3, 0][..]));
        let plain = frame(b"{}", None);
        assert_eq!(split(&plain).unwrap().bin, None);
    }

    #[test]
    fn a_cut_or_foreign_header_is_named() {
        let bytes = frame(b"{}", None);
        assert!(matches!(
            split(&bytes[..8]),
            Err(GlbError::ShortHeader { len: 8 })
        ));
        let mut v1 = bytes.clone();
        v1[4] = 1;
        assert!(matches!(split(&v1), Err(GlbError::Version(1))));
        let cut = &bytes[..bytes.len() - 1];
        assert!(matches!(split(cut), Err(GlbError::Truncated { .. })));
    }
}
