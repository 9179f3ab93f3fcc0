//! What a stage reads and writes, as a trait with two implementations: [`crate::BusIo`]
//! (the runtime's ports in shared memory) and [`crate::testing::MemIo`] (in memory, for
//! unit tests that launch nothing).
//!
//! Every method takes `&self`, so a stage can hold an input sample (a point cloud in
//! shared memory) while it publishes its outputs.

use aisle_bus::{NodeError, Stamp};
use aisle_messages::{Message, Topic};
use std::ops::Deref;
use std::time::Duration;

pub trait Io {
    /// A received message: in shared memory on the bus, owned in tests.
    type Sample<'a, T: Message>: Deref<Target = T>
    where
        Self: 'a;

    /// The newest sample of `topic` that arrived since the last read (older ones are
    /// dropped), or `None` when nothing new arrived.
    fn latest<T: Message>(&self, topic: Topic<T>)
    -> Result<Option<Self::Sample<'_, T>>, NodeError>;

    /// The next sample of `topic` in arrival order, if any.
    fn receive<T: Message>(
        &self,
        topic: Topic<T>,
    ) -> Result<Option<Self::Sample<'_, T>>, NodeError>;

    /// Waits up to `timeout` for a sample of `topic` that satisfies `pred` (samples
    /// that do not are dropped); heartbeats go on meanwhile. `None` on timeout.
    fn wait_for<T: Message>(
        &self,
        topic: Topic<T>,
        timeout: Duration,
        pred: impl FnMut(&T) -> bool,
    ) -> Result<Option<Self::Sample<'_, T>>, NodeError>;

    /// Writes a message in place (zero-filled first) and sends it.
    fn publish<T: Message>(
        &self,
        topic: Topic<T>,
        stamp: Stamp,
        fill: impl FnOnce(&mut T),
    ) -> Result<(), NodeError>;

    /// Says the node is alive during a long computation (a plan), so the supervisor
    /// does not take it for a hung one. Call it every few milliseconds of work; it is
    /// cheap and rate-limited. Waits need no call: they beat by themselves.
    fn keep_alive(&self);

    /// The newest retained sample of one of this node's own outputs (kept by the
    /// supervisor across a crash), waiting up to `timeout`: what a restarted stage
    /// resumes from.
    fn retained<T: Message>(
        &self,
        topic: Topic<T>,
        timeout: Duration,
    ) -> Result<Option<Self::Sample<'_, T>>, NodeError>;
}
