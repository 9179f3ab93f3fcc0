//! Collisions during a session: every ground-truth sample goes through the
//! [`CollisionWatch`](crate::collisions::CollisionWatch), and the first collision fails
//! the mission unless `--allow-collisions`.
//!
//! Policy: the first collision halts the robot at once (zero goal, simulator Stop), as
//! a real robot's bumper would e-stop it, and ends the mission as failed; nothing is
//! driven after it. With `--allow-collisions` (demonstrations such as `--no-lidar`) the
//! collisions are only counted and reported.

use super::{RunAborted, RunOptions, Session};
use crate::mission::Action;

impl Session {
    /// Reads every truth sample since the last tick (none is skipped: a contact may
    /// begin and end between two ticks in realtime), keeping the newest for the report.
    pub(super) fn observe_truth(&mut self) -> Result<(), RunAborted> {
        while let Some(t) = self.ports.truth.receive()? {
            // The simulator logs each collision; the report lists them.
            self.collisions.observe(&t);
            self.truth = Some(*t);
        }
        Ok(())
    }

    /// When a collision fails the mission: the actions that stop the robot (they replace
    /// whatever the mission asked for this tick).
    pub(super) fn collision_halt(&mut self, opts: &RunOptions) -> Option<Vec<Action>> {
        if opts.allow_collisions || self.mission.is_finished() {
            return None;
        }
        let first = self.collisions.first()?.to_string();
        tracing::error!("{first}: the robot is stopped and the mission fails");
        Some(self.mission.abort(self.now_s, self.pose, first))
    }
}
