//! The tick protocol.
//!
//! Lockstep: the simulator publishes `RobotState` and then `Tick{k}`; every stage that
//! acts on tick k publishes its outputs and then `TickDone{k}`; the simulator advances
//! only when all required `TickDone{k}` are in (lidar, mapper, supervisor, and the
//! controller on ticks flagged `STAGE_CONTROLLER`). Results therefore depend only on
//! inputs and seeds. Realtime: the simulator ticks on the wall clock and waits for
//! nobody; a stage that is late just acts on the newest tick it sees.

use crate::port::{Publisher, Stamp, Subscriber};
use crate::{Bus, BusError, HeartbeatSender, WaitOutcome, clock};
use aisle_messages::{NodeKind, NodeState, StageStatus, Tick, TickDone, services};
use std::time::Duration;

/// Waits for ticks and acknowledges them, heartbeating while it waits.
pub struct TickFollower {
    ticks: Subscriber<Tick>,
    done: Publisher<TickDone>,
    heartbeat: HeartbeatSender,
    kind: NodeKind,
}

impl TickFollower {
    pub fn new(bus: &Bus) -> Result<Self, BusError> {
        Ok(Self {
            ticks: bus.subscriber(services::TICK)?,
            done: bus.publisher(services::TICK_DONE)?,
            heartbeat: bus.heartbeat()?,
            kind: bus.kind(),
        })
    }

    pub fn heartbeat(&mut self) -> &mut HeartbeatSender {
        &mut self.heartbeat
    }

    /// Announces that this process is ready to act on ticks.
    pub fn ready(&mut self) -> Result<(), BusError> {
        self.heartbeat.send(NodeState::Ready, "")
    }

    /// Blocks until a tick arrives and returns the newest one (in realtime mode a slow
    /// stage skips ticks it can no longer serve). `Err(StopRequested)` on SIGINT/SIGTERM.
    pub fn wait_tick(&mut self) -> Result<Tick, BusError> {
        self.wait_tick_refreshing(|| {})
    }

    /// As [`TickFollower::wait_tick`], calling `refresh` between sleeps: a node passes
    /// the `update_connections` of its state publishers, so that a process restarted
    /// while the pipeline waits on it receives their history.
    pub fn wait_tick_refreshing(&mut self, mut refresh: impl FnMut()) -> Result<Tick, BusError> {
        loop {
            let hb = &mut self.heartbeat;
            let (outcome, sample) = self.ticks.wait_for(
                Duration::from_millis(50),
                |_| true,
                || {
                    let _ = hb.tick(NodeState::Running);
                    refresh();
                },
            )?;
            if outcome == WaitOutcome::Matched
                && let Some(first) = sample
            {
                let mut tick = *first;
                drop(first);
                while let Some(newer) = self.ticks.receive()? {
                    tick = *newer;
                }
                return Ok(tick);
            }
        }
    }

    /// Acknowledges `tick`: outputs for it are published.
    pub fn done(
        &mut self,
        tick: &Tick,
        status: StageStatus,
        compute_ns: u64,
    ) -> Result<(), BusError> {
        self.done_for(&tick.header, status, compute_ns)
    }

    /// Acknowledges the tick a message was stamped with (stages driven by data, such
    /// as the mapper, which acts on each point cloud rather than on the tick itself).
    pub fn done_for(
        &mut self,
        header: &aisle_messages::Header,
        status: StageStatus,
        compute_ns: u64,
    ) -> Result<(), BusError> {
        let kind = self.kind;
        self.done.publish(Stamp::of(header), |m| {
            m.node = kind as u32;
            m.status = status as u32;
            m.compute_ns = compute_ns;
        })?;
        self.heartbeat.tick(NodeState::Running)
    }
}

/// Times a stage's work on the monotonic clock (node adapters only).
pub struct StageTimer(u64);

impl StageTimer {
    pub fn start() -> Self {
        StageTimer(clock::monotonic_ns())
    }
    pub fn elapsed_ns(&self) -> u64 {
        clock::monotonic_ns().saturating_sub(self.0)
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
