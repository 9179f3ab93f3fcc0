//! Whether a controller's "goal reached" ends the leg: the controller judges the goal it
//! was given, and the leg ends only where the robot stands at the leg's own goal. A
//! report on another goal (a straight move out from under a body that is still being
//! driven after a replan failed) must not count: a sweep's mission took "reached" 18.9 m
//! from the leg's goal and went on to the next leg from there.
//!
//! Part of the pure state machine: no bus, no clocks.

use super::Mission;
use crate::mission::events::Action;
use aisle_geometry::Pose2;

/// How many times the mission's goal tolerance a "reached" report may stand from the
/// leg's goal: the controller stops within the tolerance, and the robot may still
/// settle a little after its last step.
const REACHED_SLACK: f64 = 2.0;

impl Mission {
    /// Whether `pose` stands at the leg's goal: along and across the goal's heading
    /// and in heading (as [`Mission::heading_error`] measures it), within
    /// [`REACHED_SLACK`] times the mission's `goal_tolerance`.
    pub(super) fn at_leg_goal(&self, pose: &Pose2) -> bool {
        let goal = self.goal();
        let [along_tol, across_tol, heading_tol] = self.cfg.goal_tolerance;
        let (s, c) = goal.theta.sin_cos();
        let (dx, dy) = (pose.x - goal.x, pose.y - goal.y);
        let along = c * dx + s * dy;
        let across = -s * dx + c * dy;
        along.abs() <= REACHED_SLACK * along_tol
            && across.abs() <= REACHED_SLACK * across_tol
            && self.heading_error(pose, &goal) <= REACHED_SLACK * heading_tol
    }

    /// The controller reached a goal that is not where the leg ends: plan again from
    /// here (one replan of the leg's budget).
    pub(super) fn reached_elsewhere(&mut self, now_s: f64, pose: Pose2) -> Vec<Action> {
        let goal = self.goal();
        tracing::warn!(
            "t = {now_s:.1} s: the controller reported its goal reached {:.2} m from leg {}'s goal: planning again",
            pose.distance(&goal),
            self.leg + 1
        );
        if self.replan_spends_budget() {
            let what = format!("stopped {:.2} m from the goal", pose.distance(&goal));
            return self.fail_after_replans(now_s, pose, &what);
        }
        self.replan_from(now_s, pose)
    }
}
