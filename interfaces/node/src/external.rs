//! External nodes: the contract between the supervisor and a process of the user's own
//! (Rust through this crate, Python through `python/aisle`, anything that speaks it).
//!
//! The supervisor starts a graph node that has a `command` in the directory of the graph
//! file, with the instance and the node's identity in its environment ([`Env`]); the node
//! joins like a built-in one (schema check, heartbeats on `aisle/heartbeat` with its
//! code, `TickDone` with its code for the ticks its `acknowledges` names) and stops on
//! SIGTERM. [`main`] is the whole of a Rust external node's `main`.
//!
//! Knows environment variables and exit codes; the loop is [`crate::run`].

use crate::Stage;
use aisle_bus::{Instance, NodeArgs};
use std::path::PathBuf;
use std::process::ExitCode;

/// The instance prefix.
pub const PREFIX_VAR: &str = "AISLE_PREFIX";
/// The instance root.
pub const ROOT_VAR: &str = "AISLE_ROOT";
/// The config directory (it holds the `graph.toml` the node is declared in).
pub const CONFIG_DIR_VAR: &str = "AISLE_CONFIG_DIR";
/// The node's name in the graph.
pub const NODE_VAR: &str = "AISLE_NODE";
/// The node's wire code (decimal), `aisle_messages::external_code` of its name.
pub const NODE_ID_VAR: &str = "AISLE_NODE_ID";
/// "1" when the node replaces one that died, else "0".
pub const RESTARTED_VAR: &str = "AISLE_RESTARTED";
/// Simulated time per tick, nanoseconds.
pub const DT_NS_VAR: &str = "AISLE_DT_NS";
/// The controller acts on every n-th tick.
pub const CONTROLLER_EVERY_VAR: &str = "AISLE_CONTROLLER_EVERY";

/// What the supervisor tells an external node.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Env {
    pub prefix: String,
    pub root: PathBuf,
    pub config_dir: PathBuf,
    pub node: String,
    pub restarted: bool,
    pub dt_ns: u64,
    pub controller_every: u32,
}

impl Env {
    /// The variables to set for `node`, in a stable order.
    pub fn vars(&self) -> Vec<(&'static str, String)> {
        vec![
            (PREFIX_VAR, self.prefix.clone()),
            (ROOT_VAR, self.root.display().to_string()),
            (CONFIG_DIR_VAR, self.config_dir.display().to_string()),
            (NODE_VAR, self.node.clone()),
            (
                NODE_ID_VAR,
                aisle_messages::external_code(&self.node).to_string(),
            ),
            (RESTARTED_VAR, if self.restarted { "1" } else { "0" }.into()),
            (DT_NS_VAR, self.dt_ns.to_string()),
            (CONTROLLER_EVERY_VAR, self.controller_every.to_string()),
        ]
    }

    /// Reads the variables through `get` (the process environment in [`Env::from_env`]);
    /// `Err` names the missing or malformed variable.
    pub fn read(get: impl Fn(&str) -> Option<String>) -> Result<Env, String> {
        let need = |var: &str| {
            get(var).ok_or_else(|| {
                format!(
                    "{var} is not set: an external node is started by `aisle run` from its graph"
                )
            })
        };
        let number = |var: &str, default: u64| -> Result<u64, String> {
            match get(var) {
                None => Ok(default),
                Some(v) => v
                    .parse()
                    .map_err(|_| format!("{var}={v:?} is not a whole number")),
            }
        };
        let restarted = match get(RESTARTED_VAR).as_deref() {
            None | Some("0") => false,
            Some("1") => true,
            Some(v) => return Err(format!("{RESTARTED_VAR}={v:?}: expected 0 or 1")),
        };
        Ok(Env {
            prefix: need(PREFIX_VAR)?,
            root: need(ROOT_VAR)?.into(),
            config_dir: need(CONFIG_DIR_VAR)?.into(),
            node: need(NODE_VAR)?,
            restarted,
            dt_ns: number(DT_NS_VAR, 100_000_000)?,
            controller_every: number(CONTROLLER_EVERY_VAR, 1)?.clamp(1, u32::MAX as u64) as u32,
        })
    }

    pub fn from_env() -> Result<Env, String> {
        Self::read(|v| std::env::var(v).ok())
    }

    /// The node arguments of the runtime.
    pub fn node_args(&self) -> Result<NodeArgs, String> {
        let instance = Instance::new(self.prefix.clone(), self.root.clone())
            .map_err(|e| format!("{PREFIX_VAR}/{ROOT_VAR}: {e}"))?;
        Ok(NodeArgs {
            instance,
            config_dir: self.config_dir.clone(),
            dt_ns: self.dt_ns,
            controller_every: self.controller_every,
            start: [0.0; 3],
            lidar_off: false,
            restarted: self.restarted,
            recorded: false,
        })
    }
}

/// Runs `stage` as the external node the environment names: exit 0 after SIGTERM or
/// SIGINT, 1 when the node failed (the reason on stderr), 2 when the environment is not
/// that of an external node or names another node than `S::KIND`.
pub fn main<S: Stage>(stage: &mut S) -> ExitCode {
    let name = S::KIND.name();
    let env = match Env::from_env() {
        Ok(e) => e,
        Err(e) => {
            eprintln!("error: {name}: {e}");
            return ExitCode::from(2);
        }
    };
    if env.node != name {
        eprintln!(
            "error: {name}: started as `{}` ({NODE_VAR}); this program is the node `{name}`",
            env.node
        );
        return ExitCode::from(2);
    }
    let args = match env.node_args() {
        Ok(a) => a,
        Err(e) => {
            eprintln!("error: {name}: {e}");
            return ExitCode::from(2);
        }
    };
    match crate::run(stage, &args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) if e.is_stop() => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {name}: {e}");
            ExitCode::from(1)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashMap;

    #[test]
    fn the_environment_round_trips_and_names_what_is_wrong() {
        let env = Env {
            prefix: "p_".into(),
            root: "/tmp/r".into(),
            config_dir: "/c".into(),
            node: "safety_monitor".into(),
            restarted: true,
            dt_ns: 50_000_000,
            controller_every: 2,
        };
        let vars: HashMap<&str, String> = env.vars().into_iter().collect();
        assert_eq!(
            vars[NODE_ID_VAR],
            aisle_messages::external_code("safety_monitor").to_string()
        );
        let back = Env::read(|v| vars.get(v).cloned()).unwrap();
        assert_eq!(back, env);
        let e = Env::read(|v| (v != ROOT_VAR).then(|| vars.get(v).cloned()).flatten());
        assert!(e.unwrap_err().contains(ROOT_VAR));
        let e = Env::read(|v| {
            if v == DT_NS_VAR {
                Some("fast".into())
            } else {
                vars.get(v).cloned()
            }
        });
        assert!(e.unwrap_err().contains("AISLE_DT_NS=\"fast\""));
    }
}
