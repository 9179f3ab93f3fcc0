//! Carrying out what the mission asks ([`Action`]s): plan requests (and waiting for the
//! answer while watching the children), controller goals, simulator commands, the
//! mapper's ignore and carried rectangles. Translates between the mission's types and
//! the message layouts; decides nothing itself.

use super::run_config::RunConfig;
use super::{POLL, RunAborted, Session};
use crate::mission::{Action, Dock, PlanFailure, Planned};
use aisle_bus::{Stamp, clock};
use aisle_geometry::{Footprint, PathPose, Pose2};
use aisle_messages::{
    DockMove, GoalMode, MAX_PATH_POSES, NodeKind, PathPoseMsg, PlanRequest, PlanResponse,
    PlanStatus, RectMsg, SimCommandKind,
};
use anyhow::anyhow;
use std::collections::VecDeque;
use std::time::{Duration, Instant};

/// Added around rectangles the mapper ignores, metres.
const IGNORE_MARGIN: f64 = 0.05;

impl Session {
    /// Carries out `actions` in order, and those the mission answers a plan with;
    /// `planner_ns` accumulates the wall time spent waiting for plans.
    pub(super) fn execute(
        &mut self,
        actions: Vec<Action>,
        config: &RunConfig,
        planner_timeout: Duration,
        planner_ns: &mut u64,
    ) -> Result<(), RunAborted> {
        let mut queue: VecDeque<Action> = actions.into();
        while let Some(action) = queue.pop_front() {
            match action {
                Action::Plan {
                    start,
                    goal,
                    footprint,
                    margin,
                    use_detections,
                    dock,
                    fixed_budget,
                } => {
                    let t0 = Instant::now();
                    let ask = Ask {
                        start,
                        goal,
                        footprint,
                        margin,
                        use_detections,
                        dock,
                        fixed_budget,
                    };
                    let result = self.plan(&ask, planner_timeout)?;
                    *planner_ns += t0.elapsed().as_nanos() as u64;
                    queue.extend(self.mission.on_plan(self.now_s, self.pose, result));
                }
                Action::Follow {
                    reference,
                    goal,
                    footprint,
                    margin,
                    tolerance,
                } => {
                    let tol = tolerance.unwrap_or(config.mission.goal_tolerance);
                    let to = Target::new(goal, footprint, margin, tol);
                    self.send_goal(GoalMode::Follow, &reference, &to)?;
                }
                Action::Straight {
                    goal,
                    footprint,
                    margin,
                } => {
                    let to = Target::new(goal, footprint, margin, config.mission.goal_tolerance);
                    self.send_goal(GoalMode::Straight, &[], &to)?;
                }
                Action::Rotate {
                    goal,
                    footprint,
                    margin,
                } => {
                    let to = Target::new(goal, footprint, margin, config.mission.goal_tolerance);
                    self.send_goal(GoalMode::RotateInPlace, &[], &to)?;
                }
                Action::Attach(name) => {
                    let index = config.scene.body(&name).map_or(-1, |(i, _)| i as i32);
                    self.sim_command(SimCommandKind::Attach, Some((index, &name)))?;
                    self.expect_carried(index, &name);
                }
                Action::Detach => {
                    self.sim_command(SimCommandKind::Detach, None)?;
                    let held = usize::try_from(self.carried).ok();
                    let name = held
                        .and_then(|i| config.scene.bodies.get(i))
                        .map_or_else(|| "the load".to_string(), |b| b.name.clone());
                    self.expect_carried(-1, &name);
                }
                Action::MapperControl {
                    ignore,
                    carried,
                    placed,
                } => {
                    self.mapper_control(ignore, carried, &placed, config)?;
                }
                Action::Halt => {
                    let to = Target::new(
                        self.pose,
                        config.footprints.alone,
                        0.0,
                        config.mission.goal_tolerance,
                    );
                    self.send_goal(GoalMode::Idle, &[], &to)?;
                    self.sim_command(SimCommandKind::Stop, None)?;
                }
            }
        }
        Ok(())
    }

    /// Asks the planner for a path and waits for the answer; a planner restarted
    /// meanwhile is asked again. `Err` only when the run cannot go on.
    fn plan(
        &mut self,
        ask: &Ask,
        timeout: Duration,
    ) -> Result<Result<Planned, PlanFailure>, RunAborted> {
        let stamp = self.stamp();
        let request = |m: &mut PlanRequest| {
            m.start = ask.start.into();
            m.goal = ask.goal.into();
            m.footprint_length = ask.footprint.length;
            m.footprint_width = ask.footprint.width;
            m.margin = ask.margin;
            m.use_detections = ask.use_detections as u32;
            m.timeout_ms = timeout.as_millis() as u32;
            if let Some(budget) = ask.fixed_budget {
                m.max_expansions = budget;
                m.fixed_budget = 1;
            }
            fill_dock(m, ask.dock.as_ref());
        };
        let mut id = self.ports.planner.send(stamp, request)?;
        // Set while a restarted planner has still to be asked: one that is not ready
        // may not be listening yet, and the request would be lost.
        let mut resend = !self.health.ready.contains(&NodeKind::GlobalPlanner);
        let mut started = Instant::now();
        // The planner bounds its own time; allow it a second more to answer.
        let limit = timeout + Duration::from_secs(1);
        loop {
            if let Some(resp) = self.ports.planner.wait(id, POLL, || {})? {
                self.book.record_plan(&resp);
                let status = PlanStatus::from_u32(resp.status);
                return Ok(match status {
                    Some(PlanStatus::Ok) => {
                        let n = (resp.len as usize).min(MAX_PATH_POSES);
                        let path: Vec<PathPose> = resp.poses[..n]
                            .iter()
                            .filter_map(PathPoseMsg::to_path_pose)
                            .collect();
                        if path.len() == n && n > 0 {
                            Ok(planned(path, &resp))
                        } else {
                            Err(PlanFailure::new("the planner's path is empty or malformed"))
                        }
                    }
                    Some(s) => Err(PlanFailure {
                        why: format!(
                            "{} after {} expansions ({:.1} ms)",
                            plan_status_text(s),
                            resp.expansions,
                            resp.solve_ns as f64 / 1e6
                        ),
                        // The start within the margin, no path that keeps it (also "no
                        // path" at the first expansion: the heuristic's grid grows
                        // obstacles by the margin and cut the start off), a search that
                        // ran out threading the whole margin through a tight gap, or a
                        // goal close to a wall or a rack (parked beside a row).
                        margin_bound: matches!(
                            s,
                            PlanStatus::StartOccupied
                                | PlanStatus::NoPath
                                | PlanStatus::Timeout
                                | PlanStatus::GoalOccupied
                        ),
                    }),
                    None => Err(PlanFailure::new(format!(
                        "unknown plan status {}",
                        resp.status
                    ))),
                });
            }
            self.supervise()?;
            if self.health.restarted.contains(&NodeKind::GlobalPlanner) {
                // The planner died with the request (or before it, and its successor
                // was not listening yet): ask the successor once it is ready.
                self.health
                    .restarted
                    .retain(|k| *k != NodeKind::GlobalPlanner);
                resend = true;
                started = Instant::now();
            }
            if resend && self.health.ready.contains(&NodeKind::GlobalPlanner) {
                resend = false;
                id = self.ports.planner.send(stamp, request)?;
                started = Instant::now();
            }
            if started.elapsed() > limit {
                return Ok(Err(PlanFailure::new(format!(
                    "the planner did not answer within {:.1} s",
                    limit.as_secs_f64()
                ))));
            }
        }
    }

    fn send_goal(
        &mut self,
        mode: GoalMode,
        reference: &[PathPose],
        to: &Target,
    ) -> Result<(), RunAborted> {
        if reference.len() > MAX_PATH_POSES {
            return Err(RunAborted::Error(anyhow!(
                "reference path of {} poses exceeds the message capacity of {MAX_PATH_POSES}",
                reference.len()
            )));
        }
        self.goal_id += 1;
        let id = self.goal_id;
        let stamp = self.stamp();
        // Zero: teb.toml's limits.
        let speed_limit = self.mission.speed_limit().unwrap_or([0.0; 2]);
        self.health.goal.publish(stamp, |m| {
            m.goal_id = id;
            m.mode = mode as u32;
            m.max_velocity = speed_limit;
            m.len = reference.len() as u32;
            m.footprint_length = to.footprint.length;
            m.footprint_width = to.footprint.width;
            m.margin = to.margin;
            m.goal_tolerance = to.tolerance;
            m.target = to.goal.into();
            for (dst, src) in m.reference.iter_mut().zip(reference) {
                *dst = (*src).into();
            }
        })?;
        Ok(())
    }

    fn mapper_control(
        &mut self,
        ignore: Option<(Pose2, Footprint)>,
        carried: Option<Footprint>,
        placed: &[(Pose2, Footprint)],
        config: &RunConfig,
    ) -> Result<(), RunAborted> {
        let tol = config.mission.goal_tolerance;
        let carry_margin = tol[0].max(tol[1]) + IGNORE_MARGIN;
        if placed.len() > aisle_messages::MAX_PLACED_PARTS {
            tracing::warn!(
                "{} parts of bodies set down, the mapper keeps the newest {}",
                placed.len(),
                aisle_messages::MAX_PLACED_PARTS
            );
        }
        let stamp = self.stamp();
        self.health.mapper_control.publish(stamp, |m| {
            // Margins: range noise on the legs' faces (ignore), and how far the
            // robot may stand off the rack's centre when it lifts it (carried:
            // the goal tolerance).
            if let Some((pose, fp)) = ignore {
                m.ignore = rect(pose, fp.inflated(IGNORE_MARGIN));
            }
            if let Some(fp) = carried {
                m.carried = rect(Pose2::default(), fp.inflated(carry_margin));
            }
            // Exact parts: the mapper marks every cell they overlap. Beyond the
            // capacity (more than four racks set down) the newest are kept: the robot
            // is nearest to them.
            let n = placed.len().min(m.placed.len());
            for (dst, (pose, fp)) in m.placed.iter_mut().zip(&placed[placed.len() - n..]) {
                *dst = rect(*pose, *fp);
            }
            m.placed_count = n as u32;
        })?;
        Ok(())
    }

    pub(super) fn sim_command(
        &mut self,
        kind: SimCommandKind,
        body: Option<(i32, &str)>,
    ) -> Result<(), RunAborted> {
        let stamp = self.stamp();
        self.health.send_sim_command(stamp, kind, body)?;
        Ok(())
    }

    /// The header of what the supervisor publishes now: sim time of the current tick.
    pub(super) fn stamp(&self) -> Stamp {
        Stamp {
            stamp_ns: (self.now_s * 1e9).round() as u64,
            tick: self.ticks,
            tick_wall_ns: clock::monotonic_ns(),
        }
    }
}

fn rect(pose: Pose2, fp: Footprint) -> RectMsg {
    RectMsg {
        pose: pose.into(),
        length: fp.length,
        width: fp.width,
        valid: 1,
        _pad: [0; 7],
    }
}

fn plan_status_text(s: PlanStatus) -> &'static str {
    match s {
        PlanStatus::Ok => "ok",
        PlanStatus::StartOccupied => "the start is in collision",
        PlanStatus::GoalOccupied => "the goal is in collision",
        PlanStatus::StartOutsideMap => "the start is outside the map",
        PlanStatus::GoalOutsideMap => "the goal is outside the map",
        PlanStatus::NoPath => "no path exists",
        PlanStatus::Timeout => "the search ran out of time",
        PlanStatus::InvalidRequest => "the request is invalid",
        PlanStatus::NoOpenSide => "no side of the body has a clear straight way in or out",
    }
}

/// One plan request as the mission asked for it.
struct Ask {
    start: Pose2,
    goal: Pose2,
    footprint: Footprint,
    margin: f64,
    use_detections: bool,
    dock: Option<Dock>,
    fixed_budget: Option<u32>,
}

/// A controller goal's pose, footprint, margin and tolerances.
struct Target {
    goal: Pose2,
    footprint: Footprint,
    margin: f64,
    tolerance: [f64; 3],
}

impl Target {
    fn new(goal: Pose2, footprint: Footprint, margin: f64, tolerance: [f64; 3]) -> Target {
        Target {
            goal,
            footprint,
            margin,
            tolerance,
        }
    }
}

/// The request's docking fields: the body and its parts, or nothing.
fn fill_dock(m: &mut PlanRequest, dock: Option<&Dock>) {
    let (kind, body, free) = match dock {
        None => return,
        Some(Dock::Into { body, free_heading }) => (DockMove::Dock, body, *free_heading),
        Some(Dock::OutOf { body }) => (DockMove::Undock, body, false),
    };
    m.dock = kind as u32;
    m.free_heading = free as u32;
    m.body = rect(body.pose, body.footprint);
    for (dst, (pose, fp)) in m.parts.iter_mut().zip(&body.parts) {
        *dst = rect(*pose, *fp);
    }
}

/// The response's path with its straight move.
fn planned(path: Vec<PathPose>, resp: &PlanResponse) -> Planned {
    let split = resp.split as usize;
    let mut p = Planned::plain(path);
    match DockMove::from_u32(resp.straight) {
        Some(DockMove::Dock) => p.dock_from = Some(split),
        Some(DockMove::Undock) => p.undock_to = Some(split),
        _ => {}
    }
    p
}
