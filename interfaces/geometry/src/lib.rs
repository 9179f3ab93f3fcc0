//! Planar geometry shared by every algorithm crate: SE(2) poses, rectangular
//! footprints and occupancy grids.
//!
//! Knows nothing of the bus, of configuration files or of clocks: plain data and
//! pure functions, so planners, controllers and tests can use it directly.

mod footprint;
mod grid;
mod path;
mod pose;

pub use footprint::Footprint;
pub use grid::{CellIndex, FREE, GridError, GridMap, GridView, OCCUPIED_DETECTED, OCCUPIED_STATIC};
pub use path::{Direction, PathPose, path_length};
pub use pose::{Pose2, wrap_angle};
