//! `config/hosts.toml`: the hosts of a spread group, their Zenoh endpoints, and the nodes
//! each runs.
//!
//! ```toml
//! [[host]]
//! name = "a"                            # [a-z0-9_-], 1-32 characters
//! listen = ["tcp/10.20.0.1:7447"]       # Zenoh endpoints this host listens on
//! nodes = ["supervisor", "simulator"]
//!
//! [[host]]
//! name = "b"
//! connect = ["tcp/10.20.0.1:7447"]      # Zenoh endpoints of other hosts it dials
//! nodes = ["lidar", "mapper", "global_planner", "teb_controller"]
//! ```
//!
//! Every node of the graph that the file does not name runs on the supervisor's host.
//! The Zenoh session of every host is in peer mode with exactly these endpoints: no
//! multicast scouting. Knows names and endpoints, checked against a [`Graph`]; it opens
//! nothing.

use aisle_config::{ConfigError, InvalidKey, Validate};
use aisle_node::Graph;
use serde::Deserialize;
use std::path::{Path, PathBuf};

/// One `[[host]]`.
#[derive(Debug, Clone, PartialEq, Eq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HostDecl {
    pub name: String,
    /// Zenoh endpoints this host listens on (`tcp/ADDRESS:PORT`).
    #[serde(default)]
    pub listen: Vec<String>,
    /// Zenoh endpoints of other hosts this host connects to.
    #[serde(default)]
    pub connect: Vec<String>,
    /// The graph's nodes this host runs.
    #[serde(default)]
    pub nodes: Vec<String>,
}

/// The whole file, checked for its own consistency (not yet against a graph).
#[derive(Debug, Clone, PartialEq, Eq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HostsFile {
    pub host: Vec<HostDecl>,
}

/// The transports a Zenoh endpoint may name here.
const TRANSPORTS: &[&str] = &["tcp", "udp", "tls", "quic", "unixsock-stream"];

impl Validate for HostsFile {
    fn validate(&self) -> Result<(), InvalidKey> {
        if self.host.len() < 2 {
            return Err(InvalidKey::new(
                "host",
                format!(
                    "a spread group needs at least two hosts, the file has {}",
                    self.host.len()
                ),
            ));
        }
        for (i, h) in self.host.iter().enumerate() {
            let key = |field: &str| format!("host[{i}].{field}");
            check_host_name(&h.name).map_err(|r| InvalidKey::new(key("name"), r))?;
            if self.host[..i].iter().any(|g| g.name == h.name) {
                return Err(InvalidKey::new(
                    key("name"),
                    format!("`{}` is declared twice", h.name),
                ));
            }
            for (field, list) in [("listen", &h.listen), ("connect", &h.connect)] {
                if let Some(e) = list.iter().find(|e| check_endpoint(e).is_err()) {
                    let reason = check_endpoint(e).unwrap_err();
                    return Err(InvalidKey::new(key(field), reason));
                }
            }
            if h.listen.is_empty() && h.connect.is_empty() {
                return Err(InvalidKey::new(
                    key("listen"),
                    format!(
                        "host `{}` neither listens nor connects: give `listen` or `connect` endpoints",
                        h.name
                    ),
                ));
            }
        }
        check_placed_once(&self.host)?;
        Ok(())
    }
}

/// No node is placed on two hosts (nor twice on one).
fn check_placed_once(hosts: &[HostDecl]) -> Result<(), InvalidKey> {
    let mut seen: Vec<(&str, &str)> = Vec::new();
    for (i, h) in hosts.iter().enumerate() {
        for n in &h.nodes {
            if let Some((_, g)) = seen.iter().find(|(m, _)| m == n) {
                return Err(InvalidKey::new(
                    format!("host[{i}].nodes"),
                    format!(
                        "node `{n}` is placed twice: on host `{g}` and on host `{}`",
                        h.name
                    ),
                ));
            }
            seen.push((n, &h.name));
        }
    }
    Ok(())
}

fn check_host_name(name: &str) -> Result<(), String> {
    let ok = !name.is_empty()
        && name.len() <= 32
        && name
            .bytes()
            .all(|b| b.is_ascii_lowercase() || b.is_ascii_digit() || b == b'_' || b == b'-');
    if ok {
        Ok(())
    } else {
        Err(format!(
            "host name `{name}` must be 1-32 characters of [a-z0-9_-]"
        ))
    }
}

/// `transport/address`, with a transport Zenoh knows.
fn check_endpoint(e: &str) -> Result<(), String> {
    match e.split_once('/') {
        Some((t, addr)) if TRANSPORTS.contains(&t) && !addr.is_empty() => Ok(()),
        _ => Err(format!(
            "endpoint `{e}` is not TRANSPORT/ADDRESS with a transport of {}",
            TRANSPORTS.join(", ")
        )),
    }
}

/// A hosts file checked against a graph: every node it names is in the graph, and the
/// supervisor's host is known.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Placement {
    hosts: Vec<HostDecl>,
    /// Index of the host that runs the supervisor (and every unplaced node).
    home: usize,
    file: PathBuf,
}

impl Placement {
    /// Reads `path` and checks it against `graph`.
    pub fn load(path: &Path, graph: &Graph) -> Result<Placement, ConfigError> {
        let text = aisle_config::read_capped(path).map_err(|source| ConfigError::Read {
            file: path.to_path_buf(),
            source,
        })?;
        Self::parse(path, &text, graph)
    }

    /// As [`Placement::load`], from text in memory (`path` names it in errors).
    pub fn parse(path: &Path, text: &str, graph: &Graph) -> Result<Placement, ConfigError> {
        let file: HostsFile = aisle_config::parse(path, text)?;
        let invalid = |key: String, reason: String| ConfigError::invalid(path, text, &key, reason);
        for (i, h) in file.host.iter().enumerate() {
            if let Some(n) = h
                .nodes
                .iter()
                .find(|n| !graph.nodes().iter().any(|d| &d.name == *n))
            {
                let names: Vec<&str> = graph.nodes().iter().map(|d| d.name.as_str()).collect();
                return Err(invalid(
                    format!("host[{i}].nodes"),
                    format!(
                        "no node called `{n}` in the graph; its nodes are {}",
                        names.join(", ")
                    ),
                ));
            }
        }
        let home = file
            .host
            .iter()
            .position(|h| h.nodes.iter().any(|n| n == "supervisor"))
            .ok_or_else(|| {
                invalid(
                    "host".into(),
                    "no host runs `supervisor`: name it in the `nodes` of one host".into(),
                )
            })?;
        Ok(Placement {
            hosts: file.host,
            home,
            file: path.to_path_buf(),
        })
    }

    pub fn hosts(&self) -> &[HostDecl] {
        &self.hosts
    }

    /// The file this placement was read from, for messages.
    pub fn file(&self) -> &Path {
        &self.file
    }

    /// The host that runs the supervisor.
    pub fn home(&self) -> &HostDecl {
        &self.hosts[self.home]
    }

    pub fn host(&self, name: &str) -> Option<&HostDecl> {
        self.hosts.iter().find(|h| h.name == name)
    }

    /// The host that runs `node`: the one naming it, else the supervisor's.
    pub fn host_of(&self, node: &str) -> &str {
        self.hosts
            .iter()
            .find(|h| h.nodes.iter().any(|n| n == node))
            .unwrap_or(self.home())
            .name
            .as_str()
    }
}

#[cfg(test)]
mod tests;
