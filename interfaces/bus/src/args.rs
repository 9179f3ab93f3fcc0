//! What every node process is started with ([`NodeArgs`]) and how a stage times its
//! work ([`StageTimer`]). The tick protocol itself lives in `aisle-node`.

use crate::clock;
use std::time::Duration;

/// Times a stage's work on the monotonic clock and on the calling thread's CPU clock
/// (node adapters only).
pub struct StageTimer {
    wall: u64,
    cpu: u64,
}

impl StageTimer {
    pub fn start() -> Self {
        StageTimer {
            wall: clock::monotonic_ns(),
            cpu: clock::thread_cpu_ns(),
        }
    }
    /// Wall time since the start.
    pub fn elapsed_ns(&self) -> u64 {
        clock::monotonic_ns().saturating_sub(self.wall)
    }
    /// CPU time this thread consumed since the start.
    pub fn cpu_ns(&self) -> u64 {
        clock::thread_cpu_ns().saturating_sub(self.cpu)
    }
}

/// Command-line context every node receives from the supervisor.
#[derive(Debug, Clone)]
pub struct NodeArgs {
    pub instance: crate::Instance,
    pub config_dir: std::path::PathBuf,
    /// Simulated time per tick.
    pub dt_ns: u64,
    /// The controller acts on every n-th tick.
    pub controller_every: u32,
    /// Where the simulator puts the robot (x, y, heading), from the mission.
    pub start: [f64; 3],
    /// The lidar returns nothing (tests that prove the unseen obstacles matter).
    pub lidar_off: bool,
    /// This process replaces one that died: resume from the state it published.
    pub restarted: bool,
    /// A recorder runs: in lockstep the simulator also waits for its acknowledgement,
    /// so the record is complete.
    pub recorded: bool,
}

impl NodeArgs {
    /// How long a starting node waits for the supervisor's announcement.
    pub const JOIN_TIMEOUT: Duration = Duration::from_secs(10);
}
