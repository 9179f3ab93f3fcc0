//! Which clock a record's `log_time` is on, so a viewer plays it at the speed of the
//! mission and dates it correctly:
//! - lockstep: the message's sim time (`stamp_ns`); a message without one (a
//!   heartbeat, the membership, the recorder's own acknowledgement: stamp 0) is logged
//!   at the newest sim time seen before it;
//! - realtime: the wall time since the Unix epoch at which it was received (the
//!   monotonic receive time plus the epoch offset taken once at the start, so the log
//!   never jumps with the wall clock), the sim time being its `publish_time`.
//!
//! Knows the header's stamp; takes clock readings only in [`LogClock::of_mode`].

use crate::payload_fields::{STAMP_AT, u64_at};
use aisle_bus::clock;
use aisle_messages::TickMode;

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LogClock {
    Sim { newest: u64 },
    Unix { offset_ns: u64 },
}

impl LogClock {
    /// The clock of a run in `mode`.
    pub fn of_mode(mode: TickMode) -> LogClock {
        match mode {
            TickMode::Lockstep => LogClock::Sim { newest: 0 },
            TickMode::Realtime => {
                let unix = std::time::SystemTime::now()
                    .duration_since(std::time::UNIX_EPOCH)
                    .map_or(0, |d| d.as_nanos() as u64);
                LogClock::Unix {
                    offset_ns: unix.saturating_sub(clock::monotonic_ns()),
                }
            }
        }
    }

    /// The name written in the run's metadata (`log_time`).
    pub fn name(&self) -> &'static str {
        match self {
            LogClock::Sim { .. } => "sim time",
            LogClock::Unix { .. } => "unix time",
        }
    }

    /// `log_time` of `payload`, received at monotonic `received_ns`.
    pub fn of_payload(&mut self, received_ns: u64, payload: &[u8]) -> u64 {
        match self {
            LogClock::Sim { newest } => {
                let stamp = u64_at(payload, STAMP_AT);
                if stamp == 0 {
                    *newest
                } else {
                    *newest = (*newest).max(stamp);
                    stamp
                }
            }
            LogClock::Unix { offset_ns } => received_ns.saturating_add(*offset_ns),
        }
    }

    /// `log_time` of something that is not a message (an attachment) made at
    /// monotonic `at_ns`.
    pub fn of_event(&self, at_ns: u64) -> u64 {
        match self {
            LogClock::Sim { newest } => *newest,
            LogClock::Unix { offset_ns } => at_ns.saturating_add(*offset_ns),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use aisle_messages::{Header, Message, Tick, zeroed_box};

    fn payload(stamp_ns: u64) -> Vec<u8> {
        let mut t = zeroed_box::<Tick>();
        t.header_mut().stamp_ns = stamp_ns;
        let h: &Header = t.header();
        assert_eq!(h.stamp_ns, stamp_ns);
        crate::aligned::message_bytes(&*t).to_vec()
    }

    #[test]
    fn lockstep_logs_sim_time_and_unstamped_messages_at_the_newest() {
        let mut c = LogClock::of_mode(TickMode::Lockstep);
        assert_eq!(c.of_payload(123, &payload(0)), 0);
        assert_eq!(c.of_payload(456, &payload(200_000_000)), 200_000_000);
        assert_eq!(c.of_payload(789, &payload(0)), 200_000_000);
        // A late message keeps its own sim time.
        assert_eq!(c.of_payload(999, &payload(100_000_000)), 100_000_000);
        assert_eq!(c.of_event(5), 200_000_000);
        assert_eq!(c.name(), "sim time");
    }

    #[test]
    fn realtime_logs_unix_time() {
        let mut c = LogClock::of_mode(TickMode::Realtime);
        let now = clock::monotonic_ns();
        let t = c.of_payload(now, &payload(7));
        // After 2020-01-01 and before 2200: a date, not a time since boot.
        assert!(
            t > 1_577_836_800_000_000_000 && t < 7_258_118_400_000_000_000,
            "{t}"
        );
        assert_eq!(c.of_payload(now + 10, &payload(7)), t + 10);
        assert_eq!(c.of_event(now), t);
    }
}
