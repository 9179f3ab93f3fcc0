//! The node runtime: what every aisle process shares, so that a process is a [`Stage`]
//! and nothing else.
//!
//! - [`graph`]: the process graph of `config/graph.toml` (who publishes, subscribes and
//!   acknowledges what), checked against the topic table.
//! - [`tick`]: the tick protocol ([`tick::Awaited`]: which acknowledgement counts).
//! - [`Stage`] and [`run`]: a stage says what starts its cycle and what a cycle does; the
//!   runtime joins, opens the declared ports, heartbeats, restores after a restart,
//!   waits, times and acknowledges.
//! - [`Io`]: what a stage reads and writes, on the bus ([`BusIo`]) or in memory
//!   ([`testing::MemIo`]), so a stage is unit-tested without launching anything.
//! - [`external`]: what the supervisor gives a node of the user's own, and [`external::main`],
//!   the whole `main` of one written in Rust.
//! - [`realtime`]: the real-time execution options of `config/realtime.toml` (affinity,
//!   SCHED_FIFO, locked and pre-faulted memory), applied in each node's own process.

mod bus_io;
pub mod external;
pub mod graph;
mod io;
pub mod realtime;
mod runtime;
mod stage;
pub mod testing;
pub mod tick;

pub use bus_io::BusIo;
pub use graph::Graph;
pub use io::Io;
pub use runtime::run;
pub use stage::{Cycle, RunContext, Stage};
