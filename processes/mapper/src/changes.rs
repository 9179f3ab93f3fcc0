//! Which cells of the global map changed since a base (the last full map the node
//! published): the list a `MapChanges` message carries, kept as the map changes so that
//! publishing a change costs what changed, not a copy of the map.
//!
//! The log keeps a copy of the map as of the last look (`shadow`) and compares only the
//! span of cells an update may have written. A cell once changed stays listed until
//! the next base, even when it changes back: a holder of the base map that applies the
//! list is exact whichever earlier list it applied. Knows cells only; nothing of the
//! bus or of what the cells mean.

use std::ops::RangeInclusive;

/// The cells changed since the base, in the order they were first seen to change.
#[derive(Debug, Clone, Default)]
pub struct ChangeLog {
    /// The map as of the last [`ChangeLog::note`] (or the base).
    shadow: Vec<u8>,
    touched: Vec<u64>,
    /// One bit a cell: listed in `touched`.
    listed: Vec<u64>,
    base_version: u64,
}

impl ChangeLog {
    /// A log whose base is `cells` at `version`, with nothing changed.
    pub fn new(cells: &[u8], version: u64) -> ChangeLog {
        ChangeLog {
            shadow: cells.to_vec(),
            // One more than the node lists: it publishes the whole map beyond that.
            touched: Vec::with_capacity(crate::config::MAX_LISTED_CHANGES + 1),
            listed: vec![0; cells.len().div_ceil(64)],
            base_version: version,
        }
    }

    /// Makes `cells` at `version` the base: nothing has changed since.
    pub fn rebase(&mut self, cells: &[u8], version: u64) {
        self.shadow.copy_from_slice(cells);
        for &i in &self.touched {
            self.listed[(i / 64) as usize] = 0;
        }
        self.touched.clear();
        self.base_version = version;
    }

    /// Lists the cells of `span` (row-major indices into `cells`, the map now) that
    /// differ from the last look and are not listed yet. Cells outside `span` must not
    /// have changed since the last look.
    pub fn note(&mut self, cells: &[u8], span: RangeInclusive<usize>) {
        let (lo, hi) = (
            *span.start(),
            (*span.end()).min(cells.len().saturating_sub(1)),
        );
        if lo > hi || cells.len() != self.shadow.len() {
            return;
        }
        // Eight cells at a time: a scan's span covers many rows of mostly equal cells.
        let start = lo - lo % 8;
        let end = (hi + 1).next_multiple_of(8).min(cells.len());
        let (now, was) = (&cells[start..end], &mut self.shadow[start..end]);
        for (w, (a, b)) in now.chunks(8).zip(was.chunks_mut(8)).enumerate() {
            if a == b {
                continue;
            }
            for (k, (x, y)) in a.iter().zip(b.iter_mut()).enumerate() {
                if x != y {
                    list(&mut self.touched, &mut self.listed, start + 8 * w + k);
                    *y = *x;
                }
            }
        }
    }

    /// Lists `cells` (indices into the map) as changed since the base; indices past
    /// the map are left out.
    pub fn relist(&mut self, cells: impl IntoIterator<Item = u64>) {
        let n = self.shadow.len() as u64;
        for i in cells.into_iter().filter(|&i| i < n) {
            list(&mut self.touched, &mut self.listed, i as usize);
        }
    }

    /// Cells changed since the base, each once.
    pub fn touched(&self) -> &[u64] {
        &self.touched
    }

    /// The version of the base.
    pub fn base_version(&self) -> u64 {
        self.base_version
    }
}

fn list(touched: &mut Vec<u64>, listed: &mut [u64], i: usize) {
    let (w, bit) = (i / 64, 1u64 << (i % 64));
    if listed[w] & bit == 0 {
        listed[w] |= bit;
        touched.push(i as u64);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lists_each_changed_cell_once_until_the_next_base() {
        let mut map = vec![0u8; 100];
        let mut log = ChangeLog::new(&map, 4);
        map[3] = 2;
        map[70] = 2;
        log.note(&map, 0..=99);
        assert_eq!(log.touched(), &[3, 70]);
        // Changed back, and changed again: still listed once.
        map[3] = 0;
        map[99] = 1;
        log.note(&map, 3..=99);
        assert_eq!(log.touched(), &[3, 70, 99]);
        log.note(&map, 0..=99);
        assert_eq!(log.touched(), &[3, 70, 99], "nothing new");
        log.rebase(&map, 9);
        assert_eq!((log.touched(), log.base_version()), (&[][..], 9));
        map[3] = 2;
        log.note(&map, 3..=3);
        assert_eq!(log.touched(), &[3]);
    }

    #[test]
    fn a_span_that_is_not_word_aligned_sees_every_cell_in_it() {
        let mut map = vec![0u8; 37];
        let mut log = ChangeLog::new(&map, 0);
        for i in [5, 9, 17, 36] {
            map[i] = 2;
        }
        log.note(&map, 5..=36);
        assert_eq!(log.touched(), &[5, 9, 17, 36]);
        // A span past the map's end is cut to it.
        map[0] = 1;
        log.note(&map, 0..=1000);
        assert_eq!(log.touched(), &[5, 9, 17, 36, 0]);
    }
}
