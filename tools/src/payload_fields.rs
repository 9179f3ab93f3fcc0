//! Fields read straight from a payload's bytes: the header every message starts with,
//! and the node and status of a `TickDone`, at the offsets of the message crate's layout.
//!
//! A stored payload may lack its trailing zeros, so bytes past its end read as zero.
//! Knows the layouts; not the files, the bus or what the fields are used for.

use aisle_messages::{Header, Tick, TickDone};
use std::mem::offset_of;

pub(crate) const SEQ_AT: usize = offset_of!(Header, seq);
pub(crate) const STAMP_AT: usize = offset_of!(Header, stamp_ns);
pub(crate) const TICK_AT: usize = offset_of!(Header, tick);
pub(crate) const TICK_WALL_AT: usize = offset_of!(Header, tick_wall_ns);
pub(crate) const PUBLISH_WALL_AT: usize = offset_of!(Header, publish_wall_ns);
pub(crate) const SOURCE_AT: usize = offset_of!(Header, source);
pub(crate) const DONE_NODE_AT: usize = offset_of!(TickDone, node);
pub(crate) const DONE_STATUS_AT: usize = offset_of!(TickDone, status);
pub(crate) const TICK_STAGES_AT: usize = offset_of!(Tick, stages);

/// The `N` bytes at `at` (zero past the end of `b`).
fn bytes_at<const N: usize>(b: &[u8], at: usize) -> [u8; N] {
    let mut w = [0u8; N];
    if at < b.len() {
        let n = (b.len() - at).min(N);
        w[..n].copy_from_slice(&b[at..at + n]);
    }
    w
}

/// The little-endian `u64` at `at` (zero-extended past the end of `b`).
pub(crate) fn u64_at(b: &[u8], at: usize) -> u64 {
    u64::from_le_bytes(bytes_at(b, at))
}

/// The little-endian `u32` at `at` (zero-extended past the end of `b`).
pub(crate) fn u32_at(b: &[u8], at: usize) -> u32 {
    u32::from_le_bytes(bytes_at(b, at))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn header_offsets_match_the_message_crate() {
        let f = aisle_messages::Header::FIELDS;
        let at = |n: &str| f.iter().find(|x| x.name == n).unwrap().offset;
        assert_eq!(at("seq"), SEQ_AT);
        assert_eq!(at("stamp_ns"), STAMP_AT);
        assert_eq!(at("source"), SOURCE_AT);
        assert_eq!(
            (
                SEQ_AT,
                STAMP_AT,
                TICK_AT,
                TICK_WALL_AT,
                PUBLISH_WALL_AT,
                SOURCE_AT
            ),
            (0, 8, 16, 24, 32, 40)
        );
        assert_eq!((DONE_NODE_AT, DONE_STATUS_AT), (48, 52));
    }

    #[test]
    fn bytes_past_the_end_read_as_zero() {
        let b = [1u8, 2, 3];
        assert_eq!(u64_at(&b, 0), 0x030201);
        assert_eq!(u32_at(&b, 2), 3);
        assert_eq!(u64_at(&b, 8), 0);
    }
}
