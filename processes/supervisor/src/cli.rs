//! Command-line interface. Parses arguments, sets up logging, converts the parsed
//! arguments into the plain option structs of the modules that do the work (which know
//! nothing of clap), and maps every outcome to an exit code ([`crate::exit`]): 0
//! success, 1 a negative verdict, 2 could not do what was asked.

use crate::nodes::NodeOptions;
use crate::records::{RecordRequest, ReplayRequest};
use crate::scenario_cli::{self, ScenarioCommand, SweepArgs};
use crate::session::RunOptions;
use crate::{check, exit, nodes, records, session};
use aisle_messages::TickMode;
use clap::{Args, Parser, Subcommand};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

#[derive(Debug, Parser)]
#[command(
    name = "aisle",
    version,
    about = "Warehouse robot navigation: run the seed mission, check configs, export maps",
    after_help = exit::TABLE
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Debug, Subcommand)]
pub enum Command {
    /// Launch the process group and run the mission of `config/mission.toml`.
    #[command(
        after_help = "Exit: 0 mission succeeded, 1 mission failed (a collision unless \
--allow-collisions, an unreachable goal, a timeout), 2 could not run (invalid config or \
mission, output path not writable, setup failure, the group could not go on, interrupted)."
    )]
    Run(RunArgs),
    /// Validate every file in the config directory, and across files: the lidar against
    /// the robot's stopping distance, the mission's start and goals against the scene
    /// and the map.
    #[command(
        after_help = "Exit: 0 valid, 1 invalid (the first error names file, line and \
key), 2 the config directory cannot be read."
    )]
    Check {
        #[arg(long)]
        config_dir: Option<PathBuf>,
    },
    /// Maps: export the scene's static map in ROS map_server format.
    #[command(after_help = "Exit: 0 written, 2 could not (invalid config, unwritable directory).")]
    Map {
        #[command(subcommand)]
        command: MapCommand,
    },
    /// Publish a recorded run into a live process group (`--prefix`/`--root` of its
    /// instance, as `aisle run` logs them) or, without them, into an instance of its own
    /// that consumers find by discovery; or `--check` it against this build.
    #[command(
        after_help = "Exit: 0 replayed (--check: identical), 1 --check diverged \
(the first divergence is printed), 2 could not (unreadable or damaged record, no group, \
setup failure)."
    )]
    Replay(ReplayArgs),
    /// Record a running group (`--prefix`/`--root` as `aisle run` logs them) to an MCAP
    /// file, until Ctrl-C or until the group has been silent for --idle-stop seconds.
    #[command(after_help = "Exit: 0 recorded, 2 could not (no group, unwritable file).")]
    Record(RecordArgs),
    /// The latency table of a recorded run (as `aisle run` prints it), scored against the
    /// `budgets.toml` attached to the record.
    #[command(
        after_help = "Exit: 0 profiled (a damaged file: what could be read, said so), \
2 could not (unreadable record, invalid budgets, unwritable output)."
    )]
    Profile(crate::profile_cli::ProfileArgs),
    /// Draw the top view of a recorded run as a PNG, or (`-o run.html`) a self-contained
    /// page that plays the run back.
    #[command(after_help = "Exit: 0 written, 2 could not (unreadable record, unwritable output).")]
    Render {
        file: PathBuf,
        #[arg(short, long)]
        output: PathBuf,
        #[arg(long, default_value_t = 25.0)]
        pixels_per_metre: f64,
        /// Draw every n-th controller band (0 for none).
        #[arg(long, default_value_t = 15)]
        band_every: usize,
    },
    /// Remove what killed runs left (instance roots in the run directory, /dev/shm
    /// files) whose supervisor is gone; a running group's instance is never touched.
    /// Exit 0, or 2 when the run directory is refused or a removal failed.
    Clean {
        /// Only list what would be removed.
        #[arg(long)]
        dry_run: bool,
    },
    /// Scenarios: config directories varied deterministically from a seed.
    #[command(
        after_help = "Exit: 0 written (it passes `aisle check`), 2 could not (invalid \
base config, unknown family, unwritable directory, no valid draw)."
    )]
    Scenario {
        #[command(subcommand)]
        command: ScenarioCommand,
    },
    /// Generate N scenarios over the families, run each (and its oracle, every unseen
    /// body on the map) J at a time, and print a table: success rate per family with a
    /// 95% interval, collisions, clean failures, time to goal, path length against the
    /// oracle's. Writes DIR/sweep.json and DIR/sweep.md; failures get a record and a
    /// picture in DIR/failures.
    #[command(
        after_help = "Exit: 0 every feasible scenario succeeded with 0 collisions and \
every infeasible one failed cleanly (exit 1, no collision, a reason), 1 otherwise (a \
failure, a collision, an unclean failure, an error: exit 2, crash or timeout of a run, or \
a scenario that could not be generated), 2 could not run (invalid base config, bad \
arguments, unwritable output directory)."
    )]
    Sweep(SweepArgs),
    #[command(flatten)]
    Inspect(crate::inspect_cli::InspectCommand),
    #[command(flatten)]
    Gen(crate::gen_cli::GenCommand),
    /// Run one node of a process group (started by `aisle run`, not by hand).
    #[command(hide = true)]
    Node(NodeCmd),
}

#[derive(Debug, Subcommand)]
pub enum MapCommand {
    /// Write `<dir>/<name>.yaml` and `<dir>/<name>.pgm` from the static scene.
    Export {
        /// Output directory (created if missing).
        dir: PathBuf,
        #[arg(long, default_value = "warehouse")]
        name: String,
        #[arg(long)]
        config_dir: Option<PathBuf>,
    },
}

#[derive(Debug, Clone, Args)]
pub struct RunArgs {
    /// Tick on the wall clock at the update rate instead of lockstep.
    #[arg(long)]
    pub realtime: bool,
    /// Directory of the config files (default: ./config, else the built-in one).
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
}

#[derive(Debug, Clone, Args)]
pub struct ReplayArgs {
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
    #[arg(long)]
    pub prefix: String,
    #[arg(long)]
    pub root: PathBuf,
    /// The MCAP file to write.
    #[arg(short, long)]
    pub output: PathBuf,
    /// The group's config directory (attached to the file); default `config/`.
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
    pub name: String,
    #[arg(long)]
    pub prefix: String,
    #[arg(long)]
    pub root: PathBuf,
    #[arg(long)]
    pub config_dir: PathBuf,
    #[arg(long, default_value_t = 100_000_000)]
    pub dt_ns: u64,
    #[arg(long, default_value_t = 5)]
    pub controller_every: u32,
    /// Start pose `x,y,heading`.
    #[arg(long, default_value = "0,0,0", allow_hyphen_values = true)]
    pub start: String,
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

/// The config directory: explicit, else `./config`, else the one this binary was built
/// from (so `cargo run` works from any directory of the checkout).
pub fn config_dir(explicit: Option<&Path>) -> PathBuf {
    if let Some(p) = explicit {
        return p.to_path_buf();
    }
    let local = PathBuf::from("config");
    if local.join("warehouse.toml").is_file() {
        return local;
    }
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config")
}

fn init_logging(default: &str) {
    let filter = tracing_subscriber::EnvFilter::try_from_env("AISLE_LOG")
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new(default));
    let _ = tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .with_target(false)
        .try_init();
}

pub fn main() -> ExitCode {
    let cli = Cli::parse();
    match cli.command {
        Command::Node(cmd) => {
            init_logging("warn");
            nodes::main(cmd.into())
        }
        Command::Check { config_dir: dir } => {
            init_logging("warn");
            check(&config_dir(dir.as_deref()))
        }
        Command::Map {
            command:
                MapCommand::Export {
                    dir,
                    name,
                    config_dir: cd,
                },
        } => {
            init_logging("warn");
            export_map(&config_dir(cd.as_deref()), &dir, &name)
        }
        Command::Replay(a) => {
            init_logging("info");
            records::replay(&a.into())
        }
        Command::Record(a) => {
            init_logging("info");
            records::record(&a.into())
        }
        Command::Profile(a) => {
            init_logging("warn");
            crate::profile_cli::profile(&a)
        }
        Command::Render {
            file,
            output,
            pixels_per_metre,
            band_every,
        } => {
            init_logging("warn");
            records::render(&file, &output, pixels_per_metre, band_every)
        }
        Command::Clean { dry_run } => crate::clean::clean(dry_run),
        Command::Inspect(c) => crate::inspect_cli::main(c),
        Command::Gen(c) => crate::gen_cli::main(c),
        Command::Scenario {
            command:
                ScenarioCommand::Generate {
                    seed,
                    family,
                    out,
                    config_dir: cd,
                },
        } => {
            init_logging("warn");
            scenario_cli::generate(seed, &family, out, &config_dir(cd.as_deref()))
        }
        Command::Sweep(a) => {
            init_logging("warn");
            scenario_cli::sweep(a)
        }
        Command::Run(args) => {
            init_logging("info");
            run(&args.into())
        }
    }
}

/// `aisle check`: 1 for an invalid config, 2 when there is no directory to check.
fn check(dir: &Path) -> ExitCode {
    if !dir.is_dir() {
        return exit::fail(format!("{}: not a directory", dir.display()));
    }
    match check::check_dir(dir) {
        Ok(files) => {
            for f in &files {
                println!("ok  {}", f.display());
            }
            println!("{} config files valid in {}", files.len(), dir.display());
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {e}");
            exit::negative()
        }
    }
}

/// `aisle map export`.
fn export_map(config_dir: &Path, dir: &Path, name: &str) -> ExitCode {
    match aisle_mapper::export_from_config_dir(config_dir, dir, name) {
        Ok(files) => {
            println!(
                "wrote {} and {}",
                files.yaml.display(),
                files.image.display()
            );
            ExitCode::SUCCESS
        }
        Err(e) => exit::fail(e),
    }
}

/// `aisle run`.
fn run(opts: &RunOptions) -> ExitCode {
    aisle_bus::discovery::set_creator("run", Some(&opts.config_dir));
    match session::run(opts) {
        Ok(outcome) => {
            if outcome.succeeded {
                ExitCode::SUCCESS
            } else {
                exit::negative()
            }
        }
        Err(e) => exit::fail(format!("{e:#}")),
    }
}

impl From<RunArgs> for RunOptions {
    fn from(args: RunArgs) -> RunOptions {
        RunOptions {
            config_dir: config_dir(args.config_dir.as_deref()),
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

impl From<RecordArgs> for RecordRequest {
    fn from(a: RecordArgs) -> RecordRequest {
        RecordRequest {
            config_dir: config_dir(a.config_dir.as_deref()),
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
