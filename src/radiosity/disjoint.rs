//! Disjoint sets whose every set is named by its smallest member: the sets come out in a fixed
//! order whatever the order of the joins (chart seams' parts, emissive groups, double-sided
//! sheets).

/// Disjoint sets over `0..n`.
pub(super) struct Sets {
    parent: Vec<usize>,
}

impl Sets {
    /// `n` sets of one member each.
    pub fn new(n: usize) -> Sets {
        Sets {
            parent: (0..n).collect(),
        }
    }

    /// The smallest member of `i`'s set.
    pub fn root(&mut self, mut i: usize) -> usize {
        while self.parent[i] != i {
            self.parent[i] = self.parent[self.parent[i]];
            i = self.parent[i];
        }
        i
    }

    /// Joins the sets of `a` and `b`.
    pub fn join(&mut self, a: usize, b: usize) {
        let (ra, rb) = (self.root(a), self.root(b));
        self.parent[ra.max(rb)] = ra.min(rb);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_set_is_named_by_its_smallest_member_whatever_the_join_order() {
        let mut s = Sets::new(6);
        s.join(5, 3);
        s.join(3, 4);
        s.join(4, 1);
        s.join(2, 2);
        assert_eq!(
            (0..6).map(|i| s.root(i)).collect::<Vec<_>>(),
            [0, 1, 2, 1, 1, 1]
        );
    }
}
