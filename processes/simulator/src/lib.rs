//! aisle-simulator: the simulated warehouse world the rest of the stack drives.
//!
//! - [`kinematics`]: differential drive with wheel clamping and exact arc integration;
//! - [`timeline`]: zero-order-hold command timelines with a watchdog;
//! - [`collision`]: upright boxes, overlap and clearance;
//! - [`world`]: the state, one step of simulated time, carrying, snapshots.
//!
//! The robot itself (`robot.toml`, the URDF) is described by `aisle-robot`. The library
//! knows nothing of iceoryx2 or wall clocks: the `node` module (written separately)
//! adapts it to the bus and hands it simulated time.
//!
//! Typical use:
//! ```no_run
//! # use std::path::Path;
//! use aisle_simulator::{World, DEFAULT_DT_NS};
//! let (cfg, model) = aisle_robot::load_robot(Path::new("config/robot.toml"))?;
//! let scene = aisle_config::scene::Scene::load(Path::new("config/warehouse.toml"))?;
//! let mut world = World::new(&scene, &model, &cfg)?;
//! world.set_timeline(0, &[(0.0, 0.5, 0.0), (0.3, 0.5, 0.2)])?;
//! let report = world.step(DEFAULT_DT_NS);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

pub mod collision;
mod error;
pub mod kinematics;
pub mod node;
mod sim_state;
pub mod timeline;
pub mod world;

pub use error::SimError;

/// Non-static bodies a scene may have: `WorldTruth` lists them all every tick and keeps
/// room for the static bodies in contact (static bodies: any number).
pub const MAX_MOVABLE_BODIES: usize = aisle_messages::MAX_BODIES - aisle_messages::MAX_CONTACTS;
pub use kinematics::{DiffDrive, Twist, WheelSpeeds};
pub use timeline::{CommandTimeline, MAX_COMMANDS, TimelineError};
pub use world::{Carried, DEFAULT_DT_NS, RobotState, StepReport, World, WorldSnapshot};
