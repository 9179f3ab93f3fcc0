//! aisle-simulator: the simulated warehouse world the rest of the stack drives.
//!
//! - [`config`]: `config/robot.toml` (kinematics, footprints, mounts, watchdog, spawn);
//! - [`model`]: the robot's frames from its URDF (lidar mount, carry mount, floor);
//! - [`kinematics`]: differential drive with wheel clamping and exact arc integration;
//! - [`timeline`]: zero-order-hold command timelines with a watchdog;
//! - [`collision`]: upright boxes, overlap and clearance;
//! - [`world`]: the state, one step of simulated time, carrying, snapshots.
//!
//! The library knows nothing of iceoryx2 or wall clocks: the `node` module (written
//! separately) adapts it to the bus and hands it simulated time.
//!
//! Typical use:
//! ```no_run
//! # use std::path::Path;
//! use aisle_simulator::{World, load_robot, DEFAULT_DT_NS};
//! let (cfg, model) = load_robot(Path::new("config/robot.toml"))?;
//! let scene = aisle_config::scene::Scene::load(Path::new("config/warehouse.toml"))?;
//! let mut world = World::new(&scene, &model, &cfg)?;
//! world.set_timeline(0, &[(0.0, 0.5, 0.0), (0.3, 0.5, 0.2)])?;
//! let report = world.step(DEFAULT_DT_NS);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

pub mod collision;
pub mod config;
mod error;
pub mod kinematics;
pub mod model;
pub mod node;
pub mod timeline;
pub mod world;

pub use config::{InvalidKey, RobotConfig};
pub use error::{LoadError, SimError};
pub use kinematics::{DiffDrive, Twist, WheelSpeeds};
pub use model::{ModelError, RobotModel};
pub use timeline::{CommandTimeline, MAX_COMMANDS, TimelineError};
pub use world::{Carried, DEFAULT_DT_NS, RobotState, StepReport, World, WorldSnapshot};

use std::path::Path;

/// Loads `robot.toml` and the URDF it names (relative to its directory).
pub fn load_robot(robot_toml: &Path) -> Result<(RobotConfig, RobotModel), LoadError> {
    let cfg = RobotConfig::load(robot_toml)?;
    let model = RobotModel::load(&cfg.urdf_path(robot_toml), &cfg)?;
    Ok((cfg, model))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shipped_robot_loads() {
        let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config/robot.toml");
        let (cfg, model) = load_robot(&p).unwrap();
        assert_eq!(cfg, RobotConfig::default());
        assert!(model.link_pose_in_base("mid_mount").is_some());
    }
}
