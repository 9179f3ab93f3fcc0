//! What a step returns, in MATLAB controllerTEB's terms: a timeline of (t, v, w)
//! commands (in sim time, starting at the step's time rather than MATLAB's 0), the predicted poses with their times, and an info record
//! (reached goal, exit flag, last feasible index, cost, iterations, worst violation).
//!
//! Knows nothing of how the band was optimised.

use aisle_geometry::Pose2;

/// Most commands (and predicted poses) a step returns.
pub const MAX_COMMANDS: usize = 512;

/// Velocity command in force from sim time `t`, s.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Command {
    pub t: f64,
    /// Linear velocity, m/s (negative when reversing).
    pub v: f64,
    /// Angular velocity, rad/s (counter-clockwise positive).
    pub w: f64,
}

/// A predicted pose of the optimised band and the sim time, s, the robot should be there.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct TimedPose {
    pub t: f64,
    pub pose: Pose2,
}

/// MATLAB controllerTEB's ExitFlag.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash)]
pub enum ExitFlag {
    /// 0: the band is feasible.
    #[default]
    Valid,
    /// 1: the footprint overlaps an obstacle cell somewhere along the band.
    Collision,
    /// 2: an obstacle is closer than 0.9 x the safety margin.
    MarginViolated,
    /// 3: a turning radius is below 0.9 x the minimum turning radius.
    TurningRadius,
    /// 4: the time steps are not increasing.
    TimeNotIncreasing,
    /// 5: the robot is farther from the reference path than the look-ahead distance.
    OffPath,
    /// 6 (not MATLAB's): a linear or angular acceleration along the band, or from the
    /// measured velocity into it, exceeds its limit by more than 10 %. The commands are
    /// still driven (stopping dead would be a harder acceleration still).
    AccelerationExceeded,
}

impl ExitFlag {
    /// MATLAB's numeric code.
    pub fn code(self) -> u8 {
        match self {
            ExitFlag::Valid => 0,
            ExitFlag::Collision => 1,
            ExitFlag::MarginViolated => 2,
            ExitFlag::TurningRadius => 3,
            ExitFlag::TimeNotIncreasing => 4,
            ExitFlag::OffPath => 5,
            ExitFlag::AccelerationExceeded => 6,
        }
    }

    /// Whether the commands of this step must not be driven (the timeline is then a
    /// single zero command).
    pub fn stops_robot(self) -> bool {
        matches!(
            self,
            ExitFlag::Collision | ExitFlag::TimeNotIncreasing | ExitFlag::OffPath
        )
    }
}

/// Result of one controller step. Buffers are reused from step to step.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct StepOutput {
    /// Sim time the step was computed for, s (the `t` passed to the step).
    pub t0: f64,
    /// Timeline of commands in sim time, `commands[0].t == t0`, times strictly
    /// increasing, at most [`MAX_COMMANDS`]. Ends with (t_end, 0, 0) when the goal of
    /// the current section lies inside the horizon.
    pub commands: Vec<Command>,
    /// Optimised band with its sim times; `poses[0]` is the robot's pose at `t0`.
    pub poses: Vec<TimedPose>,
    /// The robot was within the goal tolerance of the final goal at this step.
    pub reached_goal: bool,
    pub exit_flag: ExitFlag,
    /// Index into `poses` of the last pose before the first infeasible one.
    pub last_feasible_index: usize,
    /// Merit of the band: total time plus weighted deviations and violations.
    pub cost: f64,
    /// Convex subproblems solved in this step.
    pub iterations: usize,
    /// Largest constraint violation of the returned band, each in its own unit
    /// (m/s, rad/s, m/s^2, rad/s^2, m); 0 when everything holds.
    pub max_violation: f64,
}

impl StepOutput {
    /// Zero-order hold over [`StepOutput::commands`].
    pub fn command_at(&self, t: f64) -> (f64, f64) {
        command_at(&self.commands, t)
    }

    pub(crate) fn clear(&mut self) {
        self.t0 = 0.0;
        self.commands.clear();
        self.poses.clear();
        self.reached_goal = false;
        self.exit_flag = ExitFlag::Valid;
        self.last_feasible_index = 0;
        self.cost = 0.0;
        self.iterations = 0;
        self.max_violation = 0.0;
    }

    pub(crate) fn set_stop(&mut self) {
        self.commands.clear();
        self.commands.push(Command {
            t: self.t0,
            v: 0.0,
            w: 0.0,
        });
    }
}

/// The command in force at `t`: the last one whose timestamp is <= t; (0, 0) before
/// the first, for an empty timeline, or for a NaN time.
pub fn command_at(commands: &[Command], t: f64) -> (f64, f64) {
    if t.is_nan() {
        return (0.0, 0.0);
    }
    let n = commands.partition_point(|c| c.t <= t);
    if n == 0 {
        (0.0, 0.0)
    } else {
        (commands[n - 1].v, commands[n - 1].w)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn zero_order_hold_matches_matlab_example() {
        let c = [
            Command {
                t: 0.0,
                v: 1.0,
                w: 0.0,
            },
            Command {
                t: 0.2,
                v: 2.0,
                w: 0.1,
            },
            Command {
                t: 0.45,
                v: 3.0,
                w: 0.2,
            },
            Command {
                t: 0.7,
                v: 0.0,
                w: 0.0,
            },
        ];
        assert_eq!(command_at(&c, 0.55), (3.0, 0.2));
        assert_eq!(command_at(&c, 0.45), (3.0, 0.2));
        assert_eq!(command_at(&c, 0.0), (1.0, 0.0));
        assert_eq!(command_at(&c, 10.0), (0.0, 0.0));
        assert_eq!(command_at(&c, -1.0), (0.0, 0.0));
        assert_eq!(command_at(&[], 1.0), (0.0, 0.0));
        assert_eq!(command_at(&c, f64::NAN), (0.0, 0.0));
    }
}
