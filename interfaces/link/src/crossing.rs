//! The topics a placement makes cross hosts: published on one host and subscribed on
//! another. Only these are bridged; every other topic stays in the shared memory of its
//! host.
//!
//! Besides what `graph.toml` declares, every node publishes heartbeats and every node
//! that acknowledges ticks publishes `TickDone` (the runtime opens both). The supervisor's
//! announcement (`aisle/instance`) never crosses: each host announces its own instance to
//! the nodes it runs, after the schema check.
//!
//! Knows the graph and the placement; opens nothing.

use crate::Placement;
use aisle_messages::topics;
use aisle_node::Graph;
use aisle_node::graph::{Acknowledges, NodeDecl};

/// One topic that crosses hosts, with the hosts on each side (sorted, no repeats).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Crossing {
    pub topic: String,
    pub publishers: Vec<String>,
    pub subscribers: Vec<String>,
}

impl Crossing {
    /// Whether `host` has a port on this topic, so its link must bridge it.
    pub fn touches(&self, host: &str) -> bool {
        self.publishers
            .iter()
            .chain(&self.subscribers)
            .any(|h| h == host)
    }
}

/// Whether `node` publishes `topic` in a run: declared, or implied by the runtime.
fn publishes(node: &NodeDecl, topic: &str) -> bool {
    node.may_publish(topic)
        || topic == topics::HEARTBEAT.name
        || (topic == topics::TICK_DONE.name && node.acknowledges != Acknowledges::None)
}

/// The topics that cross hosts under `placement`, in the order of the topic table (user
/// topics after it). `present` says whether a node that is not launched (the recorder)
/// takes part in this run.
pub fn crossing_topics(
    graph: &Graph,
    placement: &Placement,
    present: impl Fn(&NodeDecl) -> bool,
) -> Vec<Crossing> {
    let nodes: Vec<&NodeDecl> = graph
        .nodes()
        .iter()
        .filter(|n| n.launched || n.name == "supervisor" || present(n))
        .collect();
    let mut names: Vec<String> = topics::all()
        .into_iter()
        .map(|t| t.name.to_string())
        .collect();
    for n in &nodes {
        for t in n.publishes.iter().chain(&n.subscribes) {
            if t != "*" && !names.contains(t) {
                names.push(t.clone());
            }
        }
    }
    names
        .into_iter()
        .filter(|t| t != topics::INSTANCE.name)
        .filter_map(|topic| {
            let hosts = |pred: &dyn Fn(&NodeDecl) -> bool| {
                let mut h: Vec<String> = nodes
                    .iter()
                    .filter(|n| pred(n))
                    .map(|n| placement.host_of(&n.name).to_string())
                    .collect();
                h.sort();
                h.dedup();
                h
            };
            let publishers = hosts(&|n| publishes(n, &topic));
            let subscribers = hosts(&|n| n.may_subscribe(&topic));
            let crosses = publishers
                .iter()
                .any(|p| subscribers.iter().any(|s| s != p));
            crosses.then_some(Crossing {
                topic,
                publishers,
                subscribers,
            })
        })
        .collect()
}
