//! PVS rows as Quake stores them: one bit per leaf (Quake 1: bit j is leaf j + 1, leaf 0 the
//! shared solid one never seen) or per cluster (Quake 2), compressed by the zero-run scheme
//! every engine's `Mod_DecompressVis` reads: a nonzero byte is itself, a zero byte is followed
//! by how many zero bytes it stands for (1 to 255).

/// Appends `row` compressed to `out`, as the extension's `zeroRun` rows are: runs stop at 255
/// zero bytes, the most one count says.
pub fn compress_row(row: &[u8], out: &mut Vec<u8>) {
    crate::format::visibility::zero_run_into(row, out);
}

/// Why a stored row cannot be read back.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RowError {
    /// The row starts outside the lump.
    Outside,
    /// The lump ends before the row does.
    Short,
    /// A zero byte followed by a count of 0, which engines read as an endless row.
    ZeroRun,
}

impl std::fmt::Display for RowError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            RowError::Outside => "starts outside the visibility lump",
            RowError::Short => "runs past the end of the visibility lump",
            RowError::ZeroRun => "has a zero run of length 0",
        })
    }
}

/// The `len`-byte row stored at `start` of `data`, as `Mod_DecompressVis` reads it (a run
/// that overshoots the row is cut at its end, as engines stop there).
pub fn decompress_row(data: &[u8], start: usize, len: usize) -> Result<Vec<u8>, RowError> {
    let mut out = Vec::with_capacity(len);
    let mut i = start;
    if start > data.len() || (start == data.len() && len > 0) {
        return Err(RowError::Outside);
    }
    while out.len() < len {
        let &b = data.get(i).ok_or(RowError::Short)?;
        if b != 0 {
            out.push(b);
            i += 1;
            continue;
        }
        let &run = data.get(i + 1).ok_or(RowError::Short)?;
        if run == 0 {
            return Err(RowError::ZeroRun);
        }
        let n = usize::from(run).min(len - out.len());
        out.resize(out.len() + n, 0);
        i += 2;
    }
    Ok(out)
}

/// Bytes of one uncompressed row of `n` bits.
pub fn row_bytes(n: usize) -> usize {
    n.div_ceil(8)
}

/// Sets bit `i` of a byte row.
pub(crate) fn set(row: &mut [u8], i: usize) {
    row[i >> 3] |= 1 << (i & 7);
}

/// Bit `i` of a byte row.
pub fn get(row: &[u8], i: usize) -> bool {
    row.get(i >> 3).is_some_and(|b| b >> (i & 7) & 1 == 1)
}

/// Set bits of a byte row.
pub fn count(row: &[u8]) -> usize {
    row.iter().map(|b| b.count_ones() as usize).sum()
}

/// Quake 2's visibility lump: the cluster count, each cluster's PVS and PHS offsets (from
/// the lump's start), then the compressed rows, every PVS row first, as q2 vis lays it out.
pub fn quake2_lump(pvs: &[Vec<u8>], phs: &[Vec<u8>]) -> Vec<u8> {
    let n = pvs.len();
    let header = 4 + 8 * n;
    let mut rows = Vec::new();
    let mut offsets = vec![[0usize; 2]; n];
    for (kind, set) in [pvs, phs].into_iter().enumerate() {
        for (c, row) in set.iter().enumerate() {
            offsets[c][kind] = header + rows.len();
            compress_row(row, &mut rows);
        }
    }
    let mut out = Vec::with_capacity(header + rows.len());
    out.extend((n as i32).to_le_bytes());
    for [a, b] in offsets {
        out.extend((a as i32).to_le_bytes());
        out.extend((b as i32).to_le_bytes());
    }
    out.extend(rows);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_round_trip_through_the_zero_runs() {
        let mut row = vec![0u8; 700];
        row[0] = 1;
        row[1] = 0x80;
        row[300] = 7;
        row[699] = 2;
        let mut packed = Vec::new();
        compress_row(&row, &mut packed);
        // 1, 0x80, then 298 zeros as a run of 255 and one of 43, 7, 398 zeros, 2.
        assert_eq!(&packed[..6], &[1, 0x80, 0, 255, 0, 43]);
        assert_eq!(decompress_row(&packed, 0, 700), Ok(row.clone()));
        let all_zero = vec![0u8; 3];
        let mut p = Vec::new();
        compress_row(&all_zero, &mut p);
        assert_eq!(p, vec![0, 3]);
        assert_eq!(decompress_row(&p, 0, 3), Ok(all_zero));
    }

    #[test]
    fn broken_rows_are_errors_not_panics() {
        assert_eq!(decompress_row(&[5], 0, 2), Err(RowError::Short));
        assert_eq!(decompress_row(&[0], 0, 2), Err(RowError::Short));
        assert_eq!(decompress_row(&[0, 0], 0, 2), Err(RowError::ZeroRun));
        assert_eq!(decompress_row(&[1], 4, 1), Err(RowError::Outside));
        // A run longer than the row stops at its end.
        assert_eq!(decompress_row(&[0, 9], 0, 2), Ok(vec![0, 0]));
    }
}
