//! Bringing a session up: the iceoryx2 instance and the supervisor's ports, the
//! mission, and the process group launched with each node's command line. Knows
//! nothing of ticks or of what the nodes do once they run.

use super::health::NodeHealth;
use super::retained_state::RetainedState;
use super::run_config::RunConfig;
use super::{GRACE, RunOptions, Session};
use crate::launch::{LaunchSpec, ProcessGroup};
use crate::mission::{Mission, NamedBody};
use crate::remote::{RemoteNodes, SpreadStart};
use crate::restart::RestartBook;
use aisle_bus::{Bus, Client, Instance, Publisher, Subscriber};
use aisle_geometry::{Footprint, Pose2};
use aisle_messages::{
    MissionStatus, NodeKind, PlanRequest, PlanResponse, RobotState, Tick, TickDone, Trajectory,
    WorldTruth, topics,
};
use aisle_node::tick::Awaited;
use aisle_tools::latency::SampleBook;
use anyhow::{Context, bail};
use std::path::PathBuf;
use std::time::Instant;

/// The ports the tick loop reads and writes (the state publishers a joining node must
/// see live in [`NodeHealth`]).
pub(super) struct DataPorts {
    pub tick: Subscriber<Tick>,
    pub tick_done_in: Subscriber<TickDone>,
    pub tick_done: Publisher<TickDone>,
    pub robot: Subscriber<RobotState>,
    pub truth: Subscriber<WorldTruth>,
    pub trajectory: Subscriber<Trajectory>,
    pub planner: Client<PlanRequest, PlanResponse>,
    pub status: Publisher<MissionStatus>,
}

impl DataPorts {
    /// Connects every subscriber to the publishers that exist now.
    pub fn connect(&self) -> Result<(), aisle_bus::BusError> {
        self.tick.update_connections()?;
        self.tick_done_in.update_connections()?;
        self.robot.update_connections()?;
        self.truth.update_connections()?;
        self.trajectory.update_connections()?;
        self.planner.update_connections()
    }

    fn open(bus: &Bus) -> anyhow::Result<DataPorts> {
        Ok(DataPorts {
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
        })
    }
}

impl Session {
    /// Creates the instance, opens the ports and launches the group. The ports a
    /// restarted node must find its old state on are opened after the launch, as the
    /// supervisor's state publishers are.
    pub(super) fn start(
        opts: &RunOptions,
        config: &RunConfig,
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
        let ports = DataPorts::open(&bus)?;
        let mission = new_mission(config);
        let (group, expected) = launch_group(opts, config, instance, exe, &bus)?;
        let now = Instant::now();
        let retained = RetainedState::open(&bus, &config.graph)?;
        let health = NodeHealth {
            sim_command: bus.publisher(topics::SIM_COMMAND)?,
            goal: bus.publisher(topics::CONTROLLER_GOAL)?,
            mapper_control: bus.publisher(topics::MAPPER_CONTROL)?,
            members: bus.publisher(topics::GROUP)?,
            retained,
            group,
            info,
            heartbeat,
            bus,
            restart: config.restart.clone(),
            restarts: RestartBook::default(),
            last_seen: expected.iter().map(|k| (*k, now)).collect(),
            ready: Vec::new(),
            expected,
            running: false,
            restarted: Vec::new(),
            declared_dead: Vec::new(),
            hung: Vec::new(),
            links: Default::default(),
            rejoining: Default::default(),
            resuming: Vec::new(),
            mode: opts.mode,
            command_id: 0,
            stamp: aisle_bus::Stamp::default(),
            started: now,
        };
        Ok(Session {
            ports,
            health,
            mode: opts.mode,
            book: SampleBook::default(),
            mission,
            goal_id: 0,
            trajectory_tick: None,
            pose: config.mission.start_pose(),
            carried: -1,
            grasp: None,
            now_s: 0.0,
            ticks: 0,
            driven: Vec::new(),
            path_length: 0.0,
            truth: None,
            collisions: Default::default(),
            last_progress_s: f64::NEG_INFINITY,
            graph: config.graph.clone(),
            awaited: Awaited::new(),
        })
    }
}

/// The mission of this run, with the scene's movable bodies it may name.
fn new_mission(config: &RunConfig) -> Mission {
    let bodies = config
        .scene
        .movable_bodies()
        .map(|b| NamedBody {
            name: b.name.clone(),
            pose: b.pose,
            footprint: b.footprint(),
            // What the robot can hit when it drives under the body: parts reaching
            // below the top of its collision body (a rack's legs, not its deck).
            parts: b
                .parts
                .iter()
                .filter(|p| p.z_min() < config.footprints.height)
                .map(|p| {
                    let at = Pose2::new(p.center[0], p.center[1], 0.0);
                    (at, Footprint::new(p.size[0], p.size[1]))
                })
                .collect(),
        })
        .collect();
    Mission::new(config.mission.clone(), config.footprints, bodies)
}

/// Spawns every node of the run (the five, and a recorder when recording); returns the
/// group and the nodes it expects to become ready.
fn launch_group(
    opts: &RunOptions,
    config: &RunConfig,
    instance: &Instance,
    exe: PathBuf,
    bus: &Bus,
) -> anyhow::Result<(ProcessGroup, Vec<NodeKind>)> {
    let cfg = &config.mission;
    let start = cfg.start;
    let dt_ns = cfg.dt_ns();
    let every = cfg.controller_every();
    let lidar_off = opts.lidar_off;
    let crash = opts.crash_on_start.clone();
    // The recorder runs in the nodes' working directory: give it an absolute path.
    let record = match &config.record {
        Some(p) if p.is_relative() => Some(std::env::current_dir()?.join(p)),
        other => other.clone(),
    };
    // A live view (`--foxglove`) is served by the recorder, with or without a file.
    let live = opts.foxglove;
    let recorder = record.is_some() || live.is_some();
    let mut expected: Vec<NodeKind> = config.graph.launched().collect();
    if recorder {
        expected.push(NodeKind::Recorder);
    }
    if let Some(addr) = live {
        tracing::info!("live view: open ws://{addr} in Foxglove or Lichtblick");
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
        if kind == NodeKind::Simulator && recorder {
            v.push("--recorded".into());
        }
        if kind == NodeKind::Recorder
            && let Some(addr) = live
        {
            v.push(format!("--foxglove={addr}"));
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
    let mut group = ProcessGroup::new(LaunchSpec {
        external: crate::launch::external_commands(&config.graph),
        exe,
        instance: instance.clone(),
        config_dir,
        extra: Box::new(extra),
        dt_ns,
        controller_every: every,
    });
    if let Some(placement) = &config.placement {
        let spread = SpreadStart {
            placement,
            graph: &config.graph,
            bus,
            instance,
            recorder,
            args: &|k| group.args_of(k),
            seed: opts.seed,
            mode: opts.mode as u32,
            dt_ns,
            controller_every: every,
            down_limit_s: config.restart.link.down_limit_s,
        };
        let remote = RemoteNodes::start(&spread, &expected)?;
        group.attach_remote(remote);
    }
    let local: Vec<NodeKind> = expected
        .iter()
        .copied()
        .filter(|k| group.is_local(*k))
        .collect();
    for kind in local {
        if let Err(e) = group.spawn(kind, false) {
            group.stop(GRACE);
            bail!(e);
        }
    }
    Ok((group, expected))
}
