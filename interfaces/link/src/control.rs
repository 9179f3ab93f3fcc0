//! The control plane of a spread group: the supervisor asks a host (`aisle host`) to start
//! its part of the group, to start or kill one node, and to stop; the host tells when one
//! of its nodes ended.
//!
//! Zenoh queryables, not a topic over the bridge: a request gets exactly one reply (a
//! refusal carries its reason, e.g. both schema hashes), it works before the host has
//! an iceoryx2 instance to bridge (the instance is what `start` creates), and the message
//! catalogue (and so the schema hash) stays as it is. Requests and replies are JSON.
//!
//! Keys, under the session's namespace: `aisle/host/<name>/control` (queryable of host
//! `<name>`) and `aisle/host/<name>/exit` (its nodes' ends); the hosts' beats are
//! `crate::beat`.
//!
//! Knows the requests and their keys; not how a host runs its nodes.

use crate::LinkError;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::time::{Duration, Instant};

/// How long a request waits before it is sent again to a host that did not answer.
const RETRY: Duration = Duration::from_millis(200);
use zenoh::Wait;
use zenoh::handlers::FifoChannelHandler;
use zenoh::query::{Query, Queryable};
use zenoh::sample::Sample;

/// What the supervisor tells a host to start: its schema, the run's seed and clock, and
/// the command-line arguments of each node the host runs.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StartGroup {
    /// The supervisor's [`crate::group_hash`] (the message schema with the link's wire
    /// version), 16 hex digits.
    pub schema_hash: String,
    pub seed: u64,
    /// `TickMode` as announced on `aisle/instance`.
    pub mode: u32,
    /// Simulated time per tick and the controller's period in ticks (external nodes'
    /// environment).
    pub dt_ns: u64,
    pub controller_every: u32,
    /// The topics the host bridges: those that cross hosts and touch it.
    pub topics: Vec<String>,
    /// Per node placed on the host, the arguments after `aisle node <name> --prefix ...`.
    pub nodes: BTreeMap<String, Vec<String>>,
    /// The supervisor's host, and how long it may be silent before the host stops
    /// its nodes (`restart.toml` `link.down_limit_s`).
    pub home: String,
    pub down_limit_ms: u64,
}

#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, rename_all = "snake_case")]
pub enum HostRequest {
    Start(StartGroup),
    Spawn {
        node: String,
        restarted: bool,
    },
    Kill {
        node: String,
    },
    /// The samples that crossed to the host since the last ask (`crate::probe`).
    LinkSamples,
    Stop,
}

#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, rename_all = "snake_case")]
pub enum HostReply {
    Done,
    Refused(String),
    /// The samples, and how many were not kept.
    LinkSamples(Vec<crate::LinkSample>, u64),
}

/// One of a host's nodes ended: the raw wait status (`ExitStatusExt::from_raw`).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NodeExit {
    pub host: String,
    pub node: String,
    pub status: i32,
}

fn control_key(host: &str) -> String {
    format!("aisle/host/{host}/control")
}

fn exit_key(host: &str) -> String {
    format!("aisle/host/{host}/exit")
}

fn zerr(host: &str, what: &str, e: impl std::fmt::Display) -> LinkError {
    LinkError::Start {
        host: host.into(),
        what: format!("{what}: {e}"),
    }
}

/// Opens the Zenoh session of a host.
pub fn open_session(host: &str, config: zenoh::Config) -> Result<zenoh::Session, LinkError> {
    zenoh::open(config)
        .wait()
        .map_err(|e| zerr(host, "cannot open the zenoh session", e))
}

/// A host's side: the requests addressed to it.
pub struct ControlServer {
    host: String,
    session: zenoh::Session,
    queryable: Queryable<FifoChannelHandler<Query>>,
}

/// A request waiting for its reply.
pub struct Pending {
    query: Query,
    pub request: Result<HostRequest, String>,
}

impl Pending {
    pub fn reply(self, reply: &HostReply) {
        let text = serde_json::to_string(reply).unwrap_or_default();
        let key = self.query.key_expr().clone();
        if let Err(e) = self.query.reply(key, text).wait() {
            tracing::warn!("cannot reply to a control request: {e}");
        }
    }
}

impl ControlServer {
    pub fn declare(session: &zenoh::Session, host: &str) -> Result<ControlServer, LinkError> {
        let queryable = session
            .declare_queryable(control_key(host))
            .wait()
            .map_err(|e| zerr(host, "cannot declare the control queryable", e))?;
        Ok(ControlServer {
            host: host.into(),
            session: session.clone(),
            queryable,
        })
    }

    /// The next request, waiting up to `timeout`.
    pub fn next(&self, timeout: Duration) -> Option<Pending> {
        let query = self.queryable.recv_timeout(timeout).ok().flatten()?;
        let request = match query.payload() {
            Some(p) => serde_json::from_slice(&p.to_bytes()).map_err(|e| e.to_string()),
            None => Err("a control request without a payload".to_string()),
        };
        Some(Pending { query, request })
    }

    /// Tells the supervisor that `node` ended with the raw wait `status`.
    pub fn exited(&self, node: &str, status: i32) {
        let exit = NodeExit {
            host: self.host.clone(),
            node: node.into(),
            status,
        };
        let text = serde_json::to_string(&exit).unwrap_or_default();
        if let Err(e) = self.session.put(exit_key(&self.host), text).wait() {
            tracing::warn!("cannot report the end of {node}: {e}");
        }
    }
}

/// The supervisor's side: requests to hosts, their nodes' ends and their beats.
pub struct ControlClient {
    session: zenoh::Session,
    exits: zenoh::pubsub::Subscriber<FifoChannelHandler<Sample>>,
    beats: crate::beat::Beats,
}

impl ControlClient {
    pub fn new(session: &zenoh::Session) -> Result<ControlClient, LinkError> {
        let exits = session
            .declare_subscriber(exit_key("*"))
            .wait()
            .map_err(|e| zerr("*", "cannot subscribe to the hosts' node ends", e))?;
        let beats = crate::beat::Beats::declare(session)?;
        Ok(ControlClient {
            session: session.clone(),
            exits,
            beats,
        })
    }

    /// When each host's last beat arrived (`aisle_bus::clock::monotonic_ns`); a host
    /// not heard yet is absent.
    pub fn beats(&self) -> BTreeMap<String, u64> {
        self.beats.last()
    }

    /// Sends `request` to `host` and waits up to `timeout` for its reply. A host not yet
    /// reachable (its session still connecting) answers nothing: the request is sent
    /// again until `timeout`.
    pub fn request(
        &self,
        host: &str,
        request: &HostRequest,
        timeout: Duration,
    ) -> Result<HostReply, LinkError> {
        let text = serde_json::to_string(request).map_err(|e| zerr(host, "request", e))?;
        let deadline = Instant::now() + timeout;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            let replies = self
                .session
                .get(control_key(host))
                .payload(text.clone())
                .timeout(left)
                .wait()
                .map_err(|e| zerr(host, "cannot send a control request", e))?;
            if let Ok(reply) = replies.recv() {
                let sample = reply
                    .result()
                    .map_err(|e| zerr(host, "the host answered with an error", format!("{e:?}")))?;
                return serde_json::from_slice(&sample.payload().to_bytes())
                    .map_err(|e| zerr(host, "unreadable reply", e));
            }
            if Instant::now() + RETRY >= deadline {
                return Err(LinkError::Start {
                    host: host.into(),
                    what: format!(
                        "no answer within {:.1} s: is `aisle host --name {host}` running and reachable?",
                        timeout.as_secs_f64()
                    ),
                });
            }
            std::thread::sleep(RETRY);
        }
    }

    /// The next node end a host reported, if any.
    pub fn next_exit(&self) -> Option<NodeExit> {
        let sample = self.exits.try_recv().ok().flatten()?;
        serde_json::from_slice(&sample.payload().to_bytes()).ok()
    }
}
