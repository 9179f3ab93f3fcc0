//! One run of the process group: load and check the configs, create an isolated
//! instance, launch the nodes, wait until all are ready, drive the mission tick by tick,
//! then stop the group and remove every trace of the instance.
//!
//! In lockstep the supervisor acts on tick k only after lidar, mapper (and, on its
//! ticks, the controller) have acknowledged k, and the simulator advances only after
//! the supervisor's own acknowledgement; plans are requested inside that window, so a
//! run depends on its inputs and seed alone. In realtime nobody waits for anybody.

use crate::budgets::{Budgets, LatencyBook, format_table};
use crate::check::{self, ConfigFiles};
use crate::launch::{LaunchSpec, ProcessGroup, current_exe, describe};
use crate::mission::{
    Action, ControllerReport, Footprints, Mission, MissionConfig, NamedBody, PlanFailure,
};
use crate::report::{BodyPose, ReferencePath, RunReport, SerdeLeg, SerdeStage};
use crate::restart::{RestartBook, RestartConfig};
use aisle_bus::{
    Bus, BusError, Client, Instance, Publisher, Stamp, Subscriber, WaitOutcome, clock,
    message_bytes,
};
use aisle_config::scene::Scene;
use aisle_geometry::{Footprint, PathPose, Pose2};
use aisle_messages::{
    ControllerBand, ControllerGoal, GoalMode, Heartbeat, InstanceInfo, MAX_PATH_POSES,
    MapperControl, MissionState, MissionStatus, NodeKind, NodeState, OccupancyGrid, PathPoseMsg,
    PlanRequest, PlanResponse, PlanStatus, RectMsg, RobotState, STAGE_CONTROLLER, SimCommand,
    SimCommandKind, SimState, StageStatus, Tick, TickDone, TickMode, Trajectory, WorldTruth,
    read_name, topics, write_name,
};
use anyhow::{Context, anyhow, bail};
use std::collections::HashMap;
use std::path::PathBuf;
use std::time::{Duration, Instant};

#[derive(Debug, Clone)]
pub struct RunOptions {
    pub config_dir: PathBuf,
    pub mode: TickMode,
    pub report: Option<PathBuf>,
    pub quiet: bool,
    pub seed: u64,
    pub lidar_off: bool,
    pub mission: Option<PathBuf>,
    /// Fault injection: SIGKILL a node at a tick (`lidar@120`).
    pub kill: Vec<String>,
    /// Fault injection: this node fails at every start.
    pub crash_on_start: Option<String>,
    /// Record every service to this MCAP file.
    pub record: Option<PathBuf>,
}

pub struct RunOutcome {
    pub succeeded: bool,
    pub report: RunReport,
}

/// Where instances live: `$AISLE_RUN_DIR`, else `<tmp>/aisle` (`/tmp/aisle` when the
/// temporary directory's path is too long for iceoryx2's socket paths).
pub(crate) fn run_base_dir() -> PathBuf {
    if let Some(d) = std::env::var_os("AISLE_RUN_DIR") {
        return PathBuf::from(d);
    }
    let t = std::env::temp_dir().join("aisle");
    if t.as_os_str().len() <= 24 {
        t
    } else {
        PathBuf::from("/tmp/aisle")
    }
}

/// `NODE@TICK` of `--kill`.
fn parse_kill(spec: &str) -> anyhow::Result<(NodeKind, u64)> {
    let (name, tick) = spec
        .split_once('@')
        .ok_or_else(|| anyhow!("--kill {spec}: expected NODE@TICK"))?;
    let kind = NodeKind::from_name(name)
        .filter(|k| NodeKind::LAUNCHED.contains(k))
        .ok_or_else(|| anyhow!("--kill {spec}: no node `{name}`"))?;
    let tick = tick
        .parse()
        .map_err(|_| anyhow!("--kill {spec}: `{tick}` is not a tick number"))?;
    Ok((kind, tick))
}

const READY_TIMEOUT: Duration = Duration::from_secs(60);
const GRACE: Duration = Duration::from_millis(1500);
/// Longest a lockstep tick may take before the run is declared stuck.
const LOCKSTEP_STALL: Duration = Duration::from_secs(60);
const REALTIME_STALL: Duration = Duration::from_secs(5);
/// Added around rectangles the mapper ignores, metres.
const IGNORE_MARGIN: f64 = 0.05;
const POLL: Duration = Duration::from_millis(100);

/// A reason the run could not go on (as opposed to a mission that failed).
#[derive(Debug)]
enum Halt {
    Interrupted,
    Other(anyhow::Error),
}

impl From<BusError> for Halt {
    fn from(e: BusError) -> Self {
        match e {
            BusError::StopRequested => Halt::Interrupted,
            e => Halt::Other(e.into()),
        }
    }
}

impl From<anyhow::Error> for Halt {
    fn from(e: anyhow::Error) -> Self {
        Halt::Other(e)
    }
}

/// Everything loaded before launching anything.
struct Loaded {
    restart: RestartConfig,
    kills: Vec<(NodeKind, u64)>,
    scene: Scene,
    mission: MissionConfig,
    budgets: Budgets,
    footprints: Footprints,
}

fn load(opts: &RunOptions) -> anyhow::Result<Loaded> {
    let files = ConfigFiles::in_dir(&opts.config_dir);
    check::check_dir(&opts.config_dir).map_err(|e| anyhow!(e))?;
    let scene = Scene::load(&files.scene)?;
    let mission_path = opts.mission.clone().unwrap_or(files.mission.clone());
    let mission = MissionConfig::load(&mission_path, &scene)?;
    let budgets = Budgets::load(&files.budgets)?;
    let robot = aisle_config::load::<aisle_robot::RobotConfig>(&files.robot)?;
    let f = &robot.footprint;
    let footprints = Footprints {
        alone: f.alone.footprint(),
        alone_margin: f.alone.margin,
        carrying: f.carrying.footprint(),
        carrying_margin: f.carrying.margin,
    };
    let restart = RestartConfig::load(&files.restart)?;
    let kills = opts
        .kill
        .iter()
        .map(|k| parse_kill(k))
        .collect::<anyhow::Result<Vec<_>>>()?;
    if let Some(n) = &opts.crash_on_start
        && NodeKind::from_name(n).is_none_or(|k| !NodeKind::LAUNCHED.contains(&k))
    {
        bail!("--crash-on-start: no node `{n}`");
    }
    Ok(Loaded {
        restart,
        kills,
        scene,
        mission,
        budgets,
        footprints,
    })
}

/// Runs the mission; `Err` only when the group could not be run at all.
pub fn run(opts: &RunOptions) -> anyhow::Result<RunOutcome> {
    let loaded = load(opts)?;
    let instance = Instance::unique(&run_base_dir());
    tracing::info!(
        "instance --prefix {} --root {}",
        instance.prefix,
        instance.root.display()
    );
    let exe = current_exe().map_err(|e| anyhow!(e))?;
    let wall_start = Instant::now();
    let result = Session::start(opts, &loaded, &instance, exe).map(|mut s| {
        let r = s.drive(opts, &loaded);
        let report = s.finish(opts, &loaded, wall_start, &r);
        (report, r)
    });
    // Every port is dropped by now; remove what is left of the instance.
    let cleanup = instance.remove();
    let (report, r) = result?;
    if let Err(e) = cleanup {
        tracing::warn!("could not remove instance {}: {e}", instance.prefix);
    }
    print!("{}", report.summary());
    let rows: Vec<_> = report.latency.clone();
    if !rows.is_empty() {
        let table: Vec<crate::budgets::StageSummary> = rows
            .iter()
            .map(|r| crate::budgets::StageSummary {
                stage: r.stage.clone(),
                samples: r.samples,
                p50_ms: r.p50_ms,
                p99_ms: r.p99_ms,
                max_ms: r.max_ms,
                jitter_ms: r.jitter_ms,
                budget_ms: r.budget_ms,
                misses: r.misses,
            })
            .collect();
        print!("{}", format_table(&table));
    }
    if let Some(path) = &opts.report {
        let json = serde_json::to_string_pretty(&report)?;
        std::fs::write(path, json)
            .with_context(|| format!("writing the report {}", path.display()))?;
    }
    match r {
        Ok(()) => Ok(RunOutcome {
            succeeded: report.success,
            report,
        }),
        Err(Halt::Interrupted) => bail!("interrupted: the process group was stopped"),
        Err(Halt::Other(e)) => Err(e),
    }
}

struct Ports {
    tick: Subscriber<Tick>,
    tick_done_in: Subscriber<TickDone>,
    tick_done: Publisher<TickDone>,
    robot: Subscriber<RobotState>,
    truth: Subscriber<WorldTruth>,
    trajectory: Subscriber<Trajectory>,
    planner: Client<PlanRequest, PlanResponse>,
    status: Publisher<MissionStatus>,
}

/// Keeps the newest state each stateful node published (simulator state, global map,
/// controller band) and publishes it again when that node is restarted: a publisher's
/// history dies with its process, so the state that must survive a crash is held here.
struct Keeper {
    sim_state: Subscriber<SimState>,
    global_map: Subscriber<OccupancyGrid>,
    band: Subscriber<ControllerBand>,
    sim_state_out: Publisher<SimState>,
    global_map_out: Publisher<OccupancyGrid>,
    band_out: Publisher<ControllerBand>,
    sim_state_copy: Vec<u8>,
    global_map_copy: Vec<u8>,
    band_copy: Vec<u8>,
}

impl Keeper {
    fn take(&mut self) -> Result<(), Halt> {
        fn keep<M: aisle_messages::Message>(
            sub: &Subscriber<M>,
            copy: &mut Vec<u8>,
        ) -> Result<(), Halt> {
            if let Some(s) = sub.latest()? {
                copy.clear();
                copy.extend_from_slice(message_bytes(&*s));
            }
            Ok(())
        }
        keep(&self.sim_state, &mut self.sim_state_copy)?;
        keep(&self.global_map, &mut self.global_map_copy)?;
        keep(&self.band, &mut self.band_copy)
    }

    fn republish(&mut self, kind: NodeKind) -> Result<(), Halt> {
        match kind {
            NodeKind::Simulator if !self.sim_state_copy.is_empty() => {
                self.sim_state_out.publish_bytes(&self.sim_state_copy)?
            }
            NodeKind::Mapper if !self.global_map_copy.is_empty() => {
                self.global_map_out.publish_bytes(&self.global_map_copy)?
            }
            NodeKind::TebController if !self.band_copy.is_empty() => {
                self.band_out.publish_bytes(&self.band_copy)?
            }
            _ => {}
        }
        Ok(())
    }

    fn refresh(&self) -> Result<(), Halt> {
        self.sim_state_out.update_connections()?;
        self.global_map_out.update_connections()?;
        self.band_out.update_connections()?;
        Ok(())
    }
}

/// The children and their health: liveness by reaping and by heartbeat, restarts
/// against the policy, readiness. Kept apart from the data ports so that a wait on a
/// port can watch the children at the same time.
struct Watch {
    // Field order matters: ports drop before the bus node.
    info: Publisher<InstanceInfo>,
    /// The supervisor's own state publishers (history 1): a node that (re)joins gets
    /// them through `update_connections`.
    sim_command: Publisher<SimCommand>,
    goal: Publisher<ControllerGoal>,
    mapper_control: Publisher<MapperControl>,
    keeper: Keeper,
    heartbeat: Subscriber<Heartbeat>,
    _bus: Bus,
    group: ProcessGroup,
    restart: RestartConfig,
    restarts: RestartBook,
    last_seen: HashMap<NodeKind, Instant>,
    ready: Vec<NodeKind>,
    /// The nodes of this run (the five, and a recorder when recording).
    expected: Vec<NodeKind>,
    /// The mission runs: a node that dies now resumes from its published state.
    running: bool,
    /// Nodes restarted since the session last looked (plans to resend, a robot to stop).
    restarted: Vec<NodeKind>,
    started: Instant,
    instance: Instance,
    last_hygiene: Instant,
}

impl Watch {
    /// Reaps dead children and restarts them within the policy, kills nodes whose
    /// heartbeats stopped, serves the instance announcement to (re)joining nodes.
    fn check(&mut self) -> Result<(), Halt> {
        self.drain_heartbeats()?;
        self.keeper.take()?;
        while let Some((kind, status)) = self.group.poll_exit() {
            if kind == NodeKind::Recorder {
                // Losing the record must not stop the robot: go on without it.
                tracing::error!(
                    "the recorder {}; the run goes on unrecorded",
                    describe(&status)
                );
                self.expected.retain(|k| *k != NodeKind::Recorder);
                continue;
            }
            let policy = self.restart.policy(kind);
            let now_s = self.started.elapsed().as_secs_f64();
            let last = self
                .group
                .last_line(kind)
                .map(|l| format!("; its last words: {l}"))
                .unwrap_or_default();
            match self.restarts.allow(kind, &policy, now_s) {
                Ok(n) => {
                    tracing::warn!(
                        "node `{}` {}{last}: restarting it ({n} of {} within {} s)",
                        kind.name(),
                        describe(&status),
                        policy.max_restarts,
                        policy.window_s
                    );
                    // Its iceoryx2 node is dead: free what it held before its successor joins,
                    // and hand the successor the state the dead one published.
                    self._bus.cleanup_dead_nodes();
                    if self.running {
                        self.keeper.republish(kind)?;
                    }
                    self.ready.retain(|k| *k != kind);
                    self.group
                        .spawn(kind, self.running)
                        .map_err(|e| Halt::Other(anyhow!(e)))?;
                    self.last_seen.insert(kind, Instant::now());
                    self.restarted.push(kind);
                }
                Err(n) => {
                    return Err(Halt::Other(anyhow!(
                        "node `{}` {}{last}; it was restarted {n} times within {} s, the limit of config/restart.toml",
                        kind.name(),
                        describe(&status),
                        policy.window_s
                    )));
                }
            }
        }
        let now = Instant::now();
        for kind in NodeKind::LAUNCHED
            .into_iter()
            .filter(|k| self.expected.contains(k))
        {
            let timeout = Duration::from_secs_f64(self.restart.policy(kind).heartbeat_timeout_s);
            if self
                .last_seen
                .get(&kind)
                .is_some_and(|t| now.duration_since(*t) > timeout)
            {
                tracing::warn!(
                    "node `{}` sent no heartbeat for {:.1} s: killing it",
                    kind.name(),
                    timeout.as_secs_f64()
                );
                self.group.kill(kind);
                // Reaped (and restarted) by the next check; do not kill it twice.
                self.last_seen.insert(kind, now);
            }
        }
        self.info.update_connections()?;
        self.sim_command.update_connections()?;
        self.goal.update_connections()?;
        self.mapper_control.update_connections()?;
        self.keeper.refresh()?;
        // New nodes (restarts) create new segments: keep them private, twice a second.
        if self.last_hygiene.elapsed() > Duration::from_millis(500) {
            self.last_hygiene = Instant::now();
            self.instance.restrict_shm_permissions();
        }
        Ok(())
    }

    fn note_heartbeat(&mut self, hb: &Heartbeat) {
        let Some(kind) = NodeKind::from_u32(hb.node) else {
            return;
        };
        self.last_seen.insert(kind, Instant::now());
        if matches!(
            NodeState::from_u32(hb.state),
            Some(NodeState::Ready | NodeState::Running)
        ) && !self.ready.contains(&kind)
        {
            self.ready.push(kind);
        }
    }

    fn drain_heartbeats(&mut self) -> Result<(), Halt> {
        while let Some(hb) = self.heartbeat.receive()? {
            let hb = *hb;
            self.note_heartbeat(&hb);
        }
        Ok(())
    }

    /// Sleeps on the heartbeat service up to `timeout`, taking note of what arrives.
    fn heartbeat_wait(&mut self, timeout: Duration) -> Result<(), Halt> {
        let mut seen = Vec::new();
        let _ = self.heartbeat.wait_for(
            timeout,
            |hb| {
                seen.push(*hb);
                false
            },
            || {},
        )?;
        for hb in &seen {
            self.note_heartbeat(hb);
        }
        Ok(())
    }

    /// Waits for a message matching `pred` on `sub` while watching the children.
    fn wait_on<M: aisle_messages::Message + Copy>(
        &mut self,
        sub: &Subscriber<M>,
        limit: Duration,
        what: &str,
        mut pred: impl FnMut(&M) -> bool,
    ) -> Result<M, Halt> {
        let started = Instant::now();
        loop {
            let (outcome, sample) = sub.wait_for(POLL, &mut pred, || {})?;
            if outcome == WaitOutcome::Matched
                && let Some(s) = sample
            {
                return Ok(*s);
            }
            let restarts = self.restarted.len();
            self.check()?;
            if self.restarted.len() > restarts {
                // A node is coming back: give it the time it needs to resume.
                return self.wait_on(sub, limit, what, pred);
            }
            if started.elapsed() > limit {
                return Err(Halt::Other(anyhow!(
                    "no {what} within {} s",
                    limit.as_secs()
                )));
            }
        }
    }
}

struct Session {
    // Field order matters: ports drop before the bus node, and both before the group
    // is stopped in `finish`.
    ports: Ports,
    watch: Watch,
    mode: TickMode,
    book: LatencyBook,
    mission: Mission,
    goal_id: u64,
    command_id: u64,
    pose: Pose2,
    now_s: f64,
    ticks: u64,
    driven: Vec<[f64; 4]>,
    path_length: f64,
    truth: Option<WorldTruth>,
    last_progress_s: f64,
}

impl Session {
    fn start(
        opts: &RunOptions,
        loaded: &Loaded,
        instance: &Instance,
        exe: PathBuf,
    ) -> anyhow::Result<Session> {
        let (bus, info) =
            Bus::create_instance(instance, opts.seed, opts.mode).with_context(|| {
                format!(
                    "creating the iceoryx2 instance under {}",
                    instance.root.display()
                )
            })?;
        let heartbeat = bus.subscriber(topics::HEARTBEAT)?;
        let ports = Ports {
            tick: bus.subscriber(topics::TICK)?,
            tick_done_in: bus.subscriber(topics::TICK_DONE)?,
            tick_done: bus.publisher(topics::TICK_DONE)?,
            robot: bus.subscriber(topics::ROBOT_STATE)?,
            truth: bus.subscriber(topics::WORLD_TRUTH)?,
            trajectory: bus.subscriber(topics::TRAJECTORY)?,
            planner: Client::new(
                bus.publisher(topics::PLAN_REQUEST)?,
                bus.subscriber(topics::PLAN_RESPONSE)?,
            ),
            status: bus.publisher(topics::MISSION_STATUS)?,
        };
        let cfg = &loaded.mission;
        let bodies = loaded
            .scene
            .movable_bodies()
            .map(|b| NamedBody {
                name: b.name.clone(),
                pose: b.pose,
                footprint: b.footprint(),
            })
            .collect();
        let mission = Mission::new(cfg.clone(), loaded.footprints, bodies);
        let start = cfg.start;
        let dt_ns = cfg.dt_ns();
        let every = cfg.controller_every();
        let lidar_off = opts.lidar_off;
        let crash = opts.crash_on_start.clone();
        // The recorder runs in the nodes' working directory: give it an absolute path.
        let record = match &opts.record {
            Some(p) if p.is_relative() => Some(std::env::current_dir()?.join(p)),
            other => other.clone(),
        };
        let mut expected: Vec<NodeKind> = NodeKind::LAUNCHED.to_vec();
        if record.is_some() {
            expected.push(NodeKind::Recorder);
        }
        let extra = move |kind: NodeKind| -> Vec<String> {
            let mut v = vec![
                "--dt-ns".to_string(),
                dt_ns.to_string(),
                "--controller-every".to_string(),
                every.to_string(),
                format!("--start={},{},{}", start[0], start[1], start[2]),
            ];
            if lidar_off && kind == NodeKind::Lidar {
                v.push("--lidar-off".into());
            }
            if crash.as_deref() == Some(kind.name()) {
                v.push("--fail-on-start".into());
            }
            if kind == NodeKind::Simulator && record.is_some() {
                v.push("--recorded".into());
            }
            if kind == NodeKind::Recorder
                && let Some(out) = &record
            {
                v.push("--out".into());
                v.push(out.display().to_string());
            }
            v
        };
        let config_dir = std::fs::canonicalize(&opts.config_dir)
            .with_context(|| format!("config directory {}", opts.config_dir.display()))?;
        let spec = LaunchSpec {
            exe,
            instance: instance.clone(),
            config_dir,
            extra: Box::new(extra),
        };
        let mut group = ProcessGroup::new(spec);
        for kind in expected.iter().copied() {
            if let Err(e) = group.spawn(kind, false) {
                group.stop(GRACE);
                bail!(e);
            }
        }
        let now = Instant::now();
        let keeper = Keeper {
            sim_state: bus.subscriber(topics::SIM_STATE)?,
            global_map: bus.subscriber(topics::GLOBAL_MAP)?,
            band: bus.subscriber(topics::CONTROLLER_BAND)?,
            sim_state_out: bus.publisher(topics::SIM_STATE)?,
            global_map_out: bus.publisher(topics::GLOBAL_MAP)?,
            band_out: bus.publisher(topics::CONTROLLER_BAND)?,
            sim_state_copy: Vec::new(),
            global_map_copy: Vec::new(),
            band_copy: Vec::new(),
        };
        let watch = Watch {
            sim_command: bus.publisher(topics::SIM_COMMAND)?,
            goal: bus.publisher(topics::CONTROLLER_GOAL)?,
            mapper_control: bus.publisher(topics::MAPPER_CONTROL)?,
            keeper,
            group,
            info,
            heartbeat,
            _bus: bus,
            restart: loaded.restart.clone(),
            restarts: RestartBook::default(),
            last_seen: NodeKind::LAUNCHED.iter().map(|k| (*k, now)).collect(),
            ready: Vec::new(),
            expected,
            running: false,
            restarted: Vec::new(),
            started: now,
            instance: instance.clone(),
            last_hygiene: now,
        };
        Ok(Session {
            ports,
            watch,
            mode: opts.mode,
            book: LatencyBook::default(),
            mission,
            goal_id: 0,
            command_id: 0,
            pose: cfg.start_pose(),
            now_s: 0.0,
            ticks: 0,
            driven: Vec::new(),
            path_length: 0.0,
            truth: None,
            last_progress_s: f64::NEG_INFINITY,
        })
    }

    /// Watches the children (see [`Watch::check`]); a realtime run whose controller
    /// died stops the robot at once.
    fn supervise(&mut self) -> Result<(), Halt> {
        self.watch.check()?;
        self.after_restarts()
    }

    fn after_restarts(&mut self) -> Result<(), Halt> {
        if self.mode == TickMode::Realtime
            && self.watch.restarted.contains(&NodeKind::TebController)
        {
            self.watch
                .restarted
                .retain(|k| *k != NodeKind::TebController);
            // Its timeline may run for seconds: stop now; motion resumes with the
            // restarted controller's first fresh trajectory.
            self.sim_command(SimCommandKind::Stop, None)?;
        }
        Ok(())
    }

    fn wait_ready(&mut self) -> Result<(), Halt> {
        let started = Instant::now();
        while self
            .watch
            .expected
            .iter()
            .any(|k| !self.watch.ready.contains(k))
        {
            self.watch.check()?;
            self.watch.heartbeat_wait(POLL)?;
            if started.elapsed() > READY_TIMEOUT {
                let missing: Vec<&str> = self
                    .watch
                    .expected
                    .iter()
                    .filter(|k| !self.watch.ready.contains(k))
                    .map(|k| k.name())
                    .collect();
                return Err(Halt::Other(anyhow!(
                    "not ready within {} s: {}",
                    READY_TIMEOUT.as_secs(),
                    missing.join(", ")
                )));
            }
        }
        self.watch.running = true;
        self.watch.instance.restrict_shm_permissions();
        tracing::info!(
            "all {} nodes ready after {:.2} s",
            self.watch.ready.len(),
            started.elapsed().as_secs_f64()
        );
        Ok(())
    }

    fn stamp(&self) -> Stamp {
        Stamp {
            stamp_ns: (self.now_s * 1e9).round() as u64,
            tick: self.ticks,
            tick_wall_ns: clock::monotonic_ns(),
        }
    }

    fn sim_command(&mut self, kind: SimCommandKind, body: Option<(i32, &str)>) -> Result<(), Halt> {
        self.command_id += 1;
        let id = self.command_id;
        let stamp = self.stamp();
        self.watch.sim_command.publish(stamp, |m| {
            m.command_id = id;
            m.kind = kind as u32;
            m.body_index = body.map_or(-1, |b| b.0);
            if let Some((_, name)) = body {
                write_name(&mut m.name, name);
            }
        })?;
        Ok(())
    }

    fn drive(&mut self, opts: &RunOptions, loaded: &Loaded) -> Result<(), Halt> {
        self.wait_ready()?;
        self.sim_command(SimCommandKind::Start, None)?;
        let stall = if self.mode == TickMode::Lockstep {
            LOCKSTEP_STALL
        } else {
            REALTIME_STALL
        };
        let mut next_tick = 0u64;
        let mut started = false;
        let mut kills = loaded.kills.clone();
        let planner_timeout = Duration::from_secs_f64(loaded.mission.planner_timeout_s);
        loop {
            let tick =
                self.watch
                    .wait_on(&self.ports.tick, stall, "tick from the simulator", |_| true)?;
            // Realtime: act on the newest tick; lockstep delivers them one by one.
            let mut tick = tick;
            while let Some(t) = self.ports.tick.receive()? {
                tick = *t;
            }
            // Ticks may keep coming (realtime) while a node is dead: look every tick.
            self.supervise()?;
            let k = tick.header.tick;
            if k < next_tick {
                // A restarted simulator repeats the tick it died in: acknowledge again,
                // act once.
                if self.mode == TickMode::Lockstep {
                    self.ports.tick_done.publish(Stamp::of(&tick.header), |m| {
                        m.node = NodeKind::Supervisor as u32;
                        m.status = StageStatus::Done as u32;
                    })?;
                }
                continue;
            }
            next_tick = k + 1;
            self.ticks = k;
            self.now_s = tick.header.stamp_ns as f64 * 1e-9;
            let controller_tick = tick.stages & STAGE_CONTROLLER != 0;
            if self.mode == TickMode::Lockstep {
                // Act after the perception pipeline (and the controller) finished this tick,
                // so plans see the newest map and the run is repeatable.
                let mut pending: Vec<NodeKind> = vec![NodeKind::Lidar, NodeKind::Mapper];
                if controller_tick {
                    pending.push(NodeKind::TebController);
                }
                while !pending.is_empty() {
                    let book = &mut self.book;
                    let done = self.watch.wait_on(
                        &self.ports.tick_done_in,
                        stall,
                        "acknowledgement",
                        |d| {
                            record_done(book, d);
                            d.header.tick == k && pending.iter().any(|p| *p as u32 == d.node)
                        },
                    )?;
                    pending.retain(|p| *p as u32 != done.node);
                }
            }
            // Fault injection: a node killed at a known tick, restarted as after a crash.
            // (Realtime may skip the very tick: the first tick at or after it counts.)
            kills.retain(|(kind, at)| {
                if *at > k {
                    return true;
                }
                tracing::warn!("killing `{}` at tick {k}, as --kill asks", kind.name());
                self.watch.group.kill(*kind);
                false
            });
            let work = Instant::now();
            while let Some(d) = self.ports.tick_done_in.receive()? {
                record_done(&mut self.book, &d);
            }
            if let Some(rs) = self.ports.robot.latest()? {
                let pose: Pose2 = rs.pose.into();
                if !self.driven.is_empty() {
                    self.path_length += pose.distance(&self.pose);
                }
                self.pose = pose;
                self.driven
                    .push([rs.header.stamp_ns as f64 * 1e-9, pose.x, pose.y, pose.theta]);
            }
            if let Some(t) = self.ports.truth.latest()? {
                self.truth = Some(*t);
            }
            let mut actions = Vec::new();
            if !started {
                started = true;
                actions = self.mission.start_leg(self.now_s, self.pose);
            }
            while let Some(traj) = self.ports.trajectory.receive()? {
                let e2e = traj
                    .header
                    .publish_wall_ns
                    .saturating_sub(traj.header.tick_wall_ns);
                self.book.record("end_to_end", e2e);
                if traj.goal_id == self.goal_id && traj.goal_id != 0 {
                    let n = (traj.len as usize).min(traj.commands.len());
                    let increasing = traj.commands[..n].windows(2).all(|w| w[1].t > w[0].t);
                    tracing::debug!(
                        "t = {:.1} s goal {}: exit flag {}, reached {}, {} commands, first (v {:.3}, w {:.3}), {} iterations",
                        self.now_s,
                        traj.goal_id,
                        traj.exit_flag,
                        traj.reached_goal,
                        n,
                        traj.commands[0].v,
                        traj.commands[0].w,
                        traj.iterations
                    );
                    let report = ControllerReport {
                        reached_goal: traj.reached_goal != 0,
                        exit_flag: traj.exit_flag,
                        timestamps_increasing: increasing,
                    };
                    actions.extend(self.mission.on_controller(self.now_s, self.pose, report));
                }
            }
            actions.extend(self.mission.on_tick(self.now_s, self.pose));
            let mut planner_ns = 0;
            self.execute(actions, loaded, planner_timeout, &mut planner_ns)?;
            self.publish_status()?;
            self.progress(opts);
            let compute = (work.elapsed().as_nanos() as u64).saturating_sub(planner_ns);
            self.book.record("supervisor", compute);
            if self.mode == TickMode::Lockstep {
                self.ports.tick_done.publish(Stamp::of(&tick.header), |m| {
                    m.node = NodeKind::Supervisor as u32;
                    m.status = StageStatus::Done as u32;
                    m.compute_ns = compute;
                })?;
            }
            self.watch.restarted.clear();
            if self.mission.is_finished() {
                return Ok(());
            }
        }
    }

    fn execute(
        &mut self,
        actions: Vec<Action>,
        loaded: &Loaded,
        planner_timeout: Duration,
        planner_ns: &mut u64,
    ) -> Result<(), Halt> {
        let mut queue: std::collections::VecDeque<Action> = actions.into();
        while let Some(action) = queue.pop_front() {
            match action {
                Action::Plan {
                    start,
                    goal,
                    footprint,
                    margin,
                    use_detections,
                } => {
                    let t0 = Instant::now();
                    let result = self.plan(
                        start,
                        goal,
                        footprint,
                        margin,
                        use_detections,
                        planner_timeout,
                    )?;
                    *planner_ns += t0.elapsed().as_nanos() as u64;
                    queue.extend(self.mission.on_plan(self.now_s, self.pose, result));
                }
                Action::Follow {
                    reference,
                    goal,
                    footprint,
                    margin,
                } => {
                    self.send_goal(
                        GoalMode::Follow,
                        &reference,
                        goal,
                        footprint,
                        margin,
                        loaded,
                    )?;
                }
                Action::Rotate {
                    goal,
                    footprint,
                    margin,
                } => {
                    self.send_goal(
                        GoalMode::RotateInPlace,
                        &[],
                        goal,
                        footprint,
                        margin,
                        loaded,
                    )?;
                }
                Action::Attach(name) => {
                    let index = loaded.scene.body(&name).map_or(-1, |(i, _)| i as i32);
                    self.sim_command(SimCommandKind::Attach, Some((index, &name)))?;
                }
                Action::Detach => self.sim_command(SimCommandKind::Detach, None)?,
                Action::MapperControl { ignore, carried } => {
                    let tol = loaded.mission.goal_tolerance;
                    let carry_margin = tol[0].max(tol[1]) + IGNORE_MARGIN;
                    let stamp = self.stamp();
                    self.watch.mapper_control.publish(stamp, |m| {
                        // Margins: range noise on the legs' faces (ignore), and how far the
                        // robot may stand off the rack's centre when it lifts it (carried:
                        // the goal tolerance).
                        if let Some((pose, fp)) = ignore {
                            m.ignore = rect(pose, fp.inflated(IGNORE_MARGIN));
                        }
                        if let Some(fp) = carried {
                            m.carried = rect(Pose2::default(), fp.inflated(carry_margin));
                        }
                    })?;
                }
                Action::Halt => {
                    self.send_goal(
                        GoalMode::Idle,
                        &[],
                        self.pose,
                        loaded.footprints.alone,
                        0.0,
                        loaded,
                    )?;
                    self.sim_command(SimCommandKind::Stop, None)?;
                }
            }
        }
        Ok(())
    }

    fn plan(
        &mut self,
        start: Pose2,
        goal: Pose2,
        footprint: Footprint,
        margin: f64,
        use_detections: bool,
        timeout: Duration,
    ) -> Result<Result<Vec<PathPose>, PlanFailure>, Halt> {
        let stamp = self.stamp();
        let request = |m: &mut PlanRequest| {
            m.start = start.into();
            m.goal = goal.into();
            m.footprint_length = footprint.length;
            m.footprint_width = footprint.width;
            m.margin = margin;
            m.use_detections = use_detections as u32;
            m.timeout_ms = timeout.as_millis() as u32;
        };
        let mut id = self.ports.planner.send(stamp, request)?;
        let mut started = Instant::now();
        // The planner bounds its own time; allow it a second more to answer.
        let limit = timeout + Duration::from_secs(1);
        loop {
            if let Some(resp) = self.ports.planner.wait(id, POLL, || {})? {
                self.book.record("global_planner", resp.solve_ns);
                let status = PlanStatus::from_u32(resp.status);
                return Ok(match status {
                    Some(PlanStatus::Ok) => {
                        let n = (resp.len as usize).min(MAX_PATH_POSES);
                        let path: Vec<PathPose> = resp.poses[..n]
                            .iter()
                            .filter_map(PathPoseMsg::to_path_pose)
                            .collect();
                        if path.len() == n && n > 0 {
                            Ok(path)
                        } else {
                            Err(PlanFailure(
                                "the planner's path is empty or malformed".into(),
                            ))
                        }
                    }
                    Some(s) => Err(PlanFailure(format!(
                        "{} after {} expansions ({:.1} ms)",
                        plan_status_text(s),
                        resp.expansions,
                        resp.solve_ns as f64 / 1e6
                    ))),
                    None => Err(PlanFailure(format!("unknown plan status {}", resp.status))),
                });
            }
            self.supervise()?;
            if self.watch.restarted.contains(&NodeKind::GlobalPlanner) {
                // The planner died with the request: ask its successor.
                self.watch
                    .restarted
                    .retain(|k| *k != NodeKind::GlobalPlanner);
                id = self.ports.planner.send(stamp, request)?;
                started = Instant::now();
            }
            if started.elapsed() > limit {
                return Ok(Err(PlanFailure(format!(
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
        goal: Pose2,
        footprint: Footprint,
        margin: f64,
        loaded: &Loaded,
    ) -> Result<(), Halt> {
        if reference.len() > MAX_PATH_POSES {
            return Err(Halt::Other(anyhow!(
                "reference path of {} poses exceeds the message capacity of {MAX_PATH_POSES}",
                reference.len()
            )));
        }
        self.goal_id += 1;
        let id = self.goal_id;
        let tol = loaded.mission.goal_tolerance;
        let stamp = self.stamp();
        self.watch.goal.publish(stamp, |m| {
            m.goal_id = id;
            m.mode = mode as u32;
            m.len = reference.len() as u32;
            m.footprint_length = footprint.length;
            m.footprint_width = footprint.width;
            m.margin = margin;
            m.goal_tolerance = tol;
            m.target = goal.into();
            for (dst, src) in m.reference.iter_mut().zip(reference) {
                *dst = (*src).into();
            }
        })?;
        Ok(())
    }

    fn publish_status(&mut self) -> Result<(), Halt> {
        let m = &self.mission;
        let state = if m.succeeded() {
            MissionState::Succeeded
        } else if m.is_finished() {
            MissionState::Failed
        } else if m.is_planning() {
            MissionState::Planning
        } else if m.is_rotating() {
            MissionState::Rotating
        } else {
            MissionState::Driving
        };
        let (segment, segments, replans) = (
            m.leg_index() as u32,
            m.leg_count() as u32,
            m.replans_total(),
        );
        let text = m
            .failure()
            .map(str::to_string)
            .unwrap_or_else(|| m.leg_name().to_string());
        let distance = self.path_length;
        let stamp = self.stamp();
        self.ports.status.publish(stamp, |s| {
            s.state = state as u32;
            s.segment = segment;
            s.segments = segments;
            s.replans = replans;
            s.distance = distance;
            write_name(&mut s.text, &text);
        })?;
        Ok(())
    }

    fn progress(&mut self, opts: &RunOptions) {
        if opts.quiet || self.now_s - self.last_progress_s < 5.0 {
            return;
        }
        self.last_progress_s = self.now_s;
        let m = &self.mission;
        println!(
            "[{:7.1} s] leg {}/{} {:<14} driven {:6.2} m  replans {}",
            self.now_s,
            m.leg_index() + 1,
            m.leg_count(),
            m.leg_name(),
            self.path_length,
            m.replans_total()
        );
    }

    /// Stops the robot and the group and assembles the report.
    fn finish(
        &mut self,
        opts: &RunOptions,
        loaded: &Loaded,
        wall_start: Instant,
        outcome: &Result<(), Halt>,
    ) -> RunReport {
        if let Err(halt) = outcome {
            let why = match halt {
                Halt::Interrupted => "interrupted".to_string(),
                Halt::Other(e) => format!("{e:#}"),
            };
            let _ = self.mission.abort(self.now_s, self.pose, why);
            // Whatever happened, the robot must not keep moving.
            let _ = self.sim_command(SimCommandKind::Stop, None);
        }
        self.watch.group.stop(GRACE);
        let truth = self.truth.as_ref();
        let bodies_final = truth
            .map(|t| {
                t.bodies[..(t.len as usize).min(t.bodies.len())]
                    .iter()
                    .filter(|b| b.is_static == 0)
                    .map(|b| BodyPose {
                        name: read_name(&b.name).to_string(),
                        x: b.pose.x,
                        y: b.pose.y,
                        theta: b.pose.theta,
                    })
                    .collect()
            })
            .unwrap_or_default();
        let m = &self.mission;
        RunReport {
            success: m.succeeded(),
            failure: m.failure().map(str::to_string),
            mode: match self.mode {
                TickMode::Lockstep => "lockstep".into(),
                TickMode::Realtime => "realtime".into(),
            },
            seed: opts.seed,
            lidar: !opts.lidar_off,
            sim_time_s: self.now_s,
            wall_time_s: wall_start.elapsed().as_secs_f64(),
            ticks: self.ticks,
            path_length_m: self.path_length,
            min_clearance_m: truth.map_or(f64::NAN, |t| t.min_clearance),
            collisions: truth.map_or(0, |t| t.collisions),
            replans: m.replans_total(),
            restarts: self.watch.restarts.total(),
            legs: m.results.iter().map(SerdeLeg::from).collect(),
            latency: self
                .book
                .summarise(&loaded.budgets)
                .iter()
                .map(SerdeStage::from)
                .collect(),
            driven_path: std::mem::take(&mut self.driven),
            reference_paths: m
                .reference_paths
                .iter()
                .map(|(leg, poses)| ReferencePath {
                    leg: *leg,
                    poses: poses
                        .iter()
                        .map(|p| [p.pose.x, p.pose.y, p.pose.theta, p.direction.as_i8() as f64])
                        .collect(),
                })
                .collect(),
            bodies_final,
        }
    }
}

fn record_done(book: &mut LatencyBook, d: &TickDone) {
    // Idle acknowledgements (the controller between its ticks) are not work.
    if let Some(kind) = NodeKind::from_u32(d.node)
        && kind != NodeKind::Supervisor
        && d.status != StageStatus::Idle as u32
    {
        book.record(kind.name(), d.compute_ns);
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
        PlanStatus::NoPath => "no path exists",
        PlanStatus::Timeout => "the search ran out of time",
        PlanStatus::InvalidRequest => "the request is invalid",
    }
}
