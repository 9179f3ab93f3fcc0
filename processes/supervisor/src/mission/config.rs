//! `mission.toml`: the legs of a mission and its timing, parsed and validated (body
//! names against the scene). Knows nothing of how a mission is driven.

use aisle_config::ConfigError;
use aisle_config::scene::Scene;
use aisle_geometry::Pose2;
use serde::Deserialize;
use std::f64::consts::{PI, TAU};
use std::path::Path;

/// Builds the error for a bad key of the file being loaded.
type Invalid<'a> = dyn Fn(&str, String) -> ConfigError + 'a;

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LegSpec {
    pub name: String,
    /// The goal as the file states it; a leg that approaches a body may leave it out.
    #[serde(rename = "goal")]
    pub goal_given: Option<[f64; 3]>,
    /// The goal the leg drives to (x, y, heading), resolved by [`MissionConfig::load`]:
    /// the stated goal, or the approached body's centre.
    #[serde(skip)]
    pub goal: [f64; 3],
    /// No heading was stated: the planner chooses it (the side a rack is entered from).
    #[serde(skip)]
    pub free_heading: bool,
    #[serde(default)]
    pub rotate: bool,
    pub carry: Option<String>,
    pub approach: Option<String>,
    /// Drive this far straight ahead before heading for the goal (metres): how the
    /// robot leaves from under a rack it has just set down.
    pub depart: Option<f64>,
    /// Speed limits for this leg, [m/s, rad/s]: the lower of these and `teb.toml`'s
    /// `limits` apply (every move of the leg, forwards and backwards).
    pub max_velocity: Option<[f64; 2]>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MissionConfig {
    pub start: [f64; 3],
    pub leg_timeout_s: f64,
    pub max_replans_per_leg: u32,
    pub replan_cooldown_steps: u32,
    /// Sim time a driving leg may go without getting closer to what it drives to before
    /// it counts as stuck and recovers like an infeasible band.
    #[serde(default = "default_stall_timeout")]
    pub stall_timeout_s: f64,
    /// Simulation ticks per second of sim time (the seed: 10 Hz).
    #[serde(default = "default_rate")]
    pub update_rate_hz: f64,
    /// Sim time between controller steps (the seed: 0.5 s).
    #[serde(default = "default_controller_period")]
    pub controller_period_s: f64,
    /// Wall time the supervisor waits for one plan before counting it as failed.
    #[serde(default = "default_planner_timeout")]
    pub planner_timeout_s: f64,
    /// The most the planner may expand for a try to plan with the full margin again
    /// after a leg backed off (`backoff.rs`): the leg drives on with the reduced margin
    /// when the try finds nothing within it.
    #[serde(default = "default_restore_max_expansions")]
    pub restore_max_expansions: u32,
    /// x, y and heading tolerance for a goal to count as reached (the seed: 0.2 m, 0.2 m, 0.2 rad).
    #[serde(default = "default_tolerance")]
    pub goal_tolerance: [f64; 3],
    pub leg: Vec<LegSpec>,
}

/// The longest sim time a leg may take or stall (one day).
const MAX_SIM_SECONDS: f64 = 86_400.0;
/// The longest controller period: far beyond any controller's horizon.
const MAX_CONTROLLER_PERIOD_S: f64 = 60.0;
/// The largest expansion budget of a full-margin try: about a minute of search.
const MAX_RESTORE_EXPANSIONS: u32 = 10_000_000;
/// Most replans per leg, and most steps of cooldown between them.
const MAX_COUNT: u32 = 10_000;
/// The widest position tolerance of a goal (metres): a wider one counts a leg as
/// arrived a robot length or more away from where the file says.
const MAX_TOLERANCE_M: f64 = 2.0;
/// The farthest a position may lie from the map frame's origin (metres): whether it lies
/// on the map is `check`'s question (`mapper.toml`); beyond this it is no position.
const MAX_COORDINATE_M: f64 = 1.0e6;

/// A pose `[x, y, heading]` of the mission file at `key`: finite, a position within
/// [`MAX_COORDINATE_M`] of the origin and a heading within one turn either way.
fn check_pose(key: &str, pose: &[f64; 3], bad: &Invalid) -> Result<(), ConfigError> {
    if !pose.iter().all(|v| v.is_finite()) {
        return Err(bad(key, format!("not finite: {pose:?}")));
    }
    if pose[0].abs() > MAX_COORDINATE_M || pose[1].abs() > MAX_COORDINATE_M {
        return Err(bad(
            key,
            format!(
                "x and y must be within -{MAX_COORDINATE_M}..={MAX_COORDINATE_M} m, got {pose:?}"
            ),
        ));
    }
    // A little over a turn, so that 2 pi written out in decimals still passes.
    if pose[2].abs() > TAU + 1e-9 {
        return Err(bad(
            key,
            format!(
                "the heading must be within -2 pi..=2 pi rad (one turn either way), got {:?}",
                pose[2]
            ),
        ));
    }
    Ok(())
}

fn default_rate() -> f64 {
    10.0
}
fn default_controller_period() -> f64 {
    0.5
}
fn default_planner_timeout() -> f64 {
    5.0
}
fn default_stall_timeout() -> f64 {
    10.0
}
/// Of 16 tries that found the way in three generated halls, 13 took at most 1,628
/// expansions, one 9,706 and two about 310,000; 34 that did not spent 85,000 to 360,000
/// (1 to 3.7 s). 10,000 took 58-313 ms there, over the planner's 200 ms stage budget;
/// 5,000 took 44-167 ms.
fn default_restore_max_expansions() -> u32 {
    5_000
}
fn default_tolerance() -> [f64; 3] {
    [0.2, 0.2, 0.2]
}

impl MissionConfig {
    /// `mission.toml`'s settings without its legs (the start pose, timing and
    /// tolerances, each checked): what a generator keeps when it draws the legs anew
    /// for a scene the file's legs do not fit.
    pub fn load_settings(path: &Path) -> Result<MissionConfig, ConfigError> {
        let (mut cfg, text) = aisle_config::load_toml::<MissionConfig>(path)?;
        let bad = |key: &str, why: String| ConfigError::invalid(path, &text, key, why);
        cfg.check_numbers(&bad)?;
        cfg.leg.clear();
        Ok(cfg)
    }

    /// Loads and validates `mission.toml`; body names are checked against the scene.
    pub fn load(path: &Path, scene: &Scene) -> Result<MissionConfig, ConfigError> {
        let (cfg, text) = aisle_config::load_toml::<MissionConfig>(path)?;
        let bad = |key: &str, why: String| ConfigError::invalid(path, &text, key, why);
        cfg.check_numbers(&bad)?;
        if cfg.leg.is_empty() {
            return Err(bad("leg", "the mission has no legs".into()));
        }
        let mut cfg = cfg;
        for (i, leg) in cfg.leg.iter_mut().enumerate() {
            leg.resolve_goal(i, scene, &bad)?;
            leg.check(i, scene, &bad)?;
        }
        Ok(cfg)
    }

    /// The start pose, the timing and the tolerances; the first error found, in the
    /// order the file documents them. Every number has a range: a finite but absurd
    /// value (a heading of 1e300, a tolerance of a kilometre) is refused here, naming
    /// the key, rather than driven.
    fn check_numbers(&self, bad: &Invalid) -> Result<(), ConfigError> {
        check_pose("start", &self.start, bad)?;
        for (key, v, max) in [
            ("leg_timeout_s", self.leg_timeout_s, MAX_SIM_SECONDS),
            ("stall_timeout_s", self.stall_timeout_s, MAX_SIM_SECONDS),
        ] {
            if !(v.is_finite() && v > 0.0 && v <= max) {
                return Err(bad(
                    key,
                    format!("must be a number of seconds within (0, {max}], got {v:?}"),
                ));
            }
        }
        for (key, v) in [
            ("max_replans_per_leg", self.max_replans_per_leg),
            ("replan_cooldown_steps", self.replan_cooldown_steps),
        ] {
            if v > MAX_COUNT {
                return Err(bad(key, format!("must be at most {MAX_COUNT}, got {v}")));
            }
        }
        if !(self.update_rate_hz.is_finite()
            && self.update_rate_hz >= 1.0
            && self.update_rate_hz <= 1000.0)
        {
            return Err(bad(
                "update_rate_hz",
                format!("must be within 1..=1000 Hz, got {:?}", self.update_rate_hz),
            ));
        }
        let ticks = self.controller_period_s * self.update_rate_hz;
        if !(ticks.is_finite()
            && ticks >= 0.999
            && (ticks - ticks.round()).abs() < 1e-6
            && self.controller_period_s <= MAX_CONTROLLER_PERIOD_S)
        {
            return Err(bad(
                "controller_period_s",
                format!(
                    "must be a whole number (>= 1) of ticks of 1/update_rate_hz, at most \
                     {MAX_CONTROLLER_PERIOD_S} s, got {:?} s",
                    self.controller_period_s
                ),
            ));
        }
        // The request carries whole milliseconds in 32 bits (0 is the planner's default).
        if !(self.planner_timeout_s.is_finite()
            && (0.001..=3600.0).contains(&self.planner_timeout_s))
        {
            return Err(bad(
                "planner_timeout_s",
                format!(
                    "must be within 0.001..=3600 s, got {:?}",
                    self.planner_timeout_s
                ),
            ));
        }
        if !(1..=MAX_RESTORE_EXPANSIONS).contains(&self.restore_max_expansions) {
            return Err(bad(
                "restore_max_expansions",
                format!(
                    "must be within 1..={MAX_RESTORE_EXPANSIONS}, got {}",
                    self.restore_max_expansions
                ),
            ));
        }
        let [tx, ty, th] = self.goal_tolerance;
        let in_range = |v: f64, max: f64| v.is_finite() && v > 0.0 && v <= max;
        if !(in_range(tx, MAX_TOLERANCE_M) && in_range(ty, MAX_TOLERANCE_M) && in_range(th, PI)) {
            return Err(bad(
                "goal_tolerance",
                format!(
                    "must be x and y within (0, {MAX_TOLERANCE_M}] m and a heading within \
                     (0, pi] rad, got {:?}",
                    self.goal_tolerance
                ),
            ));
        }
        Ok(())
    }

    /// Simulated nanoseconds per tick.
    pub fn dt_ns(&self) -> u64 {
        (1e9 / self.update_rate_hz).round() as u64
    }

    /// The controller acts on every n-th tick.
    pub fn controller_every(&self) -> u32 {
        (self.controller_period_s * self.update_rate_hz)
            .round()
            .max(1.0) as u32
    }

    pub fn start_pose(&self) -> Pose2 {
        Pose2::new(self.start[0], self.start[1], self.start[2])
    }
}

impl LegSpec {
    /// Fills [`LegSpec::goal`]: the stated goal, else (an approach leg) the approached
    /// body's centre with the heading left to the planner.
    fn resolve_goal(&mut self, i: usize, scene: &Scene, bad: &Invalid) -> Result<(), ConfigError> {
        if let Some(goal) = self.goal_given {
            self.goal = goal;
            self.free_heading = false;
            return Ok(());
        }
        let body = self.approach.as_deref().and_then(|n| scene.body(n));
        match body {
            Some((_, b)) => {
                self.goal = [b.pose.x, b.pose.y, b.pose.theta];
                self.free_heading = true;
                Ok(())
            }
            None if self.approach.is_some() => Ok(()), // named in `check`
            None => Err(bad(
                &format!("leg[{i}].goal"),
                "missing: only a leg that approaches a body (`approach`) may leave its goal out"
                    .into(),
            )),
        }
    }

    /// Leg `i` (0-based) against the scene: a finite goal, bodies that exist and can
    /// move, and no contradictory options.
    fn check(&self, i: usize, scene: &Scene, bad: &Invalid) -> Result<(), ConfigError> {
        if self.goal_given.is_some() {
            check_pose(&format!("leg[{i}].goal"), &self.goal, bad)?;
        }
        for (key, body) in [("carry", &self.carry), ("approach", &self.approach)] {
            if let Some(name) = body {
                match scene.body(name) {
                    None => {
                        return Err(bad(
                            &format!("leg[{i}].{key}"),
                            format!("no body named `{name}` in the scene"),
                        ));
                    }
                    Some((_, b)) if b.is_static => {
                        return Err(bad(
                            &format!("leg[{i}].{key}"),
                            format!("`{name}` is static and cannot be moved"),
                        ));
                    }
                    _ => {}
                }
            }
        }
        if let Some(d) = self.depart
            && !(d.is_finite() && d > 0.0 && d <= 5.0)
        {
            return Err(bad(
                &format!("leg[{i}].depart"),
                format!("must be within (0, 5] metres, got {d:?}"),
            ));
        }
        if let Some(limit) = self.max_velocity
            && !limit
                .iter()
                .all(|v| v.is_finite() && *v > 0.0 && *v <= 100.0)
        {
            return Err(bad(
                &format!("leg[{i}].max_velocity"),
                format!("must be two speeds within (0, 100] (m/s, rad/s), got {limit:?}"),
            ));
        }
        if self.rotate && self.depart.is_some() {
            return Err(bad(
                &format!("leg[{i}].depart"),
                "a rotate leg does not drive anywhere".into(),
            ));
        }
        if self.rotate && self.carry.is_some() {
            return Err(bad(
                &format!("leg[{i}].rotate"),
                "a rotate leg cannot also carry: carry on the leg after it".into(),
            ));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use aisle_config::testing::shipped;

    /// Loads the shipped mission with `from` replaced by `to`; the error, if any.
    fn load_with(from: &str, to: &str) -> Result<MissionConfig, String> {
        let text = std::fs::read_to_string(shipped("mission.toml")).unwrap();
        let changed = text.replacen(from, to, 1);
        assert!(changed != text, "{from} not in mission.toml");
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("mission.toml");
        std::fs::write(&path, changed).unwrap();
        let scene = Scene::load(&shipped("warehouse.toml")).unwrap();
        MissionConfig::load(&path, &scene).map_err(|e| e.to_string())
    }

    #[test]
    fn every_number_has_a_range_and_an_absurd_one_names_its_key() {
        let pick = "goal = [2.0, 13.0, 1.5707963267948966]";
        for (from, to, key) in [
            (pick, "goal = [2.0, 13.0, 1e300]", "leg[0].goal"),
            (pick, "goal = [2.0, 13.0, -7.0]", "leg[0].goal"),
            (pick, "goal = [1e300, 13.0, 0.0]", "leg[0].goal"),
            (
                "start = [0.0, 0.0, 0.0]",
                "start = [0.0, 0.0, 1e300]",
                "start",
            ),
            (
                "start = [0.0, 0.0, 0.0]",
                "start = [0.0, -2e6, 0.0]",
                "start",
            ),
            (
                "goal_tolerance = [0.2, 0.2, 0.2]",
                "goal_tolerance = [1e300, 0.2, 0.2]",
                "goal_tolerance",
            ),
            (
                "goal_tolerance = [0.2, 0.2, 0.2]",
                "goal_tolerance = [0.2, 0.2, 4.0]",
                "goal_tolerance",
            ),
            (
                "leg_timeout_s = 120.0",
                "leg_timeout_s = 1e300",
                "leg_timeout_s",
            ),
            (
                "stall_timeout_s = 10.0",
                "stall_timeout_s = 1e9",
                "stall_timeout_s",
            ),
            (
                "controller_period_s = 0.5",
                "controller_period_s = 1e12",
                "controller_period_s",
            ),
            (
                "max_replans_per_leg = 12",
                "max_replans_per_leg = 4000000000",
                "max_replans_per_leg",
            ),
            (
                "replan_cooldown_steps = 2",
                "replan_cooldown_steps = 4000000000",
                "replan_cooldown_steps",
            ),
            (
                "restore_max_expansions = 5000",
                "restore_max_expansions = 0",
                "restore_max_expansions",
            ),
            (
                "restore_max_expansions = 5000",
                "restore_max_expansions = 4000000000",
                "restore_max_expansions",
            ),
            (
                "approach = \"rack2b\"",
                "approach = \"rack2b\"\nmax_velocity = [0.0, 1.0]",
                "leg[0].max_velocity",
            ),
            (
                "approach = \"rack2b\"",
                "approach = \"rack2b\"\nmax_velocity = [1.0, nan]",
                "leg[0].max_velocity",
            ),
        ] {
            let e = load_with(from, to).unwrap_err();
            assert!(
                e.contains("mission.toml:") && e.contains(&format!("key `{key}`")),
                "{to}: {e}"
            );
        }
        let slow = load_with(
            "approach = \"rack2b\"",
            "approach = \"rack2b\"\nmax_velocity = [0.5, 0.4]",
        )
        .unwrap();
        assert_eq!(slow.leg[0].max_velocity, Some([0.5, 0.4]));
        // A heading written as a full turn, and the widest tolerances, still load.
        load_with(
            "goal = [6.0, 8.0, 1.5707963267948966]",
            "goal = [6.0, 8.0, 6.283185307179586]",
        )
        .unwrap();
        load_with(
            "goal_tolerance = [0.2, 0.2, 0.2]",
            "goal_tolerance = [2.0, 2.0, 3.141592653589793]",
        )
        .unwrap();
    }
}
