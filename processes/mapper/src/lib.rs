//! aisle-mapper: the global occupancy map (static scene + lidar detections) and the
//! rolling local map the controller reads.
//!
//! - [`static_map`]: the static map from the warehouse scene (MATLAB's
//!   `binaryOccupancyMap(scenario, ...)` plus the occupied boundary band).
//! - [`ros_map`]: ROS map_server YAML + PGM in and out, so users can bring their own map.
//! - [`obstacle_layer`]: lidar returns become `OCCUPIED_DETECTED` cells; rays clear them.
//! - [`export`]: `aisle map export`, the scene's static map as YAML + PGM.
//! - `placed`: the legs of bodies the mission set down, static cells no ray clears.
//! - [`local_map`]: the window centred on the robot, written into a caller buffer.
//! - [`Mapper`]: the object the node drives, tying the above together.
//!
//! The library knows nothing of iceoryx2 or clocks; the `node` module adapts it to the bus.
//!
//! How a node drives it:
//! 1. Once: `aisle_config::load::<MapConfig>(mapper.toml)`, `load_static_map(&cfg, warehouse.toml)` (the
//!    scene, or the ROS map named in the config), `Mapper::new(map, &cfg, beams)`; or
//!    `Mapper::from_files` for the three at once.
//! 2. Every cloud: build a [`Scan`] (borrowed points, sensor pose, robot pose, robot
//!    footprint, carried rack, ignore rectangles) and call [`Mapper::integrate`]; it
//!    allocates nothing, and [`ScanStats::changed`] / [`Mapper::version`] say whether
//!    the global map must be republished.
//! 3. Copy out: [`Mapper::local_map_into`] into the message's cell buffer (returns the
//!    window's origin and size), [`Mapper::global_map`] / [`Mapper::static_map`] as
//!    `GridView`s whose `cells` are copied as they are.
//! 4. `aisle map export <dir>`: [`export_from_config_dir`].

#[cfg(test)]
mod alloc_probe;
pub mod changes;
mod clearing;
pub mod cloud;
pub mod config;
mod error;
pub mod export;
pub mod local_map;
mod mapper;
pub mod node;
pub mod obstacle_layer;
mod placed;
pub mod ros_map;
pub mod static_map;
pub mod synthetic;

pub use cloud::{BeamGeometry, MAX_CLOUD_POINTS, OrganizedCloud, SensorPose};
pub use config::{LocalMapConfig, MAX_GRID_SIDE, MapConfig, ObstacleConfig};
pub use error::MapError;
pub use export::{ExportedMap, export_from_config_dir, export_scene_map};
pub use local_map::LocalMapInfo;
pub use mapper::{Mapper, load_static_map};
pub use obstacle_layer::{IgnoreZone, MAX_IGNORE_ZONES, ObstacleLayer, Scan, ScanStats};
pub use ros_map::{read_ros_map, write_ros_map};
pub use static_map::static_map_from_scene;
