//! One controller step of a recorded run, replayed by the library alone: the goal it
//! drove, the band the previous step left, the robot state and local map of its tick.
//! The node resumes a restarted controller from the same messages, so the step is the
//! mission's own, bit for bit ([`reproduces`] checks it against the
//! recorded `Trajectory`). Benchmarks time the mission's worst steps this way.
//!
//! Knows messages and the library; reading record files is the caller's.

use aisle_geometry::Pose2;
use aisle_messages::{ControllerBand, ControllerGoal, GridCopy, OccupancyGrid, RobotState, Tick};
use aisle_messages::{MAX_COMMANDS, Trajectory};

use crate::resume::{goal_of, snapshot_of};
use crate::{Goal, Snapshot, StepOutput, TebConfig, TebController, TebError};

/// The messages a controller step acted on.
pub struct StepInputs<'a> {
    pub tick: &'a Tick,
    /// The goal the step drove (the recorded trajectory's `goal_id`).
    pub goal: &'a ControllerGoal,
    /// The band the previous controller step published, if it was under the same goal.
    pub band: Option<&'a ControllerBand>,
    pub state: &'a RobotState,
    pub map: &'a OccupancyGrid,
}

/// A controller step ready to run, and to run again from the same state.
pub struct RecordedStep {
    teb: TebController,
    goal: Goal,
    snapshot: Option<Snapshot>,
    pose: Pose2,
    velocity: (f64, f64),
    t: f64,
    map: GridCopy,
}

impl RecordedStep {
    /// The step of `inputs` under `cfg`; an error names what could not be read.
    pub fn new(cfg: TebConfig, inputs: &StepInputs) -> Result<RecordedStep, String> {
        let goal = match goal_of(inputs.goal) {
            None => return Err(format!("goal {} is Idle", inputs.goal.goal_id)),
            Some(g) => g?,
        };
        let snapshot = inputs
            .band
            .filter(|b| b.goal_id == inputs.goal.goal_id)
            .map(snapshot_of);
        let mut map = GridCopy::with_capacity(inputs.map.cells.len());
        map.copy_from(inputs.map);
        let mut step = RecordedStep {
            teb: TebController::new(cfg).map_err(|e| e.to_string())?,
            goal,
            snapshot,
            pose: inputs.state.pose.into(),
            velocity: (inputs.state.twist[0], inputs.state.twist[1]),
            t: inputs.tick.header.stamp_ns as f64 * 1e-9,
            map,
        };
        step.reset().map_err(|e| e.to_string())?;
        Ok(step)
    }

    /// Puts the controller back where the mission had it before the step.
    pub fn reset(&mut self) -> Result<(), TebError> {
        self.teb.clear_goal();
        self.teb.set_goal(&self.goal)?;
        if let Some(s) = &self.snapshot {
            self.teb.restore(s)?;
        }
        Ok(())
    }

    /// Runs the step (once per [`RecordedStep::reset`]).
    pub fn step(&mut self) -> Result<&StepOutput, TebError> {
        let view = self
            .map
            .view()
            .map_err(|e| TebError::InvalidInput(format!("local map: {e}")))?;
        self.teb.step(self.pose, self.velocity, self.t, &view)
    }

    /// Runs the step (once per [`RecordedStep::reset`]) with a copy of its band run on
    /// to convergence on the same problem (at most `max_subproblems` more
    /// subproblems): the step's cost and the converged one, `None` when the step
    /// optimised nothing.
    pub fn converged_cost(
        &mut self,
        max_subproblems: usize,
    ) -> Result<Option<(f64, f64)>, TebError> {
        self.teb.set_convergence_audit(Some(max_subproblems));
        let cost = self.step().map(|out| out.cost);
        self.teb.set_convergence_audit(None);
        let cost = cost?;
        Ok(self.teb.converged_cost().map(|c| (cost, c)))
    }

    /// Poses of the band the step starts from (0: a fresh band).
    pub fn warm_poses(&self) -> usize {
        self.snapshot.as_ref().map_or(0, |s| s.band.poses.len())
    }
}

/// Whether `out` is what the mission published: iterations, cost and every command
/// bit for bit.
pub fn reproduces(out: &StepOutput, recorded: &Trajectory) -> bool {
    let n = out.commands.len().min(MAX_COMMANDS);
    out.iterations as u32 == recorded.iterations
        && out.cost.to_bits() == recorded.cost.to_bits()
        && n == recorded.len as usize
        && out.commands[..n]
            .iter()
            .zip(&recorded.commands[..n])
            .all(|(c, r)| {
                (c.t - out.t0).to_bits() == r.t.to_bits()
                    && c.v.to_bits() == r.v.to_bits()
                    && c.w.to_bits() == r.w.to_bits()
            })
}
