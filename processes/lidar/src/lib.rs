//! aisle-lidar: a simulated 3D lidar that raycasts the warehouse scene.
//!
//! [`Raycaster::scan`] casts the organised pattern of [`LidarConfig`] (rows = elevation
//! channels, row 0 the lowest; columns = azimuth channels, column 0 the most clockwise;
//! point of ray (row, col) at index `row * columns + col`) from a [`SensorPose`] against
//! every enabled body of an `aisle_config::scene::Scene` and writes sensor-frame points,
//! NaN for no return within `max_range`, into a caller's buffer. [`ParryReference`] is
//! the parry3d oracle it is tested against.
//!
//! Use from a node (once, then per tick):
//!
//! ```no_run
//! # use aisle_lidar::{LidarConfig, Raycaster, SensorPose};
//! # use aisle_config::scene::Scene;
//! # use aisle_geometry::Pose2;
//! # use std::path::Path;
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let cfg = aisle_config::load::<LidarConfig>(Path::new("config/lidar.toml"))?;
//! let scene = Scene::load(Path::new("config/warehouse.toml"))?;
//! let mut lidar = Raycaster::new(&cfg, &scene)?;
//! // The sensor in the robot's floor frame, from robot.toml's [lidar_mount].
//! let (robot, model) = aisle_robot::load_robot(Path::new("config/robot.toml"))?;
//! lidar.set_mount(model.mount_in_base(&robot.lidar_mount)?)?;
//! let rack = lidar.body_index("rack2b").expect("in the scene");
//! let mut cloud = vec![[0.0f32; 3]; lidar.len()]; // or the loaned sample's slice
//! for tick in 0..10u64 {
//!     lidar.set_body_pose(rack, Pose2::new(2.0, 13.0, 1.57))?; // O(parts of that body)
//!     let stats = lidar.scan_robot(&Pose2::new(0.0, 0.0, 0.0), tick, &mut cloud)?;
//!     let _ = stats.returns;
//! }
//! # Ok(())
//! # }
//! ```
//!
//! The floor (z = 0) is a plane, hit only by rays that point down: with the seed's
//! elevations (0..30 deg) and a level sensor ~0.2 m up, none does.
//!
//! The sensor's description ([`LidarConfig`], `lidar.toml`) and its mount (`robot.toml`,
//! resolved through the URDF to a [`SensorPose`]) come from `aisle-robot`. The library
//! modules know nothing of the bus or the URDF: the caller passes the mount (or the
//! sensor's world pose).

mod column;
mod error;
mod general;
mod grid;
pub mod node;
mod noise;
mod pattern;
mod planar;
mod raycaster;
pub mod reference;
mod world;

pub use aisle_robot::{LidarConfig, NoiseConfig, SensorPose};
pub use error::LidarError;
pub use pattern::ScanPattern;
pub use raycaster::{Raycaster, ScanPath, ScanStats};
pub use reference::ParryReference;

/// Packs the returns (non-NaN points) of `cloud` to its front, in order, and returns
/// how many there are: the unorganised form of a scan. The tail is left NaN.
pub fn compact_returns(cloud: &mut [[f32; 3]]) -> usize {
    let mut n = 0;
    for i in 0..cloud.len() {
        if !cloud[i][0].is_nan() {
            cloud[n] = cloud[i];
            n += 1;
        }
    }
    for p in &mut cloud[n..] {
        *p = [f32::NAN; 3];
    }
    n
}

#[cfg(test)]
mod tests;
