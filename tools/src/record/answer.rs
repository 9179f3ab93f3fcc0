//! When the recorder acknowledges a tick in lockstep: once the nodes its graph entry
//! lists in `after` have, and every external node that acknowledges every tick (so what
//! a user's node published for tick k is in the record of k, whatever the timing).
//!
//! Knows the graph and acknowledgement codes; not the bus (the drain reads the
//! acknowledgements and publishes the recorder's own).

use aisle_messages::NodeKind;
use aisle_node::Graph;
use aisle_node::graph::Acknowledges;
use std::collections::BTreeMap;

/// When the recorder acknowledges tick t: once every node its graph entry lists in
/// `after` acknowledged t (raw `TickDone` payloads: node code and tick).
#[derive(Debug)]
pub(super) struct AnswerRule {
    after: Vec<u32>,
    /// Ticks with some but not all of those acknowledgements, and who gave them.
    partial: BTreeMap<u64, Vec<u32>>,
}

impl AnswerRule {
    pub(super) fn of(graph: &Graph) -> AnswerRule {
        let mut after: Vec<u32> = graph
            .node(NodeKind::Recorder)
            .map(|d| d.after.iter().filter_map(|a| NodeKind::from_name(a)))
            .into_iter()
            .flatten()
            .map(NodeKind::code)
            .collect();
        for n in graph
            .external()
            .filter(|n| n.acknowledges == Acknowledges::EveryTick)
        {
            let code = n.kind().code();
            if !after.contains(&code) {
                after.push(code);
            }
        }
        AnswerRule {
            after,
            partial: BTreeMap::new(),
        }
    }

    /// Notes `node`'s acknowledgement of `tick`; true when that completes the tick.
    pub(super) fn note(&mut self, tick: u64, node: u32) -> bool {
        if !self.after.contains(&node) {
            return false;
        }
        let seen = self.partial.entry(tick).or_default();
        if !seen.contains(&node) {
            seen.push(node);
        }
        if seen.len() < self.after.len() {
            return false;
        }
        self.partial.remove(&tick);
        // Older incomplete ticks will not complete any more.
        self.partial.retain(|t, _| *t > tick);
        true
    }
}
