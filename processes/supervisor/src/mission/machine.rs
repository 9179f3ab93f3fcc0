//! The mission state machine, following the seed's loop: per leg choose the footprint
//! and margin, ask for a reference path, hand the controller its goal, attach or detach
//! the rack, rotate in place where the mission says so, and recover by replanning when
//! the controller reports an infeasible band.
//!
//! Pure: it is fed events (plan results, controller reports, time) and answers with
//! [`Action`]s. It knows nothing of the bus, of clocks or of processes.

use super::config::{LegSpec, MissionConfig};
use super::events::{Action, ControllerReport, DockBody, LegResult, PlanFailure, Planned};
use aisle_geometry::{Footprint, PathPose, Pose2};

/// The smallest fraction of the margin a backing-off plan keeps (a halving, then 3/8).
const MIN_MARGIN_SCALE: f64 = 0.375;
/// The smallest margin, m, a backing-off plan keeps. It bounds how close a
/// reduced-margin plan takes the robot to what its lidar saw, and what the lidar saw is
/// not all there is: an EUR pallet's 0.144 m base, below the lowest ray, sticks out
/// 0.1 m beyond its load. So 0.15 m, the overhang and half a map cell. Sweeps drove into
/// such bases with less: carrying a rack with a quarter of its 0.4 m margin (seed 7
/// `093-gap`), and alone with half of its 0.1 m (seed 29 `165-gap`, at 2 m/s). A load
/// whose full margin is no more than this (the robot alone, 0.1 m) never backs off.
const MIN_BACKED_OFF_MARGIN: f64 = 0.15;

/// Footprint and safety margin with and without the carried rack.
#[derive(Debug, Clone, Copy)]
pub struct Footprints {
    pub alone: Footprint,
    pub alone_margin: f64,
    pub carrying: Footprint,
    pub carrying_margin: f64,
    /// Height of the robot's collision body, m: parts of a body lower than this are
    /// what it can hit when it drives under the body.
    pub height: f64,
}

/// Where a body the mission names stands (from the scene), for the mapper's ignore list.
#[derive(Debug, Clone)]
pub struct NamedBody {
    pub name: String,
    pub pose: Pose2,
    pub footprint: Footprint,
    /// The parts the robot can hit when it drives under the body (body frame).
    pub parts: Vec<(Pose2, Footprint)>,
}

impl NamedBody {
    /// The body standing at `pose`, in the map frame.
    pub fn placed_at(&self, pose: Pose2) -> DockBody {
        DockBody {
            pose,
            footprint: self.footprint,
            parts: self
                .parts
                .iter()
                .map(|(p, f)| (pose.compose(p), *f))
                .collect(),
        }
    }
}

/// Where a driving leg is, around its straight moves.
#[derive(Debug, Clone, PartialEq)]
enum Stage {
    /// On the reference path (no straight move, or past the one out).
    Path,
    /// On the way to the pose the move under the body starts from; then to `under`.
    ToDock { from: Pose2, under: Pose2 },
    /// Driving straight under the body.
    Docking,
    /// Turning in place under the body to face the side it leaves through; then
    /// straight out to `out`.
    UndockTurn { out: Pose2, rest: Vec<PathPose> },
    /// Driving straight out of the body; then `rest` of the path.
    Undocking { rest: Vec<PathPose> },
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

/// One mission in progress: the current leg, its phase and counters, and what the
/// finished legs left behind (results, reference paths).
pub struct Mission {
    cfg: MissionConfig,
    footprints: Footprints,
    bodies: Vec<NamedBody>,
    leg: usize,
    phase: Phase,
    leg_start_s: f64,
    replans: u32,
    plan_failures: u32,
    margin_backoffs: u32,
    cooldown: u32,
    carrying: bool,
    /// The body the robot stands under (picked up next, or just set down), where it
    /// stands: the next driving leg leaves it straight.
    under: Option<DockBody>,
    /// The carried body's pose relative to the robot (from the pick).
    carried_rel: Option<Pose2>,
    /// Bodies the mission set down, by name, where they stand now.
    placed: Vec<(String, DockBody)>,
    stage: Stage,
    /// Whether the current stage is getting anywhere.
    progress: progress::Progress,
    /// Fraction of the margin the leg's plans keep: below 1 once the leg had to back
    /// out of the margin or squeeze through a gap; back to 1 with the next leg, or
    /// once the robot is clear of the spot (`backoff.rs`).
    margin_scale: f64,
    /// Where the robot began driving a reduced-margin plan (`backoff.rs`).
    backed_off_at: Option<Pose2>,
    /// How far from there the leg next asks for its full margin (`backoff.rs`).
    restore_after_m: f64,
    /// A plan with the full margin again is under way (`backoff.rs`).
    restoring: bool,
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
            margin_backoffs: 0,
            cooldown: 0,
            carrying: false,
            under: None,
            carried_rel: None,
            placed: Vec::new(),
            stage: Stage::Path,
            progress: progress::Progress::default(),
            margin_scale: 1.0,
            backed_off_at: None,
            restore_after_m: backoff::RESTORE_MARGIN_AFTER_M,
            restoring: false,
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

    /// The current leg's speed limits (`max_velocity` of its spec), if it sets them.
    pub fn speed_limit(&self) -> Option<[f64; 2]> {
        self.cfg.leg.get(self.leg).and_then(|l| l.max_velocity)
    }

    fn goal(&self) -> Pose2 {
        self.departure.unwrap_or_else(|| self.leg_goal())
    }

    /// The footprint and margin of the current load (the margin scaled down while
    /// backing off).
    fn footprint(&self) -> (Footprint, f64) {
        // Backing off never goes below MIN_BACKED_OFF_MARGIN: what the lidar cannot see.
        let scaled = |m: f64| backoff::scaled_margin(m, self.margin_scale);
        if self.carrying {
            let margin = scaled(self.footprints.carrying_margin);
            (self.carrying_footprint(), margin)
        } else {
            (self.footprints.alone, scaled(self.footprints.alone_margin))
        }
    }

    fn body(&self, name: &str) -> Option<&NamedBody> {
        self.bodies.iter().find(|b| b.name == name)
    }

    /// Begins the current leg at sim time `now_s` from `pose`.
    pub fn start_leg(&mut self, now_s: f64, pose: Pose2) -> Vec<Action> {
        self.leg_start_s = now_s;
        self.replans = 0;
        self.plan_failures = 0;
        self.margin_backoffs = 0;
        self.cooldown = 0;
        self.has_reference = false;
        self.stage = Stage::Path;
        self.progress.reset(now_s);
        self.reset_margin();
        self.restore_after_m = backoff::RESTORE_MARGIN_AFTER_M;
        self.restoring = false;
        let mut actions = Vec::new();
        if let Some(body) = self.spec().carry.clone() {
            self.begin_carrying(&body, pose);
            actions.push(Action::Attach(body));
        }
        if self.spec().rotate {
            self.phase = Phase::Rotating;
            actions.push(self.mapper_control());
            let (footprint, margin) = self.footprint();
            actions.push(Action::Rotate {
                goal: self.goal(),
                footprint,
                margin,
            });
        } else {
            self.phase = Phase::Planning;
            actions.push(self.mapper_control());
            self.departure = self
                .spec()
                .depart
                .map(|d| pose.compose(&Pose2::new(d, 0.0, 0.0)));
            // As in the seed, the first reference path of a leg is planned on the static
            // map; replans use the lidar detections too. A leg that starts under a body
            // is the exception: its first move, straight out of one side, is committed
            // before any replan could change it, so the side is chosen with what the
            // lidar has seen around the body.
            let undocking = self.under.is_some() && self.departure.is_none();
            actions.push(self.plan_action(pose, undocking));
        }
        actions
    }

    /// The planner answered.
    pub fn on_plan(
        &mut self,
        now_s: f64,
        pose: Pose2,
        result: Result<Planned, PlanFailure>,
    ) -> Vec<Action> {
        if self.phase != Phase::Planning {
            return Vec::new();
        }
        match result {
            Ok(planned) => {
                if self.margin_scale < 1.0 {
                    tracing::info!("t = {now_s:.1} s: backing off with a reduced margin");
                }
                self.note_backed_off(pose);
                self.phase = Phase::Driving;
                self.has_reference = true;
                self.reference_paths.push((self.leg, planned.path.clone()));
                self.drive(planned)
            }
            Err(failure)
                if failure.margin_bound
                    && self.margin_scale > MIN_MARGIN_SCALE
                    && self.footprint().1 > MIN_BACKED_OFF_MARGIN =>
            {
                // Back off rather than give up: plan again with half the margin, so
                // the path leads out of the margin the robot stands in, or through a
                // gap the footprint fits with less of it.
                self.margin_scale = (0.5 * self.margin_scale).max(MIN_MARGIN_SCALE);
                self.margin_backoffs += 1;
                tracing::info!(
                    "t = {now_s:.1} s: {}; planning with {:.0} % of the margin",
                    failure.why,
                    100.0 * self.margin_scale
                );
                vec![self.plan_action(pose, true)]
            }
            Err(PlanFailure { why, .. }) => {
                if let Some(actions) = self.restore_failed(now_s, pose, &why) {
                    return actions;
                }
                // The anchor stays: a reduced-margin plan the controller still drives
                // is replaced once the robot is clear (`backoff.rs`).
                self.margin_scale = 1.0;
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
            self.under = None;
            self.phase = Phase::Planning;
            self.has_reference = false;
            return vec![self.mapper_control(), self.plan_action(pose, false)];
        }
        if report.reached_goal {
            return match self.stage_reached(pose) {
                Some(actions) => actions,
                None if self.at_leg_goal(&pose) => self.finish_leg(now_s, pose),
                None => self.reached_elsewhere(now_s, pose),
            };
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
            let window = self.cfg.stall_timeout_s;
            let stalled = !infeasible
                && self
                    .progress
                    .stalled(now_s, &pose, &self.stage_target(pose), window);
            if report.exit_flag == 6 {
                tracing::warn!(
                    "t = {now_s:.1} s: the controller's band exceeds an acceleration limit (exit flag 6)"
                );
            }
            if infeasible || stalled {
                if self.replan_spends_budget() {
                    let what = if stalled {
                        format!("made no progress for {window} s")
                    } else {
                        format!("stayed infeasible (exit flag {})", report.exit_flag)
                    };
                    return self.fail_after_replans(now_s, pose, &what);
                }
                if stalled {
                    tracing::info!("t = {now_s:.1} s: no progress for {window} s: recovering");
                }
                return self.replan_from(now_s, pose);
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
        // Every tick, not every controller step: at speed, half a second is a metre.
        if self.phase == Phase::Driving {
            return self.restore_margin(now_s, pose).unwrap_or_default();
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
            margin_backoffs: self.margin_backoffs,
            final_error_m: pose.distance(&goal),
            final_heading_error_rad: self.heading_error(&pose, &goal),
        });
    }

    fn finish_leg(&mut self, now_s: f64, pose: Pose2) -> Vec<Action> {
        self.record(now_s, pose, true);
        let mut actions = Vec::new();
        if self.carrying {
            self.end_carrying(pose);
            actions.push(Action::Detach);
        } else if self.stage == Stage::Docking {
            // Under the approached body now: the next driving leg leaves it straight.
            self.under = self.approached();
        }
        self.leg += 1;
        if self.leg == self.cfg.leg.len() {
            self.phase = Phase::Succeeded;
            self.leg -= 1;
            actions.push(Action::MapperControl {
                ignore: None,
                carried: None,
                placed: self.placed_parts(None),
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

mod arrival;
pub mod backoff;
pub mod docking;
mod progress;
mod replan;

#[cfg(test)]
mod tests;
