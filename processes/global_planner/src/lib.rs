//! aisle-global-planner: a Hybrid A* planner on SE(2) over an occupancy grid for a
//! differential-drive robot with a rectangular footprint.
//!
//! Reeds-Shepp motion primitives (forward cost 1, reverse cost 3 as in MATLAB's
//! `plannerHybridAStar`) plus turning on the spot, an analytic Reeds-Shepp (or
//! rotate-drive-rotate) connection to the goal every few expansions, the heuristic
//! max(2D obstacle-aware distance, free-space Reeds-Shepp cost), collision checks of the
//! real rectangle grown by the margin, and a smoothed path validated again before it is
//! returned.
//!
//! The library knows nothing of the bus, of files or of clocks: the node module adapts
//! it to requests and responses. Use [`Planner::plan`] (or [`Planner::plan_with_stop`]
//! for a caller-side deadline) and [`validate_path`] to check any path.
//!
//! ```no_run
//! use aisle_global_planner::{PlanRequest, Planner, PlannerConfig};
//! use aisle_geometry::{Footprint, GridMap, Pose2};
//! # fn demo(map: &GridMap) -> Result<(), Box<dyn std::error::Error>> {
//! let cfg = aisle_config::load::<PlannerConfig>("config/planner.toml".as_ref())?;
//! let mut planner = Planner::new(cfg)?; // validates; keep it for every request
//! let req = PlanRequest {
//!     start: Pose2::new(0.0, 0.0, 0.0),
//!     goal: Pose2::new(2.0, 13.0, std::f64::consts::FRAC_PI_2),
//!     footprint: Footprint::new(0.508, 0.43),
//!     margin: 0.1,
//!     max_expansions: 200_000,
//!     fixed_budget: false, // grows with the reachable area
//! };
//! match planner.plan(&req, &map.view()) {
//!     Ok(plan) => println!("{} poses, {:.2} m", plan.path.len(), plan.stats.path_length),
//!     Err(e) => println!("{:?} after {} expansions", e.kind, e.stats.expansions),
//! }
//! # Ok(()) }
//! ```

mod angle;
mod blocked;
mod both_ends;
mod budget;
mod collision;
pub mod config;
mod dist_tiles;
mod distance_map;
pub mod dock;
mod docked;
pub mod error;
mod heuristic;
pub mod large_map;
mod meet;
mod model;
pub mod motion;
mod motion_cache;
pub mod node;
pub mod reeds_shepp;
mod relief;
mod sampling;
mod search;
mod search_buffers;
mod search_core;
pub mod seed_map;
mod smooth;
mod states;
pub mod validate;

pub use config::PlannerConfig;
pub use dock::{DockKind, DockSite, Placed};
pub use docked::DockedPlan;
pub use error::{InvalidInput, PlanError, PlanErrorKind, PlanStats};
pub use search::{Plan, PlanRequest, Planner};
pub use validate::{PathViolation, check_turning_radius, footprint_touches, validate_path};

#[cfg(test)]
mod tests;
