//! One replan of a leg's budget (`max_replans_per_leg`, which failed plans share): once
//! it is spent the leg fails, saying what the controller did and how many replans and
//! failed plans it took; until then the leg plans again from where the robot stands.
//!
//! Part of the pure state machine: no bus, no clocks.

use super::Mission;
use crate::mission::events::Action;
use aisle_geometry::Pose2;

impl Mission {
    /// Counts a replan of the leg; whether that spends its budget.
    pub(super) fn replan_spends_budget(&mut self) -> bool {
        self.replans += 1;
        self.replans + self.plan_failures > self.cfg.max_replans_per_leg
    }

    /// The leg fails: "the controller `what`" after the replans before this one.
    pub(super) fn fail_after_replans(
        &mut self,
        now_s: f64,
        pose: Pose2,
        what: &str,
    ) -> Vec<Action> {
        // Failed plans use up the same budget: say so, or the count looks short of
        // `max_replans_per_leg`.
        let failed = match self.plan_failures {
            0 => String::new(),
            n => format!(" and {n} failed plan(s)"),
        };
        let why = format!(
            "leg {} `{}`: the controller {what} after {} replans{failed}",
            self.leg + 1,
            self.leg_name(),
            self.replans - 1
        );
        self.fail(now_s, pose, why)
    }

    /// Plans again from `pose`: the cooldown and the stall window start over.
    pub(super) fn replan_from(&mut self, now_s: f64, pose: Pose2) -> Vec<Action> {
        self.cooldown = self.cfg.replan_cooldown_steps;
        self.progress.reset(now_s);
        self.recover(pose)
    }
}
