//! Lost and repeated samples, found from each publisher's sequence numbers.
//!
//! Knows the header's `seq` and `source` fields; not the bus, nor what is done about a
//! loss (the drain counts and logs it).

use crate::payload_fields::{SEQ_AT, SOURCE_AT, u32_at, u64_at};
use std::collections::HashMap;

/// Tracks each publisher's sequence numbers to find lost and repeated samples.
#[derive(Debug, Default)]
pub(super) struct SeqTracker {
    last: HashMap<(usize, u32), u64>,
}

pub(super) enum SeqVerdict {
    New { lost: u64 },
    Repeat,
}

impl SeqTracker {
    /// The verdict on a sample of source `index` (one per service) with these bytes.
    pub(super) fn check(&mut self, index: usize, bytes: &[u8]) -> SeqVerdict {
        let seq = u64_at(bytes, SEQ_AT);
        let source = u32_at(bytes, SOURCE_AT);
        match self.last.insert((index, source), seq) {
            // A redelivered history sample (the same one we already have).
            Some(last) if last == seq => SeqVerdict::Repeat,
            Some(last) if seq > last => SeqVerdict::New {
                lost: seq - last - 1,
            },
            // First sample of this publisher, or it restarted its count.
            _ => SeqVerdict::New { lost: 0 },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn header_bytes(seq: u64, source: u32) -> Vec<u8> {
        let mut b = vec![0u8; 72];
        b[0..8].copy_from_slice(&seq.to_le_bytes());
        b[40..44].copy_from_slice(&source.to_le_bytes());
        b
    }

    fn lost(v: SeqVerdict) -> Option<u64> {
        match v {
            SeqVerdict::New { lost } => Some(lost),
            SeqVerdict::Repeat => None,
        }
    }

    #[test]
    fn sequence_gaps_count_as_lost_and_repeats_are_skipped() {
        let mut t = SeqTracker::default();
        assert_eq!(lost(t.check(0, &header_bytes(5, 1))), Some(0));
        assert_eq!(lost(t.check(0, &header_bytes(6, 1))), Some(0));
        assert_eq!(lost(t.check(0, &header_bytes(9, 1))), Some(2));
        assert_eq!(lost(t.check(0, &header_bytes(9, 1))), None);
        // Another publisher on the same service has its own count.
        assert_eq!(lost(t.check(0, &header_bytes(1, 2))), Some(0));
        // A restarted publisher counts from 1 again: not a loss.
        assert_eq!(lost(t.check(0, &header_bytes(1, 1))), Some(0));
    }
}
