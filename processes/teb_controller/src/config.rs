//! `TebConfig`: kinematic limits, horizon, band resizing, cost weights and solver budget,
//! read from `config/teb.toml`.
//!
//! Defaults are the seed's numbers (MaxVelocity [2 1], LookAheadTime 3, GoalTolerance
//! [0.2 0.2 0.2]) and MATLAB controllerTEB's defaults for what the seed leaves open
//! (ReferenceDeltaTime 0.3, MaxAcceleration [2.4 4.8], reverse limit = forward limit).
//! The footprint and the safety margin are not here: they change with the load and
//! arrive with each [`crate::Goal`]. Load it with `aisle_config::load::<TebConfig>`.
//! Knows nothing of the bus or of the map.

use aisle_config::checks::{non_negative, positive};
use aisle_config::{InvalidKey, Validate};
use aisle_geometry::Direction;
use serde::Deserialize;
use std::f64::consts::PI;

/// Kinematic limits of the differential-drive base.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct LimitsConfig {
    /// Forward speed limit, m/s.
    pub max_velocity: f64,
    /// Reverse speed limit, m/s (MATLAB: NaN means "same as forward").
    pub max_reverse_velocity: f64,
    /// Turn rate limit, rad/s.
    pub max_angular_velocity: f64,
    /// Linear acceleration limit, m/s^2.
    pub max_acceleration: f64,
    /// Angular acceleration limit, rad/s^2.
    pub max_angular_acceleration: f64,
    /// Smallest turning radius, m; 0 lets a differential drive turn on the spot.
    pub min_turning_radius: f64,
}

impl Default for LimitsConfig {
    fn default() -> Self {
        Self {
            max_velocity: 2.0,
            max_reverse_velocity: 2.0,
            max_angular_velocity: 1.0,
            max_acceleration: 2.4,
            max_angular_acceleration: 4.8,
            min_turning_radius: 0.0,
        }
    }
}

/// Horizon and band resolution.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct BandConfig {
    /// Look-ahead time, s: the band ends where the reference is
    /// `max_velocity * look_ahead_time` metres ahead of the robot (or at the goal).
    pub look_ahead_time: f64,
    /// Preferred time step between band poses, s.
    pub dt_ref: f64,
    /// Hysteresis around `dt_ref` before a segment is split or merged, s.
    pub dt_hysteresis: f64,
    /// The band keeps `dt_ref` for this many seconds from the robot; beyond, the
    /// reference step grows in proportion to the time from the robot
    /// ([`crate::Steps`]). 0: `dt_ref` along the whole band.
    pub fine_time: f64,
    /// Smallest time step the optimiser may choose, s (keeps timestamps increasing).
    pub min_dt: f64,
    /// Fewest and most poses in the band (the start pose included).
    pub min_poses: usize,
    pub max_poses: usize,
    /// Goal tolerance in the goal's frame: along, across (m) and heading (rad).
    pub goal_tolerance: [f64; 3],
    /// A warm band is dropped and rebuilt when the robot is farther than this from the
    /// band's first pose, m.
    pub reinit_distance: f64,
}

impl BandConfig {
    /// The reference steps along the band (`fine_time` 0: uniform).
    pub fn steps(&self) -> crate::steps::Steps {
        crate::steps::Steps {
            dt_ref: self.dt_ref,
            hysteresis: self.dt_hysteresis,
            fine_time: self.fine_time,
        }
    }
}

impl Default for BandConfig {
    fn default() -> Self {
        Self {
            look_ahead_time: 3.0,
            dt_ref: 0.3,
            dt_hysteresis: 0.1,
            fine_time: 1.5,
            min_dt: 0.02,
            min_poses: 3,
            max_poses: 60,
            goal_tolerance: [0.2, 0.2, 0.2],
            reinit_distance: 1.0,
        }
    }
}

/// Cost weights. Time is in seconds, so every other weight reads as "seconds of travel
/// worth one unit of this term".
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct WeightsConfig {
    /// Per second of total band time (the minimum-time objective).
    pub time: f64,
    /// Per square metre of distance from a band pose to the reference path.
    pub reference: f64,
    /// Per square radian of heading second difference along the band.
    pub smoothness: f64,
    /// Per metre (or radian) the band's end misses the local goal. Must exceed the time
    /// a slow robot needs per metre, or the band stops short.
    pub goal: f64,
    /// Per unit violation of a linearised constraint (kinematics, acceleration,
    /// clearance, drive direction). An exact L1 penalty: large enough that violations
    /// vanish whenever the constraints can be met.
    pub constraint: f64,
}

impl Default for WeightsConfig {
    fn default() -> Self {
        Self {
            time: 1.0,
            reference: 0.5,
            smoothness: 0.2,
            goal: 50.0,
            constraint: 200.0,
        }
    }
}

/// Budget and tuning of the sequential convex programme.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SolverConfig {
    /// Convex subproblems solved per step at most.
    pub max_iterations: usize,
    /// Interior-point iterations per subproblem (clarabel `max_iter`).
    pub max_qp_iterations: u32,
    /// Initial and smallest trust-region half-width on positions, m.
    pub trust_radius: f64,
    pub min_trust_radius: f64,
    /// Trust-region half-width on headings, rad.
    pub trust_heading: f64,
    /// Stop when the predicted merit decrease falls below this.
    pub tolerance: f64,
    /// Also stop when the band meets every constraint and the next subproblem
    /// promises less than this fraction of the merit. The next step starts from this
    /// band anyway (real-time iteration), but the band driven now should be near its
    /// optimum: at 0.005 (8 subproblems) a seed run's steps end p50 0.06 %, p90 3.5 %
    /// above it (at 0.05 and 6, 3.7 % and 20 %).
    pub relative_tolerance: f64,
    /// Obstacle cells this far beyond the margin still produce constraints, m.
    pub obstacle_influence: f64,
    /// Clearance the optimiser keeps beyond the margin, m: a converged band meets its
    /// constraints exactly, and the robot tracks it only to a few centimetres (at speed
    /// and the turn-rate limit), which took it inside what the planner counts as a
    /// collision (a start it could not plan from). The exit flag judges the margin itself.
    pub clearance_allowance: f64,
    /// Position step between footprint checks along the band for the exit flag, m.
    pub check_step: f64,
    /// Proximal weight keeping each subproblem strictly convex.
    pub proximal: f64,
}

impl Default for SolverConfig {
    fn default() -> Self {
        Self {
            max_iterations: 8,
            max_qp_iterations: 40,
            trust_radius: 0.6,
            min_trust_radius: 0.01,
            trust_heading: 0.6,
            tolerance: 1e-3,
            relative_tolerance: 0.005,
            obstacle_influence: 0.6,
            clearance_allowance: 0.02,
            check_step: 0.05,
            proximal: 1e-3,
        }
    }
}

/// Alternative bands around obstacles (homotopy classes).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct HomotopyConfig {
    /// Optimise a second band that passes blocking obstacles on the other side.
    pub enabled: bool,
    /// The current band's cost is multiplied by this when compared with an
    /// alternative, so the choice does not flip on noise.
    pub hysteresis: f64,
}

impl Default for HomotopyConfig {
    fn default() -> Self {
        Self {
            enabled: false,
            hysteresis: 0.9,
        }
    }
}

/// How old the controller's inputs may be. Read by the node adapter (the optimiser
/// itself is handed a pose and a map and never asks their age).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct InputsConfig {
    /// Seconds: a local map or robot state older than this (sim time in lockstep, also
    /// wall time in realtime) is refused and the robot commanded to stop.
    pub max_age: f64,
    /// false: the local map's detected cells (lidar obstacles the static map does not
    /// have) are taken as free, so the controller drives through them. A test switch:
    /// it leaves obstacle avoidance to something else (an external safety monitor).
    pub avoid_detected: bool,
}

impl Default for InputsConfig {
    fn default() -> Self {
        Self {
            max_age: 0.3,
            avoid_detected: true,
        }
    }
}

/// Straight moves along a line ([`crate::Mode::Straight`]: docking under a rack and
/// leaving it). Accelerations are `[limits]`'.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct StraightConfig {
    /// Cruise speed along the line, m/s, forwards and backwards. Also the crawl's: a
    /// step whose optimised band collides drives the reference at this speed instead,
    /// when the robot is no faster and the reference band does not collide.
    pub speed: f64,
    /// Clearance kept between the footprint and occupied cells (taken as squares), m.
    /// Replaces the goal's margin, which is sized for open space and would close the
    /// 0.135 m a robot has on either side between a rack's legs.
    pub margin: f64,
    /// Pure pursuit: distance of the carrot ahead of the robot's projection on the
    /// line, m. Shorter converges sooner and turns harder (a lateral offset decays
    /// about e-fold per this distance driven).
    pub look_ahead: f64,
    /// Heading error from the line above which the robot turns on the spot before it
    /// drives, rad.
    pub turn_first: f64,
    /// Integration step of the rolled-out timeline, s (one command per step).
    pub step: f64,
}

impl Default for StraightConfig {
    fn default() -> Self {
        Self {
            speed: 0.3,
            margin: 0.02,
            look_ahead: 0.3,
            turn_first: 0.35,
            step: 0.02,
        }
    }
}

/// Everything in `config/teb.toml`.
#[derive(Debug, Clone, PartialEq, Deserialize, Default)]
#[serde(deny_unknown_fields, default)]
pub struct TebConfig {
    pub limits: LimitsConfig,
    pub band: BandConfig,
    pub weights: WeightsConfig,
    pub solver: SolverConfig,
    pub homotopy: HomotopyConfig,
    pub inputs: InputsConfig,
    pub straight: StraightConfig,
}

fn bad(key: &str, reason: impl Into<String>) -> InvalidKey {
    InvalidKey::new(key, reason)
}

impl LimitsConfig {
    /// Speed limit when driving in `direction`, m/s (the forward one on the spot).
    pub(crate) fn speed_limit(&self, direction: Direction) -> f64 {
        if direction == Direction::Reverse {
            self.max_reverse_velocity
        } else {
            self.max_velocity
        }
    }
}

impl Validate for TebConfig {
    fn validate(&self) -> Result<(), InvalidKey> {
        let l = &self.limits;
        positive("limits.max_velocity", l.max_velocity)?;
        positive("limits.max_reverse_velocity", l.max_reverse_velocity)?;
        positive("limits.max_angular_velocity", l.max_angular_velocity)?;
        positive("limits.max_acceleration", l.max_acceleration)?;
        positive(
            "limits.max_angular_acceleration",
            l.max_angular_acceleration,
        )?;
        non_negative("limits.min_turning_radius", l.min_turning_radius)?;
        let b = &self.band;
        positive("band.look_ahead_time", b.look_ahead_time)?;
        positive("band.dt_ref", b.dt_ref)?;
        non_negative("band.dt_hysteresis", b.dt_hysteresis)?;
        if b.dt_hysteresis >= b.dt_ref {
            return Err(bad(
                "band.dt_hysteresis",
                "must be smaller than band.dt_ref",
            ));
        }
        non_negative("band.fine_time", b.fine_time)?;
        positive("band.min_dt", b.min_dt)?;
        if b.min_dt >= b.dt_ref - b.dt_hysteresis {
            return Err(bad(
                "band.min_dt",
                "must be below band.dt_ref - band.dt_hysteresis",
            ));
        }
        if b.min_poses < 2 {
            return Err(bad("band.min_poses", "at least 2 poses"));
        }
        // 512 timeline entries hold at most 511 segments plus the final stop.
        if b.max_poses < b.min_poses.max(4) || b.max_poses > 512 {
            return Err(bad(
                "band.max_poses",
                "must lie in [max(min_poses, 4), 512]",
            ));
        }
        for (i, t) in b.goal_tolerance.iter().enumerate() {
            if !(t.is_finite() && *t > 0.0) {
                return Err(bad(
                    "band.goal_tolerance",
                    format!("entry {i} ({t}) is not positive"),
                ));
            }
        }
        positive("band.reinit_distance", b.reinit_distance)?;
        positive("inputs.max_age", self.inputs.max_age)?;
        let w = &self.weights;
        positive("weights.time", w.time)?;
        non_negative("weights.reference", w.reference)?;
        non_negative("weights.smoothness", w.smoothness)?;
        positive("weights.goal", w.goal)?;
        positive("weights.constraint", w.constraint)?;
        let s = &self.solver;
        if s.max_iterations == 0 || s.max_iterations > 100 {
            return Err(bad("solver.max_iterations", "must lie in [1, 100]"));
        }
        if s.max_qp_iterations == 0 {
            return Err(bad("solver.max_qp_iterations", "must be at least 1"));
        }
        positive("solver.trust_radius", s.trust_radius)?;
        positive("solver.min_trust_radius", s.min_trust_radius)?;
        positive("solver.trust_heading", s.trust_heading)?;
        positive("solver.tolerance", s.tolerance)?;
        if !(s.relative_tolerance.is_finite() && (0.0..1.0).contains(&s.relative_tolerance)) {
            return Err(bad("solver.relative_tolerance", "must lie in [0, 1)"));
        }
        non_negative("solver.obstacle_influence", s.obstacle_influence)?;
        non_negative("solver.clearance_allowance", s.clearance_allowance)?;
        positive("solver.check_step", s.check_step)?;
        positive("solver.proximal", s.proximal)?;
        let h = &self.homotopy;
        if !(h.hysteresis.is_finite() && h.hysteresis > 0.0 && h.hysteresis <= 1.0) {
            return Err(bad("homotopy.hysteresis", "must lie in (0, 1]"));
        }
        self.validate_straight()
    }
}

impl TebConfig {
    fn validate_straight(&self) -> Result<(), InvalidKey> {
        let s = &self.straight;
        positive("straight.speed", s.speed)?;
        let limit = self
            .limits
            .max_velocity
            .min(self.limits.max_reverse_velocity);
        if s.speed > limit {
            return Err(bad(
                "straight.speed",
                format!(
                    "{} exceeds limits.max_velocity or limits.max_reverse_velocity ({limit})",
                    s.speed
                ),
            ));
        }
        non_negative("straight.margin", s.margin)?;
        positive("straight.look_ahead", s.look_ahead)?;
        if !(s.turn_first.is_finite() && s.turn_first > 0.0 && s.turn_first <= PI) {
            return Err(bad("straight.turn_first", "must lie in (0, pi]"));
        }
        positive("straight.step", s.step)?;
        // One command per step over the horizon, plus the final stop.
        let steps = self.band.look_ahead_time / s.step;
        if steps > (crate::MAX_COMMANDS - 1) as f64 {
            return Err(bad(
                "straight.step",
                format!(
                    "band.look_ahead_time / straight.step = {steps:.0} commands, at most {}",
                    crate::MAX_COMMANDS - 1
                ),
            ));
        }
        Ok(())
    }

    /// Distance along the reference the band reaches ahead of the robot, m.
    pub fn look_ahead_distance(&self) -> f64 {
        self.limits.max_velocity * self.band.look_ahead_time
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::TebError;

    #[test]
    fn defaults_are_valid_and_bad_values_name_their_key() {
        TebConfig::default().validate().unwrap();
        let mut c = TebConfig::default();
        c.limits.max_velocity = f64::NAN;
        assert_eq!(c.validate().unwrap_err().key, "limits.max_velocity");
        let mut c = TebConfig::default();
        c.solver.relative_tolerance = 1.0;
        assert_eq!(c.validate().unwrap_err().key, "solver.relative_tolerance");
        let mut c = TebConfig::default();
        c.band.dt_hysteresis = 0.5;
        let e = crate::TebController::new(c).err().unwrap();
        assert!(
            matches!(&e, TebError::InvalidConfig(k) if k.key == "band.dt_hysteresis"),
            "{e}"
        );
    }

    #[test]
    fn bad_straight_values_name_their_key() {
        let key = |f: fn(&mut StraightConfig)| {
            let mut c = TebConfig::default();
            f(&mut c.straight);
            c.validate().unwrap_err().key
        };
        assert_eq!(key(|s| s.speed = 0.0), "straight.speed");
        assert_eq!(key(|s| s.speed = 2.5), "straight.speed");
        assert_eq!(key(|s| s.margin = -0.01), "straight.margin");
        assert_eq!(key(|s| s.look_ahead = f64::NAN), "straight.look_ahead");
        assert_eq!(key(|s| s.turn_first = 4.0), "straight.turn_first");
        assert_eq!(key(|s| s.step = 0.001), "straight.step");
        let r = toml::from_str::<TebConfig>("[straight]\nspeed = 0.2\n").unwrap();
        assert_eq!(r.straight.speed, 0.2);
        assert_eq!(r.straight.margin, StraightConfig::default().margin);
    }

    #[test]
    fn shipped_file_equals_defaults() {
        let path = aisle_config::testing::shipped("teb.toml");
        let cfg = aisle_config::load::<TebConfig>(&path).unwrap();
        assert_eq!(cfg, TebConfig::default());
    }

    #[test]
    fn unknown_keys_are_refused() {
        let r = toml::from_str::<TebConfig>("[limits]\nmax_velocty = 2.0\n");
        assert!(r.is_err());
    }
}
