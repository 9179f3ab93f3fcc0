//! The state that must survive a node's crash. A publisher's history dies with its
//! process, so the supervisor keeps a copy of the newest sample of every topic its
//! graph entry `retains` (simulator state, global map, controller band in the shipped
//! graph) and publishes it again when the topic's producer is restarted; the successor
//! resumes from it.
//!
//! Its own standing orders ([`ORDERS`]: the controller's goal, the mapper's control)
//! reach a restarted node through their history, except across hosts: a link's mirror
//! hands history on only when it publishes again. So the newest of each is kept too and
//! sent again, while a node that reads it resumes on another host. Knows nothing of
//! when a node dies (see `health`).

use super::RunAborted;
use aisle_bus::{Bus, RawPublisher, RawSubscriber};
use aisle_messages::{NodeKind, topics};
use aisle_node::Graph;
use anyhow::anyhow;

/// One retained topic: its producer, the ports, the newest payload.
struct Retained {
    producer: NodeKind,
    source: Box<dyn RawSubscriber>,
    republisher: Box<dyn RawPublisher>,
    copy: Vec<u8>,
}

/// The supervisor's topics that hold a standing order rather than an event: the newest
/// sample is what a reader must know.
pub(super) const ORDERS: [&str; 2] = [topics::CONTROLLER_GOAL.name, topics::MAPPER_CONTROL.name];

/// One standing order: the nodes that read it, the port it is copied from, the newest
/// payload. (It is sent again through the supervisor's own publisher: the topic allows
/// no second one.)
struct Order {
    name: &'static str,
    readers: Vec<NodeKind>,
    source: Box<dyn RawSubscriber>,
    copy: Vec<u8>,
}

/// The newest state each stateful node published, and the newest standing orders, as
/// raw message bytes.
pub(super) struct RetainedState {
    topics: Vec<Retained>,
    orders: Vec<Order>,
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
        let mut orders = Vec::new();
        for name in ORDERS {
            let missing = || anyhow!("`{name}` is not a topic");
            orders.push(Order {
                name,
                readers: graph
                    .nodes()
                    .iter()
                    .filter(|n| n.may_subscribe(name))
                    .map(|n| n.kind())
                    .collect(),
                source: bus.raw_subscriber(name)?.ok_or_else(missing)?,
                copy: Vec::new(),
            });
        }
        Ok(RetainedState { topics, orders })
    }

    /// Copies what each node published last (nothing new: the old copy stays).
    pub fn copy_newest(&mut self) -> Result<(), RunAborted> {
        for t in &mut self.topics {
            t.source.latest_into(&mut t.copy)?;
        }
        for o in &mut self.orders {
            o.source.latest_into(&mut o.copy)?;
        }
        Ok(())
    }

    /// The newest standing orders `kind` reads: (topic, payload), to send again to a
    /// node resuming on another host.
    pub fn orders_for(&self, kind: NodeKind) -> impl Iterator<Item = (&'static str, &[u8])> {
        self.orders
            .iter()
            .filter(move |o| o.readers.contains(&kind) && !o.copy.is_empty())
            .map(|o| (o.name, o.copy.as_slice()))
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
