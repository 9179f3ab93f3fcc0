//! Planner configuration (`config/planner.toml`): serde with unknown keys refused,
//! defaults from the seed and MATLAB's `plannerHybridAStar`, and a `validate()` whose
//! error names the offending key. Knows nothing of files: load it with
//! `aisle_config::load::<PlannerConfig>`.

use aisle_config::checks::{at_least, in_range, positive};
use aisle_config::{InvalidKey, Validate};
use serde::{Deserialize, Serialize};

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct PlannerConfig {
    /// Minimum turning radius of the arcs (m). 1.0 m: at the controller's 1 rad/s limit
    /// the robot can follow it at 1 m/s, half its top speed, so the reference path is
    /// trackable without in-place corrections; tighter spots use rotation primitives.
    pub min_turning_radius: f64,
    /// Heading bins of the search's closed set (MATLAB and Nav2 use 72: 5 degrees).
    pub heading_bins: u32,
    /// Minimum length of one motion primitive (m); arcs are rounded up to a whole number
    /// of heading bins, and never shorter than one search cell diagonal.
    pub primitive_length: f64,
    /// Cell size of the search's closed set (m); independent of the map resolution.
    pub search_resolution: f64,
    /// Cell size of the 2D obstacle heuristic (m), rounded to whole map cells.
    pub heuristic_resolution: f64,
    /// Cost per metre driven forward (MATLAB default 1).
    pub forward_cost: f64,
    /// Cost per metre driven in reverse (MATLAB default 3).
    pub reverse_cost: f64,
    /// Added at every change between forward and reverse driving (MATLAB default 0; we
    /// charge 1 m so that cusps appear only when they save more than a metre).
    pub direction_switch_cost: f64,
    /// Extra fraction of the length charged for turning arcs (discourages weaving).
    pub steering_penalty: f64,
    /// Whether turning on the spot is allowed (a differential-drive robot can).
    pub allow_rotation: bool,
    /// Cost per radian turned on the spot.
    pub rotation_cost: f64,
    /// Heading bins turned by one rotation primitive.
    pub rotation_step_bins: u32,
    /// Try an analytic (Reeds-Shepp or rotate-drive-rotate) connection to the goal every
    /// this many expansions (MATLAB default 5), and on the first one.
    pub analytic_expansion_interval: u32,
    /// Far from the goal, space analytic attempts by at least this many expansions per
    /// metre of remaining (heuristic) cost; 0 keeps the fixed interval. Nav2 uses about
    /// 5.7 per metre (one per 3.5 cells of 5 cm).
    pub analytic_interval_per_metre: f64,
    /// How many of the cheapest analytic candidates to collision-check per attempt.
    pub analytic_candidates: u32,
    /// Spacing of the output path poses (m); MATLAB's ValidationDistance in the seed.
    pub validation_distance: f64,
    /// Reach of one exact collision check (m): checks are spaced so that no pose between
    /// them goes unchecked, at the price of this much extra clearance near obstacles.
    pub sweep_cover: f64,
    /// Smooth the path (then re-validate; a piece whose smoothing breaks validity keeps
    /// its original shape).
    pub smoothing: bool,
    pub smoothing_weight_data: f64,
    pub smoothing_weight_smooth: f64,
    pub smoothing_iterations: u32,
    /// How often (in expansions) the optional stop callback is asked.
    pub stop_check_interval: u32,
    /// The expansion budget grows with the problem: a search may expand at least this
    /// many nodes per grid cell reachable from the goal (the obstacle heuristic's cells,
    /// `heuristic_resolution` apart), when that is more than the request's budget. 0
    /// keeps the request's budget alone.
    pub expansions_per_reachable_cell: f64,
    /// Docking: straight run (m) between a rack's side and the robot at the pose where
    /// the straight move under it starts (or the move out of it ends): room to line up.
    pub dock_run_in: f64,
    /// Docking: clearance (m) the straight move keeps from the rack's legs and from
    /// occupied cells (the legs leave 0.135 m beside the Jackal in the narrower opening).
    pub dock_clearance: f64,
    /// A start inside the margin (the controller keeps the margin as a soft cost):
    /// motions leaving from within this distance (m) of it keep at least the clearance
    /// the start has, every other motion the full margin (`relief.rs`). 0: none.
    pub start_relief_radius: f64,
    /// Weighted A*: the search orders nodes by `g + heuristic_weight * h`, so a path
    /// costs at most this factor over the best the search could find, and far fewer
    /// nodes are expanded where many paths cost nearly the same (the open floor of a
    /// large hall, where the plain search expands every heading of every cell whose
    /// detour fits in the final path's slack). 1: plain A*.
    pub heuristic_weight: f64,
}

impl Default for PlannerConfig {
    fn default() -> Self {
        Self {
            min_turning_radius: 1.0,
            heading_bins: 72,
            primitive_length: 0.25,
            search_resolution: 0.1,
            heuristic_resolution: 0.1,
            forward_cost: 1.0,
            reverse_cost: 3.0,
            direction_switch_cost: 1.0,
            steering_penalty: 0.05,
            allow_rotation: true,
            rotation_cost: 1.5,
            rotation_step_bins: 3,
            analytic_expansion_interval: 5,
            analytic_interval_per_metre: 2.0,
            analytic_candidates: 3,
            validation_distance: 0.1,
            sweep_cover: 0.03,
            smoothing: true,
            smoothing_weight_data: 0.2,
            smoothing_weight_smooth: 0.3,
            smoothing_iterations: 200,
            stop_check_interval: 256,
            expansions_per_reachable_cell: 4.0,
            dock_run_in: 0.5,
            dock_clearance: 0.03,
            start_relief_radius: 0.5,
            heuristic_weight: 1.0,
        }
    }
}

impl Validate for PlannerConfig {
    fn validate(&self) -> Result<(), InvalidKey> {
        positive("min_turning_radius", self.min_turning_radius)?;
        in_range("heading_bins", self.heading_bins, 8, 720)?;
        positive("primitive_length", self.primitive_length)?;
        positive("search_resolution", self.search_resolution)?;
        positive("heuristic_resolution", self.heuristic_resolution)?;
        at_least("forward_cost", self.forward_cost, 1.0)?;
        at_least("reverse_cost", self.reverse_cost, 1.0)?;
        at_least("direction_switch_cost", self.direction_switch_cost, 0.0)?;
        at_least("steering_penalty", self.steering_penalty, 0.0)?;
        positive("rotation_cost", self.rotation_cost)?;
        in_range(
            "rotation_step_bins",
            self.rotation_step_bins,
            1,
            self.heading_bins / 2,
        )?;
        in_range(
            "analytic_expansion_interval",
            self.analytic_expansion_interval,
            1,
            1_000_000,
        )?;
        at_least(
            "analytic_interval_per_metre",
            self.analytic_interval_per_metre,
            0.0,
        )?;
        in_range("analytic_candidates", self.analytic_candidates, 1, 48)?;
        positive("validation_distance", self.validation_distance)?;
        positive("sweep_cover", self.sweep_cover)?;
        if self.sweep_cover > 0.5 * self.validation_distance {
            return Err(InvalidKey::new(
                "sweep_cover",
                "must not exceed half of validation_distance",
            ));
        }
        let w = self.smoothing_weight_data;
        let s = self.smoothing_weight_smooth;
        at_least("smoothing_weight_data", w, 0.0)?;
        at_least("smoothing_weight_smooth", s, 0.0)?;
        if w + 2.0 * s > 1.0 {
            return Err(InvalidKey::new(
                "smoothing_weight_smooth",
                "weight_data + 2 * weight_smooth must be <= 1 for a stable update",
            ));
        }
        in_range(
            "smoothing_iterations",
            self.smoothing_iterations,
            0,
            100_000,
        )?;
        in_range("stop_check_interval", self.stop_check_interval, 1, u32::MAX)?;
        in_range(
            "expansions_per_reachable_cell",
            self.expansions_per_reachable_cell,
            0.0,
            1000.0,
        )?;
        positive("dock_run_in", self.dock_run_in)?;
        at_least("dock_clearance", self.dock_clearance, 0.0)?;
        at_least("start_relief_radius", self.start_relief_radius, 0.0)?;
        in_range("heuristic_weight", self.heuristic_weight, 1.0, 5.0)?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    #[test]
    fn default_is_valid_and_matches_the_shipped_file() {
        PlannerConfig::default().validate().unwrap();
        let path = aisle_config::testing::shipped("planner.toml");
        let cfg = aisle_config::load::<PlannerConfig>(&path).unwrap();
        assert_eq!(cfg, PlannerConfig::default());
    }

    #[test]
    fn bad_values_name_their_key() {
        let mut c = PlannerConfig {
            reverse_cost: 0.5,
            ..Default::default()
        };
        assert_eq!(c.validate().unwrap_err().key, "reverse_cost");
        c.reverse_cost = 3.0;
        c.min_turning_radius = f64::NAN;
        assert_eq!(c.validate().unwrap_err().key, "min_turning_radius");
        let typo = aisle_config::parse::<PlannerConfig>(Path::new("x.toml"), "heading_binz = 3\n");
        assert!(typo.is_err());
    }
}
