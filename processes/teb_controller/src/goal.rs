//! What the controller is asked to do: follow a reference path or turn on the spot,
//! with the footprint and safety margin of the current load.

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
}

impl Goal {
    /// Where the task ends: the reference's last pose when following (the goal pose is
    /// not a separate field, so it cannot disagree with the path); `None` for a
    /// rotation, whose position is wherever the robot is at the first step.
    pub fn goal_pose(&self) -> Option<Pose2> {
        match self.mode {
            Mode::Follow => self.reference.last().map(|p| p.pose),
            Mode::RotateInPlace { .. } => None,
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
        }
        if let Some(i) = self.reference.iter().position(|p| !p.pose.is_finite()) {
            return Err(TebError::InvalidGoal(format!(
                "reference pose {i} is not finite"
            )));
        }
        Ok(())
    }
}
