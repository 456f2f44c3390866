//! Quake 2's potentially hearable set: a sound in cluster b is sent to a client in cluster a
//! when b is in the PHS row of a. q2 vis (and ericw's `CalcPHS`) makes that row the union
//! of the PVS rows of every cluster a's PVS holds, so a sound one room beyond what a client
//! could see still reaches it.

use crate::format::bits;
use crate::vis::Pvs;

/// Each cluster's PHS as a byte row (`ceil(n / 8)` bytes, bit j is cluster j).
pub fn phs(pvs: &Pvs) -> Vec<Vec<u8>> {
    let n = pvs.cells();
    let words = bits::words(n);
    let mut acc = vec![0u64; words];
    (0..n)
        .map(|a| {
            acc.iter_mut().for_each(|w| *w = 0);
            for b in pvs.visible(a) {
                for (w, v) in acc.iter_mut().zip(pvs.bits.row(b)) {
                    *w |= v;
                }
            }
            bytes_of(&acc, n)
        })
        .collect()
}

/// A cluster's PVS as a byte row.
pub fn pvs_row(pvs: &Pvs, a: usize) -> Vec<u8> {
    bytes_of(pvs.bits.row(a), pvs.cells())
}

/// The first `ceil(n / 8)` bytes of a row of words, little end first.
fn bytes_of(row: &[u64], n: usize) -> Vec<u8> {
    let mut out: Vec<u8> = row.iter().flat_map(|w| w.to_le_bytes()).collect();
    out.truncate(super::visdata::row_bytes(n));
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_phs_reaches_one_cluster_past_the_pvs() {
        // A chain 0 - 1 - 2 - 3, each seeing its neighbours.
        let mut pvs = Pvs::identity(4);
        for (a, b) in [(0, 1), (1, 2), (2, 3)] {
            pvs.bits.set(a, b);
            pvs.bits.set(b, a);
        }
        let h = phs(&pvs);
        assert_eq!(h[0], vec![0b0111]);
        assert_eq!(h[1], vec![0b1111]);
        assert_eq!(h[3], vec![0b1110]);
        assert_eq!(pvs_row(&pvs, 0), vec![0b0011]);
    }
}
