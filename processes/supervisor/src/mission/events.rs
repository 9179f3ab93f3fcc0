//! What goes into the mission state machine besides time and pose (plan results,
//! controller reports) and what comes out of it ([`Action`]s for the supervisor to
//! carry out). Plain data: no bus, no message layouts.

use aisle_geometry::{Footprint, PathPose, Pose2};

/// What the supervisor should do.
#[derive(Debug, Clone, PartialEq)]
pub enum Action {
    Plan {
        start: Pose2,
        goal: Pose2,
        footprint: Footprint,
        margin: f64,
        use_detections: bool,
    },
    Follow {
        reference: Vec<PathPose>,
        goal: Pose2,
        footprint: Footprint,
        margin: f64,
    },
    Rotate {
        goal: Pose2,
        footprint: Footprint,
        margin: f64,
    },
    Attach(String),
    Detach,
    /// The mapper's ignore rectangle (map frame) and carried rectangle (robot frame).
    MapperControl {
        ignore: Option<(Pose2, Footprint)>,
        carried: Option<Footprint>,
    },
    /// Stop the robot and the controller: the mission ended.
    Halt,
}

/// Why a plan request failed, in the planner's words.
#[derive(Debug, Clone, PartialEq)]
pub struct PlanFailure(pub String);

/// The controller's report for the current goal.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ControllerReport {
    pub reached_goal: bool,
    pub exit_flag: u32,
    pub timestamps_increasing: bool,
}
