//! The safety monitor's process: `aisle run` starts it from its `graph.toml` entry
//! (`command = [".../safety_monitor"]`) with the instance in its environment.
//!
//! Exit codes: 0 after SIGTERM/SIGINT, 1 when the node failed, 2 when its environment or
//! configuration is wrong (the reason on stderr).

use aisle_example_safety_monitor::node::{MonitorStage, NAME};
use std::process::ExitCode;

fn main() -> ExitCode {
    let _ = tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_env("AISLE_LOG")
                .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("info")),
        )
        .with_writer(std::io::stderr)
        .try_init();
    let config_dir = match aisle_node::external::Env::from_env() {
        Ok(env) => env.config_dir,
        Err(e) => {
            eprintln!("error: {NAME}: {e}");
            return ExitCode::from(2);
        }
    };
    let mut stage = match MonitorStage::load(&config_dir) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("error: {NAME}: {e}");
            return ExitCode::from(2);
        }
    };
    aisle_node::external::main(&mut stage)
}
