//! The command timeline the controller hands to the simulator: up to
//! [`MAX_COMMANDS`] (t, v, w) entries relative to an absolute start time, applied by
//! zero-order hold, with a watchdog hold after the last entry.
//!
//! Semantics:
//! - the command in force at absolute time `T` is the last entry whose
//!   `start + t <= T` (entries with equal stamps: the later one wins);
//! - before the first entry, no command is in force;
//! - the last entry stays in force for `hold` after its stamp, then no command is in
//!   force (the watchdog): the robot stops until a new timeline arrives;
//! - nothing is in force from the timeline's expiry on (when its successor is overdue,
//!   [`CommandTimeline::set_expiry`]), however many entries it still holds.
//!
//! Times are integer nanoseconds (u64) so boundaries compare exactly; the seconds
//! given by the controller are rounded to the nearest nanosecond once, on entry.
//! Storage is a fixed array: setting a timeline never allocates.
//!
//! Knows nothing of kinematics or the world.

use crate::kinematics::Twist;

/// Most entries a timeline holds (the controller's message capacity).
pub const MAX_COMMANDS: usize = 512;

/// Largest stamp accepted, seconds (about 31 years: far beyond any run, far below
/// the u64 nanosecond range).
const MAX_STAMP_S: f64 = 1e9;

/// One entry: offset from the timeline's start, and the commanded twist.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct TimedCommand {
    pub offset_ns: u64,
    pub twist: Twist,
}

/// A timeline that cannot be used; the previous one stays in force.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TimelineError {
    #[error("timeline has {len} commands, at most {MAX_COMMANDS} are allowed")]
    TooLong { len: usize },
    #[error("timeline command {index}: t, v and w must be finite, got {values:?}")]
    NotFinite { index: usize, values: [f64; 3] },
    #[error("timeline command {index}: t = {t} s is out of range [0, 1e9]")]
    OutOfRange { index: usize, t: f64 },
    #[error("timeline command {index}: t = {t} s is earlier than the previous command")]
    Decreasing { index: usize, t: f64 },
}

/// What is in force at some instant, and until when.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Segment {
    /// `None` when no command covers the instant (the robot must stop).
    pub command: Option<Twist>,
    /// First instant (ns) at which something else is in force; `u64::MAX` for never.
    pub until_ns: u64,
}

/// A zero-order-hold command timeline with fixed capacity.
#[derive(Debug, Clone, PartialEq)]
pub struct CommandTimeline {
    start_ns: u64,
    /// First instant at which nothing of this timeline is in force any more.
    expiry_ns: u64,
    len: usize,
    entries: [TimedCommand; MAX_COMMANDS],
}

impl Default for CommandTimeline {
    fn default() -> Self {
        Self {
            start_ns: 0,
            expiry_ns: u64::MAX,
            len: 0,
            entries: [TimedCommand::default(); MAX_COMMANDS],
        }
    }
}

/// Seconds to nanoseconds, rounded; the caller has checked the range.
pub fn seconds_to_ns(t: f64) -> u64 {
    (t * 1e9).round() as u64
}

impl CommandTimeline {
    /// Replaces the timeline with `commands` ((t seconds from `start_ns`, v, w)).
    /// On error the current timeline is kept untouched.
    pub fn set(
        &mut self,
        start_ns: u64,
        commands: &[(f64, f64, f64)],
    ) -> Result<(), TimelineError> {
        self.set_iter(start_ns, commands.iter().copied())
    }

    /// As [`CommandTimeline::set`], from any cloneable iterator (for example a mapping
    /// over a message's command array), so the caller needs no intermediate `Vec`.
    /// The iterator is walked twice: once to validate, once to store.
    pub fn set_iter<I>(&mut self, start_ns: u64, commands: I) -> Result<(), TimelineError>
    where
        I: IntoIterator<Item = (f64, f64, f64)>,
        I::IntoIter: Clone,
    {
        let commands = commands.into_iter();
        let mut prev = 0.0;
        let mut len = 0;
        for (index, (t, v, w)) in commands.clone().enumerate() {
            if index >= MAX_COMMANDS {
                return Err(TimelineError::TooLong {
                    len: commands.clone().count(),
                });
            }
            if !(t.is_finite() && v.is_finite() && w.is_finite()) {
                return Err(TimelineError::NotFinite {
                    index,
                    values: [t, v, w],
                });
            }
            if !(0.0..=MAX_STAMP_S).contains(&t) {
                return Err(TimelineError::OutOfRange { index, t });
            }
            if index > 0 && t < prev {
                return Err(TimelineError::Decreasing { index, t });
            }
            prev = t;
            len = index + 1;
        }
        self.start_ns = start_ns;
        self.expiry_ns = u64::MAX;
        self.len = len;
        for (e, (t, v, w)) in self.entries.iter_mut().zip(commands) {
            *e = TimedCommand {
                offset_ns: seconds_to_ns(t),
                twist: Twist { v, w },
            };
        }
        Ok(())
    }

    /// Rebuilds a timeline from stored entries, exactly (a restarted simulator reading
    /// back its published state). Refused when the entries are too many or out of order.
    pub fn from_entries(
        start_ns: u64,
        entries: &[TimedCommand],
    ) -> Result<CommandTimeline, TimelineError> {
        if entries.len() > MAX_COMMANDS {
            return Err(TimelineError::TooLong { len: entries.len() });
        }
        let mut out = CommandTimeline::default();
        for (index, e) in entries.iter().enumerate() {
            let t = e.offset_ns as f64 * 1e-9;
            if !(e.twist.v.is_finite() && e.twist.w.is_finite()) {
                return Err(TimelineError::NotFinite {
                    index,
                    values: [t, e.twist.v, e.twist.w],
                });
            }
            if index > 0 && e.offset_ns < entries[index - 1].offset_ns {
                return Err(TimelineError::Decreasing { index, t });
            }
            out.entries[index] = *e;
        }
        out.start_ns = start_ns;
        out.len = entries.len();
        Ok(out)
    }

    /// Ends the timeline at `expiry_ns` (absolute): from then on no command is in force.
    /// Setting a new timeline clears the expiry.
    pub fn set_expiry(&mut self, expiry_ns: u64) {
        self.expiry_ns = expiry_ns;
    }

    /// See [`CommandTimeline::set_expiry`]; `u64::MAX` for none.
    pub fn expiry_ns(&self) -> u64 {
        self.expiry_ns
    }

    /// Drops every command: the robot stops at once.
    pub fn clear(&mut self) {
        self.len = 0;
    }

    pub fn start_ns(&self) -> u64 {
        self.start_ns
    }

    pub fn len(&self) -> usize {
        self.len
    }

    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    pub fn commands(&self) -> &[TimedCommand] {
        &self.entries[..self.len]
    }

    fn abs_ns(&self, i: usize) -> u64 {
        self.start_ns.saturating_add(self.entries[i].offset_ns)
    }

    /// The command in force at `t_ns` and when that changes, given the watchdog hold
    /// of the last entry and the timeline's expiry.
    pub fn segment_at(&self, t_ns: u64, hold_ns: u64) -> Segment {
        if t_ns >= self.expiry_ns {
            return Segment {
                command: None,
                until_ns: u64::MAX,
            };
        }
        let mut seg = self.segment_by_entries(t_ns, hold_ns);
        if seg.command.is_some() {
            seg.until_ns = seg.until_ns.min(self.expiry_ns);
        }
        seg
    }

    fn segment_by_entries(&self, t_ns: u64, hold_ns: u64) -> Segment {
        let cmds = self.commands();
        // Number of entries stamped at or before t (stamps are non-decreasing).
        let k = cmds.partition_point(|c| self.start_ns.saturating_add(c.offset_ns) <= t_ns);
        if k == 0 {
            return Segment {
                command: None,
                until_ns: if self.len == 0 {
                    u64::MAX
                } else {
                    self.abs_ns(0)
                },
            };
        }
        let i = k - 1;
        if k < self.len {
            return Segment {
                command: Some(cmds[i].twist),
                until_ns: self.abs_ns(k),
            };
        }
        let expiry = self.abs_ns(i).saturating_add(hold_ns);
        if t_ns < expiry {
            Segment {
                command: Some(cmds[i].twist),
                until_ns: expiry,
            }
        } else {
            Segment {
                command: None,
                until_ns: u64::MAX,
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MS: u64 = 1_000_000;

    fn tl(start: u64, c: &[(f64, f64, f64)]) -> CommandTimeline {
        let mut t = CommandTimeline::default();
        t.set(start, c).unwrap();
        t
    }

    fn v_at(t: &CommandTimeline, now: u64) -> Option<f64> {
        t.segment_at(now, 600 * MS).command.map(|c| c.v)
    }

    #[test]
    fn zero_order_hold_picks_the_last_stamp_at_or_before_now() {
        let t = tl(
            1000 * MS,
            &[(0.0, 1.0, 0.0), (0.3, 2.0, 0.0), (0.6, 3.0, 0.0)],
        );
        assert_eq!(v_at(&t, 999 * MS), None);
        assert_eq!(v_at(&t, 1000 * MS), Some(1.0));
        assert_eq!(v_at(&t, 1299 * MS), Some(1.0));
        assert_eq!(v_at(&t, 1300 * MS), Some(2.0));
        assert_eq!(v_at(&t, 1300 * MS - 1), Some(1.0));
        assert_eq!(v_at(&t, 1600 * MS), Some(3.0));
        assert_eq!(t.segment_at(1000 * MS, 600 * MS).until_ns, 1300 * MS);
        assert_eq!(t.segment_at(999 * MS, 600 * MS).until_ns, 1000 * MS);
    }

    #[test]
    fn the_watchdog_ends_the_last_command_after_the_hold() {
        let t = tl(0, &[(0.0, 1.0, 0.0), (0.5, 2.0, 0.5)]);
        assert_eq!(v_at(&t, 1099 * MS), Some(2.0));
        let s = t.segment_at(1000 * MS, 600 * MS);
        assert_eq!(s.until_ns, 1100 * MS);
        assert_eq!(v_at(&t, 1100 * MS), None);
        assert_eq!(t.segment_at(1100 * MS, 600 * MS).until_ns, u64::MAX);
        let mut t = t;
        t.clear();
        assert_eq!(v_at(&t, 0), None);
    }

    #[test]
    fn an_expired_timeline_commands_nothing_and_a_new_one_clears_the_expiry() {
        // Entries run to 2.5 s, but the timeline expires at 0.8 s: a segment crossing
        // the expiry is cut there, and nothing is in force afterwards.
        let mut t = tl(0, &[(0.0, 1.0, 0.0), (0.5, 2.0, 0.0), (2.5, 3.0, 0.0)]);
        t.set_expiry(800 * MS);
        assert_eq!(t.segment_at(600 * MS, 300 * MS).until_ns, 800 * MS);
        assert_eq!(v_at(&t, 799 * MS), Some(2.0));
        assert_eq!(v_at(&t, 800 * MS), None);
        assert_eq!(v_at(&t, 2600 * MS), None);
        assert_eq!(t.segment_at(800 * MS, 300 * MS).until_ns, u64::MAX);
        t.set(1000 * MS, &[(0.0, 4.0, 0.0)]).unwrap();
        assert_eq!(t.expiry_ns(), u64::MAX);
        assert_eq!(v_at(&t, 1200 * MS), Some(4.0));
    }

    #[test]
    fn equal_stamps_let_the_later_entry_win() {
        let t = tl(0, &[(0.0, 1.0, 0.0), (0.2, 2.0, 0.0), (0.2, 5.0, 0.0)]);
        assert_eq!(v_at(&t, 200 * MS), Some(5.0));
        assert_eq!(v_at(&t, 199 * MS), Some(1.0));
    }

    #[test]
    fn bad_timelines_are_refused_and_keep_the_old_one() {
        let mut t = tl(0, &[(0.0, 1.0, 0.0)]);
        let before = t.clone();
        // NaN != NaN, so compare by pattern.
        assert!(matches!(
            t.set(0, &[(0.0, 1.0, 0.0), (0.1, f64::NAN, 0.0)]),
            Err(TimelineError::NotFinite { index: 1, .. })
        ));
        assert!(matches!(
            t.set(0, &[(0.3, 1.0, 0.0), (0.2, 1.0, 0.0)]),
            Err(TimelineError::Decreasing { index: 1, .. })
        ));
        assert!(matches!(
            t.set(0, &[(-0.1, 1.0, 0.0)]),
            Err(TimelineError::OutOfRange { index: 0, .. })
        ));
        let long = vec![(0.0, 0.0, 0.0); MAX_COMMANDS + 1];
        assert_eq!(t.set(0, &long), Err(TimelineError::TooLong { len: 513 }));
        assert_eq!(t, before);
        let full = vec![(0.0, 0.0, 0.0); MAX_COMMANDS];
        assert!(t.set(0, &full).is_ok());
    }

    #[test]
    fn set_iter_matches_set_and_validates_the_same() {
        let cmds = [(0.0, 1.0, 0.1), (0.3, 2.0, -0.2), (0.6, 0.5, 0.0)];
        let mut a = CommandTimeline::default();
        a.set(7, &cmds).unwrap();
        let mut b = CommandTimeline::default();
        // A mapping over some other record type, as a message adapter would write it.
        let msgs: Vec<[f64; 3]> = cmds.iter().map(|&(t, v, w)| [t, v, w]).collect();
        b.set_iter(7, msgs.iter().map(|m| (m[0], m[1], m[2])))
            .unwrap();
        assert_eq!(a, b);
        let before = b.clone();
        let long = std::iter::repeat_n((0.0, 0.0, 0.0), MAX_COMMANDS + 3);
        assert_eq!(
            b.set_iter(0, long),
            Err(TimelineError::TooLong { len: 515 })
        );
        assert!(matches!(
            b.set_iter(0, [(0.2, 0.0, 0.0), (0.1, 0.0, 0.0)]),
            Err(TimelineError::Decreasing { index: 1, .. })
        ));
        assert_eq!(b, before);
        b.set_iter(0, std::iter::empty()).unwrap();
        assert!(b.is_empty());
    }

    #[test]
    fn stamps_round_to_the_nearest_nanosecond() {
        let t = tl(0, &[(0.0, 0.0, 0.0), (0.3, 1.0, 0.0), (2.7, 2.0, 0.0)]);
        assert_eq!(t.commands()[1].offset_ns, 300 * MS);
        assert_eq!(t.commands()[2].offset_ns, 2700 * MS);
    }

    #[test]
    fn a_timeline_rebuilt_from_its_entries_is_identical() {
        let mut a = CommandTimeline::default();
        a.set(
            5_000_000_000,
            &[(0.0, 1.0, 0.1), (0.3, 1.5, -0.2), (0.7, 0.1, 1.0 / 3.0)],
        )
        .unwrap();
        let b = CommandTimeline::from_entries(a.start_ns(), a.commands()).unwrap();
        assert_eq!(a, b);
        let mut wrong = a.commands().to_vec();
        wrong.swap(0, 2);
        assert!(CommandTimeline::from_entries(0, &wrong).is_err());
    }
}
