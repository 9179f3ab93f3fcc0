//! The controller process: on every controller tick, one TEB step from the robot's
//! state at that tick on the local map of that tick, published as a `Trajectory`
//! (commands timed from the tick's sim time) and the band (`ControllerBand`, history 1).
//!
//! Goals come from the supervisor (`ControllerGoal`, history 1): a new `goal_id`
//! replaces the task; `Idle` clears it. Without a task, or when a step fails, the
//! trajectory is a single zero command, so the robot stops.
//!
//! Adapter only: the optimisation is [`crate::TebController`].

use crate::{Band, Goal, Mode, Snapshot, StepOutput, TebConfig, TebController};
use aisle_bus::{Bus, NodeArgs, NodeError, StageTimer, Stamp, TickFollower, WaitOutcome};
use aisle_geometry::{Footprint, PathPose, Pose2};
use aisle_messages::{
    ControllerBand, ControllerGoal, GoalMode, GridCopy, MAX_COMMANDS, NodeKind, OccupancyGrid,
    RobotState, STAGE_CONTROLLER, StageStatus, TickMode, Trajectory, services,
};
use std::time::Duration;

const MAP_TIMEOUT: Duration = Duration::from_secs(30);

/// A restarted controller takes its task back (the newest goal) and, in lockstep when
/// its last band belongs to that goal, the band itself. Returns the tick of that band.
fn resume(
    bus: &Bus,
    teb: &mut TebController,
    task: &mut Task,
    mode: TickMode,
) -> Result<Option<u64>, NodeError> {
    let wait = Duration::from_secs(1);
    let goals = bus.subscriber::<ControllerGoal>(services::CONTROLLER_GOAL)?;
    let (WaitOutcome::Matched, Some(goal)) = goals.wait_for(wait, |_| true, || {})? else {
        return Ok(None);
    };
    task.goal_id = goal.goal_id;
    match goal_of(&goal) {
        Some(Ok(g)) => {
            teb.set_goal(&g)
                .map_err(|e| NodeError::Protocol(format!("teb_controller: resuming goal: {e}")))?;
            task.active = true;
        }
        Some(Err(e)) => {
            return Err(NodeError::Protocol(format!(
                "teb_controller: resuming goal: {e}"
            )));
        }
        None => teb.clear_goal(),
    }
    let bands = bus.subscriber::<ControllerBand>(services::CONTROLLER_BAND)?;
    let (WaitOutcome::Matched, Some(b)) = bands.wait_for(wait, |_| true, || {})? else {
        return Ok(None);
    };
    // In realtime the robot has moved on since that band (and was stopped): start a fresh
    // band from where it stands. In lockstep nothing moved, and resuming the band keeps
    // the run identical to an undisturbed one.
    if mode == TickMode::Lockstep && b.goal_id == task.goal_id && task.active {
        let n = (b.len as usize).min(MAX_COMMANDS);
        let band = Band {
            poses: b.poses[..n]
                .iter()
                .map(|p| Pose2::new(p.x, p.y, p.theta))
                .collect(),
            dts: b.dts[..n.saturating_sub(1)].to_vec(),
        };
        let snap = Snapshot {
            band,
            section: b.section as usize,
            progress: b.progress,
        };
        teb.restore(&snap)
            .map_err(|e| NodeError::Protocol(format!("teb_controller: resuming band: {e}")))?;
    }
    tracing::warn!(
        "teb_controller: resumed goal {} after tick {}",
        task.goal_id,
        b.header.tick
    );
    Ok(Some(b.header.tick))
}

/// The task the controller is on, by goal id.
struct Task {
    goal_id: u64,
    active: bool,
}

fn goal_of(msg: &ControllerGoal) -> Option<Result<Goal, String>> {
    let footprint = Footprint::new(msg.footprint_length, msg.footprint_width);
    let mode = match GoalMode::from_u32(msg.mode) {
        Some(GoalMode::Idle) => return None,
        Some(GoalMode::Follow) => Mode::Follow,
        Some(GoalMode::RotateInPlace) => Mode::RotateInPlace {
            target_heading: msg.target.theta,
        },
        None => return Some(Err(format!("unknown goal mode {}", msg.mode))),
    };
    let n = (msg.len as usize).min(msg.reference.len());
    let reference: Option<Vec<PathPose>> = msg.reference[..n]
        .iter()
        .map(|p| p.to_path_pose())
        .collect();
    let Some(reference) = reference else {
        return Some(Err("a reference pose has an unknown direction".into()));
    };
    Some(Ok(Goal {
        reference,
        footprint,
        margin: msg.margin,
        mode,
    }))
}

pub fn run(args: &NodeArgs) -> Result<(), NodeError> {
    let path = args.config_dir.join("teb.toml");
    let cfg = aisle_config::load::<TebConfig>(&path)
        .map_err(|e| NodeError::setup("teb_controller", e))?;
    let mut teb = TebController::new(cfg)
        .map_err(|e| NodeError::setup(format!("teb_controller: {}", path.display()), e))?;

    let (bus, info) = Bus::join(
        &args.instance,
        NodeKind::TebController,
        NodeArgs::JOIN_TIMEOUT,
    )?;
    let mode = TickMode::from_u32(info.mode).unwrap_or(TickMode::Lockstep);
    let robot = bus.subscriber::<RobotState>(services::ROBOT_STATE)?;
    let goals = bus.subscriber::<ControllerGoal>(services::CONTROLLER_GOAL)?;
    let maps = bus.subscriber::<OccupancyGrid>(services::LOCAL_MAP)?;
    let mut trajectory = bus.publisher::<Trajectory>(services::TRAJECTORY)?;
    let mut band = bus.publisher::<ControllerBand>(services::CONTROLLER_BAND)?;
    let mut ticks = TickFollower::new(&bus)?;

    let mut task = Task {
        goal_id: 0,
        active: false,
    };
    // The last controller tick stepped: a tick seen again (the simulator restarted) is
    // only acknowledged, so the band is never stepped twice for one tick.
    let mut last_done: Option<u64> = None;
    if args.restarted {
        last_done = resume(&bus, &mut teb, &mut task, mode)?;
    }
    ticks.ready()?;
    let mut pose = Pose2::new(args.start[0], args.start[1], args.start[2]);
    let mut velocity = (0.0, 0.0);
    // The local map in use, copied out of shared memory (a realtime step may have to
    // reuse it when no newer one arrived). Capacity is reserved once.
    let mut map = GridCopy::with_capacity(aisle_messages::MAX_GRID_CELLS);
    loop {
        let tick = ticks.wait_tick_refreshing(|| {
            let _ = trajectory.update_connections();
            let _ = band.update_connections();
        })?;
        if tick.stages & STAGE_CONTROLLER == 0 {
            ticks.done(&tick, StageStatus::Idle, 0)?;
            continue;
        }
        let k = tick.header.tick;
        if last_done.is_some_and(|d| k <= d) {
            ticks.done(&tick, StageStatus::Done, 0)?;
            continue;
        }
        last_done = Some(k);
        // The local map of this tick (lockstep), or the newest one (realtime).
        match mode {
            TickMode::Lockstep => {
                let hb = ticks.heartbeat();
                let (outcome, sample) = maps.wait_for(
                    MAP_TIMEOUT,
                    |m| m.header.tick >= k,
                    || {
                        let _ = hb.tick(aisle_messages::NodeState::Running);
                    },
                )?;
                match (outcome, sample) {
                    (WaitOutcome::Matched, Some(m)) => map.copy_from(&m),
                    _ => {
                        return Err(NodeError::Protocol(format!(
                            "teb_controller: no local map for tick {k}"
                        )));
                    }
                }
            }
            TickMode::Realtime => {
                if let Some(m) = maps.latest()? {
                    map.copy_from(&m);
                }
            }
        }
        let timer = StageTimer::start();
        if let Some(rs) = robot.latest()? {
            pose = rs.pose.into();
            velocity = (rs.twist[0], rs.twist[1]);
        }
        if let Some(g) = goals.latest()?
            && g.goal_id != task.goal_id
        {
            task.goal_id = g.goal_id;
            task.active = false;
            match goal_of(&g) {
                None => teb.clear_goal(),
                Some(Ok(goal)) => match teb.set_goal(&goal) {
                    Ok(()) => task.active = true,
                    Err(e) => tracing::warn!("teb_controller: goal {} refused: {e}", g.goal_id),
                },
                Some(Err(e)) => tracing::warn!("teb_controller: goal {} refused: {e}", g.goal_id),
            }
        }
        let stamp = Stamp::of(&tick.header);
        let start_ns = tick.header.stamp_ns;
        let now_s = start_ns as f64 * 1e-9;
        let goal_id = task.goal_id;
        let step: Option<Result<&StepOutput, String>> = match (map.is_empty(), task.active) {
            (_, false) => None,
            (true, true) => Some(Err("no local map yet".into())),
            (false, true) => match map.view() {
                Ok(view) => Some(
                    teb.step(pose, velocity, now_s, &view)
                        .map_err(|e| e.to_string()),
                ),
                Err(e) => Some(Err(format!("local map: {e}"))),
            },
        };
        let status = match &step {
            Some(Err(e)) => {
                tracing::warn!("teb_controller: step of tick {k} failed: {e}");
                StageStatus::Failed
            }
            _ => StageStatus::Done,
        };
        let compute_ns = timer.elapsed_ns();
        trajectory.publish(stamp, |t| {
            t.goal_id = goal_id;
            t.start_ns = start_ns;
            t.solve_ns = compute_ns;
            match &step {
                Some(Ok(out)) => {
                    let n = out.commands.len().min(MAX_COMMANDS);
                    t.len = n as u32;
                    for (dst, c) in t.commands.iter_mut().zip(&out.commands[..n]) {
                        // The library's times are absolute; the message's count from start_ns.
                        dst.t = c.t - now_s;
                        dst.v = c.v;
                        dst.w = c.w;
                    }
                    let np = out.poses.len().min(MAX_COMMANDS);
                    t.poses_len = np as u32;
                    for (dst, p) in t.poses.iter_mut().zip(&out.poses[..np]) {
                        dst.t = p.t - now_s;
                        dst.x = p.pose.x;
                        dst.y = p.pose.y;
                        dst.theta = p.pose.theta;
                    }
                    t.exit_flag = out.exit_flag.code() as u32;
                    t.last_feasible_index = out.last_feasible_index as i32;
                    t.reached_goal = out.reached_goal as u32;
                    t.iterations = out.iterations as u32;
                    t.cost = out.cost;
                    t.max_violation = out.max_violation;
                }
                Some(Err(_)) => {
                    // Stop: one zero command, flagged as infeasible so the supervisor replans.
                    t.len = 1;
                    t.exit_flag = 1;
                    t.last_feasible_index = -1;
                }
                None => {
                    t.len = 1;
                    t.last_feasible_index = -1;
                }
            }
        })?;
        let snap = teb.snapshot();
        band.publish(stamp, |m| {
            m.goal_id = goal_id;
            let b = &snap.band;
            let n = b.poses.len().min(MAX_COMMANDS);
            m.len = n as u32;
            m.section = snap.section as u32;
            m.progress = snap.progress;
            let mut t = 0.0;
            for (i, (dst, p)) in m.poses.iter_mut().zip(&b.poses[..n]).enumerate() {
                dst.t = t;
                dst.x = p.x;
                dst.y = p.y;
                dst.theta = p.theta;
                t += b.dts.get(i).copied().unwrap_or(0.0);
            }
            for (dst, dt) in m.dts.iter_mut().zip(&b.dts) {
                *dst = *dt;
            }
        })?;
        ticks.done(&tick, status, compute_ns)?;
    }
}
