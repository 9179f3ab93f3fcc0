use super::*;
use crate::crossing_topics;

/// Simulator and supervisor on `a`, the pipeline on `b` (the acceptance placement).
pub(crate) const SPREAD: &str = r#"
[[host]]
name = "a"
listen = ["tcp/10.20.0.1:7447"]
nodes = ["supervisor", "simulator"]

[[host]]
name = "b"
connect = ["tcp/10.20.0.1:7447"]
nodes = ["lidar", "mapper", "global_planner", "teb_controller"]
"#;

fn parse(text: &str) -> Result<Placement, ConfigError> {
    Placement::parse(Path::new("hosts.toml"), text, &Graph::shipped())
}

fn error(text: &str) -> String {
    parse(text).unwrap_err().to_string()
}

#[test]
fn nodes_run_where_placed_and_the_rest_with_the_supervisor() {
    let p = parse(SPREAD).unwrap();
    assert_eq!(p.home().name, "a");
    assert_eq!(p.host_of("lidar"), "b");
    assert_eq!(p.host_of("simulator"), "a");
    assert_eq!(
        p.host_of("recorder"),
        "a",
        "an unplaced node runs with the supervisor"
    );
    assert_eq!(p.host("b").unwrap().connect, vec!["tcp/10.20.0.1:7447"]);
    assert!(p.host("c").is_none());
}

#[test]
fn an_unknown_node_is_named_with_file_and_key() {
    let e = error(&SPREAD.replace("\"mapper\"", "\"maper\""));
    assert!(e.contains("hosts.toml"), "{e}");
    assert!(e.contains("host[1].nodes"), "{e}");
    assert!(e.contains("`maper`"), "{e}");
}

#[test]
fn a_node_placed_twice_is_refused() {
    let e = error(&SPREAD.replace("\"lidar\",", "\"lidar\", \"simulator\","));
    assert!(e.contains("host[1].nodes"), "{e}");
    assert!(e.contains("`simulator` is placed twice"), "{e}");
}

#[test]
fn an_unknown_key_is_refused() {
    let e = error(&SPREAD.replace("name = \"b\"", "name = \"b\"\nport = 7447"));
    assert!(e.contains("port"), "{e}");
}

#[test]
fn the_supervisor_must_be_placed() {
    let e = error(&SPREAD.replace("\"supervisor\", ", ""));
    assert!(e.contains("no host runs `supervisor`"), "{e}");
}

#[test]
fn endpoints_names_and_counts_are_checked() {
    let e = error(&SPREAD.replace("tcp/10.20.0.1:7447\"]\nnodes", "10.20.0.1:7447\"]\nnodes"));
    assert!(
        e.contains("host[0].listen") && e.contains("`10.20.0.1:7447`"),
        "{e}"
    );
    let e = error(&SPREAD.replace("name = \"b\"", "name = \"a\""));
    assert!(
        e.contains("host[1].name") && e.contains("declared twice"),
        "{e}"
    );
    let e = error(&SPREAD.replace("name = \"b\"", "name = \"B\""));
    assert!(e.contains("host[1].name"), "{e}");
    let e = error(&SPREAD.replace("connect = [\"tcp/10.20.0.1:7447\"]", ""));
    assert!(
        e.contains("host[1].listen") && e.contains("neither listens nor connects"),
        "{e}"
    );
    let one = &SPREAD[..SPREAD.find("[[host]]\nname = \"b\"").unwrap()];
    assert!(error(one).contains("at least two hosts"));
}

fn crossing_names(text: &str, recorder: bool) -> Vec<String> {
    let g = Graph::shipped();
    let p = Placement::parse(Path::new("hosts.toml"), text, &g).unwrap();
    crossing_topics(&g, &p, |_| recorder)
        .into_iter()
        .map(|c| c.topic)
        .collect()
}

#[test]
fn exactly_the_topics_between_the_two_sides_cross() {
    let expected = [
        "aisle/tick",
        "aisle/tick_done",
        "aisle/heartbeat",
        "aisle/robot_state",
        "aisle/world_truth",
        "aisle/map/global",
        "aisle/map/global_changes",
        "aisle/map/control",
        "aisle/planner/request",
        "aisle/planner/response",
        "aisle/controller/goal",
        "aisle/controller/trajectory",
        "aisle/controller/band",
    ];
    assert_eq!(crossing_names(SPREAD, false), expected);
    // A recorder with the supervisor sees everything, so the pipeline's own topics cross too.
    let with_recorder = crossing_names(SPREAD, true);
    for t in ["aisle/lidar/points", "aisle/map/local"] {
        assert!(
            with_recorder.iter().any(|c| c == t),
            "{t}: {with_recorder:?}"
        );
    }
    assert!(!with_recorder.iter().any(|c| c == "aisle/instance"));
}

#[test]
fn a_topic_whose_ends_share_a_host_stays_local() {
    // The pipeline with the supervisor, only the simulator away: the point cloud and the
    // local map never leave host `a`, the ground truth and the tick do.
    let text = SPREAD
        .replace(
            "\"supervisor\", \"simulator\"",
            "\"supervisor\", \"lidar\", \"mapper\", \"global_planner\", \"teb_controller\"",
        )
        .replace(
            "[\"lidar\", \"mapper\", \"global_planner\", \"teb_controller\"]",
            "[\"simulator\"]",
        );
    let names = crossing_names(&text, false);
    assert!(names.iter().any(|c| c == "aisle/tick"), "{names:?}");
    assert!(names.iter().any(|c| c == "aisle/sim_command"), "{names:?}");
    assert!(
        !names.iter().any(|c| c == "aisle/lidar/points"),
        "{names:?}"
    );
    assert!(
        !names.iter().any(|c| c == "aisle/planner/request"),
        "{names:?}"
    );
    let g = Graph::shipped();
    let p = Placement::parse(Path::new("hosts.toml"), &text, &g).unwrap();
    let tick = crossing_topics(&g, &p, |_| false)
        .into_iter()
        .find(|c| c.topic == "aisle/tick")
        .unwrap();
    assert_eq!(
        (tick.publishers.clone(), tick.subscribers.clone()),
        (vec!["b".to_string()], vec!["a".to_string()])
    );
    assert!(tick.touches("a") && tick.touches("b") && !tick.touches("c"));
}
