//! Which topics a tool may publish into a live instance it did not create: none that the
//! live group publishes itself. A subscriber cannot tell a replayed sample from its
//! publisher's (the header, `source` included, is the recorded one), so a replay of
//! `aisle/sim_command` into a running group would be obeyed by the simulator as the
//! supervisor's, and a replayed robot state would count as driven distance. Checked once,
//! before the first publisher is opened, so a refused replay publishes nothing.
//!
//! A topic is the group's when its graph (`graph.toml` of the instance's config
//! directory, as its discovery file names it; the shipped one otherwise) has a node
//! publishing or retaining it (`aisle/tick_done` and heartbeats: every node). It is
//! refused when that node has a live node in the instance, or when the topic already has
//! a publisher (a supervisor's retained copy while its node restarts). A topic whose
//! publisher is absent (a group run without its lidar, nodes started by hand) may be
//! replayed. Knows the graph, the instance's live nodes and port counts; not what is
//! replayed or when.

use aisle_bus::{Bus, BusError, discovery};
use aisle_messages::topics::names as s;
use aisle_node::Graph;
use std::collections::BTreeMap;

/// A topic the live group publishes itself, and who publishes it there.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct GroupTopic {
    pub topic: String,
    /// The live publisher(s), e.g. `simulator (pid 4242)`.
    pub who: String,
}

/// The topics of `topics` that the live group publishes, each with who does.
///
/// `members`: the instance's live nodes other than this process (name, pid);
/// `publishers`: the publishers connected to each service now.
pub fn group_topics(
    graph: &Graph,
    members: &[(String, u32)],
    publishers: &BTreeMap<String, usize>,
    topics: &[String],
) -> Vec<GroupTopic> {
    let mut refused = Vec::new();
    for topic in topics {
        let every = topic == s::TICK_DONE || topic == s::HEARTBEAT;
        let owners: Vec<&str> = graph
            .nodes()
            .iter()
            .filter(|n| every || n.may_publish(topic))
            .map(|n| n.name.as_str())
            .collect();
        if owners.is_empty() {
            continue;
        }
        let live: Vec<String> = members
            .iter()
            .filter(|(name, _)| owners.contains(&name.as_str()))
            .map(|(name, pid)| format!("{name} (pid {pid})"))
            .collect();
        let connected = publishers.get(topic).copied().unwrap_or(0);
        let who = if !live.is_empty() {
            live.join(", ")
        } else if connected > 0 {
            format!(
                "{connected} connected publisher(s) of the group's {}",
                owners.join("/")
            )
        } else {
            continue;
        };
        refused.push(GroupTopic {
            topic: topic.clone(),
            who,
        });
    }
    refused
}

/// The group's graph: the instance's config directory's, else the shipped one.
fn instance_graph(bus: &Bus) -> Graph {
    let root = &bus.instance().root;
    let Some(dir) = discovery::read(root).ok().and_then(|r| r.config_dir) else {
        return Graph::shipped();
    };
    Graph::load_dir(&dir).unwrap_or_else(|e| {
        tracing::warn!(
            "the instance's graph in {} cannot be read ({e}); judging by the shipped graph",
            dir.display()
        );
        Graph::shipped()
    })
}

/// Every topic of `topics` the live group of `bus`'s instance publishes itself.
pub fn live_group_topics(bus: &Bus, topics: &[String]) -> Result<Vec<GroupTopic>, BusError> {
    let publishers: BTreeMap<String, usize> = bus
        .services()?
        .into_iter()
        .filter_map(|s| Some((s.name, s.ports?.0)))
        .collect();
    let mut members = bus.instance().live_nodes();
    members.sort();
    Ok(group_topics(
        &instance_graph(bus),
        &members,
        &publishers,
        topics,
    ))
}

/// The refusal's text: each topic with who publishes it.
pub fn describe(refused: &[GroupTopic]) -> String {
    refused
        .iter()
        .map(|r| format!("`{}` (published by {})", r.topic, r.who))
        .collect::<Vec<_>>()
        .join(", ")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn topics(t: &[&str]) -> Vec<String> {
        t.iter().map(|s| s.to_string()).collect()
    }

    #[test]
    fn a_topic_a_live_member_publishes_is_refused_naming_it() {
        let g = Graph::shipped();
        let members = vec![
            ("supervisor".to_string(), 10),
            ("simulator".to_string(), 11),
            ("mapper".to_string(), 12),
            ("replay".to_string(), 13),
        ];
        let asked = topics(&[
            s::SIM_COMMAND,
            s::ROBOT_STATE,
            s::CONTROLLER_GOAL,
            s::TICK_DONE,
            s::POINT_CLOUD,
        ]);
        let refused = group_topics(&g, &members, &BTreeMap::new(), &asked);
        let named: Vec<(&str, &str)> = refused
            .iter()
            .map(|r| (r.topic.as_str(), r.who.as_str()))
            .collect();
        assert_eq!(
            named,
            [
                (s::SIM_COMMAND, "supervisor (pid 10)"),
                (s::ROBOT_STATE, "simulator (pid 11)"),
                (s::CONTROLLER_GOAL, "supervisor (pid 10)"),
                (
                    s::TICK_DONE,
                    "supervisor (pid 10), simulator (pid 11), mapper (pid 12)"
                ),
            ],
            "no lidar runs: its clouds may be replayed"
        );
        let text = describe(&refused);
        assert!(text.contains("`aisle/sim_command` (published by supervisor (pid 10))"));
    }

    #[test]
    fn a_connected_publisher_of_a_group_topic_is_refused_without_its_node() {
        // The lidar is restarting, but something publishes its clouds already; no
        // simulator runs and nothing publishes ground truth: that may be replayed.
        let g = Graph::shipped();
        let members = vec![("supervisor".to_string(), 10)];
        let publishers = BTreeMap::from([
            (s::POINT_CLOUD.to_string(), 1),
            (s::WORLD_TRUTH.to_string(), 0),
        ]);
        let refused = group_topics(
            &g,
            &members,
            &publishers,
            &topics(&[s::POINT_CLOUD, s::WORLD_TRUTH]),
        );
        assert_eq!(refused.len(), 1, "{refused:?}");
        assert_eq!(refused[0].topic, s::POINT_CLOUD);
        assert_eq!(
            refused[0].who,
            "1 connected publisher(s) of the group's lidar"
        );
    }

    #[test]
    fn an_instance_without_a_group_refuses_nothing() {
        let g = Graph::shipped();
        let observers = vec![("replay".to_string(), 20)];
        let all: Vec<String> = aisle_messages::topics::ALL
            .iter()
            .map(|t| t.name.to_string())
            .collect();
        assert!(group_topics(&g, &observers, &BTreeMap::new(), &all).is_empty());
    }
}
