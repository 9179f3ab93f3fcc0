//! What goes into the mission state machine besides time and pose (plan results,
//! controller reports) and what comes out of it ([`Action`]s for the supervisor to
//! carry out). Plain data: no bus, no message layouts.

use aisle_geometry::{Footprint, PathPose, Pose2};
use serde::{Deserialize, Serialize};

/// Per-leg outcome for reports.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct LegResult {
    pub name: String,
    pub reached: bool,
    pub start_s: f64,
    pub end_s: f64,
    pub replans: u32,
    /// Plans that failed and were not retried with less margin.
    pub plan_failures: u32,
    /// Plans that failed because of the margin and were asked again with less of it.
    #[serde(default)]
    pub margin_backoffs: u32,
    pub final_error_m: f64,
    pub final_heading_error_rad: f64,
}

/// A body the robot drives under or out of, in the map frame: its footprint and the
/// parts of it the robot can hit (a rack's legs).
#[derive(Debug, Clone, PartialEq)]
pub struct DockBody {
    pub pose: Pose2,
    pub footprint: Footprint,
    pub parts: Vec<(Pose2, Footprint)>,
}

/// The straight move a plan starts or ends with.
#[derive(Debug, Clone, PartialEq)]
pub enum Dock {
    /// End under `body` (the goal), entering straight through an open side; with a
    /// free heading the planner chooses the side.
    Into { body: DockBody, free_heading: bool },
    /// Start by leaving `body` straight, forwards or backwards.
    OutOf { body: DockBody },
}

/// A planned path and where its straight move is.
#[derive(Debug, Clone, PartialEq)]
pub struct Planned {
    pub path: Vec<PathPose>,
    /// `path[split..]` is the move under the body (`Some(Dock::Into)` was asked).
    pub dock_from: Option<usize>,
    /// `path[..=split]` is the move out of the body.
    pub undock_to: Option<usize>,
}

impl Planned {
    /// A path without straight moves.
    pub fn plain(path: Vec<PathPose>) -> Planned {
        Planned {
            path,
            dock_from: None,
            undock_to: None,
        }
    }
}

/// What the supervisor should do.
#[derive(Debug, Clone, PartialEq)]
pub enum Action {
    Plan {
        start: Pose2,
        goal: Pose2,
        footprint: Footprint,
        margin: f64,
        use_detections: bool,
        dock: Option<Dock>,
        /// The most the planner may expand for this request, in all (a try with a
        /// fallback, `backoff.rs`); `None`: the planner's own budget, which grows with
        /// the reachable area.
        fixed_budget: Option<u32>,
    },
    Follow {
        reference: Vec<PathPose>,
        goal: Pose2,
        footprint: Footprint,
        margin: f64,
        /// Reach the goal within these x, y, heading tolerances instead of the
        /// mission's (the pose a docking move starts from).
        tolerance: Option<[f64; 3]>,
    },
    /// Drive straight along the line through `goal` in its heading to `goal`.
    Straight {
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
    /// The mapper's ignore rectangle (map frame) and carried rectangle (robot frame),
    /// and the parts of bodies set down it keeps as obstacles (map frame).
    MapperControl {
        ignore: Option<(Pose2, Footprint)>,
        carried: Option<Footprint>,
        placed: Vec<(Pose2, Footprint)>,
    },
    /// Stop the robot and the controller: the mission ended.
    Halt,
}

/// Why a plan request failed, in the planner's words.
#[derive(Debug, Clone, PartialEq)]
pub struct PlanFailure {
    pub why: String,
    /// The margin may be what failed: the start is within it (in collision with the
    /// margin), or no path keeps it, or the search ran out of budget looking for one
    /// (a gap the footprint fits through, but not with the whole margin). A plan with a smaller margin may back the robot out or
    /// through.
    pub margin_bound: bool,
}

impl PlanFailure {
    pub fn new(why: impl Into<String>) -> PlanFailure {
        PlanFailure {
            why: why.into(),
            margin_bound: false,
        }
    }
}

/// The controller's report for the current goal.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ControllerReport {
    pub reached_goal: bool,
    pub exit_flag: u32,
    pub timestamps_increasing: bool,
}
