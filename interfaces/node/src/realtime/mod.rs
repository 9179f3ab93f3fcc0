//! Real-time execution options per node (`config/realtime.toml`): [`config`] reads and
//! checks the file, [`apply`] applies one node's options in its own process and says
//! once what the OS refused, `lock` decides what `lock_memory` locks within the OS's
//! limit, `wakeup` holds the CPUs' wake-up latency request. The runtime ([`crate::run`]) applies a stage's options
//! after its `start` and before its first cycle; the simulator, the recorder and the
//! supervisor call [`apply_for`] at the same point of their own loops.

mod apply;
mod config;
mod lock;
mod wakeup;

pub use apply::{
    Forks, Outcome, Refusal, apply, apply_or_warn, available_cpus, inherited_affinity,
};
pub use config::{
    MAX_PREFAULT_HEAP_KB, MAX_PREFAULT_STACK_KB, MAX_PRIORITY, MAX_WAKEUP_LATENCY_US, Options,
    OptionsFile, RealtimeConfig, path_in,
};

use crate::Graph;
use aisle_config::ConfigError;
use std::path::Path;

/// Loads `config_dir/realtime.toml` and applies the options of node `name` to this
/// process (one warning for whatever the OS refused). An invalid file is an error (the
/// supervisor checked it before launch, so only a file changed since then gets here).
pub fn apply_for(
    name: &str,
    config_dir: &Path,
    graph: &Graph,
    forks: Forks,
) -> Result<Outcome, ConfigError> {
    let config = RealtimeConfig::load_dir(config_dir, graph)?;
    let options = config.options(name);
    if options.is_off() {
        return Ok(Outcome::default());
    }
    Ok(apply_or_warn(name, &options, forks))
}
