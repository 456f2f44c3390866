//! Rows of bits on u64 words: the one representation of "which portals / which cells", so
//! the hot loops of the flow are word-wide ANDs and ORs rather than per-item tests.

/// Words needed for `n` bits.
pub fn words(n: usize) -> usize {
    n.div_ceil(64)
}

/// Bit `i` of `row`.
pub fn get(row: &[u64], i: usize) -> bool {
    row[i >> 6] >> (i & 63) & 1 == 1
}

/// Sets bit `i` of `row`.
pub fn set(row: &mut [u64], i: usize) {
    row[i >> 6] |= 1 << (i & 63);
}

/// How many bits of `row` are set.
pub fn count(row: &[u64]) -> usize {
    row.iter().map(|w| w.count_ones() as usize).sum()
}

/// The indices of the set bits, ascending.
pub fn ones(row: &[u64]) -> impl Iterator<Item = usize> + '_ {
    row.iter().enumerate().flat_map(|(wi, &w)| {
        let mut w = w;
        std::iter::from_fn(move || {
            if w == 0 {
                return None;
            }
            let b = w.trailing_zeros() as usize;
            w &= w - 1;
            Some(wi * 64 + b)
        })
    })
}

/// `out = a & b`, and whether that has a bit `seen` lacks. The flow's innermost loop, on
/// equal-length slices indexed directly so it compiles to straight vector code.
pub fn and_into(out: &mut [u64], a: &[u64], b: &[u64], seen: &[u64]) -> bool {
    let n = out.len();
    let (a, b, seen) = (&a[..n], &b[..n], &seen[..n]);
    let mut more = 0;
    for i in 0..n {
        let m = a[i] & b[i];
        out[i] = m;
        more |= m & !seen[i];
    }
    more != 0
}

/// A row with the first `n` bits set (the padding bits of the last word stay clear, so
/// counts and comparisons never see them).
pub fn all(n: usize) -> Vec<u64> {
    let mut v = vec![u64::MAX; words(n)];
    if n % 64 != 0 {
        if let Some(last) = v.last_mut() {
            *last = (1u64 << (n % 64)) - 1;
        }
    }
    v
}

/// A square matrix of bits, one row per item.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct BitMatrix {
    n: usize,
    words: usize,
    bits: Vec<u64>,
}

impl BitMatrix {
    /// `n` rows of `n` clear bits.
    pub fn new(n: usize) -> BitMatrix {
        let words = words(n);
        BitMatrix {
            n,
            words,
            bits: vec![0; n * words],
        }
    }
    /// The number of rows (and of columns).
    pub fn len(&self) -> usize {
        self.n
    }
    /// No rows.
    pub fn is_empty(&self) -> bool {
        self.n == 0
    }
    /// Words per row.
    pub fn words(&self) -> usize {
        self.words
    }
    /// Row `r`'s words.
    pub fn row(&self, r: usize) -> &[u64] {
        &self.bits[r * self.words..(r + 1) * self.words]
    }
    /// Row `r`'s words, to write.
    pub fn row_mut(&mut self, r: usize) -> &mut [u64] {
        &mut self.bits[r * self.words..(r + 1) * self.words]
    }
    /// Row `r`, column `c`.
    pub fn get(&self, r: usize, c: usize) -> bool {
        get(self.row(r), c)
    }
    /// Sets row `r`, column `c`.
    pub fn set(&mut self, r: usize, c: usize) {
        set(self.row_mut(r), c)
    }
    /// How many bits are set in all.
    pub fn count(&self) -> usize {
        count(&self.bits)
    }
    /// ORs `other` (same size) into this matrix.
    pub fn union_with(&mut self, other: &BitMatrix) {
        for (a, b) in self.bits.iter_mut().zip(&other.bits) {
            *a |= b;
        }
    }
    /// Every bit set here is set in `other`.
    pub fn is_subset_of(&self, other: &BitMatrix) -> bool {
        self.n == other.n && self.bits.iter().zip(&other.bits).all(|(a, b)| a & !b == 0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_and_padding() {
        let mut m = BitMatrix::new(70);
        m.set(3, 69);
        m.set(3, 0);
        assert!(m.get(3, 69) && !m.get(3, 68));
        assert_eq!(ones(m.row(3)).collect::<Vec<_>>(), vec![0, 69]);
        assert_eq!(count(&all(70)), 70);
        assert_eq!(count(&all(128)), 128);
    }
}
