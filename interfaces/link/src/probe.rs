//! The one-way latency of the samples that cross to this host: for every bridged topic
//! but the heartbeats, a subscriber of the link's own member takes each sample written
//! by a node of another host once the link has published it here, and notes the time
//! since its writer published it (`Header::publish_wall_ns`, then
//! `aisle_bus::clock::monotonic_ns` here). The tick protocol's samples are noted where
//! `crate::ordered` publishes them. Heartbeats are left out: every process publishes
//! them and their few subscriber places (the `PROTOCOL` class) are the nodes'.
//!
//! Both stamps are CLOCK_MONOTONIC: the figure is a latency only where the hosts share
//! one clock (network namespaces of one kernel, as in the tests); between machines it
//! also holds the offset of their clocks. The samples wait in memory (at most
//! [`MAX_SAMPLES`]) until the owner takes them.
//!
//! Knows the header's layout and the bus; not what the samples mean.

use aisle_bus::{Bus, RawSubscriber, clock};
use aisle_messages::{Header, topics};
use serde::{Deserialize, Serialize};
use std::sync::{Arc, Mutex};

/// Most samples kept between two takes; later ones are counted, not kept.
pub const MAX_SAMPLES: usize = 500_000;

/// One sample that crossed to this host.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LinkSample {
    pub topic: String,
    /// `NodeKind` code of its writer.
    pub source: u32,
    pub tick: u64,
    /// From its publication to its delivery on this host, nanoseconds.
    pub ns: u64,
}

/// The samples noted so far, shared between the link thread and the link's owner.
#[derive(Debug, Default)]
pub struct Noted {
    pub samples: Vec<LinkSample>,
    /// Samples not kept because [`MAX_SAMPLES`] were waiting.
    pub dropped: u64,
}

pub type Shared = Arc<Mutex<Noted>>;

/// `(source, tick, publish_wall_ns)` of a message's bytes, if they hold a header.
fn header_of(bytes: &[u8]) -> Option<(u32, u64, u64)> {
    let field = |at: usize, n: usize| bytes.get(at..at + n);
    let u64_at = |at: usize| Some(u64::from_ne_bytes(field(at, 8)?.try_into().ok()?));
    let source = u32::from_ne_bytes(
        field(std::mem::offset_of!(Header, source), 4)?
            .try_into()
            .ok()?,
    );
    let tick = u64_at(std::mem::offset_of!(Header, tick))?;
    let published = u64_at(std::mem::offset_of!(Header, publish_wall_ns))?;
    Some((source, tick, published))
}

/// The probe of one host's link.
pub struct Probe {
    ports: Vec<(String, Box<dyn RawSubscriber>)>,
    /// `NodeKind` codes of the nodes on this host: their samples did not cross.
    sources: Vec<u32>,
    out: Shared,
}

impl Probe {
    /// Subscribes to `topics`; a topic it cannot subscribe to is left out (said once):
    /// measuring must not keep the link from running.
    pub fn open(bus: &Bus, topics: &[String], sources: Vec<u32>, out: Shared) -> Probe {
        let mut ports = Vec::new();
        for t in topics.iter().filter(|t| *t != topics::HEARTBEAT.name) {
            match bus.raw_subscriber(t) {
                Ok(Some(s)) => ports.push((t.clone(), s)),
                Ok(None) => tracing::warn!("link latency: no topic called `{t}`"),
                Err(e) => tracing::warn!("link latency of `{t}` not measured: {e}"),
            }
        }
        Probe {
            ports,
            sources,
            out,
        }
    }

    /// After a round of the link: notes every sample from another host delivered here.
    pub fn drain(&mut self) {
        let Ok(mut noted) = self.out.lock() else {
            return;
        };
        for (topic, port) in &self.ports {
            let mut keep = |b: &[u8]| note(&mut noted, topic, b, &self.sources);
            while let Ok(true) = port.receive_raw(&mut keep) {}
        }
    }
}

/// Notes `bytes` of `topic`, just delivered here, unless a node of this host (one of
/// `sources`) wrote them.
pub fn note(noted: &mut Noted, topic: &str, bytes: &[u8], sources: &[u32]) {
    let Some((source, tick, published)) = header_of(bytes) else {
        return;
    };
    if sources.contains(&source) || published == 0 {
        return;
    }
    if noted.samples.len() >= MAX_SAMPLES {
        noted.dropped += 1;
        return;
    }
    noted.samples.push(LinkSample {
        topic: topic.to_string(),
        source,
        tick,
        ns: clock::monotonic_ns().saturating_sub(published),
    });
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_header_is_read_from_the_bytes() {
        let mut bytes = vec![0u8; size_of::<Header>() + 16];
        let mut put = |at: usize, v: &[u8]| bytes[at..at + v.len()].copy_from_slice(v);
        put(std::mem::offset_of!(Header, source), &3u32.to_ne_bytes());
        put(std::mem::offset_of!(Header, tick), &42u64.to_ne_bytes());
        put(
            std::mem::offset_of!(Header, publish_wall_ns),
            &1234u64.to_ne_bytes(),
        );
        let bytes = &bytes[..];
        assert_eq!(header_of(bytes), Some((3, 42, 1234)));
        assert_eq!(header_of(&bytes[..8]), None);
    }
}
