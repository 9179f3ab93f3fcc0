//! `safety_monitor.toml` (optional, in the config directory): how hard the robot can
//! brake and how much room the monitor keeps. Every key is optional.

use aisle_config::{InvalidKey, Validate, checks};
use serde::Deserialize;

#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct MonitorConfig {
    /// m/s², the braking the stopping distance assumes (teb.toml's max_acceleration).
    pub deceleration: f64,
    /// s between a scan and the robot braking (one tick and the pipeline).
    pub reaction: f64,
    /// m kept free in front of (or behind) the footprint once stopped.
    pub margin: f64,
    /// m added to each side of the footprint for the corridor that is watched.
    pub lateral_margin: f64,
    /// m, returns at or below this height are the floor.
    pub min_height: f64,
    /// m above the robot's body height, returns above are not in its way.
    pub max_height_above_body: f64,
    /// m: returns this close outside the footprint are the robot's own (the legs of
    /// the rack it carries, seen with the lidar's noise), as a scanner's self-filter.
    pub self_filter: f64,
    /// m a robot starting from rest may cover before the monitor sees it move (one
    /// tick at the speed a first command may ask); a standing robot is held while a
    /// return in its last direction of travel is within `margin` + this.
    pub start_step: f64,
    /// m/s; slower than this the robot is standing (no stop asked).
    pub moving_speed: f64,
}

impl Default for MonitorConfig {
    fn default() -> Self {
        MonitorConfig {
            deceleration: 2.4,
            reaction: 0.2,
            margin: 0.1,
            lateral_margin: 0.05,
            min_height: 0.05,
            max_height_above_body: 0.1,
            self_filter: 0.05,
            start_step: 0.1,
            moving_speed: 0.02,
        }
    }
}

impl Validate for MonitorConfig {
    fn validate(&self) -> Result<(), InvalidKey> {
        checks::positive("deceleration", self.deceleration)?;
        checks::non_negative("reaction", self.reaction)?;
        checks::non_negative("margin", self.margin)?;
        checks::non_negative("lateral_margin", self.lateral_margin)?;
        checks::non_negative("min_height", self.min_height)?;
        checks::non_negative("max_height_above_body", self.max_height_above_body)?;
        checks::non_negative("self_filter", self.self_filter)?;
        checks::non_negative("start_step", self.start_step)?;
        checks::non_negative("moving_speed", self.moving_speed)?;
        Ok(())
    }
}
