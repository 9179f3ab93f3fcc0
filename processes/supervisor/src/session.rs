//! One run of the process group: load and check the configs, create an isolated
//! instance, launch the nodes, wait until all are ready, drive the mission tick by tick,
//! then stop the group and remove every trace of the instance.
//!
//! - [`run_config`]: everything loaded and checked before anything is launched.
//! - [`startup`]: the instance, the supervisor's ports, the launched group.
//! - [`health`]: the children's liveness, restarts and readiness.
//! - [`link_watch`]: the links to other hosts (a spread run): cut off, back, outages.
//! - [`retained_state`]: the state a restarted node resumes from.
//! - [`tick_loop`]: the loop over the simulator's ticks and the lockstep protocol.
//! - [`actions`]: the mission's actions carried out on the bus.
//! - [`grasp`]: picks and set-downs checked against the robot's state.
//! - [`status`]: the mission status and the progress lines.
//! - [`shutdown`]: stopping the group and the run's report.

mod actions;
mod collision;
mod grasp;
mod health;
mod link_watch;
mod retained_state;
mod run_config;
mod shutdown;
mod startup;
mod status;
mod tick_loop;

use crate::launch::current_exe;
use crate::mission::Mission;
use crate::report::RunReport;
use aisle_bus::{BusError, Instance};
use aisle_geometry::Pose2;
use aisle_messages::{TickMode, WorldTruth};
use aisle_tools::latency::{LatencyTable, SampleBook, format_table};
use anyhow::{Context, anyhow, bail};
use health::NodeHealth;
use run_config::RunConfig;
use startup::DataPorts;
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
    /// Collisions are reported but do not fail the mission (demonstrations).
    pub allow_collisions: bool,
    pub mission: Option<PathBuf>,
    /// Fault injection: SIGKILL a node at a tick (`lidar@120`).
    pub kill: Vec<String>,
    /// Fault injection: this node fails at every start.
    pub crash_on_start: Option<String>,
    /// Record every service to this MCAP file.
    pub record: Option<PathBuf>,
    /// Write every latency sample to this CSV file.
    pub samples: Option<PathBuf>,
    /// Serve the run live over the Foxglove WebSocket protocol here (`--foxglove`).
    pub foxglove: Option<std::net::SocketAddr>,
    /// `--hosts`: the placement of a group spread over hosts.
    pub hosts: Option<PathBuf>,
}

pub struct RunOutcome {
    pub succeeded: bool,
    pub report: RunReport,
}

/// Where instances live: `$AISLE_RUN_DIR`, else `<tmp>/aisle-<uid>`, created 0700 if
/// missing; refused (naming the variable, or the path, its owner and mode) when it is
/// not absolute or other users could write or swap it (`aisle_bus::run_dir`).
pub(crate) fn run_base_dir() -> anyhow::Result<PathBuf> {
    Ok(aisle_bus::run_dir::run_dir()?)
}

/// How long the children get to stop before they are killed.
const GRACE: Duration = Duration::from_millis(1500);
/// How long a wait on a port sleeps before it looks at the children again.
const POLL: Duration = Duration::from_millis(100);

/// Why the run stopped before the mission ended (as opposed to a mission that failed).
#[derive(Debug)]
enum RunAborted {
    /// A stop request (Ctrl-C or SIGTERM).
    Interrupted,
    /// The group could not go on: a node beyond its restart limit, a stall, a bus error.
    Error(anyhow::Error),
}

impl From<BusError> for RunAborted {
    fn from(e: BusError) -> Self {
        match e {
            BusError::StopRequested => RunAborted::Interrupted,
            e => RunAborted::Error(e.into()),
        }
    }
}

impl From<anyhow::Error> for RunAborted {
    fn from(e: anyhow::Error) -> Self {
        RunAborted::Error(e)
    }
}

/// Runs the mission; `Err` only when the group could not be run at all.
pub fn run(opts: &RunOptions) -> anyhow::Result<RunOutcome> {
    let config = RunConfig::load(opts)?;
    // The supervisor's own real-time options (`config/realtime.toml`); the nodes it
    // starts get none of them (they apply their own).
    aisle_node::realtime::apply_for(
        "supervisor",
        &opts.config_dir,
        &config.graph,
        aisle_node::realtime::Forks::Reset,
    )?;
    let base = run_base_dir()?;
    // What a killed run left is removed before this one adds its own.
    crate::clean::sweep_before_run(&base);
    let instance = Instance::unique(&base);
    tracing::info!(
        "instance --prefix {} --root {}",
        instance.prefix,
        instance.root.display()
    );
    let exe = current_exe().map_err(|e| anyhow!(e))?;
    let wall_start = Instant::now();
    let result = Session::start(opts, &config, &instance, exe).map(|mut s| {
        let r = s.drive(opts, &config);
        let report = s.finish(opts, &config, wall_start, &r);
        let samples = opts.samples.as_ref().map(|p| (p, s.write_samples(p)));
        (report, r, samples)
    });
    // Every port is dropped by now; remove what is left of the instance once the
    // processes that joined it from outside have left.
    wait_for_observers(&instance);
    let cleanup = instance.remove();
    let (report, r, samples) = result?;
    if let Err(e) = cleanup {
        tracing::warn!("could not remove instance {}: {e}", instance.prefix);
    }
    print!("{}", report.summary());
    if !report.latency.is_empty() {
        print!(
            "{}",
            format_table(&LatencyTable {
                stages: report.latency.clone(),
                tick_release: report.tick_release.clone(),
            })
        );
    }
    if !report.processes.is_empty() {
        print!("{}", crate::usage::format_table(&report.processes));
    }
    if let Some((path, written)) = samples {
        written.with_context(|| format!("writing the samples {}", path.display()))?;
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
        Err(RunAborted::Interrupted) => bail!("interrupted: the process group was stopped"),
        Err(RunAborted::Error(e)) => Err(e),
    }
}

/// How long a run waits, after its group stopped, for the processes that joined its
/// instance from outside (an external `aisle record`, `aisle echo`) to leave it.
const OBSERVER_GRACE: Duration = Duration::from_secs(10);

/// Waits (at most [`OBSERVER_GRACE`]) until no other process has a node in the
/// instance: removing the files of an observer's ports from under it is what iceoryx2
/// reports to the observer as a corrupted system when it closes them.
fn wait_for_observers(instance: &Instance) {
    let start = Instant::now();
    let mut told = false;
    loop {
        let pids = instance.attached_pids();
        if pids.is_empty() {
            return;
        }
        if start.elapsed() >= OBSERVER_GRACE {
            tracing::warn!(
                "removing the instance while processes {pids:?} are still attached to it"
            );
            return;
        }
        if !told {
            tracing::info!(
                "waiting up to {} s for processes {pids:?} attached to the instance to leave it",
                OBSERVER_GRACE.as_secs()
            );
            told = true;
        }
        std::thread::sleep(POLL);
    }
}

/// One running session: the ports, the children, the mission and what the run has
/// measured so far.
struct Session {
    // Field order matters: ports drop before the bus node, and both before the group
    // is stopped in `finish`.
    ports: DataPorts,
    health: NodeHealth,
    mode: TickMode,
    book: SampleBook,
    mission: Mission,
    goal_id: u64,
    /// The tick of the newest trajectory read: one seen again (sent again by a restarted
    /// controller, or by the retained state) is not reported to the mission twice.
    trajectory_tick: Option<u64>,
    pose: Pose2,
    /// The body the robot's state says it carries (-1: none), and the change the
    /// mission asked for and has not seen yet.
    carried: i32,
    grasp: Option<grasp::Expected>,
    now_s: f64,
    ticks: u64,
    driven: Vec<[f64; 4]>,
    path_length: f64,
    truth: Option<WorldTruth>,
    /// Collision events seen in ground truth so far.
    collisions: crate::collisions::CollisionWatch,
    last_progress_s: f64,
    /// Whose acknowledgements a lockstep tick waits for (`config/graph.toml`).
    graph: aisle_node::Graph,
    awaited: aisle_node::tick::Awaited,
}
