//! Command-line interface. Parses arguments, sets up logging, converts the parsed
//! arguments into the plain option structs of the modules that do the work (which know
//! nothing of clap), and maps every outcome to an exit code ([`crate::exit`]): 0
//! success, 1 a negative verdict, 2 could not do what was asked.
//!
//! Here: the command tree and the dispatch. `args`: the arguments of `run`, `replay`,
//! `record`, `node` and their option structs; `config`: the config directory (given,
//! or the built-in one); `commands`: `check`, `map export`, `run`; `install`: `init`,
//! `completions`, `--version`; `logging`: the tracing subscriber and `--color`.

mod args;
mod commands;
pub(crate) mod config;
mod install;
mod logging;
mod overlay;
#[cfg(test)]
mod tests;

pub use args::{NodeCmd, RecordArgs, ReplayArgs, RunArgs};
pub use config::{ConfigDir, embedded_files, resolve as resolve_config_dir};
pub use logging::Color;

use crate::scenario_cli::{self, ScenarioCommand, SweepArgs};
use crate::{exit, nodes, records};
use clap::{CommandFactory, FromArgMatches, Parser, Subcommand};
use commands::{check, export_map, run};
use logging::init_logging;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

#[derive(Debug, Parser)]
#[command(
    name = "aisle",
    about = "Warehouse robot navigation in simulation: run and record missions of a \
process group on shared memory, watch and replay them, profile, render and check them",
    long_about = "Warehouse robot navigation in simulation. `run` launches the process \
group (simulator, lidar, mapper, global planner, TEB controller, nodes of your own) on \
iceoryx2 shared memory and drives the mission (`host` serves the nodes of another host \
when `run --hosts` spreads the group); `check` validates a config, `init` writes \
the built-in one out to edit, `map export` writes its static map, `scenario` varies it, \
`scene generate` writes a larger warehouse, `sweep` runs many generated scenarios; `record`, `replay`, `profile`, `render` and \
`export` (a ROS 2 bag) work on MCAP records; `instance`, `topics`, `echo` and `hz` inspect a live group; `clean` \
removes what killed runs left; `gen` writes the Python SDK's bindings, `completions` a \
shell's completion script. Without --config-dir every command uses the config built \
into the binary.",
    after_help = exit::TABLE
)]
pub struct Cli {
    /// Colour in log lines: auto (when stderr is a terminal and NO_COLOR is unset),
    /// always or never.
    #[arg(long, global = true, value_enum, default_value_t = Color::Auto)]
    pub color: Color,
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Debug, Subcommand)]
pub enum Command {
    /// Launch the process group and run the mission of the config's `mission.toml`.
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
        /// The config directory (default: the built-in config).
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
setup failure, nothing published: no message on the topics from --start)."
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
2 could not (unreadable record, invalid budgets, unwritable output or one another \
command writes now)."
    )]
    Profile(crate::profile_cli::ProfileArgs),
    /// Draw the top view of a recorded run as a PNG, or (`-o run.html`) a self-contained
    /// page that plays the run back.
    #[command(
        after_help = "Exit: 0 written, 2 could not (unreadable record, unwritable output, \
an output not .png, .svg or .html, an output another command writes now)."
    )]
    Render {
        /// The MCAP record (`aisle run --record`).
        file: PathBuf,
        /// The picture (`.png`, `.svg`) or page (`.html`) to write; any other extension
        /// is refused.
        #[arg(short, long)]
        output: PathBuf,
        /// Scale of the picture.
        #[arg(long, default_value_t = 25.0)]
        pixels_per_metre: f64,
        /// Draw every n-th controller band (0 for none).
        #[arg(long, default_value_t = 15)]
        band_every: usize,
    },
    /// Remove what killed runs left (instance roots in the run directory, /dev/shm
    /// files) whose supervisor is gone; a running group's instance is never touched.
    #[command(
        after_help = "Exit: 0 removed (or nothing to remove), 2 the run directory is \
refused or a removal failed."
    )]
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
    #[command(flatten)]
    Export(crate::export_cli::ExportCommand),
    #[command(flatten)]
    Install(install::InstallCommand),
    #[command(flatten)]
    Scene(crate::scene_cli::SceneCommand),
    /// Serve one host of a group spread over hosts: start here the nodes `aisle run
    /// --hosts FILE` places on this host, bridge the topics that cross hosts, until
    /// Ctrl-C. Start it on every host but the supervisor's before the run.
    #[command(
        after_help = "Exit: 0 stopped, 2 could not serve (invalid hosts file or \
config, no such host, the Zenoh endpoints could not be opened)."
    )]
    Host {
        /// This host's name in the hosts file.
        #[arg(long)]
        name: String,
        /// The hosts file (`config/hosts.toml` shows the format).
        #[arg(long, value_name = "FILE")]
        hosts: PathBuf,
        /// The config directory (default: the built-in config); the same as the
        /// supervisor's, or the spread run differs from a local one.
        #[arg(long)]
        config_dir: Option<PathBuf>,
        /// Fault injection for tests: answer as a build of this schema hash (16 hex
        /// digits) would.
        #[arg(long, value_name = "HEX", hide = true)]
        pretend_schema: Option<String>,
    },
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
        /// Base name of the two files (a file name: not empty, no `/`, not `.` or `..`).
        #[arg(long, default_value = "warehouse", value_parser = file_base_name)]
        name: String,
        /// The config directory (default: the built-in config).
        #[arg(long)]
        config_dir: Option<PathBuf>,
    },
}
/// The command tree, with the version line of this build.
pub fn command() -> clap::Command {
    Cli::command().version(install::version())
}

/// Runs `f` with the config directory: `--config-dir`, else the built-in config (a
/// private copy, removed when `f` returns).
fn with_config(explicit: Option<&Path>, f: impl FnOnce(&Path) -> ExitCode) -> ExitCode {
    match config::resolve(explicit) {
        Ok(dir) => f(dir.path()),
        Err(e) => exit::fail(format!("{e:#}")),
    }
}

pub fn main() -> ExitCode {
    let cli = match Cli::from_arg_matches(&command().get_matches()) {
        Ok(cli) => cli,
        Err(e) => e.exit(),
    };
    let log = |default: &str| init_logging(default, cli.color);
    match cli.command {
        Command::Node(cmd) => {
            log("warn");
            nodes::main(cmd.into())
        }
        Command::Check { config_dir: dir } => {
            log("warn");
            with_config(dir.as_deref(), check)
        }
        Command::Map {
            command:
                MapCommand::Export {
                    dir,
                    name,
                    config_dir: cd,
                },
        } => {
            log("warn");
            with_config(cd.as_deref(), |c| export_map(c, &dir, &name))
        }
        Command::Replay(a) => {
            log("info");
            records::replay(&a.into())
        }
        Command::Record(a) => {
            log("info");
            with_config(a.config_dir.clone().as_deref(), |c| {
                records::record(&a.request(c))
            })
        }
        Command::Profile(a) => {
            log("warn");
            crate::profile_cli::profile(&a)
        }
        Command::Render {
            file,
            output,
            pixels_per_metre,
            band_every,
        } => {
            log("warn");
            records::render(&file, &output, pixels_per_metre, band_every)
        }
        Command::Host {
            name,
            hosts,
            config_dir: cd,
            pretend_schema,
        } => {
            log("info");
            with_config(cd.as_deref(), |c| {
                crate::host_cli::main(&name, &hosts, c, pretend_schema.as_deref())
            })
        }
        Command::Clean { dry_run } => crate::clean::clean(dry_run),
        Command::Inspect(c) => crate::inspect_cli::main(c),
        Command::Gen(c) => crate::gen_cli::main(c),
        Command::Export(c) => crate::export_cli::main(c),
        Command::Install(c) => install::main(c),
        Command::Scene(c) => crate::scene_cli::main(c),
        Command::Scenario {
            command:
                ScenarioCommand::Generate {
                    seed,
                    family,
                    out,
                    force,
                    config_dir: cd,
                },
        } => {
            log("warn");
            with_config(cd.as_deref(), |c| {
                scenario_cli::generate(seed, &family, out, force, c)
            })
        }
        Command::Sweep(a) => {
            log("warn");
            with_config(a.config_dir.clone().as_deref(), |c| {
                scenario_cli::sweep(a, c)
            })
        }
        Command::Run(args) => {
            log("info");
            with_config(
                args.config_dir.clone().as_deref(),
                |c| run(&args.options(c)),
            )
        }
    }
}

/// A base name `DIR/<name>.yaml` keeps inside DIR: the map export's `--name`.
fn file_base_name(name: &str) -> Result<String, String> {
    if name.is_empty() || name == "." || name == ".." || name.contains(['/', '\0']) {
        return Err(format!(
            "`{name}` is not a file name (it must be non-empty, without `/`, not `.` or `..`)"
        ));
    }
    Ok(name.to_string())
}
