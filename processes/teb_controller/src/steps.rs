//! The reference time step along a band, which auto-resize (`Band::resize`) splits and
//! merges segments around.
//!
//! TEB's steps are uniform: `dt_ref` from the robot to the band's end, so a band that
//! crawls (slowed by obstacles, or by acceleration limits at its start and end) has a
//! pose every `dt_ref` over the whole look-ahead distance: 40 poses for 6 m at
//! 0.5 m/s, where each subproblem's cost grows with the poses. Graded steps keep
//! `dt_ref` for the band's first `fine_time` seconds (what the robot drives before the
//! next step, and the obstacles nearest to it), and beyond let the step grow in
//! proportion to the time from the robot, the hysteresis with it (a geometric grid in
//! time: the far end is optimised again many times before the robot gets there). The
//! clearance samples along a segment stay one per 0.3 m of its chord, however long.
//!
//! Knows nothing of costs, obstacles or the optimiser.

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Steps {
    /// The step near the robot, s.
    pub dt_ref: f64,
    /// Around the step: split above step + hysteresis, merge below step - hysteresis.
    pub hysteresis: f64,
    /// How long the steps stay at `dt_ref`, s; 0: along the whole band (uniform).
    pub fine_time: f64,
}

impl Steps {
    /// TEB's uniform steps.
    pub fn uniform(dt_ref: f64, hysteresis: f64) -> Steps {
        Steps {
            dt_ref,
            hysteresis,
            fine_time: 0.0,
        }
    }

    /// The durations a segment starting `start` seconds into the band is kept within:
    /// split above the upper bound (its step plus the hysteresis), merged with a
    /// neighbour below the lower one (its step less the hysteresis).
    #[inline]
    pub fn range(&self, start: f64) -> (f64, f64) {
        let (step, hysteresis) = if self.fine_time > 0.0 && start > self.fine_time {
            let grow = start / self.fine_time;
            (self.dt_ref * grow, self.hysteresis * grow)
        } else {
            (self.dt_ref, self.hysteresis)
        };
        (step - hysteresis, step + hysteresis)
    }

    /// Whether a segment starting `start` seconds into the band and lasting `t` is to
    /// be split.
    #[inline]
    pub fn splits(&self, start: f64, t: f64) -> bool {
        t > self.range(start).1
    }

    /// Whether a segment starting `start` seconds into the band and lasting `t` is short
    /// enough to merge with a neighbour.
    #[inline]
    pub fn is_short(&self, start: f64, t: f64) -> bool {
        t < self.range(start).0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::band::Band;
    use crate::band::tests::straight;

    const GRADED: Steps = Steps {
        dt_ref: 0.3,
        hysteresis: 0.1,
        fine_time: 1.5,
    };

    /// Every segment within its own step's hysteresis, and the fine ones at dt_ref.
    fn assert_graded(b: &Band) {
        let mut start = 0.0;
        for &t in &b.dts {
            assert!(!GRADED.splits(start, t), "{t} at {start}: {:?}", b.dts);
            if start + t <= GRADED.fine_time {
                assert!((0.2 - 1e-12..=0.4 + 1e-12).contains(&t), "{t} at {start}");
            }
            start += t;
        }
    }

    #[test]
    fn a_slow_band_keeps_its_first_seconds_fine_and_coarsens_beyond() {
        // 6 m at 0.5 m/s: 12 s, in 0.15 s segments (81 poses).
        let slow = straight(81, 0.075, 0.15);
        let uniform = Steps::uniform(0.3, 0.1);
        let mut u = slow.clone();
        u.resize(&uniform, 3, 200);
        let mut g = slow.clone();
        g.resize(&GRADED, 3, 200);
        for b in [&u, &g] {
            assert!((b.duration() - 12.0).abs() < 1e-9);
            assert_eq!(b.poses.last(), slow.poses.last());
        }
        assert!(!u.has_long_segment(&uniform, 200));
        assert!(!g.has_long_segment(&GRADED, 200));
        assert_graded(&g);
        // Uniform steps take a pose per 0.3 s; graded ones a few beyond 1.5 s.
        assert!(u.poses.len() >= 30, "{}", u.poses.len());
        assert!(g.poses.len() <= 20, "{}", g.poses.len());
    }

    #[test]
    fn a_band_within_the_fine_time_stays_uniform() {
        let fast = straight(6, 0.6, 0.3);
        let mut b = fast.clone();
        b.resize(&GRADED, 3, 200);
        assert_eq!(b, fast);
        // Beyond it a segment of the graded step is kept whole, one of twice it split.
        assert!(!GRADED.splits(3.0, 0.65));
        assert!(GRADED.splits(3.0, 0.85));
        assert!(GRADED.is_short(3.0, 0.35) && !GRADED.is_short(3.0, 0.45));
    }
}
