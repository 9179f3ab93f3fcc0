//! The tick-release row: when each tick started against the ideal schedule. Not a
//! latency and not scored against a budget (see the module above for the definitions).

use super::stats::Summary;
use serde::{Deserialize, Serialize};

/// Name of the lateness series (in the table and the samples export).
pub const LATENESS: &str = "tick release lateness";

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TickRelease {
    /// `lockstep` or `realtime`.
    pub mode: String,
    /// Ticks seen.
    pub ticks: usize,
    /// The tick period, in milliseconds.
    pub period_ms: f64,
    /// Realtime: lateness of each tick's start against start + k·dt. `None` in lockstep
    /// (a tick starts when the group has finished the previous one).
    pub lateness: Option<Summary>,
    /// Realtime: ticks that started a whole period or more late (the loop overran).
    pub overruns: usize,
    /// Tick numbers never seen between the first and the last one seen.
    pub skipped: u64,
}

/// The lateness of every release `(tick, start wall ns)`, in order, against its
/// schedule: a new schedule begins where the tick number does not increase (a
/// restarted simulator repeats the tick it died in and starts its own clock).
pub fn lateness(releases: &[(u64, u64)], dt_ns: u64) -> Vec<(u64, u64)> {
    let mut out = Vec::with_capacity(releases.len());
    for segment in segments(releases) {
        let k0 = segment[0].0;
        let ideal = |k: u64| (k - k0) as i128 * dt_ns as i128;
        // The earliest schedule start consistent with every release of the segment.
        let anchor = segment
            .iter()
            .map(|&(k, wall)| wall as i128 - ideal(k))
            .min()
            .unwrap_or(0);
        out.extend(
            segment
                .iter()
                .map(|&(k, wall)| (k, (wall as i128 - anchor - ideal(k)) as u64)),
        );
    }
    out
}

/// Tick numbers missing inside each schedule.
pub fn skipped(releases: &[(u64, u64)]) -> u64 {
    segments(releases)
        .iter()
        .flat_map(|s| s.windows(2))
        .map(|w| w[1].0 - w[0].0 - 1)
        .sum()
}

/// Runs of strictly increasing tick numbers.
fn segments(releases: &[(u64, u64)]) -> Vec<&[(u64, u64)]> {
    releases
        .chunk_by(|a, b| b.0 > a.0)
        .filter(|s| !s.is_empty())
        .collect()
}

impl TickRelease {
    /// The row for `releases` (in arrival order) ticking every `dt_ns`.
    pub fn of(releases: &[(u64, u64)], dt_ns: u64, realtime: bool) -> TickRelease {
        let (lateness, overruns) = if realtime && dt_ns > 0 {
            let late = lateness(releases, dt_ns);
            let values: Vec<u64> = late.iter().map(|x| x.1).collect();
            (
                Summary::of(LATENESS, &values, None),
                values.iter().filter(|&&v| v >= dt_ns).count(),
            )
        } else {
            (None, 0)
        };
        TickRelease {
            mode: if realtime { "realtime" } else { "lockstep" }.into(),
            ticks: releases.len(),
            period_ms: dt_ns as f64 / 1e6,
            lateness,
            overruns,
            skipped: skipped(releases),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const DT: u64 = 100_000_000;

    #[test]
    fn lateness_is_measured_against_the_earliest_consistent_schedule() {
        // Tick 0 released 1 ms after the schedule's start, tick 2 on time, tick 3 half a
        // period late, tick 4 (after an overrun) 1.2 periods late.
        let start = 5_000_000_000u64;
        let r = [
            (0, start + 1_000_000),
            (1, start + DT + 2_000_000),
            (2, start + 2 * DT),
            (3, start + 3 * DT + DT / 2),
            (4, start + 4 * DT + DT + DT / 5),
        ];
        let late: Vec<u64> = lateness(&r, DT).iter().map(|x| x.1).collect();
        assert_eq!(late, [1_000_000, 2_000_000, 0, DT / 2, DT + DT / 5]);
        let row = TickRelease::of(&r, DT, true);
        assert_eq!((row.ticks, row.overruns, row.skipped), (5, 1, 0));
        assert_eq!(row.lateness.unwrap().max_ms, 120.0);
    }

    #[test]
    fn a_restart_begins_a_new_schedule_and_gaps_are_skipped_ticks() {
        let r = [
            (0, 1_000),
            (1, 1_000 + DT),
            (4, 1_000 + 4 * DT),
            // A restarted simulator repeats tick 4 on its own clock.
            (4, 9 * DT),
            (5, 10 * DT + 7),
        ];
        let late: Vec<u64> = lateness(&r, DT).iter().map(|x| x.1).collect();
        assert_eq!(late, [0, 0, 0, 0, 7]);
        assert_eq!(skipped(&r), 2);
    }

    #[test]
    fn lockstep_has_no_lateness() {
        let r = [(0, 10), (1, 10 + 3 * DT)];
        let row = TickRelease::of(&r, DT, false);
        assert_eq!(row.lateness, None);
        assert_eq!(
            (row.ticks, row.overruns, row.mode.as_str()),
            (2, 0, "lockstep")
        );
    }
}
