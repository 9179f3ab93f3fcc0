//! The timed elastic band: poses and the time between consecutive poses, with the
//! housekeeping between optimisations (pruning passed poses, splitting and merging
//! segments around the reference time step).
//!
//! Knows nothing of obstacles, costs or the reference path.

use aisle_geometry::{Pose2, wrap_angle};
use serde::{Deserialize, Serialize};

use crate::TebError;
use crate::steps::Steps;

/// `poses[0]` is the robot's pose when the band was optimised; `dts[k]` is the time, s,
/// from `poses[k]` to `poses[k + 1]`. Headings are continuous (not wrapped) along the
/// band so a turn through +-pi does not jump. This is the controller's whole memory
/// between steps: publish it, and hand it back with
/// [`crate::TebController::restore_band`] after a restart.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Band {
    pub poses: Vec<Pose2>,
    pub dts: Vec<f64>,
}

impl Band {
    pub fn with_capacity(n: usize) -> Band {
        Band {
            poses: Vec::with_capacity(n + 1),
            dts: Vec::with_capacity(n + 1),
        }
    }

    pub fn is_empty(&self) -> bool {
        self.poses.is_empty()
    }

    /// Total time of the band, s.
    pub fn duration(&self) -> f64 {
        self.dts.iter().sum()
    }

    pub fn clear(&mut self) {
        self.poses.clear();
        self.dts.clear();
    }

    /// Copies `other` without reallocating when the capacity suffices.
    pub fn copy_from(&mut self, other: &Band) {
        self.poses.clear();
        self.poses.extend_from_slice(&other.poses);
        self.dts.clear();
        self.dts.extend_from_slice(&other.dts);
    }

    /// Refuses bands that could not have come from this controller.
    pub fn validate(&self, max_poses: usize) -> Result<(), TebError> {
        if self.poses.len() < 2 || self.poses.len() > max_poses {
            return Err(TebError::InvalidBand(format!(
                "{} poses, expected 2..={max_poses}",
                self.poses.len()
            )));
        }
        if self.dts.len() + 1 != self.poses.len() {
            return Err(TebError::InvalidBand(format!(
                "{} poses need {} time steps, got {}",
                self.poses.len(),
                self.poses.len() - 1,
                self.dts.len()
            )));
        }
        if self.poses.iter().any(|p| !p.is_finite()) {
            return Err(TebError::InvalidBand("a pose is not finite".into()));
        }
        if self.dts.iter().any(|t| !(t.is_finite() && *t > 0.0)) {
            return Err(TebError::InvalidBand("a time step is not positive".into()));
        }
        Ok(())
    }

    /// Makes headings continuous starting from `poses[0]`.
    pub fn unwrap_headings(&mut self) {
        for i in 1..self.poses.len() {
            let prev = self.poses[i - 1].theta;
            self.poses[i].theta = prev + wrap_angle(self.poses[i].theta - prev);
        }
    }

    /// Drops the poses the robot has passed: the closest of the first `window` poses
    /// (position plus `heading_weight` x heading difference, so turning on the spot
    /// prunes too) becomes the new start, overwritten with the robot's pose. Keeps at
    /// least two poses.
    pub fn prune(&mut self, robot: &Pose2, window: usize, heading_weight: f64) {
        if self.poses.len() < 2 {
            return;
        }
        let last = (self.poses.len() - 2).min(window);
        let mut best = 0;
        let mut best_d = f64::INFINITY;
        for (i, p) in self.poses.iter().enumerate().take(last + 1) {
            let d = p.distance(robot) + heading_weight * wrap_angle(p.theta - robot.theta).abs();
            if d < best_d {
                best_d = d;
                best = i;
            }
        }
        if best > 0 {
            self.poses.drain(..best);
            self.dts.drain(..best);
        }
        self.poses[0] = *robot;
        self.unwrap_headings();
    }

    /// TEB's auto-resize around each segment's reference step ([`Steps`]): a segment
    /// the steps call too long is split in two (at the middle of the arc the segment's
    /// end poses define) and one shorter than its step less the hysteresis is merged
    /// with its neighbour, as long as the steps would not split the merged segment.
    /// The first and last poses never move.
    pub fn resize(&mut self, steps: &Steps, min_poses: usize, max_poses: usize) {
        let mut k = 0;
        // When segment k starts, s.
        let mut start = 0.0;
        while k < self.dts.len() {
            let t = self.dts[k];
            let (short_below, long_above) = steps.range(start);
            if self.poses.len() < max_poses && t > long_above {
                let mid = arc_midpoint(&self.poses[k], &self.poses[k + 1]);
                self.poses.insert(k + 1, mid);
                self.dts[k] = 0.5 * t;
                self.dts.insert(k + 1, 0.5 * t);
                continue;
            }
            if t < short_below && self.poses.len() > min_poses && self.dts.len() >= 2 {
                if k + 1 < self.dts.len() {
                    let merged = t + self.dts[k + 1];
                    if merged <= long_above {
                        self.poses.remove(k + 1);
                        self.dts[k] = merged;
                        self.dts.remove(k + 1);
                        continue;
                    }
                } else if k >= 1 {
                    let merged = t + self.dts[k - 1];
                    let before = start - self.dts[k - 1];
                    if !steps.splits(before, merged) {
                        // Last segment: drop the pose before the end instead of the end.
                        self.poses.remove(k);
                        self.dts[k - 1] = merged;
                        self.dts.remove(k);
                        break;
                    }
                }
            }
            start += t;
            k += 1;
        }
    }

    /// Whether [`Band::resize`] would split a segment.
    pub fn has_long_segment(&self, steps: &Steps, max_poses: usize) -> bool {
        if self.poses.len() >= max_poses {
            return false;
        }
        let mut start = 0.0;
        self.dts.iter().any(|&t| {
            let long = steps.splits(start, t);
            start += t;
            long
        })
    }
}

/// Distance between two band poses: a plain root, as band coordinates cannot overflow
/// and `hypot`'s care for that costs several times more on these hot paths.
#[inline]
pub(crate) fn chord(a: &Pose2, b: &Pose2) -> f64 {
    let (dx, dy) = (b.x - a.x, b.y - a.y);
    (dx * dx + dy * dy).sqrt()
}

/// The pose halfway along the circular arc that leaves `a` and reaches `b` with the
/// chord along the mean heading (the band's kinematic model), so splitting a segment
/// keeps both halves on that arc instead of cutting the corner. The chord midpoint is
/// shifted to the outside of the turn by the sagitta, half the chord times tan(turn / 4).
fn arc_midpoint(a: &Pose2, b: &Pose2) -> Pose2 {
    let turn = b.theta - a.theta;
    let (dx, dy) = (b.x - a.x, b.y - a.y);
    let (s, c) = (0.5 * (a.theta + b.theta)).sin_cos();
    // Signed chord length along the mean heading (negative when driving backwards).
    let along = c * dx + s * dy;
    let sag = 0.5 * along * (0.25 * turn).tan();
    let sag = if sag.is_finite() { sag } else { 0.0 };
    Pose2::new(
        0.5 * (a.x + b.x) + s * sag,
        0.5 * (a.y + b.y) - c * sag,
        0.5 * (a.theta + b.theta),
    )
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// `n` poses `step` m apart along x, `dt` s apart.
    pub(crate) fn straight(n: usize, step: f64, dt: f64) -> Band {
        Band {
            poses: (0..n)
                .map(|i| Pose2::new(i as f64 * step, 0.0, 0.0))
                .collect(),
            dts: vec![dt; n - 1],
        }
    }

    #[test]
    fn resize_splits_long_and_merges_short_segments() {
        let mut b = straight(3, 1.0, 0.9);
        b.resize(&Steps::uniform(0.3, 0.1), 3, 50);
        assert!(
            b.dts
                .iter()
                .all(|&t| (0.2 - 1e-12..=0.4 + 1e-12).contains(&t)),
            "{:?}",
            b.dts
        );
        assert!((b.duration() - 1.8).abs() < 1e-12);
        assert_eq!(b.poses.last().unwrap().x, 2.0);
        let mut b = straight(9, 0.1, 0.1);
        b.resize(&Steps::uniform(0.3, 0.1), 3, 50);
        assert!(b.poses.len() < 9);
        assert!((b.duration() - 0.8).abs() < 1e-12);
        assert_eq!(b.poses.last().unwrap().x, 0.8);
        b.validate(50).unwrap();
    }

    #[test]
    fn splitting_a_turning_segment_stays_on_its_arc() {
        // Quarter circle of radius 2 about (0, 2), forwards and backwards.
        for dir in [1.0, -1.0] {
            let r = 2.0;
            let on = |phi: f64| Pose2::new(dir * r * phi.sin(), r * (1.0 - phi.cos()), dir * phi);
            let mut b = Band {
                poses: vec![on(0.0), on(std::f64::consts::FRAC_PI_2)],
                dts: vec![1.0],
            };
            b.resize(&Steps::uniform(0.3, 0.1), 2, 3);
            assert_eq!(b.poses.len(), 3);
            let want = on(std::f64::consts::FRAC_PI_4);
            let got = b.poses[1];
            assert!(
                got.distance(&want) < 1e-12 && (got.theta - want.theta).abs() < 1e-12,
                "{got:?} vs {want:?}"
            );
        }
    }

    #[test]
    fn prune_drops_passed_poses() {
        let mut b = straight(6, 0.5, 0.3);
        b.prune(&Pose2::new(1.1, 0.05, 0.0), 10, 0.3);
        assert_eq!(b.poses.len(), 4);
        assert_eq!(b.poses[0], Pose2::new(1.1, 0.05, 0.0));
        assert_eq!(b.dts.len(), 3);
    }
}
