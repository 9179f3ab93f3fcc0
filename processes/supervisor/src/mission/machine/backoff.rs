//! How long a reduced margin lasts. A leg plans with less than its full margin only to
//! get out of a tight spot: the robot stands inside the margin, or the only way on is a
//! gap that needs less of it. The reduced margin also governs the controller's band, so
//! kept for the rest of the leg it would take the robot past whatever it meets later
//! (unseen pallets, the rack it is about to pass) within a few centimetres of contact.
//! So once the robot is clear of where the reduced-margin plan began, the leg plans with
//! the full margin again; where that fails, it backs off once more from there, and the
//! distance to the next try doubles (a long narrow passage would otherwise cost a
//! full-margin search, often one that spends the planner's whole budget, every metre).
//!
//! Part of the pure state machine: no bus, no clocks.

use super::{Mission, Phase, Stage};
use crate::mission::events::Action;
use aisle_geometry::Pose2;

/// How far, m, the robot gets from where a reduced-margin plan started before the leg
/// first asks for a plan with the full margin again: about two robot lengths, enough to
/// leave the spot that needed the reduction, short enough that nothing met later is
/// passed with it.
pub(super) const RESTORE_MARGIN_AFTER_M: f64 = 1.0;

/// The longest the distance to the next full-margin try grows to, m, after tries that
/// backed off again.
const RESTORE_MARGIN_AFTER_MAX_M: f64 = 4.0;

/// The least margin backing off ever plans with when the leg's margin is `m` (what the
/// mission check holds a goal to).
pub fn least_margin(m: f64) -> f64 {
    scaled_margin(m, super::MIN_MARGIN_SCALE)
}

/// The margin a plan keeps when the leg's margin `m` is scaled by `scale` while backing
/// off: never below `MIN_BACKED_OFF_MARGIN` (or `m` itself, if smaller), to the
/// micrometre, so that the planner gets the very margin `check` holds goals to and
/// messages show (3/8 of 0.4 is 0.15000000000000002 in binary).
pub(super) fn scaled_margin(m: f64, scale: f64) -> f64 {
    let margin = (m * scale.max(super::MIN_MARGIN_SCALE)).max(m.min(super::MIN_BACKED_OFF_MARGIN));
    (margin * 1e6).round() / 1e6
}

impl Mission {
    /// A plan with a reduced margin (or the full one) is about to be driven from `pose`.
    /// A full-margin try that ended backed off again doubles the distance to the next;
    /// one that kept the full margin makes it short again.
    pub(super) fn note_backed_off(&mut self, pose: Pose2) {
        let reduced = self.margin_scale < 1.0;
        if std::mem::take(&mut self.restoring) && reduced {
            self.wait_longer_to_restore();
        } else if !reduced {
            self.restore_after_m = RESTORE_MARGIN_AFTER_M;
        }
        self.backed_off_at = reduced.then_some(pose);
    }

    /// A try with the full margin that found no plan with any margin: the reduced-margin
    /// plan the controller drives is still good, so it is driven on and the next try
    /// waits twice as far from here. Not a plan failure of the leg: the try was the
    /// leg's own choice, and a robot that is stuck is found by its replans, its
    /// progress and its timeout. `None` when no such try was under way.
    pub(super) fn restore_failed(
        &mut self,
        now_s: f64,
        pose: Pose2,
        why: &str,
    ) -> Option<Vec<Action>> {
        if !std::mem::take(&mut self.restoring) || !self.has_reference {
            return None;
        }
        self.margin_scale = 1.0;
        self.wait_longer_to_restore();
        self.backed_off_at = Some(pose);
        self.phase = Phase::Driving;
        tracing::info!("t = {now_s:.1} s: {why}; driving on with the reduced margin");
        Some(Vec::new())
    }

    /// Doubles the distance to the next full-margin try, up to its most.
    fn wait_longer_to_restore(&mut self) {
        self.restore_after_m = (2.0 * self.restore_after_m).min(RESTORE_MARGIN_AFTER_MAX_M);
    }

    /// The full margin again, from now on.
    pub(super) fn reset_margin(&mut self) {
        self.margin_scale = 1.0;
        self.backed_off_at = None;
    }

    /// The plan request with the full margin once the robot is clear of where the
    /// reduced-margin plan began; `None` while it is not, or during a straight move
    /// (those keep their own clearance).
    pub(super) fn restore_margin(&mut self, now_s: f64, pose: Pose2) -> Option<Vec<Action>> {
        let from = self.backed_off_at?;
        if !matches!(self.stage, Stage::Path | Stage::ToDock { .. })
            || pose.distance(&from) < self.restore_after_m
        {
            return None;
        }
        self.reset_margin();
        self.restoring = true;
        tracing::info!(
            "t = {now_s:.1} s: clear of the tight spot: planning with the full margin \
             (at most {} expansions)",
            self.cfg.restore_max_expansions
        );
        self.phase = Phase::Planning;
        // The try has a fallback (the reduced-margin plan being driven): its search is
        // bounded, where a search that finds nothing would otherwise spend the growing
        // budget of a large hall, seconds with the planner busy.
        let mut ask = self.plan_action(pose, true);
        if let Action::Plan { fixed_budget, .. } = &mut ask {
            *fixed_budget = Some(self.cfg.restore_max_expansions);
        }
        Some(vec![ask])
    }
}

#[cfg(test)]
mod tests {
    use super::least_margin;

    #[test]
    fn backing_off_keeps_what_the_lidar_cannot_see() {
        // Carrying (0.4 m): 0.15 m, a pallet base's 0.1 m overhang and half a cell.
        assert_eq!(least_margin(0.4), 0.15);
        // A larger margin: 3/8 of it.
        assert_eq!(least_margin(0.8), 0.3);
        // Alone (0.1 m), or any margin up to the 0.15 m floor: the margin itself.
        assert_eq!(least_margin(0.1), 0.1);
        assert_eq!(least_margin(0.15), 0.15);
        assert_eq!(least_margin(0.04), 0.04);
    }
}
