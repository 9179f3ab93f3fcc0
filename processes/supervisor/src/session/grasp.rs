//! Picks and set-downs as the simulator carried them out: after the mission asks the
//! simulator to attach a body (or to let go of it), the robot's state must show it
//! within [`GRASP_TIMEOUT_S`] of sim time. The simulator refuses an attach when the
//! carry mount is not under the body, and it only logs that; a refused or lost command
//! must fail the mission, never let it carry on as if the robot held the load.
//!
//! Knows the robot state's `carried_body` and the mission's abort; nothing of how a pick
//! is planned.

use super::Session;
use crate::mission::Action;

/// Sim time the robot's state may take to show an attach or a detach (a few ticks in
/// either clock mode).
pub(super) const GRASP_TIMEOUT_S: f64 = 1.0;

/// What the robot's state should show next, and by when.
#[derive(Debug, Clone)]
pub(super) struct Expected {
    /// The scene index of the body it carries then (-1: none).
    body: i32,
    /// The body's name, for the failure.
    name: String,
    by_s: f64,
}

impl Session {
    /// The mission asked for `body` (scene index; -1 for a detach) to be carried from now.
    pub(super) fn expect_carried(&mut self, body: i32, name: &str) {
        self.grasp = Some(Expected {
            body,
            name: name.to_string(),
            by_s: self.now_s + GRASP_TIMEOUT_S,
        });
    }

    /// The robot state's carried body (-1: none).
    pub(super) fn note_carried(&mut self, body: i32) {
        self.carried = body;
        if self.grasp.as_ref().is_some_and(|e| e.body == body) {
            self.grasp = None;
        }
    }

    /// When the simulator has not done what the mission asked in time: the actions that
    /// stop the robot and fail the mission.
    pub(super) fn grasp_failed(&mut self) -> Option<Vec<Action>> {
        let e = self.grasp.as_ref()?;
        if self.now_s <= e.by_s || self.mission.is_finished() {
            return None;
        }
        let why = if e.body < 0 {
            format!("the simulator did not set `{}` down", e.name)
        } else {
            format!(
                "the simulator did not pick `{}` up within {GRASP_TIMEOUT_S} s (it refuses \
                 when the carry mount is not under the body); the robot carries {}",
                e.name,
                if self.carried < 0 {
                    "nothing".to_string()
                } else {
                    format!("body {}", self.carried)
                }
            )
        };
        self.grasp = None;
        tracing::error!(
            "t = {:.1} s: {why}: the robot is stopped and the mission fails",
            self.now_s
        );
        Some(self.mission.abort(self.now_s, self.pose, why))
    }
}
