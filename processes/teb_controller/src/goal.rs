//! What the controller is asked to do: follow a reference path, turn on the spot, or
//! drive straight along a line to a pose (docking under a rack and leaving it), with the
//! footprint and safety margin of the current load and the goal tolerance.

use crate::TebError;
use aisle_geometry::{Footprint, PathPose, Pose2};

/// How the goal is reached.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Mode {
    /// Follow `Goal::reference` to its last pose and stop there.
    Follow,
    /// Turn on the spot (where the robot is at the first step) to `target_heading`,
    /// rad, within the angular velocity and acceleration limits. The reference is not
    /// used and may be empty.
    RotateInPlace { target_heading: f64 },
    /// Drive along the line through `target` in the direction `target.theta` and stop
    /// at `target` (docking under a rack, undocking out of it): forwards when the
    /// target lies ahead of the robot's projection on the line, backwards otherwise,
    /// the heading kept at `target.theta` either way (see `straight.rs`). Not the
    /// optimiser: no band, no reference (it may be empty), and the goal's `margin`
    /// (sized for open space) is replaced by `teb.toml`'s `straight.margin`.
    Straight { target: Pose2 },
}

/// A task for the controller; replaced as a whole by [`crate::TebController::set_goal`].
#[derive(Debug, Clone, PartialEq)]
pub struct Goal {
    /// Reference path from the global planner, with the drive direction of each pose;
    /// its last pose is the goal pose (append it if the planner's path stops short).
    pub reference: Vec<PathPose>,
    /// Rectangle to keep clear of obstacles (robot alone, or robot with its rack).
    pub footprint: Footprint,
    /// Clearance to keep between the footprint and obstacle cells, m.
    pub margin: f64,
    pub mode: Mode,
    /// Goal tolerance for this task in the goal's frame: along, across (m) and heading
    /// (rad); `None` uses `teb.toml`'s `band.goal_tolerance`. Applies to every mode (a
    /// docking move's pre-dock pose is sent with a tighter one than open-space goals).
    pub tolerance: Option<[f64; 3]>,
}

impl Goal {
    /// Where the task ends: the reference's last pose when following (the goal pose is
    /// not a separate field, so it cannot disagree with the path); `None` for a
    /// rotation, whose position is wherever the robot is at the first step.
    pub fn goal_pose(&self) -> Option<Pose2> {
        match self.mode {
            Mode::Follow => self.reference.last().map(|p| p.pose),
            Mode::RotateInPlace { .. } => None,
            Mode::Straight { target } => Some(target),
        }
    }

    pub(crate) fn validate(&self) -> Result<(), TebError> {
        let f = &self.footprint;
        if !(f.length.is_finite() && f.length > 0.0 && f.width.is_finite() && f.width > 0.0) {
            return Err(TebError::InvalidGoal(format!(
                "footprint {} x {} is not positive",
                f.length, f.width
            )));
        }
        if !(self.margin.is_finite() && self.margin >= 0.0) {
            return Err(TebError::InvalidGoal(format!(
                "margin {} is not >= 0",
                self.margin
            )));
        }
        match self.mode {
            Mode::Follow => {
                if self.reference.is_empty() {
                    return Err(TebError::InvalidGoal("empty reference path".into()));
                }
            }
            Mode::RotateInPlace { target_heading } => {
                if !target_heading.is_finite() {
                    return Err(TebError::InvalidGoal("target heading is not finite".into()));
                }
            }
            Mode::Straight { target } => {
                if !target.is_finite() {
                    return Err(TebError::InvalidGoal(
                        "straight target is not finite".into(),
                    ));
                }
            }
        }
        if let Some(tol) = self.tolerance
            && let Some(i) = tol.iter().position(|t| !(t.is_finite() && *t > 0.0))
        {
            return Err(TebError::InvalidGoal(format!(
                "goal tolerance entry {i} ({}) is not positive",
                tol[i]
            )));
        }
        if let Some(i) = self.reference.iter().position(|p| !p.pose.is_finite()) {
            return Err(TebError::InvalidGoal(format!(
                "reference pose {i} is not finite"
            )));
        }
        Ok(())
    }
}
