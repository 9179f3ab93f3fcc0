//! The mission: what `mission.toml` asks for and the state machine that sequences it.
//!
//! - [`config`]: `mission.toml` parsed and validated.
//! - [`machine`]: the pure state machine ([`Mission`]) and its per-leg results.
//! - [`events`]: what the machine is told (plan results, controller reports) and what
//!   it answers ([`Action`]s).
//!
//! Nothing here knows of the bus, of clocks or of processes, so every rule is
//! unit-tested without launching anything.

mod config;
mod events;
mod machine;

pub use config::{LegSpec, MissionConfig};
pub use events::{Action, ControllerReport, Dock, DockBody, LegResult, PlanFailure, Planned};
pub use machine::backoff::least_margin;
pub use machine::docking::{carried_footprint, carrying_footprint};
pub use machine::{Footprints, Mission, NamedBody};
