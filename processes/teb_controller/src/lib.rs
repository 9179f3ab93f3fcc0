//! aisle-teb-controller: a timed-elastic-band local controller for a differential-drive
//! robot, solved as a sequence of convex subproblems (an interior-point solver for the
//! band's banded structure, `conic/`; clarabel as its fallback).
//!
//! The band's poses and time steps are optimised for minimum time, closeness to the
//! reference path and smoothness, with velocity limits as exact cones and kinematics,
//! accelerations, drive direction and obstacle clearance linearised around the previous
//! band. Outputs follow MATLAB controllerTEB: a (t, v, w) timeline, predicted poses,
//! reached-goal and exit flag. Knows nothing of the bus (the `node` module adapts it).
//!
//! Docking under a rack and leaving it (`Mode::Straight`) is not optimised: a line
//! tracker rolls the timeline out and sweeps the footprint along it (`straight.rs`).
//!
//! ```text
//! let mut teb = TebController::new(aisle_config::load::<TebConfig>(Path::new("config/teb.toml"))?)?;
//! teb.set_goal(&Goal { reference, footprint, margin: 0.1, mode: Mode::Follow, tolerance: None })?;
//! // every 0.5 s of sim time:
//! let out = teb.step(pose, (v, w), t_now, &local_map)?;   // &StepOutput, reused buffers
//! let (v, w) = out.command_at(t);                          // zero-order hold, sim time
//! let snap = teb.snapshot();                               // publish (history 1)
//! // after a restart: teb.set_goal(&same_goal)?; teb.restore(&snap)?;
//! ```

mod band;
pub mod case;
mod clearance;
mod config;
mod conic;
mod controller;
mod correction;
mod detour;
mod direction;
mod error;
mod feasibility;
mod goal;
mod kinematics;
mod leg;
pub mod node;
mod objective;
mod output;
mod planner;
mod qp;
mod reference;
pub mod resume;
mod scp;
mod seed;
mod steps;
mod straight;
mod timing;
mod trust_region;

#[cfg(test)]
mod tests;

pub use band::Band;
pub use config::{
    BandConfig, HomotopyConfig, LimitsConfig, SolverConfig, StraightConfig, TebConfig,
    WeightsConfig,
};
pub use controller::{Snapshot, TebController};
pub use error::TebError;
pub use goal::{Goal, Mode};
pub use output::{Command, ExitFlag, MAX_COMMANDS, StepOutput, TimedPose, command_at};
pub use steps::Steps;
