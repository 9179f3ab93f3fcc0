//! Stall detection: a driving leg whose controller reports no infeasibility but gets no
//! closer to what it drives to (dithering, or standing still behind something) is as
//! stuck as one whose band is infeasible, and goes through the same recovery.
//!
//! Pure: fed sim time and poses by the state machine.

use aisle_geometry::Pose2;

/// Metres of remaining distance one radian of heading error counts as.
const HEADING_WEIGHT: f64 = 0.5;
/// Smallest improvement, m, that counts as progress.
const MIN_GAIN: f64 = 0.05;

/// The best remaining distance to `target` seen since the last reset, and when it last
/// improved.
#[derive(Debug, Clone, Copy)]
pub(super) struct Progress {
    best: f64,
    since_s: f64,
    target: Option<Pose2>,
}

impl Default for Progress {
    fn default() -> Self {
        Progress {
            best: f64::INFINITY,
            since_s: 0.0,
            target: None,
        }
    }
}

impl Progress {
    /// Starts watching afresh at `now_s` (a new leg or plan; a new target resets by
    /// itself).
    pub fn reset(&mut self, now_s: f64) {
        *self = Progress {
            best: f64::INFINITY,
            since_s: now_s,
            target: None,
        };
    }

    /// Whether the robot at `pose` has not come `MIN_GAIN` closer to `target` within
    /// `window_s` of sim time. Restarts the window when it reports a stall.
    pub fn stalled(&mut self, now_s: f64, pose: &Pose2, target: &Pose2, window_s: f64) -> bool {
        if self.target != Some(*target) {
            self.reset(now_s);
            self.target = Some(*target);
        }
        let remaining = pose.distance(target) + HEADING_WEIGHT * pose.heading_error(target).abs();
        if remaining < self.best - MIN_GAIN || self.best.is_infinite() {
            self.best = remaining;
            self.since_s = now_s;
            return false;
        }
        if now_s - self.since_s > window_s {
            self.reset(now_s);
            self.target = Some(*target);
            return true;
        }
        false
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn standing_still_stalls_after_the_window_and_moving_closer_does_not() {
        let target = Pose2::new(5.0, 0.0, 0.0);
        let mut p = Progress::default();
        p.reset(0.0);
        for k in 0..20 {
            let at = Pose2::new(0.1 * k as f64, 0.0, 0.0);
            assert!(!p.stalled(0.5 * k as f64, &at, &target, 5.0));
        }
        let stuck = Pose2::new(1.9, 0.0, 0.0);
        let stalls: Vec<bool> = (20..40)
            .map(|k| p.stalled(0.5 * k as f64, &stuck, &target, 5.0))
            .collect();
        assert_eq!(stalls.iter().filter(|s| **s).count(), 1, "{stalls:?}");
        // Dithering back and forth is no progress either.
        let mut q = Progress::default();
        q.reset(0.0);
        let hits = (0..40)
            .filter(|k| {
                let at = Pose2::new(1.0 + 0.2 * (k % 2) as f64, 0.0, 0.0);
                q.stalled(0.5 * *k as f64, &at, &target, 5.0)
            })
            .count();
        assert!(hits >= 2, "{hits}");
        // A new target (the next stage) starts a new window: no stall carried over.
        let mut r = Progress::default();
        r.reset(0.0);
        assert!(!r.stalled(
            0.0,
            &Pose2::new(0.0, 0.0, 0.0),
            &Pose2::new(0.1, 0.0, 0.0),
            5.0
        ));
        for k in 1..30 {
            let t = 0.5 * k as f64;
            assert!(!r.stalled(
                t,
                &Pose2::new(0.1, 0.0, 0.0),
                &Pose2::new(0.1 + 0.1 * t, 0.0, 0.0),
                20.0
            ));
        }
    }
}
