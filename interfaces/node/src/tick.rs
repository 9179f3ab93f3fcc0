//! The tick protocol, in one place.
//!
//! Lockstep: the simulator publishes the inputs of tick k and then `Tick{k}`; every node
//! the graph says acknowledges k (`Graph::acknowledgers`) publishes its outputs and then
//! `TickDone{k}`; a node with `after` waits for those nodes' `TickDone{k}` before it acts
//! (the supervisor after the stages, the recorder after the supervisor); the simulator
//! steps when every acknowledgement is in. Results depend only on inputs and seeds.
//! Realtime: the simulator releases ticks on the wall clock and waits for nobody; a
//! stage that is late acts on the newest tick.
//!
//! [`Awaited`] is the rule which `TickDone` counts; the simulator, the supervisor, the
//! recorder and the lockstep replay all wait through it. Knows nothing of what a stage
//! computes.

use aisle_bus::{BusError, Subscriber, WaitOutcome};
use aisle_messages::{NodeKind, TickDone};
use std::time::Duration;

/// The acknowledgements still awaited for one tick.
#[derive(Debug, Clone, Default)]
pub struct Awaited {
    tick: u64,
    nodes: Vec<NodeKind>,
}

impl Awaited {
    pub fn new() -> Self {
        Awaited {
            tick: 0,
            nodes: Vec::with_capacity(NodeKind::BUILT_IN.len()),
        }
    }

    /// Starts waiting for `nodes` to acknowledge `tick` (the buffer is reused).
    pub fn expect(&mut self, tick: u64, nodes: impl IntoIterator<Item = NodeKind>) {
        self.tick = tick;
        self.nodes.clear();
        self.nodes.extend(nodes);
    }

    pub fn tick(&self) -> u64 {
        self.tick
    }

    /// Whether `done` is one of the awaited acknowledgements.
    pub fn matches(&self, done: &TickDone) -> bool {
        done.header.tick == self.tick && self.nodes.iter().any(|n| n.code() == done.node)
    }

    /// Counts `done` if it is awaited; returns whether it was.
    pub fn take(&mut self, done: &TickDone) -> bool {
        let hit = self.matches(done);
        if hit {
            self.nodes.retain(|n| n.code() != done.node);
        }
        hit
    }

    pub fn is_complete(&self) -> bool {
        self.nodes.is_empty()
    }

    /// Stops waiting for the nodes `keep` refuses (members that left the group).
    pub fn keep_only(&mut self, keep: impl Fn(NodeKind) -> bool) {
        self.nodes.retain(|n| keep(*n));
    }

    /// The nodes still awaited, for messages.
    pub fn pending(&self) -> &[NodeKind] {
        &self.nodes
    }

    pub fn pending_names(&self) -> String {
        let names: Vec<&str> = self.nodes.iter().map(|n| n.name()).collect();
        names.join(", ")
    }

    /// Waits on `acks` until every awaited node answered. `seen` sees every
    /// acknowledgement that arrives (latency books); `on_slice` runs between sleeps of at
    /// most `slice` and ends the wait with its error (a deadline, a dead node); it may
    /// also stop waiting for nodes that left ([`Awaited::keep_only`]).
    pub fn wait<E: From<BusError>>(
        &mut self,
        acks: &Subscriber<TickDone>,
        slice: Duration,
        mut seen: impl FnMut(&TickDone),
        mut on_slice: impl FnMut(&mut Awaited) -> Result<(), E>,
    ) -> Result<(), E> {
        while !self.is_complete() {
            let mut slice_error = None;
            let (outcome, sample) = acks.wait_for(
                slice,
                |d| {
                    seen(d);
                    self.matches(d)
                },
                || {},
            )?;
            if let (WaitOutcome::Matched, Some(d)) = (outcome, sample) {
                self.take(&d);
            } else if let Err(e) = on_slice(self) {
                slice_error = Some(e);
            }
            if let Some(e) = slice_error {
                return Err(e);
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn done(tick: u64, node: NodeKind) -> TickDone {
        let mut d = *aisle_messages::zeroed_box::<TickDone>();
        d.header.tick = tick;
        d.node = node.code();
        d
    }

    #[test]
    fn only_awaited_nodes_of_this_tick_count() {
        let mut a = Awaited::new();
        a.expect(7, [NodeKind::Lidar, NodeKind::Mapper]);
        assert!(!a.take(&done(6, NodeKind::Lidar)), "an older tick");
        assert!(!a.take(&done(7, NodeKind::TebController)), "not awaited");
        assert!(a.take(&done(7, NodeKind::Lidar)));
        assert!(!a.take(&done(7, NodeKind::Lidar)), "counted once");
        assert_eq!(a.pending_names(), "mapper");
        assert!(a.take(&done(7, NodeKind::Mapper)));
        assert!(a.is_complete());
        a.expect(8, [NodeKind::Lidar, NodeKind::Recorder]);
        a.keep_only(|n| n != NodeKind::Recorder);
        assert_eq!(
            a.pending_names(),
            "lidar",
            "a member that left is not awaited"
        );
    }
}
