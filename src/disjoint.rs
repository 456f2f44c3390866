//! Disjoint sets (union-find with path halving): which pieces join into one part, for the
//! floods of the cells stage (air regions, areas, welded vertices) and the generator's doors.

/// A partition of `0..n` into parts, each named by its least member.
pub(crate) struct DisjointSets {
    parent: Vec<usize>,
}

impl DisjointSets {
    /// Every member in a part of its own.
    pub fn new(n: usize) -> DisjointSets {
        DisjointSets {
            parent: (0..n).collect(),
        }
    }

    /// Adds a member in a part of its own and returns it.
    pub fn push(&mut self) -> usize {
        let n = self.parent.len();
        self.parent.push(n);
        n
    }

    /// The least member of `x`'s part.
    pub fn find(&mut self, mut x: usize) -> usize {
        while self.parent[x] != x {
            self.parent[x] = self.parent[self.parent[x]];
            x = self.parent[x];
        }
        x
    }

    /// Joins the parts of `a` and `b`; false when they were one already.
    pub fn union(&mut self, a: usize, b: usize) -> bool {
        let (a, b) = (self.find(a), self.find(b));
        if a != b {
            self.parent[a.max(b)] = a.min(b);
        }
        a != b
    }
}

#[cfg(test)]
mod tests {
    use super::DisjointSets;

    #[test]
    fn parts_are_named_by_their_least_member() {
        let mut d = DisjointSets::new(6);
        assert!(d.union(4, 2));
        assert!(d.union(5, 4));
        assert!(!d.union(2, 5));
        assert_eq!((d.find(5), d.find(4), d.find(2)), (2, 2, 2));
        assert_eq!((d.find(0), d.find(1), d.find(3)), (0, 1, 3));
    }
}
