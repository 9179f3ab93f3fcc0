//! aisle-robot: what the robot is, for every process that needs to know.
//!
//! - [`config`]: `config/robot.toml` (kinematics, footprints, body, sensor and carry
//!   mounts, watchdog, spawn pose);
//! - [`model`]: the robot's frames from its URDF (urdf-rs): links in `base_link`, floor
//!   height, mass, the lidar and carry mounts;
//! - [`mount`]: a sensor mount resolved to a [`SensorPose`] in the robot's floor frame;
//! - [`lidar`]: the lidar itself (`config/lidar.toml`: pattern, range, rate, noise) and
//!   the [`BeamGeometry`] its pattern gives;
//! - [`pose`]: [`SensorPose`], a sensor frame as a rigid transform;
//! - [`shapes`]: the URDF's collision shapes in `base_link`, for viewers.
//!
//! Knows nothing of the bus, the world or any algorithm. Every config type implements
//! `aisle_config::Validate` and is read with `aisle_config::load`.
//!
//! ```no_run
//! # use std::path::Path;
//! let (robot, model) = aisle_robot::load_robot(Path::new("config/robot.toml"))?;
//! let lidar_in_base = model.mount_in_base(&robot.lidar_mount)?;
//! let lidar = aisle_config::load::<aisle_robot::LidarConfig>(Path::new("config/lidar.toml"))?;
//! let beams = lidar.beams()?;
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod beams;
pub mod config;
pub mod lidar;
pub mod model;
pub mod mount;
pub mod pose;
pub mod shapes;

pub use beams::BeamGeometry;
pub use config::{
    BodyConfig, CarryConfig, FootprintConfig, FootprintSpec, KinematicsConfig, MountConfig,
    RobotConfig, StartConfig, WatchdogConfig,
};
pub use lidar::{LidarConfig, NoiseConfig};
pub use model::{BASE_LINK, ModelError, RobotModel, planar};
pub use pose::SensorPose;
pub use shapes::{CollisionShape, Geometry};

use aisle_config::ConfigError;
use std::path::Path;

/// Loading `robot.toml` and the URDF it names.
#[derive(Debug, thiserror::Error)]
pub enum LoadError {
    #[error(transparent)]
    Config(#[from] ConfigError),
    #[error(transparent)]
    Model(#[from] ModelError),
}

/// Loads `robot.toml` and the URDF it names (relative to its directory).
pub fn load_robot(robot_toml: &Path) -> Result<(RobotConfig, RobotModel), LoadError> {
    let cfg = aisle_config::load::<RobotConfig>(robot_toml)?;
    let model = RobotModel::load(&cfg.urdf_path(robot_toml), &cfg)?;
    Ok((cfg, model))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shipped_robot_loads() {
        let (cfg, model) = load_robot(&aisle_config::testing::shipped("robot.toml")).unwrap();
        assert_eq!(cfg, RobotConfig::default());
        assert!(model.link_pose_in_base("mid_mount").is_some());
    }
}
