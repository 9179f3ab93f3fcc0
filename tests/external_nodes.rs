//! External nodes: a process of the user's own declared in `graph.toml` with its
//! command (here the Rust example `examples/safety_monitor`) is launched, waited for in
//! lockstep, recorded and restarted like a built-in node.

mod support;

use std::path::{Path, PathBuf};
use support::TestDir;

/// The example's binary, built beside `aisle` by `cargo test --workspace` (its crate's
/// own test needs it).
fn monitor_bin() -> PathBuf {
    let bin = Path::new(support::aisle()).with_file_name("safety_monitor");
    assert!(
        bin.exists(),
        "{} is missing: build it with `cargo build --release -p aisle-example-safety-monitor`",
        bin.display()
    );
    bin
}

/// The shipped configuration with the monitor added to the graph.
fn config_with_monitor(dir: &TestDir) -> PathBuf {
    support::config_with_graph(
        dir,
        &format!(
            r#"
[[node]]
name = "safety_monitor"
command = ["{}"]
publishes = ["aisle/sim_command"]
subscribes = ["aisle/lidar/points", "aisle/robot_state", "aisle/controller/goal"]
acknowledges = "every_tick"
"#,
            monitor_bin().display()
        ),
    )
}

fn run_with_monitor(
    dir: &TestDir,
    tag: &str,
    extra: &[&str],
) -> (aisle_supervisor::report::RunReport, PathBuf, String) {
    support::run_recorded(dir, &config_with_monitor(dir), tag, extra)
}

#[test]
fn the_seed_mission_waits_for_an_external_node_and_repeats_exactly() {
    let dir = TestDir::new("ext-lockstep");
    let (a, rec_a, _) = run_with_monitor(&dir, "a", &[]);
    let (b, rec_b, _) = run_with_monitor(&dir, "b", &[]);
    for r in [&a, &b] {
        assert!(r.success, "{:?}", r.failure);
        assert_eq!(r.collisions, 0);
        // One acknowledgement of the monitor per tick the pipeline ran.
        let monitor = r
            .latency
            .iter()
            .find(|s| s.stage == "safety_monitor")
            .expect("the monitor's TickDones are in the latency book");
        assert!(
            monitor.samples + 2 >= r.ticks as usize,
            "{monitor:?} of {} ticks",
            r.ticks
        );
    }
    assert_eq!(a.driven_path, b.driven_path);
    let monitor = aisle_messages::external_code("safety_monitor");
    let (n, acks) =
        support::records::same_records(&rec_a, &rec_b, monitor, a.ticks.saturating_sub(1));
    assert!(
        acks + 2 >= a.ticks as usize,
        "{acks} acknowledgements of the monitor recorded"
    );
    // At least tick, robot state, world truth, points and local map per tick.
    assert!(n >= 5 * acks, "{n} messages compared");
}

#[test]
fn a_killed_external_node_is_restarted_and_the_mission_goes_on() {
    let dir = TestDir::new("ext-kill");
    let (r, _, err) = run_with_monitor(&dir, "k", &["--kill", "safety_monitor@30"]);
    assert!(r.success, "{:?}", r.failure);
    assert_eq!(r.restarts, 1, "{err}");
    assert_eq!(r.collisions, 0);
}

/// Exit 2 is a node's "cannot run as launched": the run ends at once naming the node and
/// its last words, with exit 2, instead of restarting it until the policy gives up.
#[test]
fn an_external_node_that_cannot_run_as_launched_is_not_restarted() {
    let dir = TestDir::new("ext-exit2");
    let config = support::config_with_graph(
        &dir,
        r#"
[[node]]
name = "broken_node"
command = ["/bin/sh", "-c", "echo 'error: broken_node: no such device' >&2; exit 2"]
publishes = []
subscribes = ["aisle/robot_state"]
acknowledges = "none"
"#,
    );
    let out = support::run(
        &dir.run_dir(),
        &["run", "--quiet", "--config-dir", config.to_str().unwrap()],
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("node `broken_node` exited with code 2")
            && err.contains("no such device")
            && err.contains("not restarted"),
        "{err}"
    );
    assert!(!err.contains("restarting it"), "{err}");
}

/// The controller blind to what the lidar detects (`inputs.avoid_detected = false`):
/// alone it drives into the unseen pallets on its reference path; with the monitor in
/// the graph it is stopped in front of them, and nothing is hit.
#[test]
fn with_obstacle_avoidance_off_the_monitor_stops_the_robot_before_unseen_pallets() {
    let dir = TestDir::new("ext-blind");
    let blind = |config: &Path| {
        let teb = config.join("teb.toml");
        let text = std::fs::read_to_string(&teb).unwrap();
        let text = text.replace("avoid_detected = true", "avoid_detected = false");
        assert!(
            text.contains("avoid_detected = false"),
            "teb.toml has the switch"
        );
        std::fs::write(teb, text).unwrap();
    };
    let with_monitor = config_with_monitor(&dir);
    blind(&with_monitor);
    let alone_dir = TestDir::new("ext-blind-cfg");
    let alone = support::config_with_graph(&alone_dir, "");
    blind(&alone);
    let (_, without) = support::run_report(
        "ext-blind-alone",
        &["--config-dir", alone.to_str().unwrap()],
    );
    assert!(
        without.collisions > 0,
        "the blind controller alone should hit an unseen pallet: {:?}",
        without.failure
    );
    let (out, with) = support::run_report(
        "ext-blind-monitored",
        &["--config-dir", with_monitor.to_str().unwrap()],
    );
    assert_eq!(
        with.collisions,
        0,
        "{:?} {:?}\n{}",
        with.failure,
        with.collision_events,
        String::from_utf8_lossy(&out.stderr)
    );
}
