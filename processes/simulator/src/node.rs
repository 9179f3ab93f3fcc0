//! The simulator process: owns simulated time and drives the tick protocol.
//!
//! The simulator is the group's clock, so it is not a [`aisle_node::Stage`] (it does not
//! wait for a trigger: it makes them). Per tick k: publish `SimState` (the whole world
//! at the start of k, history 1), then `RobotState` and `WorldTruth` for time t_k, then
//! `Tick{k}`; in lockstep wait for every node `config/graph.toml` says acknowledges k
//! (`aisle_node::tick`); apply the supervisor's new `SimCommand`s and the newest controller
//! `Trajectory`; step the world by dt. In realtime the wall clock releases the next tick
//! instead and nobody is waited for.
//!
//! A restarted simulator (`NodeArgs::restarted`) reads its last `SimState` back and
//! resumes at that tick: commands and trajectories it had not applied yet are still in
//! their services' history, so a lockstep run continues bit for bit.
//!
//! This is the adapter between [`crate::World`] and the bus; it holds no physics.

use crate::MAX_MOVABLE_BODIES;
use crate::World;
use crate::sim_state::{Applied, publish_sim_state, resume};
use aisle_bus::{
    Bus, HeartbeatSender, NodeArgs, NodeError, Publisher, StageTimer, Stamp, Subscriber,
    WaitOutcome, clock, signals,
};
use aisle_config::scene::Scene;
use aisle_geometry::Pose2;
use aisle_messages::{
    GroupMembers, NodeKind, NodeState, RobotState, STAGE_CONTROLLER, SimCommand, SimCommandKind,
    SimState, StageStatus, Tick, TickDone, TickMode, Trajectory, WorldTruth, topics, write_name,
};
use aisle_node::Graph;
use aisle_node::tick::Awaited;
use std::time::Duration;

/// How long a lockstep tick may wait for its stages before the simulator gives up.
const STAGE_TIMEOUT: Duration = Duration::from_secs(60);
/// Longest sleep of a wait, so heartbeats keep their period.
const WAIT_SLICE: Duration = Duration::from_millis(25);

struct Ports {
    state: Publisher<SimState>,
    robot: Publisher<RobotState>,
    truth: Publisher<WorldTruth>,
    tick: Publisher<Tick>,
    done_out: Publisher<TickDone>,
    done_in: Subscriber<TickDone>,
    commands: Subscriber<SimCommand>,
    trajectory: Subscriber<Trajectory>,
    group: Subscriber<GroupMembers>,
}

impl Ports {
    /// Hands the history of the state services to processes that (re)joined.
    fn refresh(&self) {
        let _ = self.state.update_connections();
        let _ = self.robot.update_connections();
        let _ = self.truth.update_connections();
        let _ = self.tick.update_connections();
    }
}

/// How long a trajectory stays in force: until its successor is due (one controller
/// period after its tick) plus the lateness `robot.toml` allows.
#[derive(Debug, Clone, Copy)]
struct TrajectoryLife {
    period_ns: u64,
    late_ns: u64,
}

impl TrajectoryLife {
    fn expiry(&self, traj: &Trajectory) -> u64 {
        traj.header
            .stamp_ns
            .saturating_add(self.period_ns)
            .saturating_add(self.late_ns)
    }
}

/// The world of `args.config_dir` with the robot at the mission's start, and how long
/// a trajectory lives.
fn load_world(args: &NodeArgs) -> Result<(World, TrajectoryLife), NodeError> {
    let robot_toml = args.config_dir.join("robot.toml");
    let scene_path = args.config_dir.join("warehouse.toml");
    let (cfg, model) =
        aisle_robot::load_robot(&robot_toml).map_err(|e| NodeError::setup("simulator", e))?;
    let life = TrajectoryLife {
        period_ns: args
            .dt_ns
            .saturating_mul(args.controller_every.max(1) as u64),
        late_ns: cfg.late_trajectory_ns(),
    };
    let scene = Scene::load(&scene_path).map_err(|e| NodeError::setup("simulator", e))?;
    let start = Pose2::new(args.start[0], args.start[1], args.start[2]);
    let world = World::new_at(&scene, &model, &cfg, start)
        .map_err(|e| NodeError::setup("simulator: start pose", e))?;
    let movable = world.bodies().iter().filter(|b| !b.is_static).count();
    if movable > MAX_MOVABLE_BODIES {
        return Err(NodeError::setup(
            format!("simulator: {}", scene_path.display()),
            format!(
                "the scene has {movable} bodies that are not static; WorldTruth holds \
                 {MAX_MOVABLE_BODIES} (static bodies: any number)"
            ),
        ));
    }
    Ok((world, life))
}

fn open_ports(bus: &Bus) -> Result<Ports, NodeError> {
    Ok(Ports {
        state: bus.publisher(topics::SIM_STATE)?,
        robot: bus.publisher(topics::ROBOT_STATE)?,
        truth: bus.publisher(topics::WORLD_TRUTH)?,
        tick: bus.publisher(topics::TICK)?,
        done_out: bus.publisher(topics::TICK_DONE)?,
        done_in: bus.subscriber(topics::TICK_DONE)?,
        commands: bus.subscriber(topics::SIM_COMMAND)?,
        trajectory: bus.subscriber(topics::TRAJECTORY)?,
        group: bus.subscriber(topics::GROUP)?,
    })
}

/// Waits for the supervisor's Start: every process is ready by then.
fn wait_for_start(ports: &Ports, heartbeat: &mut HeartbeatSender) -> Result<(), NodeError> {
    loop {
        let (outcome, _) = ports.commands.wait_for(
            WAIT_SLICE,
            |c| c.kind == SimCommandKind::Start as u32,
            || {
                let _ = heartbeat.tick(NodeState::Ready);
            },
        )?;
        if outcome == WaitOutcome::Matched {
            return Ok(());
        }
    }
}

/// Sleeps until the wall clock reaches `due` (realtime release of the next tick),
/// beating meanwhile.
fn sleep_until(due: u64, heartbeat: &mut HeartbeatSender) -> Result<(), NodeError> {
    loop {
        let now = clock::monotonic_ns();
        if now >= due {
            return Ok(());
        }
        if signals::stop_requested() {
            return Err(aisle_bus::BusError::StopRequested.into());
        }
        heartbeat.tick(NodeState::Running)?;
        std::thread::sleep(Duration::from_nanos((due - now).min(20_000_000)));
    }
}

/// Applies the supervisor's new commands and the newest controller trajectory, which
/// stays in force until its successor is overdue ([`TrajectoryLife`]).
fn apply_inputs(
    ports: &Ports,
    world: &mut World,
    applied: &mut Applied,
    life: TrajectoryLife,
    tick: u64,
) -> Result<(), NodeError> {
    while let Some(cmd) = ports.commands.receive()? {
        if cmd.header.source != NodeKind::Supervisor.code() {
            apply_external_stop(world, applied, &cmd, tick);
            continue;
        }
        // History replays commands to a restarted simulator: apply each once.
        if cmd.command_id > applied.command_id {
            applied.command_id = cmd.command_id;
            if cmd.kind == SimCommandKind::Stop as u32 {
                applied.stop_tick = cmd.header.tick;
            }
            apply_command(world, &cmd);
        }
    }
    if let Some(traj) = ports.trajectory.latest()? {
        let id = (traj.header.tick, traj.header.seq);
        if id != applied.trajectory && applied.drives(&traj) {
            applied.trajectory = id;
            let n = (traj.len as usize).min(traj.commands.len());
            if n == 0 {
                world.stop();
            } else {
                let cmds = traj.commands[..n].iter().map(|c| (c.t, c.v, c.w));
                match world.set_timeline_iter(traj.start_ns, cmds) {
                    Ok(()) => world.set_timeline_expiry(life.expiry(&traj)),
                    // A malformed timeline is refused; the previous one expires as it
                    // would have.
                    Err(e) => tracing::warn!(
                        "simulator: trajectory of tick {} refused: {e}",
                        traj.header.tick
                    ),
                }
            }
        }
    }
    Ok(())
}

/// Steps the world by `dt_ns` and says when the robot touched a body.
fn step(world: &mut World, dt_ns: u64) {
    let report = world.step(dt_ns);
    if report.new_collisions > 0 {
        let body = report
            .first_contact
            .and_then(|i| world.bodies().get(i))
            .map_or("?", |b| b.name.as_str());
        let p = report.robot.pose;
        tracing::warn!(
            "simulator: collision with `{body}` at t = {:.1} s, robot at ({:.2}, {:.2}, {:.2})",
            report.time_ns as f64 * 1e-9,
            p.x,
            p.y,
            p.theta
        );
    }
}

pub fn run(args: &NodeArgs) -> Result<(), NodeError> {
    let (mut world, life) = load_world(args)?;
    let graph = Graph::load_dir(&args.config_dir).map_err(|e| NodeError::setup("simulator", e))?;
    let mut awaited = Awaited::new();
    let mut members = Members {
        newest: None,
        recorded: args.recorded,
    };
    let (bus, info) = Bus::join(&args.instance, NodeKind::Simulator, NodeArgs::JOIN_TIMEOUT)?;
    let mode = TickMode::from_u32(info.mode).unwrap_or(TickMode::Lockstep);
    let mut ports = open_ports(&bus)?;
    let mut heartbeat = bus.heartbeat()?;
    // The node's real-time options (`config/realtime.toml`), before the first tick.
    aisle_node::realtime::apply_for(
        "simulator",
        &args.config_dir,
        &graph,
        aisle_node::realtime::Forks::Inherit,
    )
    .map_err(|e| NodeError::setup("simulator", e))?;
    let (mut k, mut applied) = (0, Applied::default());
    if args.restarted {
        (k, applied) = resume(&bus, &mut world)?;
        heartbeat.send(NodeState::Running, "resumed")?;
    } else {
        heartbeat.send(NodeState::Ready, "")?;
        wait_for_start(&ports, &mut heartbeat)?;
    }

    let dt_ns = args.dt_ns;
    let every = args.controller_every.max(1) as u64;
    let wall_start = clock::monotonic_ns();
    let first_tick = k;
    loop {
        if signals::stop_requested() {
            return Err(aisle_bus::BusError::StopRequested.into());
        }
        let stamp = Stamp {
            stamp_ns: world.time_ns(),
            tick: k,
            tick_wall_ns: clock::monotonic_ns(),
        };
        publish_sim_state(&mut ports.state, &world, stamp, applied)?;
        publish_state(&mut ports, &world, stamp)?;
        let stages = if k.is_multiple_of(every) {
            STAGE_CONTROLLER
        } else {
            0
        };
        ports.tick.publish(stamp, |t| {
            t.dt_ns = dt_ns;
            t.mode = mode as u32;
            t.stages = stages;
            t.seed = info.seed;
        })?;
        heartbeat.tick(NodeState::Running)?;
        match mode {
            TickMode::Lockstep => {
                let tick = (k, stages);
                wait_stages(
                    &ports,
                    &mut heartbeat,
                    &graph,
                    &mut awaited,
                    tick,
                    &mut members,
                )?
            }
            TickMode::Realtime => {
                sleep_until(wall_start + (k + 1 - first_tick) * dt_ns, &mut heartbeat)?
            }
        }
        let timer = StageTimer::start();
        apply_inputs(&ports, &mut world, &mut applied, life, k)?;
        step(&mut world, dt_ns);
        let compute_ns = timer.elapsed_ns();
        ports.done_out.publish(stamp, |d| {
            d.node = NodeKind::Simulator.code();
            d.status = StageStatus::Done as u32;
            d.compute_ns = compute_ns;
            d.cpu_ns = timer.cpu_ns();
        })?;
        k += 1;
    }
}

/// A command from another node than the supervisor (a safety monitor of the user's):
/// it may stop the robot, nothing else, and only while it is fresh (made for this tick or
/// the one before), so one replayed from history after a restart stops nothing. Its ids
/// are its own: the supervisor's sequence is left alone.
fn apply_external_stop(world: &mut World, applied: &mut Applied, cmd: &SimCommand, tick: u64) {
    let source = NodeKind::from_u32(cmd.header.source).map_or("an unknown node", NodeKind::name);
    if cmd.kind != SimCommandKind::Stop as u32 {
        tracing::warn!(
            "simulator: `{source}` sent command kind {}; only the supervisor may, others may only stop",
            cmd.kind
        );
        return;
    }
    if cmd.header.tick + 1 >= tick {
        // u64::MAX means no stop yet (see `Applied`).
        applied.stop_tick = match applied.stop_tick {
            u64::MAX => cmd.header.tick,
            t => t.max(cmd.header.tick),
        };
        world.stop();
    }
}

fn apply_command(world: &mut World, cmd: &SimCommand) {
    let result = match SimCommandKind::from_u32(cmd.kind) {
        Some(SimCommandKind::Attach) => {
            let name = aisle_messages::read_name(&cmd.name);
            match world.body_index(name) {
                Some(i) => world.attach(i),
                None if cmd.body_index >= 0 => world.attach(cmd.body_index as usize),
                None => world.attach_by_name(name),
            }
        }
        Some(SimCommandKind::Detach) => world.detach().map(|_| ()),
        Some(SimCommandKind::Stop) => {
            world.stop();
            Ok(())
        }
        Some(SimCommandKind::Start) => Ok(()),
        None => {
            tracing::warn!("simulator: unknown command kind {}", cmd.kind);
            Ok(())
        }
    };
    if let Err(e) = result {
        tracing::warn!("simulator: command {} refused: {e}", cmd.command_id);
    }
}

fn publish_state(ports: &mut Ports, world: &World, stamp: Stamp) -> Result<(), NodeError> {
    let rs = world.robot_state();
    let carried = world.carried().map_or(-1, |c| c.body as i32);
    let collisions = u32::try_from(world.collisions()).unwrap_or(u32::MAX);
    ports.robot.publish(stamp, |m| {
        m.pose = rs.pose.into();
        m.twist = [rs.twist.v, rs.twist.w];
        m.wheel_speeds = [rs.wheels.left, rs.wheels.right];
        m.carried_body = carried;
        m.watchdog_stopped = rs.watchdog_stopped as u32;
        m.collisions = collisions;
    })?;
    let min_clearance = world.min_clearance();
    ports.truth.publish(stamp, |m| {
        // The bodies that can move, then the static ones in contact (see `WorldTruth`).
        let bodies = world.bodies().iter().enumerate();
        let movable = bodies.clone().filter(|(_, b)| !b.is_static);
        let touched = bodies.filter(|(i, b)| b.is_static && world.in_contact(*i));
        let mut n = 0;
        for (dst, (i, b)) in m.bodies.iter_mut().zip(movable.chain(touched)) {
            write_name(&mut dst.name, &b.name);
            dst.pose = b.pose.into();
            let fp = b.footprint();
            dst.size = [fp.length, fp.width, b.height()];
            dst.index = i as u32;
            dst.is_static = b.is_static as u8;
            dst.carried = (carried == i as i32) as u8;
            dst.in_contact = world.in_contact(i) as u8;
            n += 1;
        }
        m.len = n;
        m.collisions = collisions;
        m.min_clearance = min_clearance;
    })?;
    Ok(())
}

/// Whose acknowledgements count: the supervisor's newest `GroupMembers`, or before the
/// first one, the launch's (the recorder only when `--record` attached one).
#[derive(Debug, Clone, Copy)]
struct Members {
    newest: Option<GroupMembers>,
    recorded: bool,
}

impl Members {
    /// Takes a newer membership, if one arrived; true when it changed.
    fn refresh(&mut self, group: &Subscriber<GroupMembers>) -> Result<bool, NodeError> {
        let Some(g) = group.latest()? else {
            return Ok(false);
        };
        let changed = self.newest.is_none_or(|n| n.codes() != g.codes());
        if changed {
            let before = self.newest.replace(*g);
            // The first announcement is the launch's own; only a later one can tell of
            // a member that left.
            for left in before
                .iter()
                .flat_map(|b| b.codes())
                .filter(|c| !g.codes().contains(c))
            {
                let name = NodeKind::from_u32(*left).map_or("an unknown node", NodeKind::name);
                tracing::warn!(
                    "simulator: `{name}` (code {left:#x}) left the group; its acknowledgements are no longer awaited"
                );
            }
        }
        Ok(changed)
    }

    fn contains(&self, kind: NodeKind) -> bool {
        match &self.newest {
            Some(m) => m.contains(kind),
            None => kind != NodeKind::Recorder || self.recorded,
        }
    }
}

/// Waits until every node the graph says acknowledges tick `k` did, among the
/// group's members (a recorder that died or failed leaves, and is no longer waited for).
fn wait_stages(
    ports: &Ports,
    heartbeat: &mut HeartbeatSender,
    graph: &Graph,
    awaited: &mut Awaited,
    (k, stages): (u64, u32),
    members: &mut Members,
) -> Result<(), NodeError> {
    members.refresh(&ports.group)?;
    awaited.expect(k, graph.acknowledgers(stages, |n| members.contains(n)));
    let started = std::time::Instant::now();
    awaited.wait(
        &ports.done_in,
        WAIT_SLICE,
        |_| {},
        |a| {
            let _ = heartbeat.tick(NodeState::Running);
            ports.refresh();
            if members.refresh(&ports.group)? {
                a.keep_only(|n| members.contains(n));
            }
            if started.elapsed() > STAGE_TIMEOUT {
                return Err(NodeError::Protocol(format!(
                    "tick {k}: no acknowledgement from {} within {} s",
                    a.pending_names(),
                    STAGE_TIMEOUT.as_secs()
                )));
            }
            Ok(())
        },
    )
}
