//! Typed publish/subscribe ports, each paired with an event service of the same name.

use crate::extent::Extents;
use crate::{BusError, clock, signals};
use aisle_messages::{Message, NodeKind, Qos, Topic};
use iceoryx2::port::listener::Listener;
use iceoryx2::port::notifier::Notifier;
use iceoryx2::port::publisher::Publisher as IoxPublisher;
use iceoryx2::port::subscriber::Subscriber as IoxSubscriber;
use iceoryx2::prelude::*;
use iceoryx2::sample::Sample;
use std::time::{Duration, Instant};

/// The causal stamps a message carries: simulated time, the tick, and the wall time at
/// which that tick started.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Stamp {
    pub stamp_ns: u64,
    pub tick: u64,
    pub tick_wall_ns: u64,
}

impl Stamp {
    pub fn of(header: &aisle_messages::Header) -> Stamp {
        Stamp {
            stamp_ns: header.stamp_ns,
            tick: header.tick,
            tick_wall_ns: header.tick_wall_ns,
        }
    }
}

/// The service settings every process opens a topic with beyond its [`Qos`] (iceoryx2
/// refuses to open a service with incompatible ones): stated once, here, for the Rust ports
/// and for generated bindings of other languages.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ServiceSettings {
    /// Samples a subscriber may hold at once.
    pub subscriber_max_borrowed_samples: usize,
    /// A full subscriber buffer drops its oldest sample instead of blocking the publisher.
    pub enable_safe_overflow: bool,
    /// Processes that may open one service (publish/subscribe and event alike).
    pub max_nodes: usize,
    /// Samples a publisher may loan at once.
    pub publisher_max_loaned_samples: usize,
    /// The paired event service (same name) a publisher notifies after each send.
    pub event_max_notifiers: usize,
    pub event_max_listeners: usize,
}

/// What [`Publisher`] and [`Subscriber`] open services with.
pub const SERVICE_SETTINGS: ServiceSettings = ServiceSettings {
    subscriber_max_borrowed_samples: 2,
    enable_safe_overflow: true,
    max_nodes: 24,
    publisher_max_loaned_samples: 1,
    event_max_notifiers: 16,
    event_max_listeners: 16,
};

/// Longest single sleep inside a wait, so signals and heartbeats are served promptly.
pub(crate) const WAIT_SLICE: Duration = Duration::from_millis(25);

pub struct Publisher<M: Message> {
    service: &'static str,
    port: IoxPublisher<ipc::Service, M, ()>,
    notifier: Notifier<ipc::Service>,
    source: NodeKind,
    seq: u64,
    /// What earlier messages left in each sample (see `extent.rs`).
    extents: Extents,
}

impl<M: Message> Publisher<M> {
    pub(crate) fn new(
        node: &Node<ipc::Service>,
        topic: Topic<M>,
        source: NodeKind,
    ) -> Result<Self, BusError> {
        let (service, qos) = (topic.name, topic.qos);
        let svc = pubsub_service::<M>(node, service, &qos)?;
        let port = svc
            .publisher_builder()
            .max_loaned_samples(SERVICE_SETTINGS.publisher_max_loaned_samples)
            .create()
            .map_err(|e| BusError::service(service, e))?;
        let notifier = event_service(node, service)?
            .notifier_builder()
            .create()
            .map_err(|e| BusError::service(service, e))?;
        Ok(Self {
            service,
            port,
            notifier,
            source,
            seq: 0,
            extents: Extents::new(),
        })
    }

    pub fn service(&self) -> &'static str {
        self.service
    }

    /// Loans a sample, zero-fills it in shared memory (only as far as earlier messages
    /// wrote into it: the rest is zero already), writes the header, lets `fill` write the
    /// payload in place, sends it and wakes the subscribers. `fill` must not write past
    /// the message's [`Message::used_len`]. Returns the sequence number of the message.
    pub fn publish(&mut self, stamp: Stamp, fill: impl FnOnce(&mut M)) -> Result<u64, BusError> {
        let seq = self.publish_quiet(stamp, fill)?;
        self.wake()?;
        Ok(seq)
    }

    /// [`Publisher::publish`] without waking anyone: the message is delivered (a
    /// subscriber's next receive returns it) but a subscriber asleep in a wait sleeps on
    /// until [`Publisher::wake`] (or the end of its wait slice). For a node that sends
    /// several outputs in one cycle: waking a consumer is a system call after which the
    /// consumer may take the publisher's CPU, mid-cycle, before its other outputs are
    /// sent (`aisle_node::BusIo` wakes once the cycle is done).
    pub fn publish_quiet(
        &mut self,
        stamp: Stamp,
        fill: impl FnOnce(&mut M),
    ) -> Result<u64, BusError> {
        let mut sample = self
            .port
            .loan_uninit()
            .map_err(|e| BusError::service(self.service, e))?;
        let size = std::mem::size_of::<M>();
        let at = sample.payload_mut().as_mut_ptr();
        let dirty = self.extents.dirty(at as usize, size).min(size);
        // SAFETY: `M: ZeroedValid` guarantees all-zero bytes are a valid `M`. Past
        // `dirty` the sample's bytes are zero already (the extents' invariant), so zeroing
        // its first `dirty` bytes leaves all of it zero: initialised without building an
        // `M` on the stack.
        let mut sample = unsafe {
            (at as *mut u8).write_bytes(0, dirty);
            sample.assume_init()
        };
        self.seq += 1;
        let msg = sample.payload_mut();
        fill(msg);
        let used = msg
            .used_len()
            .clamp(std::mem::size_of::<aisle_messages::Header>(), size);
        self.extents.set(at as usize, used);
        let h = msg.header_mut();
        h.seq = self.seq;
        h.stamp_ns = stamp.stamp_ns;
        h.tick = stamp.tick;
        h.tick_wall_ns = stamp.tick_wall_ns;
        h.publish_wall_ns = clock::monotonic_ns();
        h.source = self.source.code();
        sample
            .send()
            .map_err(|e| BusError::service(self.service, e))?;
        Ok(self.seq)
    }

    /// Wakes the subscribers waiting on this topic (after [`Publisher::publish_quiet`]).
    pub fn wake(&self) -> Result<(), BusError> {
        self.notifier
            .notify()
            .map_err(|e| BusError::service(self.service, e))?;
        Ok(())
    }

    /// Connects subscribers that appeared since the last send and hands them the history.
    /// Publishers of state (history > 0) call this from their wait loops, because iceoryx2
    /// delivers history to a late subscriber only when its publisher updates connections.
    pub fn update_connections(&self) -> Result<(), BusError> {
        use iceoryx2::port::update_connections::UpdateConnections;
        self.port
            .update_connections()
            .map_err(|e| BusError::service(self.service, e))
    }

    /// Publishes an exact copy of `bytes` (a recorded or retained payload) without
    /// touching the header: the whole message, or a prefix of it at least a header long
    /// (its used part, [`used_bytes`]), the rest of the message then zero.
    pub fn publish_bytes(&mut self, bytes: &[u8]) -> Result<(), BusError> {
        let size = std::mem::size_of::<M>();
        let header = std::mem::size_of::<aisle_messages::Header>();
        if bytes.len() > size || bytes.len() < header {
            return Err(BusError::Service {
                service: self.service.to_string(),
                what: format!(
                    "payload of {} bytes, {} needs {header} to {size}",
                    bytes.len(),
                    M::TYPE_NAME,
                ),
            });
        }
        let mut sample = self
            .port
            .loan_uninit()
            .map_err(|e| BusError::service(self.service, e))?;
        let at = sample.payload_mut().as_mut_ptr() as *mut u8;
        let dirty = self.extents.dirty(at as usize, size).min(size);
        self.extents.set(at as usize, bytes.len());
        // SAFETY: `bytes` fits the sample; past `dirty` the sample is zero already (the
        // extents' invariant), so after the copy and clearing what earlier messages wrote
        // past it, the sample is `bytes` then zeros, and every bit pattern of the numeric
        // fields of an `M: ZeroedValid` is a valid value.
        let sample = unsafe {
            std::ptr::copy_nonoverlapping(bytes.as_ptr(), at, bytes.len());
            if dirty > bytes.len() {
                at.add(bytes.len()).write_bytes(0, dirty - bytes.len());
            }
            sample.assume_init()
        };
        sample
            .send()
            .map_err(|e| BusError::service(self.service, e))?;
        self.notifier
            .notify()
            .map_err(|e| BusError::service(self.service, e))?;
        Ok(())
    }
}

/// The bytes of a message, exactly as they lie in shared memory (for recorders and for
/// keeping a copy of a state message to publish again with [`Publisher::publish_bytes`]).
pub fn message_bytes<M: Message>(m: &M) -> &[u8] {
    // SAFETY: messages are `#[repr(C)]` plain data with explicit padding fields, so every
    // byte of the value is initialised and may be read.
    unsafe { std::slice::from_raw_parts(m as *const M as *const u8, std::mem::size_of::<M>()) }
}

/// The leading bytes of a message its fields use ([`Message::used_len`]: a cloud's
/// points or a grid's cells in use, not the capacity; at least the header). A publisher
/// writes nothing past them, so the rest of a published message is zero.
pub fn used_bytes<M: Message>(m: &M) -> &[u8] {
    let size = std::mem::size_of::<M>();
    let used = m
        .used_len()
        .clamp(std::mem::size_of::<aisle_messages::Header>(), size);
    &message_bytes(m)[..used]
}

/// A received sample: dereferences to the message, in shared memory.
pub type Received<M> = Sample<ipc::Service, M, ()>;

/// What ended a wait.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum WaitOutcome {
    /// The predicate matched a sample (returned alongside).
    Matched,
    /// The deadline passed.
    TimedOut,
}

pub struct Subscriber<M: Message> {
    service: &'static str,
    port: IoxSubscriber<ipc::Service, M, ()>,
    listener: Listener<ipc::Service>,
}

impl<M: Message> Subscriber<M> {
    pub(crate) fn new(node: &Node<ipc::Service>, topic: Topic<M>) -> Result<Self, BusError> {
        let (service, qos) = (topic.name, topic.qos);
        let svc = pubsub_service::<M>(node, service, &qos)?;
        let mut builder = svc.subscriber_builder().buffer_size(qos.buffer);
        if qos.history > 0 {
            builder = builder.history_request(qos.history);
        }
        let port = builder
            .create()
            .map_err(|e| BusError::service(service, e))?;
        let listener = event_service(node, service)?
            .listener_builder()
            .create()
            .map_err(|e| BusError::service(service, e))?;
        Ok(Self {
            service,
            port,
            listener,
        })
    }

    pub fn service(&self) -> &'static str {
        self.service
    }

    /// Connects to publishers that appeared since the last call (mapping their data
    /// segments). `receive` does this too, but a stage calls it while it waits, so a
    /// cycle does not pay for connecting (15 ms for the supervisor's first trajectory).
    pub fn update_connections(&self) -> Result<(), BusError> {
        use iceoryx2::port::update_connections::UpdateConnections;
        self.port
            .update_connections()
            .map_err(|e| BusError::service(self.service, e))
    }

    /// The next sample in arrival order, if any.
    pub fn receive(&self) -> Result<Option<Received<M>>, BusError> {
        self.port
            .receive()
            .map_err(|e| BusError::service(self.service, e))
    }

    /// Drains the buffer and returns the newest sample, if any.
    pub fn latest(&self) -> Result<Option<Received<M>>, BusError> {
        let mut last = None;
        while let Some(s) = self.receive()? {
            last = Some(s);
        }
        Ok(last)
    }

    /// Waits until a sample satisfies `pred` or `timeout` passes; samples that do not
    /// match are dropped. Sleeps on the paired event service in slices so that a stop
    /// request ends the wait (`BusError::StopRequested`) and `on_slice` (heartbeats) runs.
    pub fn wait_for(
        &self,
        timeout: Duration,
        mut pred: impl FnMut(&M) -> bool,
        mut on_slice: impl FnMut(),
    ) -> Result<(WaitOutcome, Option<Received<M>>), BusError> {
        let start = Instant::now();
        loop {
            while let Some(s) = self.receive()? {
                if pred(&s) {
                    return Ok((WaitOutcome::Matched, Some(s)));
                }
            }
            if signals::stop_requested() {
                return Err(BusError::StopRequested);
            }
            let elapsed = start.elapsed();
            if elapsed >= timeout {
                return Ok((WaitOutcome::TimedOut, None));
            }
            let slice = wait_slice(timeout - elapsed);
            // An interrupted wait (EINTR from a signal) is not an error: the loop
            // re-checks the stop flag.
            let _ = self.listener.timed_wait(|_| {}, slice);
            on_slice();
        }
    }
}

/// How long one sleep of a wait lasts when `remaining` is left: at most [`WAIT_SLICE`],
/// and never under a millisecond. The listener sleeps with a socket receive timeout
/// (`SO_RCVTIMEO`, whole microseconds), and a timeout that rounds to zero makes it
/// block until a notification comes, which may be never: a `replay --check` hung for
/// ten minutes that way, its listener in a receive with no timeout, left by a wait with
/// less than a microsecond to go. Overshooting a deadline by under 1 ms
/// is harmless.
fn wait_slice(remaining: Duration) -> Duration {
    remaining.clamp(Duration::from_millis(1), WAIT_SLICE)
}

/// Opens (or creates) the publish/subscribe half of `service` with the QoS every process
/// agrees on.
pub(crate) fn pubsub_service<M: Message>(
    node: &Node<ipc::Service>,
    service: &str,
    qos: &Qos,
) -> Result<
    iceoryx2::service::port_factory::publish_subscribe::PortFactory<ipc::Service, M, ()>,
    BusError,
> {
    let name: ServiceName = service
        .try_into()
        .map_err(|e| BusError::service(service, e))?;
    node.service_builder(&name)
        .publish_subscribe::<M>()
        .max_publishers(qos.max_publishers)
        .max_subscribers(qos.max_subscribers)
        .history_size(qos.history)
        .subscriber_max_buffer_size(qos.buffer)
        .subscriber_max_borrowed_samples(SERVICE_SETTINGS.subscriber_max_borrowed_samples)
        .enable_safe_overflow(SERVICE_SETTINGS.enable_safe_overflow)
        .max_nodes(SERVICE_SETTINGS.max_nodes)
        .open_or_create()
        .map_err(|e| BusError::service(service, e))
}

pub(crate) fn event_service(
    node: &Node<ipc::Service>,
    service: &str,
) -> Result<iceoryx2::service::port_factory::event::PortFactory<ipc::Service>, BusError> {
    let name: ServiceName = service
        .try_into()
        .map_err(|e| BusError::service(service, e))?;
    node.service_builder(&name)
        .event()
        .max_notifiers(SERVICE_SETTINGS.event_max_notifiers)
        .max_listeners(SERVICE_SETTINGS.event_max_listeners)
        .max_nodes(SERVICE_SETTINGS.max_nodes)
        .open_or_create()
        .map_err(|e| BusError::service(service, e))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_wait_never_sleeps_less_than_a_millisecond_nor_more_than_a_slice() {
        for ns in [0, 1, 300, 999, 1_000, 999_999] {
            assert_eq!(
                wait_slice(Duration::from_nanos(ns)),
                Duration::from_millis(1)
            );
        }
        assert_eq!(
            wait_slice(Duration::from_millis(7)),
            Duration::from_millis(7)
        );
        assert_eq!(wait_slice(Duration::from_secs(60)), WAIT_SLICE);
    }
}
