//! The process group spread over two hosts (issue 19). The hosts are Linux network
//! namespaces on one bridge, each process with a mount namespace of its own in which
//! /dev/shm and the run directory are private, so shared memory cannot carry what the
//! Zenoh link must (`support/netns.rs`). The test creates them and removes them
//! afterwards, also when it fails.
//!
//! Needs root and `ip netns`: without them each test says so on stderr and passes
//! without running (CI runs as root).

mod support;

use std::time::Duration;
use support::machine::{alone, beside};
use support::netns::{CUT, Hosts, spread_run};
use support::*;

/// The spread seed mission (`run_args` added to `aisle run`): its report, or a panic
/// with both sides' stderr. No node restarts, but the one a `--kill` asks for.
fn spread_seed(
    name: &str,
    run_args: &[&str],
    cut: Option<Duration>,
) -> aisle_supervisor::report::RunReport {
    let s = spread_run(&Hosts::new(2), name, &[], run_args, cut);
    let r = s.report.unwrap_or_else(|| {
        panic!(
            "no report\nsupervisor: {}\nhost b: {}",
            String::from_utf8_lossy(&s.out.stderr),
            s.b_err
        )
    });
    assert!(r.success, "{:?}\nhost b: {}", r.failure, s.b_err);
    let killed = run_args.contains(&"--kill");
    assert_eq!(r.restarts, u32::from(killed), "host b: {}", s.b_err);
    r
}

/// The acceptance run: simulator and supervisor on `a`, the pipeline on `b`, lockstep;
/// the driven path is the single-host one to the bit.
#[test]
fn the_seed_mission_spread_over_two_hosts_drives_the_single_host_path() {
    needs_netns!();
    let _shared = beside();
    let r = spread_seed("hosts-seed", &[], None);
    assert_eq!(r.collisions, 0);
    let (digest, poses) = seed_baseline();
    assert_eq!(r.driven_path.len(), poses);
    assert_eq!(path_digest(&r.driven_path), digest);
}

#[test]
fn a_host_of_another_schema_is_refused_with_both_hashes() {
    needs_netns!();
    let _shared = beside();
    let other = "0123456789abcdef";
    let s = spread_run(
        &Hosts::new(2),
        "hosts-schema",
        &["--pretend-schema", other],
        &[],
        None,
    );
    let err = String::from_utf8_lossy(&s.out.stderr);
    assert_eq!(s.out.status.code(), Some(2), "{err}");
    let ours = format!("{:016x}", aisle_link::group_hash());
    assert!(err.contains("host `b` refused"), "{err}");
    assert!(err.contains(other) && err.contains(&ours), "{err}");
}

/// The same placement in realtime: the heartbeats, ticks and acknowledgements cross the
/// link while the clock runs on; the mission succeeds without a collision or a restart,
/// and the latency table has a row per topic and direction that crossed.
#[test]
fn the_seed_mission_spread_over_two_hosts_runs_in_realtime() {
    needs_netns!();
    let _alone = alone();
    let r = spread_seed("hosts-rt", &["--realtime"], None);
    assert_eq!(r.collisions, 0);
    let row = |name: &str| {
        r.latency
            .iter()
            .find(|s| s.stage == name)
            .unwrap_or_else(|| panic!("no row `{name}` in {:?}", r.latency))
    };
    // Every tick's robot state crosses to the pipeline, every trajectory back.
    let state = row("link a>b robot_state");
    assert!(state.samples as u64 + 5 >= r.ticks, "{state:?}");
    let traj = row("link b>a controller/trajectory");
    assert!(traj.samples > 0 && traj.p50_ms <= traj.p99_ms, "{traj:?}");
    assert!(row("link a>b tick").samples > 0 && row("link b>a tick_done").samples > 0);
}

/// Host `b` cut off for 2 s in the middle of the first leg (the robot drives it from
/// about 1 s to 13 s of sim time; the group is ready a few seconds after the start): the
/// supervisor stops the robot and holds the nodes of `b` instead of declaring them
/// hung, and the mission goes on when the link is back. Rest is measured from `b`'s
/// last beat to the simulator's first robot state at rest (ground truth, both on `a`).
#[test]
fn a_link_cut_for_two_seconds_stops_the_robot_and_the_mission_resumes() {
    needs_netns!();
    let _alone = alone();
    let r = spread_seed("hosts-cut", &["--realtime"], Some(Duration::from_secs(8)));
    assert_eq!(r.collisions, 0);
    assert_eq!(r.link_outages.len(), 1, "{:?}", r.link_outages);
    let o = &r.link_outages[0];
    assert_eq!(o.host, "b");
    let rest = o.at_rest_after_s.expect("the robot came to rest");
    assert!(rest <= 0.3, "at rest {rest:.3} s after the last beat of b");
    let down = o.down_s.expect("the link came back");
    assert!(down >= CUT.as_secs_f64() * 0.9, "down {down:.3} s");
    assert!(o.moving_after_s.is_some(), "the robot moved again: {o:?}");
}

/// A node on host `b` killed mid-run (lockstep) is restarted through `b`'s daemon: the
/// supervisor hears of its end over Zenoh, asks for the restart, and the tick it died
/// in reaches its successor (the history of the ticks that cross is handed on); the
/// driven path is the undisturbed single-host one to the bit.
#[test]
fn a_node_killed_on_the_other_host_is_restarted_through_its_daemon() {
    needs_netns!();
    let _shared = beside();
    // The lidar dies in a tick; the mapper (at 100) after the supervisor told it to
    // ignore the rack it approaches, which its successor over there must be told again.
    for (name, kill) in [("hosts-kill", "lidar@30"), ("hosts-kill-m", "mapper@100")] {
        let r = spread_seed(name, &["--kill", kill], None);
        assert_eq!(r.collisions, 0, "{kill}");
        let (digest, poses) = seed_baseline();
        assert_eq!(r.driven_path.len(), poses, "{kill}");
        assert_eq!(path_digest(&r.driven_path), digest, "{kill}");
    }
}

/// The controller killed on host `b` mid-leg: its successor gets its goal again (the
/// supervisor's standing orders are sent again while it resumes) and the mission
/// succeeds. Not to the bit: the goal crosses beside the tick protocol, so the successor
/// may step a tick before it has the goal again.
#[test]
fn a_controller_killed_on_the_other_host_gets_its_goal_again() {
    needs_netns!();
    let _shared = beside();
    let r = spread_seed("hosts-kill-c", &["--kill", "teb_controller@60"], None);
    assert_eq!(r.collisions, 0);
}
