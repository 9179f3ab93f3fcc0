//! Reference paths: poses with the direction the robot drives through them.

use crate::Pose2;
use serde::{Deserialize, Serialize};

/// Which way the robot moves when it passes a path pose. Reeds-Shepp paths reverse;
/// in-place rotations neither advance nor back up.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, Default)]
pub enum Direction {
    #[default]
    Forward,
    Reverse,
    /// Turning on the spot at this position.
    Rotate,
}

impl Direction {
    /// +1 forward, -1 reverse, 0 rotate: the wire encoding used by messages.
    pub fn as_i8(self) -> i8 {
        match self {
            Direction::Forward => 1,
            Direction::Reverse => -1,
            Direction::Rotate => 0,
        }
    }

    pub fn from_i8(v: i8) -> Option<Direction> {
        match v {
            1 => Some(Direction::Forward),
            -1 => Some(Direction::Reverse),
            0 => Some(Direction::Rotate),
            _ => None,
        }
    }
}

/// One pose of a reference path.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PathPose {
    pub pose: Pose2,
    pub direction: Direction,
}

impl PathPose {
    pub const fn new(pose: Pose2, direction: Direction) -> Self {
        Self { pose, direction }
    }
}

/// Length of the polyline through the path's positions.
pub fn path_length(path: &[PathPose]) -> f64 {
    path.windows(2)
        .map(|w| w[0].pose.distance(&w[1].pose))
        .sum()
}
