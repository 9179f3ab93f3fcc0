//! The `Stage` trait: what a process computes, cut from how it is run.
//!
//! A stage says which topic starts one cycle of work (its trigger: the tick, or a data
//! topic such as the point cloud or a plan request), what it does on start and after a
//! restart, and what one cycle does with the trigger and the [`Io`]. The runtime
//! ([`crate::run`]) does the rest for every node alike: joining the instance with the
//! schema check, opening the ports the graph declares, heartbeats (also while a cycle
//! waits), the wait for the trigger, timing, and the acknowledgement the graph asks for.

use crate::Io;
use aisle_bus::NodeError;
use aisle_messages::{Message, NodeKind, StageStatus, TickMode, Topic};

/// The run a stage is part of, as announced by the supervisor.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RunContext {
    pub mode: TickMode,
    /// The run's seed (noise streams derive from it).
    pub seed: u64,
    /// This process replaces one that died.
    pub restarted: bool,
}

/// How one cycle ended, for its acknowledgement.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Cycle {
    pub status: StageStatus,
    /// Time spent computing, when the stage measures it itself (a cycle that waited for
    /// an input excludes the wait); `None`: the runtime's measurement of the whole cycle.
    pub compute_ns: Option<u64>,
}

impl Cycle {
    pub fn done() -> Cycle {
        Cycle {
            status: StageStatus::Done,
            compute_ns: None,
        }
    }

    pub fn with_status(status: StageStatus) -> Cycle {
        Cycle {
            status,
            compute_ns: None,
        }
    }

    /// A trigger seen before (a restarted simulator repeats its tick): acknowledged,
    /// not acted on.
    pub fn repeat() -> Cycle {
        Cycle {
            status: StageStatus::Done,
            compute_ns: Some(0),
        }
    }
}

pub trait Stage {
    /// The node this stage runs as: its entry in the graph.
    const KIND: NodeKind;
    /// The message that starts a cycle.
    type Trigger: Message;
    /// Its topic (declared in the node's `subscribes`).
    const TRIGGER: Topic<Self::Trigger>;
    /// Only the newest trigger counts (ticks: a slow stage skips what it can no longer
    /// serve in realtime); otherwise every trigger is processed in arrival order.
    const NEWEST_ONLY: bool;
    /// Says `Starting` before [`Stage::start`] (a stage whose start waits for an input,
    /// such as the planner for its first map); others report only `Ready`.
    const ANNOUNCES_START: bool = false;

    /// Before the node reports ready: publish initial outputs, wait for what it cannot
    /// start without. `ctx.restarted`: [`Stage::restore`] already ran.
    fn start(&mut self, _io: &impl Io, _ctx: &RunContext) -> Result<(), NodeError> {
        Ok(())
    }

    /// After a crash: take back the state this node published (retained by the
    /// supervisor, read with [`Io::retained`]) before any trigger is processed.
    fn restore(&mut self, _io: &impl Io, _ctx: &RunContext) -> Result<(), NodeError> {
        Ok(())
    }

    /// One cycle on `trigger`. The runtime acknowledges the trigger's tick with the
    /// returned [`Cycle`] when the graph says this node acknowledges it.
    fn process(&mut self, trigger: &Self::Trigger, io: &impl Io) -> Result<Cycle, NodeError>;
}
