//! Mission sequencing, following the seed's loop: per leg choose the footprint and
//! margin, ask for a reference path, hand the controller its goal, attach or detach the
//! rack, rotate in place where the mission says so, and recover by replanning when the
//! controller reports an infeasible band.
//!
//! A pure state machine: it is fed events (plan results, controller reports, time) and
//! answers with [`Action`]s. It knows nothing of the bus, of clocks or of processes, so
//! every rule here is unit-tested without launching anything.

use aisle_config::ConfigError;
use aisle_geometry::{Footprint, PathPose, Pose2};
use serde::Deserialize;
use std::path::Path;

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LegSpec {
    pub name: String,
    pub goal: [f64; 3],
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
fn default_tolerance() -> [f64; 3] {
    [0.2, 0.2, 0.2]
}

impl MissionConfig {
    /// Loads and validates `mission.toml`; body names are checked against the scene.
    pub fn load(
        path: &Path,
        scene: &aisle_config::scene::Scene,
    ) -> Result<MissionConfig, ConfigError> {
        let (cfg, text) = aisle_config::load_toml::<MissionConfig>(path)?;
        let bad = |key: &str, why: String| ConfigError::invalid(path, &text, key, why);
        if !cfg.start.iter().all(|v| v.is_finite()) {
            return Err(bad("start", format!("not finite: {:?}", cfg.start)));
        }
        if !(cfg.leg_timeout_s.is_finite() && cfg.leg_timeout_s > 0.0) {
            return Err(bad(
                "leg_timeout_s",
                format!(
                    "must be a positive number of seconds, got {}",
                    cfg.leg_timeout_s
                ),
            ));
        }
        if !(cfg.update_rate_hz.is_finite()
            && cfg.update_rate_hz >= 1.0
            && cfg.update_rate_hz <= 1000.0)
        {
            return Err(bad(
                "update_rate_hz",
                format!("must be within 1..=1000 Hz, got {}", cfg.update_rate_hz),
            ));
        }
        let ticks = cfg.controller_period_s * cfg.update_rate_hz;
        if !(ticks.is_finite() && ticks >= 0.999 && (ticks - ticks.round()).abs() < 1e-6) {
            return Err(bad(
                "controller_period_s",
                format!(
                    "must be a whole number (>= 1) of ticks of 1/update_rate_hz, got {} s",
                    cfg.controller_period_s
                ),
            ));
        }
        if !(cfg.planner_timeout_s.is_finite() && cfg.planner_timeout_s > 0.0) {
            return Err(bad(
                "planner_timeout_s",
                format!(
                    "must be a positive number of seconds, got {}",
                    cfg.planner_timeout_s
                ),
            ));
        }
        if !cfg.goal_tolerance.iter().all(|v| v.is_finite() && *v > 0.0) {
            return Err(bad(
                "goal_tolerance",
                format!(
                    "must be three positive numbers, got {:?}",
                    cfg.goal_tolerance
                ),
            ));
        }
        if cfg.leg.is_empty() {
            return Err(bad("leg", "the mission has no legs".into()));
        }
        for (i, leg) in cfg.leg.iter().enumerate() {
            if !leg.goal.iter().all(|v| v.is_finite()) {
                return Err(bad(
                    &format!("leg[{i}].goal"),
                    format!("not finite: {:?}", leg.goal),
                ));
            }
            for (key, body) in [("carry", &leg.carry), ("approach", &leg.approach)] {
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
            if let Some(d) = leg.depart
                && !(d.is_finite() && d > 0.0 && d <= 5.0)
            {
                return Err(bad(
                    &format!("leg[{i}].depart"),
                    format!("must be within (0, 5] metres, got {d}"),
                ));
            }
            if leg.rotate && leg.depart.is_some() {
                return Err(bad(
                    &format!("leg[{i}].depart"),
                    "a rotate leg does not drive anywhere".into(),
                ));
            }
            if leg.rotate && leg.carry.is_some() {
                return Err(bad(
                    &format!("leg[{i}].rotate"),
                    "a rotate leg cannot also carry: carry on the leg after it".into(),
                ));
            }
        }
        Ok(cfg)
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

/// Footprint and safety margin with and without the carried rack.
#[derive(Debug, Clone, Copy)]
pub struct Footprints {
    pub alone: Footprint,
    pub alone_margin: f64,
    pub carrying: Footprint,
    pub carrying_margin: f64,
}

/// Where a body the mission names stands (from the scene), for the mapper's ignore list.
#[derive(Debug, Clone)]
pub struct NamedBody {
    pub name: String,
    pub pose: Pose2,
    pub footprint: Footprint,
}

/// What the supervisor should do.
#[derive(Debug, Clone, PartialEq)]
pub enum Action {
    Plan {
        start: Pose2,
        goal: Pose2,
        footprint: Footprint,
        margin: f64,
        use_detections: bool,
    },
    Follow {
        reference: Vec<PathPose>,
        goal: Pose2,
        footprint: Footprint,
        margin: f64,
    },
    Rotate {
        goal: Pose2,
        footprint: Footprint,
        margin: f64,
    },
    Attach(String),
    Detach,
    /// The mapper's ignore rectangle (map frame) and carried rectangle (robot frame).
    MapperControl {
        ignore: Option<(Pose2, Footprint)>,
        carried: Option<Footprint>,
    },
    /// Stop the robot and the controller: the mission ended.
    Halt,
}

/// Why a plan request failed, in the planner's words.
#[derive(Debug, Clone, PartialEq)]
pub struct PlanFailure(pub String);

/// The controller's report for the current goal.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ControllerReport {
    pub reached_goal: bool,
    pub exit_flag: u32,
    pub timestamps_increasing: bool,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Phase {
    Idle,
    Planning,
    Driving,
    Rotating,
    Succeeded,
    Failed,
}

/// Per-leg outcome for reports.
#[derive(Debug, Clone, serde::Serialize)]
pub struct LegResult {
    pub name: String,
    pub reached: bool,
    pub start_s: f64,
    pub end_s: f64,
    pub replans: u32,
    pub plan_failures: u32,
    pub final_error_m: f64,
    pub final_heading_error_rad: f64,
}

pub struct Mission {
    cfg: MissionConfig,
    footprints: Footprints,
    bodies: Vec<NamedBody>,
    leg: usize,
    phase: Phase,
    leg_start_s: f64,
    replans: u32,
    plan_failures: u32,
    cooldown: u32,
    carrying: bool,
    /// Where the last carried body was set down (the robot leaves from under it).
    dropped: Option<(Pose2, Footprint)>,
    /// While set, the leg is on its straight departure to this pose.
    departure: Option<Pose2>,
    /// The controller has a reference path for the current leg.
    has_reference: bool,
    failure: Option<String>,
    pub results: Vec<LegResult>,
    pub reference_paths: Vec<(usize, Vec<PathPose>)>,
}

impl Mission {
    pub fn new(cfg: MissionConfig, footprints: Footprints, bodies: Vec<NamedBody>) -> Mission {
        Mission {
            cfg,
            footprints,
            bodies,
            leg: 0,
            phase: Phase::Idle,
            leg_start_s: 0.0,
            replans: 0,
            plan_failures: 0,
            cooldown: 0,
            carrying: false,
            dropped: None,
            departure: None,
            has_reference: false,
            failure: None,
            results: Vec::new(),
            reference_paths: Vec::new(),
        }
    }

    pub fn leg_index(&self) -> usize {
        self.leg
    }

    pub fn leg_count(&self) -> usize {
        self.cfg.leg.len()
    }

    pub fn leg_name(&self) -> &str {
        self.cfg.leg.get(self.leg).map_or("", |l| l.name.as_str())
    }

    pub fn replans_total(&self) -> u32 {
        self.results.iter().map(|r| r.replans).sum::<u32>()
            + if self.is_finished() { 0 } else { self.replans }
    }

    pub fn is_finished(&self) -> bool {
        matches!(self.phase, Phase::Succeeded | Phase::Failed)
    }

    pub fn succeeded(&self) -> bool {
        self.phase == Phase::Succeeded
    }

    pub fn failure(&self) -> Option<&str> {
        self.failure.as_deref()
    }

    pub fn is_planning(&self) -> bool {
        self.phase == Phase::Planning
    }

    pub fn is_rotating(&self) -> bool {
        self.phase == Phase::Rotating
    }

    fn spec(&self) -> &LegSpec {
        &self.cfg.leg[self.leg]
    }

    fn goal(&self) -> Pose2 {
        if let Some(d) = self.departure {
            return d;
        }
        let g = self.spec().goal;
        Pose2::new(g[0], g[1], g[2])
    }

    fn footprint(&self) -> (Footprint, f64) {
        if self.carrying {
            (self.footprints.carrying, self.footprints.carrying_margin)
        } else {
            (self.footprints.alone, self.footprints.alone_margin)
        }
    }

    fn body(&self, name: &str) -> Option<&NamedBody> {
        self.bodies.iter().find(|b| b.name == name)
    }

    fn mapper_control(&self) -> Action {
        let ignore = self
            .spec()
            .approach
            .as_deref()
            .and_then(|n| self.body(n))
            .map(|b| (b.pose, b.footprint))
            .or(self.dropped);
        let carried = if self.carrying {
            self.spec()
                .carry
                .as_deref()
                .and_then(|n| self.body(n))
                .map(|b| b.footprint)
        } else {
            None
        };
        Action::MapperControl { ignore, carried }
    }

    /// Begins the current leg at sim time `now_s` from `pose`.
    pub fn start_leg(&mut self, now_s: f64, pose: Pose2) -> Vec<Action> {
        self.leg_start_s = now_s;
        self.replans = 0;
        self.plan_failures = 0;
        self.cooldown = 0;
        self.has_reference = false;
        let mut actions = Vec::new();
        if let Some(body) = self.spec().carry.clone() {
            self.carrying = true;
            actions.push(Action::Attach(body));
        }
        actions.push(self.mapper_control());
        let (footprint, margin) = self.footprint();
        if self.spec().rotate {
            self.phase = Phase::Rotating;
            actions.push(Action::Rotate {
                goal: self.goal(),
                footprint,
                margin,
            });
        } else {
            self.phase = Phase::Planning;
            self.departure = self
                .spec()
                .depart
                .map(|d| pose.compose(&Pose2::new(d, 0.0, 0.0)));
            // As in the seed, the first reference path of a leg is planned on the static
            // map; replans use the lidar detections too.
            actions.push(Action::Plan {
                start: pose,
                goal: self.goal(),
                footprint,
                margin,
                use_detections: false,
            });
        }
        actions
    }

    /// The planner answered.
    pub fn on_plan(
        &mut self,
        now_s: f64,
        pose: Pose2,
        result: Result<Vec<PathPose>, PlanFailure>,
    ) -> Vec<Action> {
        if self.phase != Phase::Planning {
            return Vec::new();
        }
        let (footprint, margin) = self.footprint();
        match result {
            Ok(reference) => {
                self.phase = Phase::Driving;
                self.has_reference = true;
                self.reference_paths.push((self.leg, reference.clone()));
                vec![Action::Follow {
                    reference,
                    goal: self.goal(),
                    footprint,
                    margin,
                }]
            }
            Err(PlanFailure(why)) => {
                self.plan_failures += 1;
                // Without any reference the controller has nothing to drive: a first plan
                // that fails (start or goal occupied, no path) ends the mission.
                if !self.has_reference
                    || self.replans + self.plan_failures > self.cfg.max_replans_per_leg
                {
                    self.fail(
                        now_s,
                        pose,
                        format!(
                            "leg {} `{}`: no reference path: {why}",
                            self.leg + 1,
                            self.leg_name()
                        ),
                    )
                } else {
                    // Keep the previous reference (the controller still has it) and retry later.
                    self.phase = Phase::Driving;
                    self.cooldown = self.cfg.replan_cooldown_steps;
                    Vec::new()
                }
            }
        }
    }

    /// The controller reported on the current goal (once per controller step).
    pub fn on_controller(
        &mut self,
        now_s: f64,
        pose: Pose2,
        report: ControllerReport,
    ) -> Vec<Action> {
        match self.phase {
            Phase::Driving | Phase::Rotating => {}
            _ => return Vec::new(),
        }
        if report.reached_goal && self.departure.is_some() {
            // Out from under: now the leg proper, from here.
            self.departure = None;
            self.phase = Phase::Planning;
            self.has_reference = false;
            let (footprint, margin) = self.footprint();
            return vec![Action::Plan {
                start: pose,
                goal: self.goal(),
                footprint,
                margin,
                use_detections: false,
            }];
        }
        if report.reached_goal {
            return self.finish_leg(now_s, pose);
        }
        if self.phase == Phase::Driving {
            // After a replan the controller gets `replan_cooldown_steps` steps on the new
            // reference before its reports can start another one.
            if self.cooldown > 0 {
                self.cooldown -= 1;
                return Vec::new();
            }
            // MATLAB's flags 1-5 mean the band cannot be driven as it is: replan. Flag 6
            // (aisle's own: an acceleration over its limit that slowing down could not
            // remove) is driven all the same, and a new reference would not change it.
            let infeasible = (1..=5).contains(&report.exit_flag) || !report.timestamps_increasing;
            if report.exit_flag == 6 {
                tracing::warn!(
                    "t = {now_s:.1} s: the controller's band exceeds an acceleration limit (exit flag 6)"
                );
            }
            if infeasible {
                self.replans += 1;
                if self.replans + self.plan_failures > self.cfg.max_replans_per_leg {
                    return self.fail(
                        now_s,
                        pose,
                        format!(
                            "leg {} `{}`: the controller stayed infeasible (exit flag {}) after {} replans",
                            self.leg + 1,
                            self.leg_name(),
                            report.exit_flag,
                            self.replans - 1
                        ),
                    );
                }
                self.phase = Phase::Planning;
                self.cooldown = self.cfg.replan_cooldown_steps;
                let (footprint, margin) = self.footprint();
                return vec![Action::Plan {
                    start: pose,
                    goal: self.goal(),
                    footprint,
                    margin,
                    use_detections: true,
                }];
            }
        }
        Vec::new()
    }

    /// Called every tick: enforces the leg timeout.
    pub fn on_tick(&mut self, now_s: f64, pose: Pose2) -> Vec<Action> {
        if !self.is_finished()
            && self.phase != Phase::Idle
            && now_s - self.leg_start_s > self.cfg.leg_timeout_s
        {
            let why = format!(
                "leg {} `{}`: not reached within {} s of sim time",
                self.leg + 1,
                self.leg_name(),
                self.cfg.leg_timeout_s
            );
            return self.fail(now_s, pose, why);
        }
        Vec::new()
    }

    fn record(&mut self, now_s: f64, pose: Pose2, reached: bool) {
        let goal = self.goal();
        self.results.push(LegResult {
            name: self.leg_name().to_string(),
            reached,
            start_s: self.leg_start_s,
            end_s: now_s,
            replans: self.replans,
            plan_failures: self.plan_failures,
            final_error_m: pose.distance(&goal),
            final_heading_error_rad: pose.heading_error(&goal),
        });
    }

    fn finish_leg(&mut self, now_s: f64, pose: Pose2) -> Vec<Action> {
        self.record(now_s, pose, true);
        let mut actions = Vec::new();
        if self.carrying {
            self.carrying = false;
            // The body stays where the robot stands, which the robot then drives out
            // from under: tell the mapper that its legs are not obstacles there.
            let footprint = self
                .spec()
                .carry
                .as_deref()
                .and_then(|n| self.body(n))
                .map(|b| b.footprint);
            self.dropped = footprint.map(|f| (pose, f));
            actions.push(Action::Detach);
        }
        self.leg += 1;
        if self.leg == self.cfg.leg.len() {
            self.phase = Phase::Succeeded;
            self.leg -= 1;
            actions.push(Action::MapperControl {
                ignore: None,
                carried: None,
            });
            actions.push(Action::Halt);
            return actions;
        }
        actions.extend(self.start_leg(now_s, pose));
        actions
    }

    fn fail(&mut self, now_s: f64, pose: Pose2, why: String) -> Vec<Action> {
        self.record(now_s, pose, false);
        self.phase = Phase::Failed;
        self.failure = Some(why);
        vec![Action::Halt]
    }

    /// Ends the mission from outside (a stop request or a dead process).
    pub fn abort(&mut self, now_s: f64, pose: Pose2, why: String) -> Vec<Action> {
        if self.is_finished() {
            return Vec::new();
        }
        self.fail(now_s, pose, why)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use aisle_geometry::Direction;

    fn mission() -> Mission {
        let cfg = MissionConfig {
            start: [0.0; 3],
            leg_timeout_s: 100.0,
            max_replans_per_leg: 2,
            replan_cooldown_steps: 1,
            update_rate_hz: 10.0,
            controller_period_s: 0.5,
            planner_timeout_s: 5.0,
            goal_tolerance: [0.2; 3],
            leg: vec![
                LegSpec {
                    name: "a".into(),
                    goal: [1.0, 0.0, 0.0],
                    rotate: false,
                    carry: None,
                    approach: Some("rack".into()),
                    depart: None,
                },
                LegSpec {
                    name: "b".into(),
                    goal: [1.0, 0.0, 3.0],
                    rotate: true,
                    carry: None,
                    approach: None,
                    depart: None,
                },
                LegSpec {
                    name: "c".into(),
                    goal: [2.0, 0.0, 0.0],
                    rotate: false,
                    carry: Some("rack".into()),
                    approach: None,
                    depart: None,
                },
            ],
        };
        let fp = Footprints {
            alone: Footprint::new(0.5, 0.4),
            alone_margin: 0.1,
            carrying: Footprint::new(0.9, 0.8),
            carrying_margin: 0.4,
        };
        let bodies = vec![NamedBody {
            name: "rack".into(),
            pose: Pose2::new(1.0, 0.0, 0.0),
            footprint: Footprint::new(0.88, 0.8),
        }];
        Mission::new(cfg, fp, bodies)
    }

    fn path() -> Vec<PathPose> {
        vec![PathPose::new(Pose2::default(), Direction::Forward)]
    }

    const OK: ControllerReport = ControllerReport {
        reached_goal: false,
        exit_flag: 0,
        timestamps_increasing: true,
    };
    const REACHED: ControllerReport = ControllerReport {
        reached_goal: true,
        exit_flag: 0,
        timestamps_increasing: true,
    };

    #[test]
    fn the_seed_sequence_plans_rotates_attaches_and_detaches() {
        let mut m = mission();
        let p = Pose2::default();
        let a = m.start_leg(0.0, p);
        assert!(matches!(
            a[0],
            Action::MapperControl {
                ignore: Some(_),
                carried: None
            }
        ));
        assert!(
            matches!(a[1], Action::Plan { use_detections: false, margin, .. } if margin == 0.1)
        );
        assert!(matches!(
            m.on_plan(0.0, p, Ok(path()))[0],
            Action::Follow { .. }
        ));
        assert!(m.on_controller(1.0, p, OK).is_empty());
        let a = m.on_controller(2.0, p, REACHED);
        assert!(
            a.iter().any(|x| matches!(x, Action::Rotate { .. })),
            "{a:?}"
        );
        let a = m.on_controller(3.0, p, REACHED);
        assert_eq!(a[0], Action::Attach("rack".into()));
        assert!(matches!(
            a[1],
            Action::MapperControl {
                ignore: None,
                carried: Some(_)
            }
        ));
        assert!(matches!(a[2], Action::Plan { margin, .. } if margin == 0.4));
        m.on_plan(3.0, p, Ok(path()));
        let a = m.on_controller(9.0, p, REACHED);
        assert_eq!(a[0], Action::Detach);
        assert_eq!(*a.last().unwrap(), Action::Halt);
        assert!(m.succeeded());
        assert_eq!(m.results.len(), 3);
    }

    #[test]
    fn infeasible_bands_replan_with_detections_then_fail_with_a_reason() {
        let mut m = mission();
        let p = Pose2::default();
        m.start_leg(0.0, p);
        m.on_plan(0.0, p, Ok(path()));
        let bad = ControllerReport {
            reached_goal: false,
            exit_flag: 1,
            timestamps_increasing: true,
        };
        let a = m.on_controller(1.0, p, bad);
        assert!(matches!(
            a[0],
            Action::Plan {
                use_detections: true,
                ..
            }
        ));
        m.on_plan(1.0, p, Ok(path()));
        // Cooldown: the next infeasible report does not replan at once.
        assert!(m.on_controller(1.5, p, bad).is_empty());
        let a = m.on_controller(
            2.0,
            p,
            ControllerReport {
                timestamps_increasing: false,
                exit_flag: 0,
                reached_goal: false,
            },
        );
        assert!(matches!(a[0], Action::Plan { .. }));
        m.on_plan(2.0, p, Ok(path()));
        m.on_controller(2.5, p, bad);
        let a = m.on_controller(3.0, p, bad);
        assert_eq!(a, vec![Action::Halt]);
        assert!(
            m.failure().unwrap().contains("infeasible"),
            "{:?}",
            m.failure()
        );
    }

    #[test]
    fn an_acceleration_flag_is_driven_not_replanned() {
        let mut m = mission();
        let p = Pose2::default();
        m.start_leg(0.0, p);
        m.on_plan(0.0, p, Ok(path()));
        let hard = ControllerReport {
            reached_goal: false,
            exit_flag: 6,
            timestamps_increasing: true,
        };
        for k in 0..10 {
            assert!(m.on_controller(1.0 + f64::from(k), p, hard).is_empty());
        }
        assert!(m.failure().is_none());
    }

    #[test]
    fn an_unreachable_goal_fails_the_mission() {
        let mut m = mission();
        let p = Pose2::default();
        m.start_leg(0.0, p);
        let a = m.on_plan(0.0, p, Err(PlanFailure("goal occupied".into())));
        assert_eq!(a, vec![Action::Halt]);
        assert!(m.failure().unwrap().contains("goal occupied"));
    }

    #[test]
    fn a_failed_replan_keeps_the_old_reference_and_retries() {
        let mut m = mission();
        let p = Pose2::default();
        m.start_leg(0.0, p);
        m.on_plan(0.0, p, Ok(path()));
        let bad = ControllerReport {
            reached_goal: false,
            exit_flag: 1,
            timestamps_increasing: true,
        };
        m.on_controller(0.5, p, bad);
        assert!(
            m.on_plan(0.5, p, Err(PlanFailure("no path".into())))
                .is_empty()
        );
        assert!(!m.is_finished());
        m.on_controller(1.0, p, bad);
        let a = m.on_controller(1.5, p, bad);
        assert!(a.is_empty() || matches!(a[0], Action::Halt), "{a:?}");
    }

    #[test]
    fn a_leg_that_takes_too_long_fails() {
        let mut m = mission();
        let p = Pose2::default();
        m.start_leg(0.0, p);
        assert!(m.on_tick(50.0, p).is_empty());
        assert_eq!(m.on_tick(100.5, p), vec![Action::Halt]);
        assert!(m.failure().unwrap().contains("not reached within"));
    }

    #[test]
    fn a_departing_leg_drives_straight_out_first_then_plans_the_leg() {
        let mut m = mission();
        m.cfg.leg[2].depart = Some(1.2);
        let p = Pose2::default();
        m.start_leg(0.0, p);
        m.on_plan(0.0, p, Ok(path()));
        m.on_controller(1.0, p, REACHED);
        let at = Pose2::new(1.0, 0.0, 0.5);
        let a = m.on_controller(2.0, at, REACHED);
        // Leg c carries; its first motion is the straight departure.
        let Some(Action::Plan { goal, .. }) = a.iter().find(|x| matches!(x, Action::Plan { .. }))
        else {
            panic!("{a:?}")
        };
        assert!(
            (goal.x - (1.0 + 1.2 * 0.5f64.cos())).abs() < 1e-12
                && (goal.y - 1.2 * 0.5f64.sin()).abs() < 1e-12
        );
        assert_eq!(goal.theta, 0.5);
        m.on_plan(3.0, at, Ok(path()));
        let out = Pose2::new(2.0, 0.5, 0.5);
        let a = m.on_controller(4.0, out, REACHED);
        assert_eq!(a.len(), 1);
        let Action::Plan {
            start,
            goal,
            use_detections,
            ..
        } = a[0]
        else {
            panic!("{a:?}")
        };
        assert_eq!(
            (start, goal, use_detections),
            (out, Pose2::new(2.0, 0.0, 0.0), false)
        );
        assert!(!m.is_finished());
        assert_eq!(m.results.len(), 2, "the departure is part of the leg");
    }
}
