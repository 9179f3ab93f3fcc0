//! Command-line interface. Parses arguments, sets up logging, converts the parsed
//! arguments into the plain option structs of the modules that do the work (which know
//! nothing of clap), and maps every outcome to an exit code ([`crate::exit`]): 0
//! success, 1 a negative verdict, 2 could not do what was asked.
//!
//! Here: the command tree and the dispatch. `args`: the arguments of `run`, `replay`,
//! `record`, `node` and their option structs; `config`: where the config directory
//! comes from; `commands`: `check`, `map export`, `run`.

mod args;
mod commands;
mod config;

pub use args::{NodeCmd, RecordArgs, ReplayArgs, RunArgs};
pub use config::config_dir;

use crate::scenario_cli::{self, ScenarioCommand, SweepArgs};
use crate::{exit, nodes, records};
use clap::{Parser, Subcommand};
use commands::{check, export_map, run};
use std::path::PathBuf;
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
