//! System tests of fault tolerance: a node (or several at once) killed with SIGKILL
//! during the seed mission is restarted, resumes from the state it published, and the mission ends exactly as an
//! undisturbed run does; its record (taken through the crash) passes `replay --check`.

mod support;

use aisle_supervisor::report::RunReport;
use std::sync::OnceLock;
use support::machine::{alone, beside};
use support::*;

fn undisturbed() -> &'static RunReport {
    static RUN: OnceLock<RunReport> = OnceLock::new();
    RUN.get_or_init(|| {
        let (out, r) = run_report("ft-base", &[]);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        r
    })
}

/// A tick in the mission picked from a seed (`AISLE_FAULT_SEED`, default 1) and the
/// node's name, printed so a failure can be replayed.
fn random_tick(node: &str, ticks: u64) -> u64 {
    let seed: u64 = std::env::var("AISLE_FAULT_SEED")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(1);
    let mut x = seed ^ 0x9E37_79B9_7F4A_7C15;
    for b in node.bytes() {
        x = (x ^ b as u64).wrapping_mul(0x0000_0100_0000_01B3);
    }
    x ^= x >> 29;
    10 + x % (ticks - 20)
}

fn killed_at_random_tick_resumes_exactly(node: &str) {
    let _shared = beside();
    let tick = random_tick(node, undisturbed().ticks);
    killed_together_resume_exactly(&[node], tick);
}

/// Kills `nodes` at the same tick.
fn killed_together_resume_exactly(nodes: &[&str], tick: u64) {
    let base = undisturbed();
    let label = nodes.join("-");
    println!("killing {label} at tick {tick} of {}", base.ticks);
    let dir = TestDir::new(&format!("ft-rec-{label}"));
    let record = dir.path("run.mcap");
    let mut args = vec!["--record".to_string(), record.display().to_string()];
    for node in nodes {
        args.extend(["--kill".to_string(), format!("{node}@{tick}")]);
    }
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let (out, r) = run_report(&format!("ft-{label}"), &args);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(r.success, "{:?}", r.failure);
    assert_eq!(r.restarts as usize, nodes.len(), "{err}");
    assert_eq!(r.collisions, 0);
    for node in nodes {
        assert!(
            err.contains(&format!(
                "node `{node}` was killed by signal 9 (SIGKILL): restarting it"
            )),
            "{err}"
        );
    }
    assert!(
        serde_json::to_string(&r.driven_path).unwrap()
            == serde_json::to_string(&base.driven_path).unwrap(),
        "the trajectory differs from the undisturbed run"
    );
    // The record of the disturbed run is complete, and this build's mapper and
    // controller, fed its inputs, give exactly its outputs.
    let check = run(
        &dir.run_dir(),
        &["replay", record.to_str().unwrap(), "--check"],
    );
    let text = String::from_utf8_lossy(&check.stdout);
    assert_eq!(
        check.status.code(),
        Some(0),
        "{text}{}",
        String::from_utf8_lossy(&check.stderr)
    );
    assert!(text.contains("identical"), "{text}");
}

#[test]
fn a_killed_simulator_resumes_exactly() {
    killed_at_random_tick_resumes_exactly("simulator");
}

#[test]
fn a_killed_lidar_resumes_exactly() {
    killed_at_random_tick_resumes_exactly("lidar");
}

#[test]
fn a_killed_mapper_resumes_exactly() {
    killed_at_random_tick_resumes_exactly("mapper");
}

#[test]
fn a_killed_planner_resumes_exactly() {
    killed_at_random_tick_resumes_exactly("global_planner");
}

#[test]
fn a_killed_controller_resumes_exactly() {
    killed_at_random_tick_resumes_exactly("teb_controller");
}

/// The simulator's copy of the trajectory it had not applied yet dies with it, and the
/// controller's history with the controller: the restarted controller sends it again.
/// Tick 200 is on the way to the drop, where the trajectory of a tick differs from the
/// rest of the one before it (so one lost shows in the path; it did, from tick 201).
#[test]
fn the_simulator_and_controller_killed_together_resume_exactly() {
    let _shared = beside();
    killed_together_resume_exactly(&["simulator", "teb_controller"], 200);
}

#[test]
fn realtime_without_its_controller_the_robot_stops_within_0_3_s() {
    let _alone = alone();
    // Tick 40 is mid-way through the first leg, with the robot at speed.
    let (out, r) = run_report(
        "ft-realtime",
        &["--realtime", "--kill", "teb_controller@40"],
    );
    let err = String::from_utf8_lossy(&out.stderr);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{text}\n{err}");
    assert!(r.success, "{:?}", r.failure);
    assert_eq!(r.collisions, 0);
    assert_eq!(r.restarts, 1, "{err}");
    let path = &r.driven_path;
    let i = path
        .iter()
        .position(|p| p[0] >= 4.0)
        .expect("tick 40 in the driven path");
    let moving =
        |a: &[f64; 4], b: &[f64; 4]| (a[1] - b[1]).hypot(a[2] - b[2]) > 1e-9 || a[3] != b[3];
    assert!(
        moving(&path[i - 1], &path[i]),
        "the robot was not moving when the controller died"
    );
    // Stopped no later than 0.3 s of sim time after the kill.
    let stopped = (i + 1..path.len())
        .find(|&j| !moving(&path[j - 1], &path[j]))
        .expect("the robot stops");
    assert!(
        path[stopped][0] - path[i][0] <= 0.3 + 1e-9,
        "stopped only at t = {}",
        path[stopped][0]
    );
}
