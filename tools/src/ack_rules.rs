//! Which of a lockstep record's acknowledgements a replay waits for again: those the
//! live simulator waited for, by the recorded run's graph (the `graph.toml` attached
//! to the record; the shipped graph when none is).
//!
//! A node that acknowledges only controller ticks (the controller) also answers any
//! other tick it happens to see, and whether it saw one is timing: it takes the newest
//! tick, and the simulator does not wait for it there. A record holding such an
//! acknowledgement is no reason for a replay to wait for it, and a replay that did
//! waited on a timing accident of the recorded run.
//!
//! Knows the graph and the tick's stage flags; not the bus nor the file's messages.

use crate::reader::RecordFile;
use aisle_messages::NodeKind;
use aisle_node::Graph;
use std::path::Path;

/// The attachment that holds the recorded run's graph.
const GRAPH_FILE: &str = "graph.toml";

/// Each node's acknowledgement rule in the recorded run: its graph.
#[derive(Debug, Clone, Default)]
pub struct AckRules {
    /// `None`: every recorded acknowledgement is awaited (a graph that did not parse).
    graph: Option<Graph>,
}

impl AckRules {
    /// The rules of `graph`.
    pub fn of_graph(graph: Graph) -> AckRules {
        AckRules { graph: Some(graph) }
    }

    /// The rules of the graph attached to `file`, or of the shipped graph when none is
    /// (a record made before graphs were attached). An attached graph that does not
    /// parse leaves every recorded acknowledgement awaited, with a warning.
    pub fn of_record(file: &RecordFile) -> AckRules {
        let attached = file
            .attachments()
            .unwrap_or_default()
            .into_iter()
            .find(|a| a.name == GRAPH_FILE);
        let Some(a) = attached else {
            return AckRules::of_graph(Graph::shipped());
        };
        let text = String::from_utf8_lossy(&a.data);
        match Graph::parse(Path::new(GRAPH_FILE), &text) {
            Ok(g) => AckRules::of_graph(g),
            Err(e) => {
                tracing::warn!(
                    "{}: the attached {GRAPH_FILE} does not parse ({e}); every recorded \
                     acknowledgement is awaited",
                    file.path().display()
                );
                AckRules::default()
            }
        }
    }

    /// Whether the live simulator waited for `node` on a tick flagged `stages` (`None`:
    /// the tick's `Tick` is not in the record, so nothing says it may be skipped; a
    /// node the graph does not declare is awaited too).
    pub fn awaited(&self, node: NodeKind, stages: Option<u32>) -> bool {
        let decl = self.graph.as_ref().and_then(|g| g.node(node));
        match (decl, stages) {
            (Some(decl), Some(stages)) => decl.acknowledges.tick(stages),
            _ => true,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use aisle_messages::STAGE_CONTROLLER;

    #[test]
    fn the_controller_is_awaited_on_controller_ticks_only() {
        let rules = AckRules::of_graph(Graph::shipped());
        let c = NodeKind::TebController;
        assert!(rules.awaited(c, Some(STAGE_CONTROLLER)));
        assert!(!rules.awaited(c, Some(0)));
        assert!(rules.awaited(c, None), "no Tick recorded: awaited");
        for every in [NodeKind::Mapper, NodeKind::Lidar] {
            assert!(rules.awaited(every, Some(0)), "{every:?}");
        }
        let none = AckRules::default();
        assert!(
            none.awaited(c, Some(0)),
            "without rules everything is awaited"
        );
    }
}
