//! The iceoryx2 Zenoh link of one host: a thread that bridges exactly the crossing topics
//! between the host's iceoryx2 instance and a Zenoh session in peer mode.
//!
//! What the link needs (iceoryx2-link 0.10 with the tunnel over the Zenoh carrier):
//! - a node of its own in the host's instance; it exports the services that *another*
//!   node of the instance holds, and mirrors the services its peers offer;
//! - every bridged service must exist on the host with the group's settings before the
//!   link sees it (`aisle_bus::Bus::hold_service`): a mirror the link creates gets
//!   iceoryx2's default settings, which the processes then cannot open;
//! - each bridged service gets one more publisher, subscriber and node (the link's), and
//!   its event service (same name) one more notifier and listener: the wake-ups cross too;
//! - samples travel as user header then payload, one Zenoh put per sample, keyed by
//!   the service hash (`iox2/v1/channel/<hash>/<types fingerprint>`); a catalogue
//!   message's payload stops at its used part (`crate::trimmed`).
//!
//! - the link keeps no order between services: the tick protocol travels beside it
//!   (`crate::ordered`), sequenced around its rounds;
//! - after each round, `crate::probe` notes the latency of what crossed to this host.
//!
//! Knows the link and Zenoh; not which topics cross (the caller says) nor the nodes.

use crate::HostDecl;
use crate::ordered::Ordered;
use crate::probe::Probe;
use crate::trimmed::Trimmed;
use aisle_bus::{Bus, Instance};
use aisle_messages::{NodeKind, topics};
use iceoryx2::prelude::*;
use iceoryx2_integrations_zenoh_link_carrier::ZenohCarrier;
use iceoryx2_link::Link;
use iceoryx2_link_tunnel::Tunnel;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// Why a link did not start.
#[derive(Debug, thiserror::Error)]
pub enum LinkError {
    #[error("host `{host}`: zenoh configuration key `{key}` = {value}: {reason}")]
    Config {
        host: String,
        key: String,
        value: String,
        reason: String,
    },
    #[error("host `{host}`: {what}")]
    Start { host: String, what: String },
}

/// The Zenoh configuration of `host`: peer mode, exactly its endpoints, no multicast
/// scouting, every key under `namespace` (so groups on one network stay apart).
pub fn zenoh_config(host: &HostDecl, namespace: &str) -> Result<zenoh::Config, LinkError> {
    let mut c = zenoh::Config::default();
    let list = |v: &[String]| {
        let quoted: Vec<String> = v.iter().map(|e| format!("\"{e}\"")).collect();
        format!("[{}]", quoted.join(","))
    };
    let entries = [
        ("mode", "\"peer\"".to_string()),
        ("listen/endpoints", list(&host.listen)),
        ("connect/endpoints", list(&host.connect)),
        ("scouting/multicast/enabled", "false".to_string()),
        // The carrier's channels put with Zenoh's default congestion control, which drops
        // a sample when the queue is full: large samples under load were lost (4 of 100
        // point clouds of 447 KB across two namespaces). A lost sample stalls lockstep.
        (
            "qos/publication",
            r#"[{"key_exprs":["**/iox2/**"],"config":{"congestion_control":"block"}}]"#.to_string(),
        ),
        ("namespace", format!("\"{namespace}\"")),
    ];
    for (key, value) in entries {
        c.insert_json5(key, &value).map_err(|e| LinkError::Config {
            host: host.name.clone(),
            key: key.into(),
            value: value.clone(),
            reason: e.to_string(),
        })?;
    }
    Ok(c)
}

/// A running link; stops (and removes its node) when dropped.
pub struct Bridge {
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
    /// The latency of the samples that crossed to this host (`crate::probe`).
    noted: crate::probe::Shared,
}

/// How long the link sleeps between two rounds of propagation. Nothing wakes the link
/// on a local publication, so a sample published on this host waits for the next round.
/// The sleep is a plain one: the link's wake listener (which the carrier signals when a
/// sample arrives from the other host) waits with a socket timeout, which Linux rounds up
/// to a scheduler tick (4 ms here), and that made every crossing take 8 ms.
const ROUND: Duration = Duration::from_micros(500);
/// How often the link looks for services that appeared or left (a listing of the
/// instance's services: too costly for every round).
const DISCOVERY: Duration = Duration::from_millis(100);

impl Bridge {
    /// Starts the link of `host` for `instance`, on `session`: the services called
    /// `topics` are bridged, those of them in [`ORDERED`] in order with the rest
    /// (`crate::ordered`), sent out when written by one of the nodes `sources` (their
    /// `NodeKind` codes: the nodes of this host).
    pub fn start(
        host: &str,
        instance: &Instance,
        session: zenoh::Session,
        topics: Vec<String>,
        sources: Vec<u32>,
    ) -> Result<Bridge, LinkError> {
        let stop = Arc::new(AtomicBool::new(false));
        let (ready_tx, ready_rx) = mpsc::channel::<Result<(), String>>();
        let (inst, flag, name) = (instance.clone(), stop.clone(), host.to_string());
        let noted = crate::probe::Shared::default();
        let sides = Sides {
            topics,
            sources,
            noted: noted.clone(),
        };
        let thread = std::thread::Builder::new()
            .name(format!("link-{host}"))
            .spawn(move || run(&name, &inst, session, sides, &flag, ready_tx))
            .map_err(|e| LinkError::Start {
                host: host.into(),
                what: format!("cannot start the link thread: {e}"),
            })?;
        let start_err = |what: String| LinkError::Start {
            host: host.into(),
            what,
        };
        match ready_rx.recv() {
            Ok(Ok(())) => Ok(Bridge {
                stop,
                thread: Some(thread),
                noted,
            }),
            Ok(Err(what)) => Err(start_err(what)),
            Err(_) => Err(start_err("the link thread ended before it started".into())),
        }
    }
}

impl Bridge {
    /// The samples that crossed to this host since the last call, and how many were
    /// not kept (`crate::probe::MAX_SAMPLES`).
    pub fn take_samples(&self) -> (Vec<crate::LinkSample>, u64) {
        match self.noted.lock() {
            Ok(mut n) => (
                std::mem::take(&mut n.samples),
                std::mem::take(&mut n.dropped),
            ),
            Err(_) => (Vec::new(), 0),
        }
    }
}

impl Drop for Bridge {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// The topics protocol samples travel beside the link, in order with the data.
pub const ORDERED: [&str; 2] = [topics::TICK.name, topics::TICK_DONE.name];

/// What a link bridges and whose protocol samples it sends out.
struct Sides {
    topics: Vec<String>,
    sources: Vec<u32>,
    noted: crate::probe::Shared,
}

fn run(
    host: &str,
    instance: &Instance,
    session: zenoh::Session,
    sides: Sides,
    stop: &AtomicBool,
    ready: mpsc::Sender<Result<(), String>>,
) {
    let setup = || -> Result<_, String> {
        let config = &instance.iceoryx_config().map_err(|e| e.to_string())?;
        // The link's own member of the instance, for the ordered topics' raw ports (they
        // copy samples whole, header and writer included). Named `replay`: like a
        // replay, it publishes what others wrote.
        let bus = Bus::second_member(instance, NodeKind::Replay).map_err(|e| e.to_string())?;
        let (ordered, bridged): (Vec<String>, Vec<String>) = sides
            .topics
            .into_iter()
            .partition(|t| ORDERED.contains(&t.as_str()));
        let probe = Probe::open(&bus, &bridged, sides.sources.clone(), sides.noted.clone());
        let ordered = Ordered::open(&bus, &session, &ordered, sides.sources, sides.noted)?;
        let topics = bridged;
        let carrier = ZenohCarrier::open(session).map_err(|e| format!("zenoh carrier: {e}"))?;
        let node = NodeBuilder::new()
            .config(config)
            .signal_handling_mode(SignalHandlingMode::Disabled)
            .create::<ipc::Service>()
            .map_err(|e| format!("link node: {e:?}"))?;
        let mut link = Link::new(node, Tunnel::new(Trimmed::new(carrier), config))
            .with_filter(move |name| topics.iter().any(|t| t.as_str() == name.as_str()));
        let listener = link.listener().map_err(|e| format!("link wake-up: {e}"))?;
        Ok((link, listener, ordered, probe, bus))
    };
    let (mut link, listener, mut ordered, mut probe, _bus) = match setup() {
        Ok(v) => {
            let _ = ready.send(Ok(()));
            v
        }
        Err(e) => {
            let _ = ready.send(Err(e));
            return;
        }
    };
    let mut discovered: Option<Instant> = None;
    let mut failing = None;
    while !stop.load(Ordering::Relaxed) {
        std::thread::sleep(ROUND);
        // Drained so the wake-ups the carrier sends do not pile up.
        let _ = listener.try_wait(|_| {});
        if discovered.is_none_or(|t| t.elapsed() >= DISCOVERY) {
            discovered = Some(Instant::now());
            if let Err(e) = link.discover() {
                tracing::warn!(host, "link discovery: {e}");
            }
            ordered.update_connections();
        }
        let held = ordered.take();
        // A failure repeats every round while it lasts: said once.
        let propagated = link.propagate();
        ordered.deliver(held);
        probe.drain();
        match propagated {
            Ok(()) => failing = None,
            Err(e) if failing != Some(e) => {
                tracing::warn!(host, "link propagation: {e}");
                failing = Some(e);
            }
            Err(_) => {}
        }
    }
}
