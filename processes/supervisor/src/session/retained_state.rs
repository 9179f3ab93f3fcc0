//! The state that must survive a node's crash. A publisher's history dies with its
//! process, so the supervisor keeps a copy of the newest sample of every topic its
//! graph entry `retains` (simulator state, global map, controller band in the shipped
//! graph) and publishes it again when the topic's producer is restarted; the successor
//! resumes from it. Knows nothing of when a node dies (see `health`).

use super::RunAborted;
use aisle_bus::{Bus, RawPublisher, RawSubscriber};
use aisle_messages::NodeKind;
use aisle_node::Graph;
use anyhow::anyhow;

/// One retained topic: its producer, the ports, the newest payload.
struct Retained {
    producer: NodeKind,
    source: Box<dyn RawSubscriber>,
    republisher: Box<dyn RawPublisher>,
    copy: Vec<u8>,
}

/// The newest state each stateful node published, as raw message bytes.
pub(super) struct RetainedState {
    topics: Vec<Retained>,
}

impl RetainedState {
    pub fn open(bus: &Bus, graph: &Graph) -> anyhow::Result<RetainedState> {
        let mut topics = Vec::new();
        let retains = graph
            .node(NodeKind::Supervisor)
            .map(|d| d.retains.clone())
            .unwrap_or_default();
        for name in &retains {
            let producer = graph
                .producer(name)
                .ok_or_else(|| anyhow!("graph.toml: no node publishes retained `{name}`"))?;
            let missing = || anyhow!("graph.toml: retained `{name}` is not a topic");
            topics.push(Retained {
                producer,
                source: bus.raw_subscriber(name)?.ok_or_else(missing)?,
                republisher: bus.raw_publisher(name)?.ok_or_else(missing)?,
                copy: Vec::new(),
            });
        }
        Ok(RetainedState { topics })
    }

    /// Copies what each node published last (nothing new: the old copy stays).
    pub fn copy_newest(&mut self) -> Result<(), RunAborted> {
        for t in &mut self.topics {
            t.source.latest_into(&mut t.copy)?;
        }
        Ok(())
    }

    /// Hands a restarted node the state its predecessor published, if it has any.
    pub fn republish(&mut self, kind: NodeKind) -> Result<(), RunAborted> {
        for t in &mut self.topics {
            if t.producer == kind && !t.copy.is_empty() {
                t.republisher.publish_raw(&t.copy)?;
            }
        }
        Ok(())
    }

    /// Connects the republishers to nodes that (re)joined.
    pub fn update_connections(&self) -> Result<(), RunAborted> {
        for t in &self.topics {
            t.republisher.update_connections()?;
        }
        Ok(())
    }
}
