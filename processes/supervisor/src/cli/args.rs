//! The arguments of `run`, `replay`, `record` and the hidden `node`, and their
//! conversion into the plain option structs of the modules that do the work.

use crate::nodes::NodeOptions;
use crate::records::{RecordRequest, ReplayRequest};
use crate::session::RunOptions;
use aisle_messages::TickMode;
use clap::Args;
use std::path::{Path, PathBuf};

#[derive(Debug, Clone, Args)]
pub struct RunArgs {
    /// Tick on the wall clock at the update rate instead of lockstep.
    #[arg(long)]
    pub realtime: bool,
    /// Directory of the config files (default: the built-in config; `aisle init DIR`
    /// writes it out to edit).
    #[arg(long)]
    pub config_dir: Option<PathBuf>,
    /// Write the mission metrics and the latency table as JSON.
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// No progress lines, only the summary.
    #[arg(long)]
    pub quiet: bool,
    /// Seed of the run (lidar noise).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Switch the lidar off: it returns nothing (shows what the unseen obstacles do;
    /// pair it with --allow-collisions to watch the whole mission).
    #[arg(long)]
    pub no_lidar: bool,
    /// Report collisions without failing the mission. Without it the first collision
    /// stops the robot (as an e-stop would) and the run exits 1 naming the body.
    #[arg(long)]
    pub allow_collisions: bool,
    /// Mission file instead of `<config-dir>/mission.toml`.
    #[arg(long)]
    pub mission: Option<PathBuf>,
    /// Record every service to this MCAP file (raw payloads plus Foxglove channels).
    #[arg(long)]
    pub record: Option<PathBuf>,
    #[command(flatten)]
    pub live: crate::live_cli::LiveArgs,
    /// Write every latency sample to this CSV file (stage, tick, ms).
    #[arg(long)]
    pub samples: Option<PathBuf>,
    /// Fault injection: SIGKILL a node when the run reaches a tick, e.g. `lidar@120`
    /// (once; the node is restarted as after any crash). Repeatable.
    #[arg(long = "kill", value_name = "NODE@TICK")]
    pub kill: Vec<String>,
    /// Fault injection: this node fails at every start (tests the restart limit).
    #[arg(long, value_name = "NODE", hide = true)]
    pub crash_on_start: Option<String>,
    /// Spread the group over the hosts of this file (`config/hosts.toml` shows the
    /// format); each other host runs `aisle host --name NAME --hosts FILE` first.
    #[arg(long, value_name = "FILE")]
    pub hosts: Option<PathBuf>,
}

#[derive(Debug, Clone, Args)]
pub struct ReplayArgs {
    /// The MCAP record to replay.
    pub file: PathBuf,
    /// Instance prefix of the live group to publish into (as `aisle run` logs it);
    /// without --prefix/--root the replay creates its own instance (found by discovery).
    #[arg(long, requires = "root")]
    pub prefix: Option<String>,
    /// Instance root of the live group.
    #[arg(long, requires = "prefix")]
    pub root: Option<PathBuf>,
    /// Play the file again from its start when it ends, until Ctrl-C.
    #[arg(long = "loop", conflicts_with_all = ["check", "lockstep"])]
    pub looping: bool,
    /// Before the first sample, wait until the replayed topics have N subscribers.
    #[arg(long, value_name = "N", default_value_t = 0, conflicts_with_all = ["check", "lockstep"])]
    pub wait_subscribers: usize,
    /// Playback rate relative to the recording (omit with --fast for no pacing).
    #[arg(long, default_value_t = 1.0)]
    pub rate: f64,
    /// As fast as possible.
    #[arg(long)]
    pub fast: bool,
    /// Only these services (e.g. aisle/lidar/points); default all but instance and heartbeats.
    #[arg(long, num_args = 1..)]
    pub topics: Vec<String>,
    /// Skip the first seconds of the recording.
    #[arg(long, default_value_t = 0.0)]
    pub start: f64,
    /// Tick by tick: publish a tick's inputs, wait until the consumers (--wait-for)
    /// acknowledged it, then the next (a lockstep recording only). Without
    /// --prefix/--root the consumers are launched from this build in a new instance.
    #[arg(long, conflicts_with_all = ["rate", "fast"])]
    pub lockstep: bool,
    /// With --lockstep: the nodes whose acknowledgements pace the replay.
    #[arg(long, value_delimiter = ',', default_value = "mapper,teb_controller")]
    pub wait_for: Vec<String>,
    /// Regression check: launch a fresh mapper and controller, replay the recorded
    /// sensor traffic and goals into them in lockstep, compare their outputs with the
    /// recorded ones. Exit 0 identical, 1 diverged (first divergence printed), 2 error.
    #[arg(long, conflicts_with_all = ["prefix", "root", "rate", "fast", "topics", "start", "lockstep"])]
    pub check: bool,
    /// With --check or a --lockstep that launches its nodes: the config directory they
    /// use (default: the config files attached to the recording).
    #[arg(long, conflicts_with = "prefix")]
    pub config_dir: Option<PathBuf>,
}

#[derive(Debug, Args)]
pub struct RecordArgs {
    /// Instance prefix of the running group (as `aisle run` logs it).
    #[arg(long)]
    pub prefix: String,
    /// Instance root of the running group.
    #[arg(long)]
    pub root: PathBuf,
    /// The MCAP file to write.
    #[arg(short, long)]
    pub output: PathBuf,
    /// The group's config directory (attached to the file); default the built-in one.
    #[arg(long)]
    pub config_dir: Option<PathBuf>,
    /// The group's mission file, for the run metadata (start pose, tick rate); default
    /// the config directory's `mission.toml`.
    #[arg(long)]
    pub mission: Option<PathBuf>,
    /// Finalise after this many seconds without traffic (the group ended).
    #[arg(long, default_value_t = 5.0)]
    pub idle_stop: f64,
}

#[derive(Debug, Args)]
pub struct NodeCmd {
    /// The node: simulator, lidar, mapper, global_planner, teb_controller, recorder.
    pub name: String,
    /// Instance prefix of the group.
    #[arg(long)]
    pub prefix: String,
    /// Instance root of the group.
    #[arg(long)]
    pub root: PathBuf,
    /// The group's config directory.
    #[arg(long)]
    pub config_dir: PathBuf,
    /// Simulated time per tick, ns.
    #[arg(long, default_value_t = 100_000_000)]
    pub dt_ns: u64,
    /// The controller acts every this many ticks.
    #[arg(long, default_value_t = 5)]
    pub controller_every: u32,
    /// Start pose `x,y,heading`.
    #[arg(long, default_value = "0,0,0", allow_hyphen_values = true)]
    pub start: String,
    /// The lidar returns nothing (`aisle run --no-lidar`).
    #[arg(long)]
    pub lidar_off: bool,
    /// This node replaces one that died: resume from its published state.
    #[arg(long)]
    pub restarted: bool,
    #[command(flatten)]
    pub recorder: crate::live_cli::RecorderArgs,
    /// A recorder runs (the simulator waits for it in lockstep).
    #[arg(long)]
    pub recorded: bool,
    /// Fault injection for tests: fail at start, every time.
    #[arg(long, hide = true)]
    pub fail_on_start: bool,
}
impl RunArgs {
    /// The options of a run whose config directory is `config_dir` (resolved from
    /// `--config-dir` by the caller, who keeps a built-in one alive).
    pub fn options(self, config_dir: &Path) -> RunOptions {
        let args = self;
        RunOptions {
            config_dir: config_dir.to_path_buf(),
            mode: if args.realtime {
                TickMode::Realtime
            } else {
                TickMode::Lockstep
            },
            report: args.report,
            quiet: args.quiet,
            seed: args.seed,
            lidar_off: args.no_lidar,
            allow_collisions: args.allow_collisions,
            mission: args.mission,
            kill: args.kill,
            record: args.record,
            foxglove: args.live.foxglove,
            samples: args.samples,
            crash_on_start: args.crash_on_start,
            hosts: args.hosts,
        }
    }
}

impl From<ReplayArgs> for ReplayRequest {
    fn from(a: ReplayArgs) -> ReplayRequest {
        ReplayRequest {
            file: a.file,
            prefix: a.prefix,
            root: a.root,
            rate: a.rate,
            fast: a.fast,
            topics: a.topics,
            start: a.start,
            lockstep: a.lockstep,
            wait_for: a.wait_for,
            check: a.check,
            config_dir: a.config_dir,
            looping: a.looping,
            wait_subscribers: a.wait_subscribers,
        }
    }
}

impl RecordArgs {
    /// The request of a recording whose config directory is `config_dir`.
    pub fn request(self, config_dir: &Path) -> RecordRequest {
        let a = self;
        RecordRequest {
            config_dir: config_dir.to_path_buf(),
            prefix: a.prefix,
            root: a.root,
            output: a.output,
            mission: a.mission,
            idle_stop: a.idle_stop,
        }
    }
}

impl From<NodeCmd> for NodeOptions {
    fn from(cmd: NodeCmd) -> NodeOptions {
        NodeOptions {
            name: cmd.name,
            prefix: cmd.prefix,
            root: cmd.root,
            config_dir: cmd.config_dir,
            dt_ns: cmd.dt_ns,
            controller_every: cmd.controller_every,
            start: cmd.start,
            lidar_off: cmd.lidar_off,
            restarted: cmd.restarted,
            out: cmd.recorder.out,
            foxglove: cmd.recorder.foxglove,
            recorded: cmd.recorded,
            fail_on_start: cmd.fail_on_start,
        }
    }
}
