//! `aisle node <name>`: runs one process of the group. The supervisor re-executes its
//! own binary with this subcommand, so every node is a separate OS process built from
//! the same source (and so the same message schema).
//!
//! Exit codes: 0 after a stop request, 1 when the node failed (the reason is on stderr
//! and in its last heartbeat), 2 for a bad command line.

use aisle_bus::{Instance, NodeArgs, NodeError};
use aisle_messages::NodeKind;
use std::path::PathBuf;
use std::process::ExitCode;

/// What `aisle node` is asked to run (the command line as `cli` parsed it).
#[derive(Debug, Clone)]
pub struct NodeOptions {
    pub name: String,
    pub prefix: String,
    pub root: PathBuf,
    pub config_dir: PathBuf,
    pub dt_ns: u64,
    pub controller_every: u32,
    /// Start pose `x,y,heading`, as given (checked here).
    pub start: String,
    pub lidar_off: bool,
    /// This node replaces one that died: resume from its published state.
    pub restarted: bool,
    /// The recorder's output file.
    pub out: Option<PathBuf>,
    /// The recorder serves the live view here.
    pub foxglove: Option<std::net::SocketAddr>,
    /// A recorder runs (the simulator waits for it in lockstep).
    pub recorded: bool,
    /// Fault injection for tests: fail at start, every time.
    pub fail_on_start: bool,
}

pub fn main(cmd: NodeOptions) -> ExitCode {
    let Some(kind) = NodeKind::from_name(&cmd.name)
        .filter(|k| NodeKind::LAUNCHED.contains(k) || *k == NodeKind::Recorder)
    else {
        let names: Vec<&str> = NodeKind::LAUNCHED.iter().map(|k| k.name()).collect();
        eprintln!(
            "error: no node named `{}`; nodes are {}",
            cmd.name,
            names.join(", ")
        );
        return ExitCode::from(2);
    };
    let instance = match Instance::new(cmd.prefix.clone(), cmd.root.clone()) {
        Ok(i) => i,
        Err(e) => {
            eprintln!("error: {}: {e}", kind.name());
            return ExitCode::from(2);
        }
    };
    let start: Vec<f64> = cmd
        .start
        .split(',')
        .filter_map(|v| v.trim().parse().ok())
        .collect();
    let Ok(start) = <[f64; 3]>::try_from(start) else {
        eprintln!(
            "error: {}: --start needs x,y,heading, got `{}`",
            kind.name(),
            cmd.start
        );
        return ExitCode::from(2);
    };
    let args = NodeArgs {
        instance,
        config_dir: cmd.config_dir,
        dt_ns: cmd.dt_ns,
        controller_every: cmd.controller_every.max(1),
        start,
        lidar_off: cmd.lidar_off,
        restarted: cmd.restarted,
        recorded: cmd.recorded,
    };
    if cmd.fail_on_start {
        eprintln!(
            "error: {}: failing at start, as the --crash-on-start fault injection asks",
            kind.name()
        );
        return ExitCode::from(1);
    }
    let out = cmd.out.clone();
    let result: Result<(), NodeError> = match kind {
        NodeKind::Simulator => aisle_simulator::node::run(&args),
        NodeKind::Lidar => aisle_lidar::node::run(&args),
        NodeKind::Mapper => aisle_mapper::node::run(&args),
        NodeKind::GlobalPlanner => aisle_global_planner::node::run(&args),
        NodeKind::TebController => aisle_teb_controller::node::run(&args),
        NodeKind::Recorder => match (&out, cmd.foxglove) {
            (Some(out), None) => aisle_tools::record::run_recorder(&args, out),
            (None, None) => {
                eprintln!("error: recorder: --out <file> or --foxglove <addr> is required");
                return ExitCode::from(2);
            }
            (out, Some(addr)) => live_recorder(&args, out.as_deref(), addr),
        },
        _ => unreachable!("filtered above"),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) if e.is_stop() => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {}: {e}", kind.name());
            ExitCode::from(1)
        }
    }
}

/// The recorder with the live view: records to `out` when given, serves at `addr`, and
/// says at the end what the live view served and dropped.
fn live_recorder(
    args: &NodeArgs,
    out: Option<&std::path::Path>,
    addr: std::net::SocketAddr,
) -> Result<(), NodeError> {
    let options = aisle_tools::RecorderOptions {
        live: Some(addr),
        ..Default::default()
    };
    let summary = aisle_tools::run_recorder_live(args, out, &options)?;
    if let Some(live) = summary.live {
        eprintln!(
            "foxglove live view ws://{addr}: {} messages served, {} dropped (the server fell behind)",
            live.served, live.dropped
        );
    }
    Ok(())
}
