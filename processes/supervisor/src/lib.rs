//! aisle-supervisor: the `aisle` command.
//!
//! - [`cli`]: argument parsing and dispatch (`run`, `check`, `node`, `map export`, ...);
//!   the only module that knows clap: it hands the others plain option structs.
//! - [`launch`]: starting, watching and stopping the node processes.
//! - [`remote`]: the nodes on other hosts of a spread run (`run --hosts`), through
//!   their hosts' daemons; [`host_cli`]: `aisle host`, that daemon.
//! - [`session`]: one run of the process group: startup, node health and restarts,
//!   the tick loop, the mission's actions on the bus, shutdown and the report.
//! - [`mission`]: `mission.toml` and the mission state machine (pure; no bus, no clock).
//! - [`report`]: the run's metrics and their JSON form.
//! - [`restart`]: the restart policy and the count of restarts.
//! - [`check`]: validation of every file in `config/`.
//! - [`exit`]: the exit codes every subcommand follows.
//! - [`collisions`]: collision events (body, time) from ground truth.
//! - [`inspect_cli`]: `aisle instance`, `topics`, `echo` and `hz`: a running instance seen
//!   from outside its group.
//! - [`clean`]: `aisle clean` and the sweep of stale instances before a run.
//! - [`pygen`], [`gen_cli`]: `aisle gen python`, the Python SDK's layouts from the catalogue.
//! - [`nodes`]: `aisle node <name>`, which runs one process's node adapter.
//! - [`export_cli`]: `aisle export --ros2`, a record as a ROS 2 bag.
//! - [`records`]: `aisle replay`, `profile` and `render` of MCAP recordings.
//! - [`replay_check`]: `aisle replay --check`, the mapper and controller against a recording.
//! - [`scenario`]: `aisle scenario generate`, config directories varied by seed and family.
//! - [`scenario_cli`]: the arguments of `scenario generate` and `sweep`.
//! - [`sweep`]: `aisle sweep`, many scenarios run in parallel against their oracles.

pub mod check;
pub mod clean;
pub mod cli;
pub mod collisions;
pub mod exit;
pub mod export_cli;
pub mod file_roles;
pub mod gen_cli;
pub mod host_cli;
pub mod inspect_cli;
pub mod launch;
pub mod live_cli;
pub mod mission;
pub mod nodes;
pub mod profile_cli;
pub mod pygen;
pub mod records;
pub mod remote;
pub mod replay_check;
pub mod report;
pub mod restart;
pub mod scenario;
pub mod scenario_cli;
pub mod scene_cli;
pub mod session;
pub mod sweep;
pub mod usage;
