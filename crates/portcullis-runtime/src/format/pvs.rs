//! The result of every method: one row of cell bits per cell, the row of `c` holding the cells
//! visible from `c`, `c` included. Ordered pairs, because one-way portals make visibility
//! asymmetric.

use super::bits::{self, BitMatrix};
use super::FormatError;

/// How many transformed portals (mirrors, teleporters) one sightline may pass through when
/// there is no level to ask: graphs built by hand or read from .prt files (which have no
/// transforms). Levels use `pipeline::transform_depth`, the loop check's run-time bound; two
/// covers a mirror seen in a mirror.
pub const DEFAULT_TRANSFORM_DEPTH: usize = 2;

/// How the PVS is computed: `flood` ⊇ `fast` ⊇ `full` are conservative, `sampled` a lower bound.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Method {
    /// Reachability through portals: the loosest.
    Flood,
    /// Quake's per-portal might-see: front tests, then a flood.
    Fast,
    /// Portal flow with separating-plane clipping, as Quake's vis: the tightest.
    Full,
    /// Random sightlines walked through the portals: a lower bound, to check the others by.
    Sampled,
}

impl Method {
    /// Every method, loosest first.
    pub const ALL: [Method; 4] = [Method::Flood, Method::Fast, Method::Full, Method::Sampled];

    /// The method named `s` as on the command line (`flood`, `fast`, `full`, `sampled`).
    pub fn parse(s: &str) -> Option<Method> {
        Some(match s {
            "flood" => Method::Flood,
            "fast" => Method::Fast,
            "full" => Method::Full,
            "sampled" => Method::Sampled,
            _ => return None,
        })
    }
    /// The name `parse` reads.
    pub fn name(self) -> &'static str {
        match self {
            Method::Flood => "flood",
            Method::Fast => "fast",
            Method::Full => "full",
            Method::Sampled => "sampled",
        }
    }
}

/// Potentially visible sets: for each cell, the cells that can be seen from anywhere in it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Pvs {
    /// Row `from`, column `to`: set when `to` may be seen from `from`.
    pub bits: BitMatrix,
}

impl Pvs {
    /// Every cell sees itself and nothing else yet.
    pub fn identity(cells: usize) -> Pvs {
        let mut bits = BitMatrix::new(cells);
        for c in 0..cells {
            bits.set(c, c);
        }
        Pvs { bits }
    }
    /// The rows and columns of the first `n` cells (the level's, without the outside).
    pub fn first_cells(&self, n: usize) -> Pvs {
        let mut out = Pvs::identity(n);
        for c in 0..n.min(self.cells()) {
            for v in self.visible(c).take_while(|&v| v < n) {
                out.bits.set(c, v);
            }
        }
        out
    }
    /// How many cells (rows).
    pub fn cells(&self) -> usize {
        self.bits.len()
    }
    /// Whether `to` may be seen from somewhere in `from`.
    pub fn sees(&self, from: usize, to: usize) -> bool {
        self.bits.get(from, to)
    }
    /// The cells `from` may see, ascending (itself included).
    pub fn visible(&self, from: usize) -> impl Iterator<Item = usize> + '_ {
        bits::ones(self.bits.row(from))
    }
    /// Ordered (cell, cell) pairs, each cell with itself included — the count the Quake
    /// tools report, so numbers compare directly.
    pub fn pairs(&self) -> usize {
        self.bits.count()
    }
    /// Whether every pair here is also in `other` (this PVS is at least as tight).
    pub fn is_subset_of(&self, other: &Pvs) -> bool {
        self.bits.is_subset_of(&other.bits)
    }
    /// Pairs set here and not in `other`, in row order.
    pub fn missing_from(&self, other: &Pvs) -> Vec<(usize, usize)> {
        (0..self.cells())
            .flat_map(|c| {
                self.visible(c)
                    .filter(move |&v| other.cells() <= c.max(v) || !other.sees(c, v))
                    .map(move |v| (c, v))
            })
            .collect()
    }

    /// One line per cell, `c: v1 v2 ...`, ascending (the form of the reference files).
    pub fn to_text(&self) -> String {
        let mut out = Vec::new();
        self.write_text(&mut out)
            .expect("writing to memory cannot fail");
        String::from_utf8(out).expect("digits, colons and spaces are UTF-8")
    }

    /// [`Pvs::to_text`] streamed, so printing a big PVS never holds its text in memory.
    pub fn write_text(&self, w: &mut impl std::io::Write) -> std::io::Result<()> {
        for c in 0..self.cells() {
            write!(w, "{c}:")?;
            for v in self.visible(c) {
                write!(w, " {v}")?;
            }
            writeln!(w)?;
        }
        Ok(())
    }

    /// Reads the `c: v1 v2 ...` form. `Err` names the line (1-based) that does not parse.
    pub fn parse_text(text: &str, cells: usize) -> Result<Pvs, FormatError> {
        let mut bits = BitMatrix::new(cells);
        for (i, line) in text.lines().enumerate() {
            let line = line.trim();
            if line.is_empty() {
                continue;
            }
            let n = i + 1;
            let (c, rest) = line.split_once(':').ok_or(FormatError::TextNoColon(n))?;
            let c: usize = c.trim().parse().map_err(|_| FormatError::TextBadCell(n))?;
            if c >= cells {
                return Err(FormatError::TextCellOutOfRange(n));
            }
            for t in rest.split_whitespace() {
                let v: usize = t.parse().map_err(|_| FormatError::TextBadVisible(n))?;
                if v >= cells {
                    return Err(FormatError::TextVisibleOutOfRange(n));
                }
                bits.set(c, v);
            }
        }
        Ok(Pvs { bits })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn text_round_trips() {
        let mut p = Pvs::identity(3);
        p.bits.set(0, 2);
        let t = p.to_text();
        assert_eq!(t, "0: 0 2\n1: 1\n2: 2\n");
        assert_eq!(Pvs::parse_text(&t, 3).unwrap(), p);
        assert_eq!(p.pairs(), 4);
        assert_eq!(
            Pvs::parse_text("0: 5", 3),
            Err(FormatError::TextVisibleOutOfRange(1))
        );
        assert_eq!(
            FormatError::TextVisibleOutOfRange(1).to_string(),
            "line 1: visible cell out of range"
        );
    }
}
