//! An example of a node of the user's own, written against the public node SDK: a
//! safety monitor that asks the simulator to stop the robot when the nearest lidar
//! return in the robot's direction of travel is within its stopping distance.
//!
//! - [`StopRule`]: the decision, a pure function of a scan, the robot's pose and
//!   velocity, and the footprint; unit-tested without a bus.
//! - [`node::MonitorStage`]: the `aisle_node::Stage` around it (trigger: the point cloud;
//!   output: a `SimCommand` Stop).
//!
//! Knows the point cloud's frames and the robot's footprint; not how it is launched
//! (`aisle run` starts it from `graph.toml`, see README "Your own nodes").

pub mod config;
pub mod node;
mod rule;

pub use config::MonitorConfig;
pub use rule::{Corridor, StopRule, Verdict};
