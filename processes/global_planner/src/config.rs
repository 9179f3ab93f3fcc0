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
    /// of heading bins, and never shorter than one search cell diagonal. At most
    /// [`MAX_PRIMITIVE_LENGTH_M`] and a quarter turn of the tightest arc
    /// (`pi / 2 * min_turning_radius`): a longer primitive steps over the gaps and
    /// aisles it should enter (every request then fails), and an arc past a quarter turn
    /// ends nowhere near where it heads.
    pub primitive_length: f64,
    /// Cell size of the search's closed set (m); independent of the map resolution,
    /// from [`MIN_SEARCH_RESOLUTION_M`] to [`MAX_SEARCH_RESOLUTION_M`]: finer than half the
    /// mapper's finest cell (0.05 m) separates no poses the map tells apart and makes the
    /// state table too large for any but a small map (every request then fails); coarser
    /// than the robot's width merges poses on either side of an aisle.
    pub search_resolution: f64,
    /// Cell size of the 2D obstacle heuristic (m), rounded to whole map cells; at most
    /// [`MAX_HEURISTIC_RESOLUTION_M`] (coarser cells close the aisles it must see).
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
    /// Spacing of the output path poses (m); MATLAB's ValidationDistance in the seed. At
    /// most [`MAX_VALIDATION_DISTANCE_M`] and half of `min_turning_radius`: the search
    /// keeps the chord's sagitta (`validation_distance^2 / (8 min_turning_radius)`) as
    /// extra clearance, which must stay a few millimetres.
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
    /// the start has, every other motion the full margin (`relief.rs`). 0: none. The same
    /// radius relieves a goal the search could not reach with its own allowance (the
    /// sagitta and `sweep_cover` beyond the margin): motions ending or leaving within it
    /// keep the clearance the goal has (0: only the motions that end on the goal).
    pub start_relief_radius: f64,
    /// A start boxed in at the margin (the search from it closed no node beyond
    /// `start_relief_radius` and found no path): the request is searched once more with
    /// the motions leaving within that radius keeping this fraction of the margin
    /// (`relief.rs`). 1: no second search.
    pub boxed_in_margin: f64,
    /// Weighted A*: the search orders nodes by `g + heuristic_weight * h`, so a path
    /// costs at most this factor over the best the search could find, and far fewer
    /// nodes are expanded where many paths cost nearly the same (the open floor of a
    /// large hall, where the plain search expands every heading of every cell whose
    /// detour fits in the final path's slack). 1: plain A*. The default, 1.05, is for
    /// corridors: a path down an aisle can shift sideways and turn a few degrees for a
    /// fraction of a percent of its cost, and plain A* expands every such variant (the
    /// seed's carrying leg: 4,930 expansions, 14 ms; at 1.05, 125 and 1.4 ms, the same
    /// way 0.4 % longer).
    pub heuristic_weight: f64,
    /// Expansions a search from the start may spend before the same request is searched
    /// from its goal's end too (`both_ends.rs`): the two then take turns, each going on
    /// where it stopped, each turn's limit four times the last while four times it fits
    /// in the request's budget; then the search from the start alone, to the whole
    /// budget. Where the hard part of a request lies at its goal (a park facing out of a
    /// dead-end aisle, reached only by turning on the spot at the end), the search from
    /// the start expands every heading of every cell within that turn's cost of the
    /// shortest way, and the one from the goal pays the turn first (`config/growth/x4`'s
    /// park: 123k expansions from the start, 1.9k from the goal). 0: from the start
    /// alone.
    pub goal_end_after: u32,
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
            boxed_in_margin: 0.5,
            heuristic_weight: 1.05,
            goal_end_after: 4096,
        }
    }
}

/// The finest `search_resolution` (m): half the mapper's finest cell (20 cells/m).
pub const MIN_SEARCH_RESOLUTION_M: f64 = 0.025;
/// The coarsest `search_resolution` (m): about the robot's width (0.43 m).
pub const MAX_SEARCH_RESOLUTION_M: f64 = 0.5;
/// The coarsest `heuristic_resolution` (m).
pub const MAX_HEURISTIC_RESOLUTION_M: f64 = 1.0;
/// The longest `primitive_length` (m): four robot lengths.
pub const MAX_PRIMITIVE_LENGTH_M: f64 = 2.0;
/// The widest `validation_distance` (m).
pub const MAX_VALIDATION_DISTANCE_M: f64 = 0.5;

impl PlannerConfig {
    /// The sizes of the search's grids and motions: within ranges every request can use
    /// (outside them every request fails, so `aisle check` refuses them before launch).
    fn validate_sizes(&self) -> Result<(), InvalidKey> {
        positive("min_turning_radius", self.min_turning_radius)?;
        in_range("heading_bins", self.heading_bins, 8, 720)?;
        let quarter_turn = std::f64::consts::FRAC_PI_2 * self.min_turning_radius;
        let max_primitive = MAX_PRIMITIVE_LENGTH_M.min(quarter_turn);
        positive("primitive_length", self.primitive_length)?;
        if self.primitive_length > max_primitive {
            return Err(InvalidKey::new(
                "primitive_length",
                format!(
                    "must be at most {max_primitive:.3} m ({MAX_PRIMITIVE_LENGTH_M} m, and a \
                     quarter turn of min_turning_radius), got {}",
                    self.primitive_length
                ),
            ));
        }
        in_range(
            "search_resolution",
            self.search_resolution,
            MIN_SEARCH_RESOLUTION_M,
            MAX_SEARCH_RESOLUTION_M,
        )?;
        positive("heuristic_resolution", self.heuristic_resolution)?;
        if self.heuristic_resolution > MAX_HEURISTIC_RESOLUTION_M {
            return Err(InvalidKey::new(
                "heuristic_resolution",
                format!(
                    "must be at most {MAX_HEURISTIC_RESOLUTION_M} m, got {}",
                    self.heuristic_resolution
                ),
            ));
        }
        let max_spacing = MAX_VALIDATION_DISTANCE_M.min(0.5 * self.min_turning_radius);
        positive("validation_distance", self.validation_distance)?;
        if self.validation_distance > max_spacing {
            return Err(InvalidKey::new(
                "validation_distance",
                format!(
                    "must be at most {max_spacing:.3} m ({MAX_VALIDATION_DISTANCE_M} m, and \
                     half of min_turning_radius), got {}",
                    self.validation_distance
                ),
            ));
        }
        Ok(())
    }
}

impl Validate for PlannerConfig {
    fn validate(&self) -> Result<(), InvalidKey> {
        self.validate_sizes()?;
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
        in_range("boxed_in_margin", self.boxed_in_margin, 0.0, 1.0)?;
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

    /// Sizes no request can use are refused by key, with the file named when loaded.
    #[test]
    fn sizes_outside_their_ranges_are_refused() {
        let bad = |c: PlannerConfig| c.validate().unwrap_err().key;
        let d = PlannerConfig::default;
        for v in [0.001, 0.02, 0.6, f64::NAN, f64::INFINITY] {
            let c = PlannerConfig {
                search_resolution: v,
                ..d()
            };
            assert_eq!(bad(c), "search_resolution", "{v}");
        }
        for v in [50.0, 2.5, 1.6, f64::NAN, 0.0] {
            let c = PlannerConfig {
                primitive_length: v,
                ..d()
            };
            assert_eq!(bad(c), "primitive_length", "{v}");
        }
        // A quarter turn of a tighter radius bounds it further.
        let tight = PlannerConfig {
            min_turning_radius: 0.5,
            primitive_length: 0.8,
            ..d()
        };
        assert_eq!(bad(tight), "primitive_length");
        let coarse = PlannerConfig {
            heuristic_resolution: 2.0,
            ..d()
        };
        assert_eq!(bad(coarse), "heuristic_resolution");
        let wide = PlannerConfig {
            validation_distance: 0.6,
            sweep_cover: 0.03,
            ..d()
        };
        assert_eq!(bad(wide), "validation_distance");
        // The ends of the ranges are accepted.
        for (s, p) in [(0.025, 1.5), (0.5, 2.0)] {
            let c = PlannerConfig {
                search_resolution: s,
                primitive_length: p,
                min_turning_radius: 2.0,
                ..d()
            };
            c.validate().unwrap();
        }
        let loaded = aisle_config::parse::<PlannerConfig>(
            Path::new("planner.toml"),
            "search_resolution = 0.001\n",
        )
        .unwrap_err()
        .to_string();
        assert!(loaded.contains("planner.toml"), "{loaded}");
        assert!(loaded.contains("search_resolution"), "{loaded}");
    }
}
