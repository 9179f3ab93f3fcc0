//! Where each product of two entries of one row (or one cone) lands in the reduced
//! banded matrix: found once per structure, so building the matrix in every
//! interior-point iteration adds at known offsets instead of locating each entry again
//! and skipping slacks. Knows the band's layout only through [`Banded::offset`], and
//! nothing of values.

use super::banded::Banded;

/// For every entry `a` of a group (a row or a cone) whose column is a core column, the
/// offsets of the products (a, b) with the group's core entries b = lo..=a, in that
/// order, each with b's value (a copy: one load fewer in the innermost loop).
pub(super) struct Pairs<T> {
    /// Per entry: where its pairs start in `pairs` (one more entry at the end).
    start: Vec<u32>,
    pairs: Vec<(u32, T)>,
}

impl<T> Default for Pairs<T> {
    fn default() -> Self {
        Pairs {
            start: Vec::new(),
            pairs: Vec::new(),
        }
    }
}

impl<T: Copy> Pairs<T> {
    /// The pairs of the groups `ptr` delimits (group g: entries ptr[g]..ptr[g + 1]),
    /// whose entries sit at elimination positions `pos` (`slack` for a slack entry) and
    /// have the values `values`.
    pub fn build(
        &mut self,
        ptr: &[usize],
        pos: &[usize],
        values: &[T],
        slack: usize,
        band: &Banded,
    ) {
        self.start.clear();
        self.pairs.clear();
        for g in ptr.windows(2) {
            for a in g[0]..g[1] {
                self.start.push(self.pairs.len() as u32);
                if pos[a] == slack {
                    continue;
                }
                for b in g[0]..=a {
                    if pos[b] != slack {
                        self.pairs
                            .push((band.offset(pos[a], pos[b]) as u32, values[b]));
                    }
                }
            }
        }
        self.start.push(self.pairs.len() as u32);
    }

    /// Entry a's pairs: (offset in the band, value of entry b).
    #[inline]
    pub fn of(&self, a: usize) -> &[(u32, T)] {
        &self.pairs[self.start[a] as usize..self.start[a + 1] as usize]
    }
}
