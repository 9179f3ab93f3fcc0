//! The process graph, declared once in `config/graph.toml`: the nodes, the topics each
//! publishes and subscribes, and which ticks each acknowledges.
//!
//! Everything that must know the wiring asks this module: the supervisor (which nodes to
//! launch), the simulator and the supervisor (whose acknowledgement a tick waits for:
//! [`Graph::acknowledgers`], [`Graph::waits_of`]), every node's runtime (which ports it
//! may open: [`NodeDecl::may_publish`]), the recorder and the lockstep replay (who
//! produces a topic: [`Graph::producer`]). A graph is checked against the topic table
//! when it is loaded, so a misspelt topic or node is an error naming file and key.
//!
//! Knows names and declarations; it does not open ports or run anything.

use aisle_config::ConfigError;
use aisle_messages::{NodeKind, STAGE_CONTROLLER, topics};
use serde::Deserialize;
use std::path::{Path, PathBuf};

/// The graph shipped in `config/graph.toml`, used when a config directory has none.
pub const SHIPPED: &str = include_str!("../../../config/graph.toml");

/// Which ticks a node answers with `TickDone`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Acknowledges {
    EveryTick,
    /// Ticks flagged [`STAGE_CONTROLLER`].
    ControllerTicks,
    None,
}

impl Acknowledges {
    /// Whether a tick with these `stages` flags needs this node's acknowledgement.
    pub fn tick(self, stages: u32) -> bool {
        match self {
            Acknowledges::EveryTick => true,
            Acknowledges::ControllerTicks => stages & STAGE_CONTROLLER != 0,
            Acknowledges::None => false,
        }
    }
}

/// One node of the graph.
#[derive(Debug, Clone, PartialEq, Eq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NodeDecl {
    pub name: String,
    #[serde(default = "yes")]
    pub launched: bool,
    pub publishes: Vec<String>,
    pub subscribes: Vec<String>,
    #[serde(default)]
    pub retains: Vec<String>,
    pub acknowledges: Acknowledges,
    #[serde(default)]
    pub after: Vec<String>,
    /// An external node's program and arguments (a built-in node has none): the
    /// supervisor starts it in the directory of the graph file, with the instance in its
    /// environment (see [`crate::external`]).
    #[serde(default)]
    pub command: Option<Vec<String>>,
    /// The kind, resolved once when the graph is loaded (an external node's name is
    /// interned then), so per-tick lookups need no lock.
    #[serde(skip)]
    resolved: Option<NodeKind>,
}

fn yes() -> bool {
    true
}

impl NodeDecl {
    /// The node kind this declaration names.
    pub fn kind(&self) -> NodeKind {
        self.resolved.unwrap_or_else(|| self.resolve())
    }

    fn resolve(&self) -> NodeKind {
        if self.command.is_some() {
            NodeKind::external(&self.name)
        } else {
            NodeKind::from_name(&self.name).expect("checked when the graph was loaded")
        }
    }

    fn lists(list: &[String], topic: &str) -> bool {
        list.iter().any(|t| t == topic || t == "*")
    }

    pub fn may_publish(&self, topic: &str) -> bool {
        Self::lists(&self.publishes, topic) || Self::lists(&self.retains, topic)
    }

    pub fn may_subscribe(&self, topic: &str) -> bool {
        Self::lists(&self.subscribes, topic)
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct GraphFile {
    node: Vec<NodeDecl>,
    /// Topics of the user's beyond the table: a name and a catalogue message type.
    #[serde(default)]
    topic: Vec<TopicDecl>,
}

/// A user topic (`[[topic]]`).
#[derive(Debug, Clone, PartialEq, Eq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TopicDecl {
    pub name: String,
    /// The versioned type name of a catalogue message, e.g. `aisle.RobotState.v1`.
    #[serde(rename = "type")]
    pub type_name: String,
}

/// The checked graph.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Graph {
    nodes: Vec<NodeDecl>,
}

impl Graph {
    /// The graph of `config_dir/graph.toml`, or the shipped one when the directory has
    /// no such file (config directories written before the graph existed).
    pub fn load_dir(config_dir: &Path) -> Result<Graph, ConfigError> {
        let path = config_dir.join("graph.toml");
        if path.exists() {
            Self::load(&path)
        } else {
            Self::parse(Path::new("<shipped>/graph.toml"), SHIPPED)
        }
    }

    pub fn load(path: &Path) -> Result<Graph, ConfigError> {
        let text = aisle_config::read_capped(path).map_err(|source| ConfigError::Read {
            file: path.to_path_buf(),
            source,
        })?;
        Self::parse(path, &text)
    }

    /// The shipped graph.
    pub fn shipped() -> Graph {
        Self::parse(Path::new("<shipped>/graph.toml"), SHIPPED).expect("the shipped graph is valid")
    }

    pub fn parse(path: &Path, text: &str) -> Result<Graph, ConfigError> {
        let file: GraphFile = aisle_config::parse_toml(path, text)?;
        // Declared before the nodes are checked, which may name them.
        for (i, t) in file.topic.iter().enumerate() {
            aisle_messages::user_topics::declare(&t.name, &t.type_name).map_err(|reason| {
                ConfigError::invalid(path, text, &format!("topic[{i}].name"), reason)
            })?;
        }
        let mut graph = Graph { nodes: file.node };
        graph
            .check()
            .map_err(|(key, reason)| ConfigError::invalid(path, text, &key, reason))?;
        // External nodes are known from now on by name and code (a code read from a
        // message can be named).
        for n in &mut graph.nodes {
            n.resolved = Some(n.resolve());
        }
        Ok(graph)
    }

    /// Every name resolves, no node is declared twice, `after` names acknowledging nodes.
    fn check(&self) -> Result<(), (String, String)> {
        for (i, n) in self.nodes.iter().enumerate() {
            let key = |field: &str| format!("node[{i}].{field}");
            check_name(n).map_err(|reason| {
                (
                    key(n.command.as_ref().map_or("name", |_| "command")),
                    reason,
                )
            })?;
            if self.nodes[..i].iter().any(|m| m.name == n.name) {
                return Err((key("name"), format!("`{}` is declared twice", n.name)));
            }
            for (field, list) in [
                ("publishes", &n.publishes),
                ("subscribes", &n.subscribes),
                ("retains", &n.retains),
            ] {
                if let Some(t) = list.iter().find(|t| *t != "*" && topics::info(t).is_none()) {
                    let names: Vec<&str> = topics::ALL.iter().map(|t| t.name).collect();
                    return Err((
                        key(field),
                        format!("no topic called `{t}`; topics are {}", names.join(", ")),
                    ));
                }
            }
            if let Some(m) = self.nodes[..i].iter().find(|m| {
                m.command.is_some() && n.command.is_some() && m.kind().code() == n.kind().code()
            }) {
                return Err((
                    key("name"),
                    format!(
                        "`{}` and `{}` have the same node code; rename one",
                        m.name, n.name
                    ),
                ));
            }
            for a in &n.after {
                let Some(m) = self.nodes.iter().find(|m| &m.name == a) else {
                    return Err((key("after"), format!("no node called `{a}` in the graph")));
                };
                if m.acknowledges == Acknowledges::None || m.name == n.name {
                    return Err((
                        key("after"),
                        format!("`{a}` acknowledges no ticks, so nothing can wait for it"),
                    ));
                }
            }
        }
        self.check_publisher_counts()?;
        for k in NodeKind::LAUNCHED {
            if !self.nodes.iter().any(|n| n.name == k.name()) {
                return Err((
                    "node".into(),
                    format!("the built-in node `{}` is missing", k.name()),
                ));
            }
        }
        Ok(())
    }

    /// No topic gets more publishers (nodes that publish or retain it) than its QoS
    /// admits: iceoryx2 would refuse the one too many at run time, after launch.
    fn check_publisher_counts(&self) -> Result<(), (String, String)> {
        for (i, n) in self.nodes.iter().enumerate() {
            for t in n.publishes.iter().chain(&n.retains) {
                let Some(info) = topics::info(t) else {
                    continue;
                };
                let before: Vec<&str> = self.nodes[..i]
                    .iter()
                    .filter(|m| m.publishes.contains(t) || m.retains.contains(t))
                    .map(|m| m.name.as_str())
                    .collect();
                if before.len() >= info.qos.max_publishers {
                    let field = if n.publishes.contains(t) {
                        "publishes"
                    } else {
                        "retains"
                    };
                    return Err((
                        format!("node[{i}].{field}"),
                        format!(
                            "`{t}` admits {} publisher(s), and {} already publish it; `{}` cannot as well",
                            info.qos.max_publishers,
                            before.join(", "),
                            n.name
                        ),
                    ));
                }
            }
        }
        Ok(())
    }

    pub fn nodes(&self) -> &[NodeDecl] {
        &self.nodes
    }

    pub fn node(&self, kind: NodeKind) -> Option<&NodeDecl> {
        self.nodes.iter().find(|n| n.name == kind.name())
    }

    /// The external nodes, in declaration order.
    pub fn external(&self) -> impl Iterator<Item = &NodeDecl> + '_ {
        self.nodes.iter().filter(|n| n.command.is_some())
    }

    /// The nodes the supervisor starts, in declaration order.
    pub fn launched(&self) -> impl Iterator<Item = NodeKind> + '_ {
        self.nodes.iter().filter(|n| n.launched).map(NodeDecl::kind)
    }

    /// The node that publishes `topic` in a run (the first that declares it); `None` for
    /// topics every node publishes (`TickDone`, heartbeats) and undeclared ones.
    pub fn producer(&self, topic: &str) -> Option<NodeKind> {
        self.nodes
            .iter()
            .find(|n| n.publishes.iter().any(|t| t == topic))
            .map(NodeDecl::kind)
    }

    /// Every node that must acknowledge a tick flagged `stages` before the simulator
    /// steps. `present` says whether an optional node (the recorder) takes part.
    pub fn acknowledgers(&self, stages: u32, present: impl Fn(NodeKind) -> bool) -> Vec<NodeKind> {
        self.nodes
            .iter()
            .filter(|n| n.acknowledges.tick(stages))
            .map(NodeDecl::kind)
            .filter(|k| present(*k))
            .collect()
    }

    /// The nodes whose acknowledgement of a tick flagged `stages` `node` waits for before
    /// it acts on that tick.
    pub fn waits_of(&self, node: NodeKind, stages: u32) -> Vec<NodeKind> {
        let Some(decl) = self.node(node) else {
            return Vec::new();
        };
        decl.after
            .iter()
            .filter_map(|a| self.nodes.iter().find(|n| &n.name == a))
            .filter(|n| n.acknowledges.tick(stages))
            .map(NodeDecl::kind)
            .collect()
    }
}

/// A built-in name without `command`, or an external one (a well-formed name that is
/// not a built-in's) with a non-empty `command`.
fn check_name(n: &NodeDecl) -> Result<(), String> {
    let built_in = NodeKind::BUILT_IN.iter().any(|k| k.name() == n.name);
    match (&n.command, built_in) {
        (None, true) => Ok(()),
        (Some(_), true) => Err(format!(
            "`{}` is a built-in node: it has no `command` (the supervisor starts it)",
            n.name
        )),
        (Some(c), false) if c.first().is_none_or(|p| p.is_empty()) => Err(format!(
            "the command of `{}` is empty: give the program and its arguments",
            n.name
        )),
        (Some(_), false) => aisle_messages::check_external_name(&n.name),
        (None, false) => {
            let known: Vec<&str> = NodeKind::BUILT_IN.iter().map(|k| k.name()).collect();
            Err(format!(
                "no node called `{}`; built-in nodes are {}; a node of your own needs a `command`",
                n.name,
                known.join(", ")
            ))
        }
    }
}

/// The path a node's graph is read from, for messages.
pub fn path_in(config_dir: &Path) -> PathBuf {
    config_dir.join("graph.toml")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_shipped_graph_says_who_waits_for_whom() {
        let g = Graph::shipped();
        let all = |_| true;
        use NodeKind::*;
        assert_eq!(
            g.acknowledgers(0, all),
            [Lidar, Mapper, Supervisor, Recorder]
        );
        assert_eq!(
            g.acknowledgers(STAGE_CONTROLLER, |k| k != Recorder),
            [Lidar, Mapper, TebController, Supervisor]
        );
        assert_eq!(g.waits_of(Supervisor, 0), [Lidar, Mapper]);
        assert_eq!(
            g.waits_of(Supervisor, STAGE_CONTROLLER),
            [Lidar, Mapper, TebController]
        );
        assert_eq!(g.waits_of(Recorder, 0), [Supervisor]);
        assert_eq!(g.producer(topics::POINT_CLOUD.name), Some(Lidar));
        assert_eq!(g.producer(topics::TICK_DONE.name), None);
        assert_eq!(g.producer(topics::CONTROLLER_GOAL.name), Some(Supervisor));
        let launched: Vec<_> = g.launched().collect();
        assert_eq!(launched, NodeKind::LAUNCHED);
    }

    #[test]
    fn a_node_of_the_users_may_not_be_a_publisher_too_many() {
        // The band has its two publishers already (the controller, and the supervisor
        // that retains it): a third would be refused by iceoryx2 only after launch.
        let ext = |topic: &str| {
            format!(
                "{SHIPPED}\n[[node]]\nname = \"mine\"\ncommand = [\"/bin/true\"]\npublishes = [\"{topic}\"]\nsubscribes = []\nacknowledges = \"none\"\n"
            )
        };
        let e = Graph::parse(Path::new("g.toml"), &ext("aisle/controller/band"))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("node[7].publishes")
                && e.contains("`aisle/controller/band` admits 2 publisher(s)")
                && e.contains("teb_controller, supervisor already publish it"),
            "{e}"
        );
        // One more publisher of a command topic is room the QoS leaves.
        Graph::parse(Path::new("g.toml"), &ext("aisle/sim_command")).unwrap();
    }

    #[test]
    fn a_misspelt_topic_or_node_names_file_line_and_key() {
        let bad = SHIPPED.replace("\"aisle/lidar/points\"]", "\"aisle/lidar/pionts\"]");
        let e = Graph::parse(Path::new("g.toml"), &bad)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("g.toml:") && e.contains("node[1].publishes"),
            "{e}"
        );
        assert!(e.contains("aisle/lidar/pionts"), "{e}");
        let bad = SHIPPED.replace("after = [\"supervisor\"]", "after = [\"global_planner\"]");
        let e = Graph::parse(Path::new("g.toml"), &bad)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("node[6].after") && e.contains("acknowledges no ticks"),
            "{e}"
        );
        let bad = SHIPPED.replace("name = \"lidar\"", "name = \"lidarr\"");
        let e = Graph::parse(Path::new("g.toml"), &bad)
            .unwrap_err()
            .to_string();
        assert!(e.contains("no node called `lidarr`"), "{e}");
        let bad = SHIPPED.replace("acknowledges = \"none\"", "acknowledges = \"sometimes\"");
        assert!(Graph::parse(Path::new("g.toml"), &bad).is_err());
    }

    #[test]
    fn external_nodes_need_a_command_and_a_name_of_their_own() {
        let ext = |name: &str, command: &str| {
            format!(
                "{SHIPPED}\n[[node]]\nname = \"{name}\"\n{command}\npublishes = []\nsubscribes = [\"aisle/tick\"]\nacknowledges = \"every_tick\"\nafter = [\"lidar\"]\n"
            )
        };
        let g = Graph::parse(Path::new("g.toml"), &ext("my_monitor", "command = [\"m\"]")).unwrap();
        let k = NodeKind::from_name("my_monitor").expect("known once the graph is loaded");
        assert!(k.is_external());
        assert_eq!(g.launched().last(), Some(k));
        assert!(g.acknowledgers(0, |_| true).contains(&k));
        assert_eq!(g.waits_of(k, 0), [NodeKind::Lidar]);
        for (name, command, says) in [
            ("my_monitor", "", "a node of your own needs a `command`"),
            (
                "lidar_two",
                "command = []",
                "the command of `lidar_two` is empty",
            ),
            ("Monitor", "command = [\"m\"]", "is not a node name"),
            ("lidar", "command = [\"m\"]", "is a built-in node"),
        ] {
            let e = Graph::parse(Path::new("g.toml"), &ext(name, command))
                .unwrap_err()
                .to_string();
            assert!(e.contains(says) && e.contains("node[7]"), "{e}");
        }
    }

    #[test]
    fn declarations_limit_ports() {
        let g = Graph::shipped();
        let lidar = g.node(NodeKind::Lidar).unwrap();
        assert!(lidar.may_publish(topics::POINT_CLOUD.name));
        assert!(!lidar.may_publish(topics::LOCAL_MAP.name));
        assert!(lidar.may_subscribe(topics::TICK.name));
        let sup = g.node(NodeKind::Supervisor).unwrap();
        assert!(sup.may_publish(topics::SIM_STATE.name), "retained state");
        let rec = g.node(NodeKind::Recorder).unwrap();
        assert!(rec.may_subscribe(topics::TRAJECTORY.name));
    }
}
