//! `mission.toml`: the legs of a mission and its timing, parsed and validated (body
//! names against the scene). Knows nothing of how a mission is driven.

use aisle_config::ConfigError;
use aisle_config::scene::Scene;
use aisle_geometry::Pose2;
use serde::Deserialize;
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
    /// x, y and heading tolerance for a goal to count as reached (the seed: 0.2 m, 0.2 m, 0.2 rad).
    #[serde(default = "default_tolerance")]
    pub goal_tolerance: [f64; 3],
    pub leg: Vec<LegSpec>,
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
fn default_tolerance() -> [f64; 3] {
    [0.2, 0.2, 0.2]
}

impl MissionConfig {
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
    /// order the file documents them.
    fn check_numbers(&self, bad: &Invalid) -> Result<(), ConfigError> {
        if !self.start.iter().all(|v| v.is_finite()) {
            return Err(bad("start", format!("not finite: {:?}", self.start)));
        }
        if !(self.leg_timeout_s.is_finite() && self.leg_timeout_s > 0.0) {
            return Err(bad(
                "leg_timeout_s",
                format!(
                    "must be a positive number of seconds, got {}",
                    self.leg_timeout_s
                ),
            ));
        }
        if !(self.stall_timeout_s.is_finite() && self.stall_timeout_s > 0.0) {
            return Err(bad(
                "stall_timeout_s",
                format!(
                    "must be a positive number of seconds, got {}",
                    self.stall_timeout_s
                ),
            ));
        }
        if !(self.update_rate_hz.is_finite()
            && self.update_rate_hz >= 1.0
            && self.update_rate_hz <= 1000.0)
        {
            return Err(bad(
                "update_rate_hz",
                format!("must be within 1..=1000 Hz, got {}", self.update_rate_hz),
            ));
        }
        let ticks = self.controller_period_s * self.update_rate_hz;
        if !(ticks.is_finite() && ticks >= 0.999 && (ticks - ticks.round()).abs() < 1e-6) {
            return Err(bad(
                "controller_period_s",
                format!(
                    "must be a whole number (>= 1) of ticks of 1/update_rate_hz, got {} s",
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
                    "must be within 0.001..=3600 s, got {}",
                    self.planner_timeout_s
                ),
            ));
        }
        if !self
            .goal_tolerance
            .iter()
            .all(|v| v.is_finite() && *v > 0.0)
        {
            return Err(bad(
                "goal_tolerance",
                format!(
                    "must be three positive numbers, got {:?}",
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
        if !self.goal.iter().all(|v| v.is_finite()) {
            return Err(bad(
                &format!("leg[{i}].goal"),
                format!("not finite: {:?}", self.goal),
            ));
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
                format!("must be within (0, 5] metres, got {d}"),
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
