//! `aisle host --name B --hosts FILE`: the daemon of one host of a spread group.
//!
//! It joins the Zenoh session with this host's endpoints (`hosts.toml`), and serves the
//! supervisor's control requests (`aisle_link::control`): `start` refuses a supervisor
//! of another schema (naming both hashes); otherwise it creates this host's iceoryx2
//! instance, announces it to its nodes as the supervisor does, holds and bridges the
//! topics the supervisor names, and starts the nodes placed here. `spawn` and `kill`
//! act on one node, `stop` stops them all and removes the instance; the end of each
//! node is reported to the supervisor, which decides on restarts. A beat every
//! `aisle_link::BEAT` tells the supervisor this host is reachable; when the supervisor's
//! host stays silent past the run's `link.down_limit_s`, the daemon stops its nodes and
//! removes the instance itself (nothing is left behind on a host cut off for good).
//!
//! Knows processes and the control requests; not what the nodes compute.

use crate::launch::{LaunchSpec, ProcessGroup, current_exe};
use crate::remote::NAMESPACE;
use aisle_bus::{Bus, HeldService, Instance, Publisher, signals};
use aisle_link::{Bridge, ControlServer, HostReply, HostRequest, Placement, StartGroup};
use aisle_messages::{InstanceInfo, NodeKind, TickMode};
use aisle_node::Graph;
use anyhow::{Context, anyhow, bail};
use std::os::unix::process::ExitStatusExt;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Duration;

/// How long the nodes get to stop before they are killed.
const GRACE: Duration = Duration::from_millis(1500);
/// How long one wait for a request lasts before the nodes are looked at again.
const POLL: Duration = Duration::from_millis(20);

/// One group's part on this host. Field order is drop order: the nodes stop (in
/// `stop`), then the link, the held services and the bus before the instance goes.
struct Part {
    group: ProcessGroup,
    bridge: Bridge,
    /// The supervisor's host, and how long it may be silent before the nodes stop.
    home: String,
    down_limit_ms: u64,
    _held: Vec<HeldService>,
    /// The announcement, handed to every node that joins (history 1).
    info: Publisher<InstanceInfo>,
    _bus: Bus,
    instance: Instance,
}

impl Part {
    /// The supervisor's host and how long it has been silent, when longer than the
    /// run's limit (a supervisor not heard yet is not counted).
    fn orphaned(&self, beats: &aisle_link::Beats) -> Option<(String, f64)> {
        let last = *beats.last().get(&self.home)?;
        let silent_s = aisle_bus::clock::monotonic_ns().saturating_sub(last) as f64 * 1e-9;
        (silent_s * 1e3 > self.down_limit_ms as f64).then(|| (self.home.clone(), silent_s))
    }

    fn stop(mut self) {
        self.group.stop(GRACE);
        let instance = self.instance.clone();
        drop(self);
        if let Err(e) = instance.remove() {
            tracing::warn!("could not remove instance {}: {e}", instance.prefix);
        }
    }
}

/// `aisle host`: serves until SIGINT or SIGTERM.
/// `pretend_schema` stands in for this build's group hash (`aisle_link::group_hash`:
/// the schema and the link's wire version; fault injection for tests).
pub fn main(name: &str, hosts: &Path, config_dir: &Path, pretend_schema: Option<&str>) -> ExitCode {
    let ours = pretend_schema.map_or_else(
        || format!("{:016x}", aisle_link::group_hash()),
        str::to_string,
    );
    match serve(name, hosts, config_dir, &ours) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => crate::exit::fail(format!("{e:#}")),
    }
}

fn serve(name: &str, hosts: &Path, config_dir: &Path, ours: &str) -> anyhow::Result<()> {
    signals::install();
    let graph = Graph::load_dir(config_dir)?;
    let placement = crate::remote::load_placement(hosts, &graph)?;
    let me = placement.host(name).ok_or_else(|| {
        let names: Vec<&str> = placement.hosts().iter().map(|h| h.name.as_str()).collect();
        anyhow!(
            "{}: no host called `{name}`; its hosts are {}",
            hosts.display(),
            names.join(", ")
        )
    })?;
    let session = aisle_link::open_session(name, aisle_link::zenoh_config(me, NAMESPACE)?)?;
    let server = ControlServer::declare(&session, name)?;
    // The beat by which the supervisor tells this host's link is up; the supervisor's
    // own beat, by which this host stops its nodes when the supervisor is gone.
    let _beating = aisle_link::Beating::start(&session, name)?;
    let beats = aisle_link::Beats::declare(&session)?;
    tracing::info!(
        host = name,
        "serving; listen {:?}, connect {:?}",
        me.listen,
        me.connect
    );
    let config_dir = std::fs::canonicalize(config_dir)
        .with_context(|| format!("config directory {}", config_dir.display()))?;
    let here = Here {
        name,
        placement: &placement,
        graph: &graph,
        config_dir: &config_dir,
        session: &session,
        schema: ours,
    };
    let mut part: Option<Part> = None;
    while !signals::stop_requested() {
        if let Some(pending) = server.next(POLL) {
            let reply = match &pending.request {
                Ok(r) => handle(r, &mut part, &here),
                Err(e) => HostReply::Refused(format!("unreadable request: {e}")),
            };
            if let HostReply::Refused(why) = &reply {
                tracing::error!(host = name, "refused: {why}");
            }
            pending.reply(&reply);
        }
        if let Some((home, silent_s)) = part.as_ref().and_then(|p| p.orphaned(&beats)) {
            tracing::error!(
                host = name,
                "nothing from the supervisor's host `{home}` for {silent_s:.1} s: stopping this host's nodes"
            );
            if let Some(p) = part.take() {
                p.stop();
            }
        }
        if let Some(p) = part.as_mut() {
            // iceoryx2 hands the history to a late subscriber when its publisher updates
            // its connections: the announcement reaches the nodes that (re)join so.
            if let Err(e) = p.info.update_connections() {
                tracing::warn!(host = name, "{e}");
            }
            while let Some((kind, status)) = p.group.poll_exit() {
                tracing::warn!(
                    host = name,
                    "{} {}",
                    kind.name(),
                    crate::launch::describe(&status)
                );
                server.exited(kind.name(), status.into_raw());
            }
        }
    }
    if let Some(p) = part.take() {
        p.stop();
    }
    Ok(())
}

/// What a host knows of itself while it serves.
struct Here<'a> {
    name: &'a str,
    placement: &'a Placement,
    graph: &'a Graph,
    config_dir: &'a Path,
    session: &'a aisle_link::Session,
    /// This build's group hash (`aisle_link::group_hash`), 16 hex digits.
    schema: &'a str,
}

fn handle(request: &HostRequest, part: &mut Option<Part>, here: &Here<'_>) -> HostReply {
    let name = here.name;
    let result = match request {
        HostRequest::Start(start) => {
            if let Some(p) = part.take() {
                tracing::warn!(host = name, "a new group replaces the running one");
                p.stop();
            }
            start_part(start, here).map(|p| {
                *part = Some(p);
            })
        }
        HostRequest::Spawn { node, restarted } => with_node(part, node, |p, kind| {
            p.group.spawn(kind, *restarted).map_err(|e| anyhow!(e))
        }),
        HostRequest::Kill { node } => with_node(part, node, |p, kind| {
            p.group.kill(kind);
            Ok(())
        }),
        HostRequest::LinkSamples => {
            let (samples, dropped) = part
                .as_ref()
                .map(|p| p.bridge.take_samples())
                .unwrap_or_default();
            return HostReply::LinkSamples(samples, dropped);
        }
        HostRequest::Stop => {
            if let Some(p) = part.take() {
                p.stop();
            }
            Ok(())
        }
    };
    match result {
        Ok(()) => HostReply::Done,
        Err(e) => HostReply::Refused(format!("host `{name}`: {e:#}")),
    }
}

fn with_node(
    part: &mut Option<Part>,
    node: &str,
    f: impl FnOnce(&mut Part, NodeKind) -> anyhow::Result<()>,
) -> anyhow::Result<()> {
    let p = part.as_mut().ok_or_else(|| anyhow!("no group runs here"))?;
    let kind = NodeKind::from_name(node).ok_or_else(|| anyhow!("no node called `{node}`"))?;
    f(p, kind)
}

/// The schema check, then this host's instance, link and nodes.
fn start_part(start: &StartGroup, here: &Here<'_>) -> anyhow::Result<Part> {
    let (name, placement, session) = (here.name, here.placement, here.session);
    let ours = here.schema;
    if start.schema_hash != ours {
        bail!(
            "schema hash {ours} of this host differs from {} of the supervisor: build both \
             from the same source",
            start.schema_hash
        );
    }
    if let Some(n) = start.nodes.keys().find(|n| placement.host_of(n) != name) {
        bail!(
            "node `{n}` is not placed on this host in {}",
            placement.file().display()
        );
    }
    let mode = TickMode::from_u32(start.mode)
        .ok_or_else(|| anyhow!("unknown clock mode {}", start.mode))?;
    let base = crate::session::run_base_dir()?;
    crate::clean::sweep_before_run(&base);
    let instance = Instance::unique(&base);
    let (bus, info) = Bus::announce(&instance, aisle_messages::schema_hash(), start.seed, mode)?;
    let mut held = Vec::new();
    for t in &start.topics {
        held.push(
            bus.hold_service(t)?
                .ok_or_else(|| anyhow!("no topic called `{t}` to bridge"))?,
        );
    }
    let sources: Vec<u32> = start
        .nodes
        .keys()
        .filter_map(|n| NodeKind::from_name(n).map(|k| k.code()))
        .collect();
    let bridge = Bridge::start(
        name,
        &instance,
        session.clone(),
        start.topics.clone(),
        sources,
    )?;
    tracing::info!(host = name, prefix = %instance.prefix, "bridging {}", start.topics.join(", "));
    let args = start.nodes.clone();
    let spec = LaunchSpec {
        exe: current_exe().map_err(|e| anyhow!(e))?,
        instance: instance.clone(),
        config_dir: PathBuf::from(here.config_dir),
        extra: Box::new(move |k: NodeKind| args.get(k.name()).cloned().unwrap_or_default()),
        external: crate::launch::external_commands(here.graph),
        dt_ns: start.dt_ns,
        controller_every: start.controller_every,
    };
    let mut group = ProcessGroup::new(spec);
    for node in start.nodes.keys() {
        let kind = NodeKind::from_name(node).ok_or_else(|| anyhow!("no node called `{node}`"))?;
        group.spawn(kind, false).map_err(|e| anyhow!(e))?;
    }
    Ok(Part {
        group,
        bridge,
        home: start.home.clone(),
        down_limit_ms: start.down_limit_ms,
        _held: held,
        info,
        _bus: bus,
        instance,
    })
}
