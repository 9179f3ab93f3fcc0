//! The tick protocol's topics (`Tick`, `TickDone`) across the link, in order with the
//! data: a node publishes its outputs of tick k and then acknowledges k, and a consumer
//! on another host must not see the acknowledgement first. The link bridges each service
//! on its own, so it keeps no order between services; these two topics therefore travel
//! beside it, on the same Zenoh session, sequenced around the link's rounds:
//!
//! - out: the protocol samples published on this host are taken *before* a round, and
//!   put on Zenoh *after* it: the round has handed every sample published before them
//!   to Zenoh, and Zenoh keeps the order of one session's puts;
//! - in: the protocol samples from the other host are taken *before* a round and
//!   published here *after* it: the round has published every sample that reached this
//!   host before them.
//!
//! A sample is sent out only when its header names a node of this host as its writer
//! (so what this module published itself never goes back). Knows topic names, the
//! header's `source` field and Zenoh; not what the samples mean.

use aisle_bus::{Bus, RawPublisher, RawSubscriber};
use aisle_messages::Header;
use zenoh::Wait;
use zenoh::handlers::FifoChannelHandler;
use zenoh::qos::{CongestionControl, Reliability};
use zenoh::sample::{Locality, Sample};

const PREFIX: &str = "aisle/ordered";

struct Port {
    topic: String,
    local_in: Box<dyn RawSubscriber>,
    local_out: Box<dyn RawPublisher>,
    remote: zenoh::pubsub::Publisher<'static>,
}

/// Samples taken before a round, to be delivered after it.
#[derive(Default)]
pub struct Held {
    out: Vec<(usize, Vec<u8>)>,
    incoming: Vec<Sample>,
}

/// The ordered topics of one host's link.
pub struct Ordered {
    ports: Vec<Port>,
    from_remote: zenoh::pubsub::Subscriber<FifoChannelHandler<Sample>>,
    /// `NodeKind` codes of the nodes on this host.
    sources: Vec<u32>,
    /// Where the latency of what arrives is noted (`crate::probe`).
    noted: crate::probe::Shared,
}

/// The writer a message's bytes name (`Header::source`), if they hold a header.
fn source_of(bytes: &[u8]) -> Option<u32> {
    let at = std::mem::offset_of!(Header, source);
    let b = bytes.get(at..at + 4)?;
    Some(u32::from_ne_bytes([b[0], b[1], b[2], b[3]]))
}

impl Ordered {
    pub fn open(
        bus: &Bus,
        session: &zenoh::Session,
        topics: &[String],
        sources: Vec<u32>,
        noted: crate::probe::Shared,
    ) -> Result<Ordered, String> {
        let mut ports = Vec::new();
        for t in topics {
            let local_in = bus
                .raw_subscriber(t)
                .map_err(|e| e.to_string())?
                .ok_or_else(|| format!("no topic called `{t}`"))?;
            let local_out = bus
                .raw_publisher(t)
                .map_err(|e| e.to_string())?
                .ok_or_else(|| format!("no topic called `{t}`"))?;
            let remote = session
                .declare_publisher(format!("{PREFIX}/{t}"))
                .reliability(Reliability::Reliable)
                .congestion_control(CongestionControl::Block)
                .allowed_destination(Locality::Remote)
                .wait()
                .map_err(|e| format!("zenoh publisher of {t}: {e}"))?;
            ports.push(Port {
                topic: t.clone(),
                local_in,
                local_out,
                remote,
            });
        }
        let from_remote = session
            .declare_subscriber(format!("{PREFIX}/**"))
            .allowed_origin(Locality::Remote)
            .wait()
            .map_err(|e| format!("zenoh subscriber of the ordered topics: {e}"))?;
        Ok(Ordered {
            ports,
            from_remote,
            sources,
            noted,
        })
    }

    /// Hands each protocol publisher's history (the current tick) to subscribers that
    /// joined since (a node restarted on this host waits for it).
    pub fn update_connections(&self) {
        for p in &self.ports {
            if let Err(e) = p.local_out.update_connections() {
                tracing::warn!("ordered {}: {e}", p.topic);
            }
        }
    }

    /// Before a round: what this host published and what arrived from the other.
    pub fn take(&mut self) -> Held {
        let mut held = Held::default();
        for (i, p) in self.ports.iter().enumerate() {
            let sources = &self.sources;
            let mut keep = |b: &[u8]| {
                if source_of(b).is_some_and(|s| sources.contains(&s)) {
                    held.out.push((i, b.to_vec()));
                }
            };
            while let Ok(true) = p.local_in.receive_raw(&mut keep) {}
        }
        while let Ok(Some(s)) = self.from_remote.try_recv() {
            held.incoming.push(s);
        }
        held
    }

    /// After the round: send out and publish here what [`Ordered::take`] held.
    pub fn deliver(&mut self, held: Held) {
        for (i, bytes) in held.out {
            if let Err(e) = self.ports[i].remote.put(bytes).wait() {
                tracing::warn!("ordered {}: {e}", self.ports[i].topic);
            }
        }
        for s in held.incoming {
            let key = s.key_expr().as_str();
            let topic = key.strip_prefix(PREFIX).map(|t| t.trim_start_matches('/'));
            let Some(p) = self
                .ports
                .iter_mut()
                .find(|p| Some(p.topic.as_str()) == topic)
            else {
                continue;
            };
            let bytes = s.payload().to_bytes();
            if let Err(e) = p.local_out.publish_raw(&bytes) {
                tracing::warn!("ordered {}: {e}", p.topic);
            } else if let Ok(mut noted) = self.noted.lock() {
                crate::probe::note(&mut noted, &p.topic, &bytes, &self.sources);
            }
        }
    }
}
