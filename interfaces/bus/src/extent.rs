//! How much of each sample in a publisher's pool its earlier messages wrote, so that a
//! publish clears only that much instead of the type's whole capacity. A 2 MiB grid
//! holding a 60 kB map was cleared whole on every publish: 0.1 ms a tick, and 1.6-2.9 ms
//! (page faults) the first time each sample of the pool was used, which made the mapper
//! miss its budget on its first tick and on each new global map.
//!
//! The invariant: past its recorded extent, every byte of a sample is zero. A sample this
//! publisher has not used yet is all zero (iceoryx2 creates a publisher's data segment
//! zeroed, and only the publisher writes payloads); after a publish its extent is the
//! message's [`Message::used_len`](aisle_messages::Message::used_len), which the message
//! writer must not write past. Knows nothing of iceoryx2 beyond sample addresses.

/// Samples tracked at most; a pool larger than this is cleared whole past it (no
/// unbounded growth, and no allocation once the pool has been seen).
const MAX_TRACKED: usize = 256;

/// Per sample (by payload address): how many leading bytes may be non-zero.
#[derive(Debug, Default)]
pub(crate) struct Extents {
    samples: Vec<(usize, usize)>,
}

impl Extents {
    pub fn new() -> Extents {
        Extents {
            samples: Vec::with_capacity(16),
        }
    }

    /// How many leading bytes of the sample at `addr` (of `size` bytes) must be cleared
    /// before a message is written into it.
    pub fn dirty(&self, addr: usize, size: usize) -> usize {
        match self.samples.iter().find(|s| s.0 == addr) {
            Some(&(_, len)) => len,
            None if self.samples.len() < MAX_TRACKED => 0,
            None => size,
        }
    }

    /// Records that the sample at `addr` now holds non-zero bytes only in its first `len`.
    pub fn set(&mut self, addr: usize, len: usize) {
        if let Some(s) = self.samples.iter_mut().find(|s| s.0 == addr) {
            s.1 = len;
        } else if self.samples.len() < MAX_TRACKED {
            self.samples.push((addr, len));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_new_sample_is_clean_and_a_used_one_dirty_up_to_its_last_message() {
        let mut e = Extents::new();
        assert_eq!(e.dirty(0x1000, 4096), 0);
        e.set(0x1000, 300);
        assert_eq!(e.dirty(0x1000, 4096), 300);
        e.set(0x1000, 40);
        assert_eq!(e.dirty(0x1000, 4096), 40);
        assert_eq!(e.dirty(0x2000, 4096), 0);
    }

    #[test]
    fn past_the_tracked_samples_everything_is_cleared() {
        let mut e = Extents::new();
        for k in 0..MAX_TRACKED {
            e.set(k * 8, 1);
        }
        e.set(usize::MAX - 7, 1);
        assert_eq!(e.dirty(usize::MAX - 7, 4096), 4096);
        assert_eq!(e.dirty(8, 4096), 1);
    }
}
