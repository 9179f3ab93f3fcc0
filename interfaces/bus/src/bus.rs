//! A process's membership of an instance: its iceoryx2 node, the schema check on join,
//! heartbeats and the cleanup of resources that dead nodes left behind.

use crate::port::{Publisher, Stamp, Subscriber};
use crate::{BusError, Instance, WaitOutcome, clock};
use aisle_messages::{
    Heartbeat, InstanceInfo, Message, NodeKind, NodeState, TickMode, Topic, topics, write_name,
};
use iceoryx2::config::Config;
use iceoryx2::prelude::*;
use std::time::Duration;

pub struct Bus {
    pub(crate) node: Node<ipc::Service>,
    pub(crate) config: Config,
    instance: Instance,
    kind: NodeKind,
}

impl Bus {
    fn open(instance: &Instance, kind: NodeKind) -> Result<Bus, BusError> {
        crate::signals::install();
        let config = instance.iceoryx_config()?;
        let name: NodeName = kind.name().try_into().map_err(|e| BusError::Instance {
            prefix: instance.prefix.clone(),
            what: format!("node name {}: {e:?}", kind.name()),
        })?;
        let node = NodeBuilder::new()
            .name(&name)
            .config(&config)
            .signal_handling_mode(SignalHandlingMode::Disabled)
            .create::<ipc::Service>()
            .map_err(|e| BusError::Instance {
                prefix: instance.prefix.clone(),
                what: format!("node {}: {e:?}", kind.name()),
            })?;
        // iceoryx2 opened the private management segment rather than making its own
        // (world-accessible) one: a mismatch with this iceoryx2 version shows here.
        instance.check_private()?;
        Ok(Bus {
            node,
            config,
            instance: instance.clone(),
            kind,
        })
    }

    /// The supervisor's side: creates the instance and announces the schema hash, the
    /// seed and the clock mode to every process that joins later (history 1).
    pub fn create_instance(
        instance: &Instance,
        seed: u64,
        mode: TickMode,
    ) -> Result<(Bus, Publisher<InstanceInfo>), BusError> {
        Self::announce(instance, aisle_messages::schema_hash(), seed, mode)
    }

    /// Announces an instance with an explicit schema hash (tests use a foreign one).
    pub fn announce(
        instance: &Instance,
        schema_hash: u64,
        seed: u64,
        mode: TickMode,
    ) -> Result<(Bus, Publisher<InstanceInfo>), BusError> {
        instance.claim()?;
        let bus = Self::open(instance, NodeKind::Supervisor)?;
        let mut info = bus.publisher(topics::INSTANCE)?;
        info.publish(Stamp::default(), |m| {
            m.schema_hash = schema_hash;
            m.seed = seed;
            m.mode = mode as u32;
        })?;
        crate::discovery::write(instance, schema_hash, seed, mode)?;
        Ok((bus, info))
    }

    /// Another member for a process that created or joined the instance already (a
    /// host's link thread): no announcement is awaited, the schema was checked.
    pub fn second_member(instance: &Instance, kind: NodeKind) -> Result<Bus, BusError> {
        instance.check_joinable()?;
        Self::open(instance, kind)
    }

    /// A process joins: it waits for the supervisor's announcement and refuses to run
    /// when the schema hashes differ, naming both.
    pub fn join(
        instance: &Instance,
        kind: NodeKind,
        timeout: Duration,
    ) -> Result<(Bus, InstanceInfo), BusError> {
        instance.check_joinable()?;
        let bus = Self::open(instance, kind)?;
        let sub = bus.subscriber(topics::INSTANCE)?;
        let (outcome, sample) = sub.wait_for(timeout, |_| true, || {})?;
        let info = match (outcome, sample) {
            (WaitOutcome::Matched, Some(s)) => *s,
            _ => {
                return Err(BusError::NoSupervisor {
                    prefix: instance.prefix.clone(),
                    waited_ms: timeout.as_millis() as u64,
                });
            }
        };
        let ours = aisle_messages::schema_hash();
        if info.schema_hash != ours {
            return Err(BusError::SchemaMismatch {
                ours: format!("{ours:016x}"),
                theirs: format!("{:016x}", info.schema_hash),
                prefix: instance.prefix.clone(),
            });
        }
        Ok((bus, info))
    }

    pub fn kind(&self) -> NodeKind {
        self.kind
    }

    pub fn instance(&self) -> &Instance {
        &self.instance
    }

    pub fn publisher<M: Message>(&self, topic: Topic<M>) -> Result<Publisher<M>, BusError> {
        Publisher::new(&self.node, topic, self.kind)
    }

    pub fn subscriber<M: Message>(&self, topic: Topic<M>) -> Result<Subscriber<M>, BusError> {
        Subscriber::new(&self.node, topic)
    }

    pub fn heartbeat(&self) -> Result<HeartbeatSender, BusError> {
        Ok(HeartbeatSender {
            port: self.publisher(topics::HEARTBEAT)?,
            kind: self.kind,
            last_ns: 0,
        })
    }

    /// Removes the resources of nodes of this instance whose process died. Returns how
    /// many dead nodes were cleaned.
    pub fn cleanup_dead_nodes(&self) -> usize {
        let mut cleaned = 0;
        let _ = Node::<ipc::Service>::list(&self.config, |state| {
            if let iceoryx2::node::NodeState::Dead(view) = state
                && view.try_remove_stale_resources().is_ok()
            {
                cleaned += 1;
            }
            CallbackProgression::Continue
        });
        cleaned
    }
}

/// Publishes this process's liveness, at most every `period` unless forced.
///
/// Keep the sender alive for as long as the process runs: a sender dropped right after
/// `send` takes its publisher with it, and subscribers never see the sample.
pub struct HeartbeatSender {
    port: Publisher<Heartbeat>,
    kind: NodeKind,
    last_ns: u64,
}

impl HeartbeatSender {
    /// Every wait ticks the sender at least every `WAIT_SLICE` (25 ms), so a waiting
    /// process beats every 50-75 ms; realtime heartbeat timeouts are a few periods.
    pub const PERIOD: Duration = Duration::from_millis(50);

    pub fn send(&mut self, state: NodeState, text: &str) -> Result<(), BusError> {
        self.last_ns = clock::monotonic_ns();
        let kind = self.kind;
        self.port.publish(Stamp::default(), |m| {
            m.node = kind.code();
            m.state = state as u32;
            m.pid = std::process::id();
            m.schema_hash = aisle_messages::schema_hash();
            write_name(&mut m.text, text);
        })?;
        Ok(())
    }

    /// Sends when the last heartbeat is older than [`Self::PERIOD`].
    pub fn tick(&mut self, state: NodeState) -> Result<(), BusError> {
        if clock::monotonic_ns().saturating_sub(self.last_ns) >= Self::PERIOD.as_nanos() as u64 {
            self.send(state, "")?;
        }
        Ok(())
    }
}
