//! The part of a process group that runs on other hosts (`aisle run --hosts`): the
//! supervisor's link for the topics that cross hosts, and the control requests by which
//! each other host (`aisle host`) starts, kills and stops its nodes and reports their
//! ends. [`crate::launch::ProcessGroup`] routes a node placed elsewhere through here.
//!
//! Knows the placement and the control requests; not what the nodes do.

use aisle_bus::{Bus, HeldService, Instance};
use aisle_link::{
    Beating, Bridge, ControlClient, HostReply, HostRequest, LinkSample, Placement, StartGroup,
    crossing_topics,
};
use aisle_messages::NodeKind;
use aisle_node::Graph;
use anyhow::{Context, anyhow, bail};
use std::collections::BTreeMap;
use std::os::unix::process::ExitStatusExt;
use std::process::ExitStatus;
use std::time::Duration;

/// Zenoh keys of a spread group live under this namespace.
pub const NAMESPACE: &str = "aisle";
/// How long a host may take to start its part of the group (instance, link, nodes).
const START_TIMEOUT: Duration = Duration::from_secs(20);
/// How long a host may take to answer a spawn or kill.
const REQUEST_TIMEOUT: Duration = Duration::from_secs(5);

/// The nodes on other hosts, and what carries their topics.
pub struct RemoteNodes {
    /// Node name -> host name, for the nodes not on this host.
    placed: BTreeMap<String, String>,
    /// This host's name.
    home: String,
    client: ControlClient,
    _beating: Beating,
    // Drop order: the link before the services it bridges.
    bridge: Bridge,
    _held: Vec<HeldService>,
    _session: aisle_link::Session,
}

/// What a spread run needs beyond a local one.
pub struct SpreadStart<'a> {
    pub placement: &'a Placement,
    pub graph: &'a Graph,
    pub bus: &'a Bus,
    pub instance: &'a Instance,
    /// Whether a recorder takes part (it subscribes to every topic).
    pub recorder: bool,
    /// Each node's extra arguments, as the local launch gives them.
    pub args: &'a dyn Fn(NodeKind) -> Vec<String>,
    pub seed: u64,
    pub mode: u32,
    pub dt_ns: u64,
    pub controller_every: u32,
    /// How long a host's daemon keeps its nodes while this host is silent.
    pub down_limit_s: f64,
}

impl RemoteNodes {
    /// Bridges this host's crossing topics, then asks every other host to start its
    /// nodes; a host that refuses (another schema) fails the start with its reason.
    pub fn start(s: &SpreadStart<'_>, expected: &[NodeKind]) -> anyhow::Result<RemoteNodes> {
        let home = s.placement.home();
        let crossing = crossing_topics(s.graph, s.placement, |_| s.recorder);
        let topics_of = |host: &str| -> Vec<String> {
            crossing
                .iter()
                .filter(|c| c.touches(host))
                .map(|c| c.topic.clone())
                .collect()
        };
        let mine = topics_of(&home.name);
        let mut held = Vec::new();
        for t in &mine {
            held.extend(s.bus.hold_service(t)?);
        }
        let zcfg = aisle_link::zenoh_config(home, NAMESPACE)?;
        let session = aisle_link::open_session(&home.name, zcfg)?;
        let sources: Vec<u32> = s
            .graph
            .nodes()
            .iter()
            .filter(|n| s.placement.host_of(&n.name) == home.name)
            .map(|n| n.kind().code())
            .collect();
        let bridge = Bridge::start(
            &home.name,
            s.instance,
            session.clone(),
            mine.clone(),
            sources,
        )?;
        tracing::info!(host = %home.name, "bridging {} topics: {}", mine.len(), mine.join(", "));
        let client = ControlClient::new(&session)?;
        let beating = Beating::start(&session, &home.name)?;
        let mut placed = BTreeMap::new();
        for h in s.placement.hosts().iter().filter(|h| h.name != home.name) {
            let nodes: BTreeMap<String, Vec<String>> = expected
                .iter()
                .filter(|k| s.placement.host_of(k.name()) == h.name)
                .map(|k| (k.name().to_string(), (s.args)(*k)))
                .collect();
            if nodes.is_empty() {
                continue;
            }
            for n in nodes.keys() {
                placed.insert(n.clone(), h.name.clone());
            }
            let start = StartGroup {
                schema_hash: format!("{:016x}", aisle_link::group_hash()),
                seed: s.seed,
                mode: s.mode,
                dt_ns: s.dt_ns,
                controller_every: s.controller_every,
                topics: topics_of(&h.name),
                nodes,
                home: home.name.clone(),
                down_limit_ms: (s.down_limit_s * 1e3) as u64,
            };
            match client.request(&h.name, &HostRequest::Start(start), START_TIMEOUT)? {
                HostReply::Done | HostReply::LinkSamples(..) => {
                    tracing::info!(host = %h.name, "host started its nodes")
                }
                HostReply::Refused(why) => bail!("host `{}` refused the group: {why}", h.name),
            }
        }
        Ok(RemoteNodes {
            placed,
            home: home.name.clone(),
            client,
            _beating: beating,
            bridge,
            _held: held,
            _session: session,
        })
    }

    /// When each other host's last beat arrived (`aisle_bus::clock::monotonic_ns`); a
    /// host not heard yet is absent, and so is this one (its own beats come back).
    pub fn beats(&self) -> BTreeMap<String, u64> {
        let mut beats = self.client.beats();
        beats.remove(&self.home);
        beats
    }

    /// The host that runs `kind`, when not this one.
    pub fn host_of(&self, kind: NodeKind) -> Option<&str> {
        self.placed.get(kind.name()).map(String::as_str)
    }

    fn ask(&self, host: &str, request: HostRequest) -> Result<(), String> {
        match self.client.request(host, &request, REQUEST_TIMEOUT) {
            Ok(HostReply::Done | HostReply::LinkSamples(..)) => Ok(()),
            Ok(HostReply::Refused(why)) => Err(format!("host `{host}`: {why}")),
            Err(e) => Err(e.to_string()),
        }
    }

    pub fn spawn(&self, host: &str, kind: NodeKind, restarted: bool) -> Result<(), String> {
        let node = kind.name().to_string();
        self.ask(host, HostRequest::Spawn { node, restarted })
    }

    pub fn kill(&self, host: &str, kind: NodeKind) {
        let node = kind.name().to_string();
        if let Err(e) = self.ask(host, HostRequest::Kill { node }) {
            tracing::warn!("cannot kill {} on {host}: {e}", kind.name());
        }
    }

    /// The next end of a remote node, if one was reported.
    pub fn poll_exit(&self) -> Option<(NodeKind, ExitStatus)> {
        let exit = self.client.next_exit()?;
        let kind = NodeKind::from_name(&exit.node)?;
        Some((kind, ExitStatus::from_raw(exit.status)))
    }

    /// The samples that crossed to each host (this one's link, and every other host's
    /// on request, but those `skip` names: cut off), as `(from, to, sample)`; a host
    /// that does not answer is said once.
    pub fn link_samples(&self, skip: impl Fn(&str) -> bool) -> Vec<(String, String, LinkSample)> {
        let from = |s: &LinkSample| {
            let node = NodeKind::from_u32(s.source).map_or("?", |k| k.name());
            self.placed.get(node).unwrap_or(&self.home).clone()
        };
        let mut all = Vec::new();
        let mut keep = |to: &str, samples: Vec<LinkSample>, dropped: u64| {
            if dropped > 0 {
                tracing::warn!("link latency on host `{to}`: {dropped} samples not kept");
            }
            all.extend(samples.into_iter().map(|s| (from(&s), to.to_string(), s)));
        };
        let (mine, dropped) = self.bridge.take_samples();
        keep(&self.home, mine, dropped);
        let hosts: std::collections::BTreeSet<&String> = self.placed.values().collect();
        for h in hosts.into_iter().filter(|h| !skip(h)) {
            match self
                .client
                .request(h, &HostRequest::LinkSamples, REQUEST_TIMEOUT)
            {
                Ok(HostReply::LinkSamples(samples, dropped)) => keep(h, samples, dropped),
                Ok(other) => tracing::warn!("host `{h}` answered {other:?} for its link samples"),
                Err(e) => tracing::warn!("no link samples from host `{h}`: {e}"),
            }
        }
        all
    }

    /// Asks every host to stop its nodes (each waits `grace` before it kills them).
    pub fn stop(&self, grace: Duration) {
        let hosts: std::collections::BTreeSet<&String> = self.placed.values().collect();
        for h in hosts {
            if let Err(e) = self
                .client
                .request(h, &HostRequest::Stop, grace + REQUEST_TIMEOUT)
            {
                tracing::warn!("host `{h}` did not confirm the stop: {e}");
            }
        }
    }
}

/// Reads `--hosts` against the graph.
pub fn load_placement(path: &std::path::Path, graph: &Graph) -> anyhow::Result<Placement> {
    Placement::load(path, graph).with_context(|| anyhow!("the hosts file {}", path.display()))
}
