//! Hangs, not crashes: a node stopped with SIGSTOP is declared hung within its
//! heartbeat timeout, SIGKILLed and restarted. In realtime the robot is at rest within
//! 0.3 s of the hang (read off the driven path, at tick resolution) and drives on only
//! with fresh inputs; in lockstep the sim clock waits, and the run ends exactly as an
//! undisturbed one. A SIGCONT to the old process afterwards finds nothing to wake.
//! A stopped supervisor is not replaced: when it wakes it finds the controller's reports
//! queued, and each reached goal must still count once (a pick happens, every leg ends
//! within its tolerance).

mod support;

use std::io::{BufRead, BufReader};
use std::sync::mpsc;
use std::time::{Duration, Instant};
use support::machine::alone;
use support::*;

/// One SIGSTOP: the node, when (wall seconds after the group is ready), for how long.
struct Hang {
    node: &'static str,
    at_s: f64,
    hold_s: f64,
}

/// Every node type once, the robot moving: the lidar on the way to the pick, the
/// controller on the way too, the mapper for 10 s on the carrying leg (it passes an
/// unseen pallet the frozen map would not show), then the planner and the simulator.
const SCHEDULE: [Hang; 5] = [
    Hang {
        node: "lidar",
        at_s: 2.5,
        hold_s: 1.0,
    },
    Hang {
        node: "teb_controller",
        at_s: 5.5,
        hold_s: 1.0,
    },
    Hang {
        node: "mapper",
        at_s: 15.0,
        hold_s: 10.0,
    },
    Hang {
        node: "global_planner",
        at_s: 27.0,
        hold_s: 1.0,
    },
    Hang {
        node: "simulator",
        at_s: 31.0,
        hold_s: 1.0,
    },
];

/// The supervisor itself stopped (wall seconds after ready, for how long): over the
/// approach to the rack, where several reports of one reached goal queue up.
const SUPERVISOR_STALL: (f64, f64) = (8.5, 4.0);

/// The pid of supervisor `sup`'s node `name` now (it changes with every restart).
fn node_pid(sup: u32, name: &str) -> Option<u32> {
    children(sup).into_iter().find(|c| {
        let cl = cmdline(*c);
        let mut parts = cl.split(' ');
        parts.any(|p| p == "node") && parts.next() == Some(name)
    })
}

fn signal(pid: u32, sig: libc::c_int) -> bool {
    // SAFETY: kill(2) with a pid the test read from /proc; no memory is shared.
    unsafe { libc::kill(pid as libc::pid_t, sig) == 0 }
}

/// Forwards the child's stderr line by line (and keeps every line).
fn stderr_lines(child: &mut std::process::Child) -> mpsc::Receiver<String> {
    let pipe = child.stderr.take().expect("stderr is piped");
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        for line in BufReader::new(pipe).lines().map_while(Result::ok) {
            if tx.send(line).is_err() {
                break;
            }
        }
    });
    rx
}

/// "t = 8.30 s: robot stopped: `mapper` (silent 0.30 s) declared dead" -> (node, t, silent).
fn parse_stop(line: &str) -> Option<(String, f64, f64)> {
    let rest = &line[line.find("t = ")? + 4..];
    let t: f64 = rest[..rest.find(' ')?].parse().ok()?;
    let rest = &rest[rest.find("robot stopped: `")? + 16..];
    let node = rest[..rest.find('`')?].to_string();
    let rest = &rest[rest.find("(silent ")? + 8..];
    let silent: f64 = rest[..rest.find(' ')?].parse().ok()?;
    Some((node, t, silent))
}

/// Whether the robot moved during the tick that starts at the first sample at or after
/// `t_s` (poses of a robot at rest are bit-identical: nothing integrates them).
fn moved_after(path: &[[f64; 4]], t_s: f64) -> Option<bool> {
    let i = path.iter().position(|p| p[0] >= t_s - 1e-9)?;
    let (a, b) = (path.get(i)?, path.get(i + 1)?);
    Some(a[1..] != b[1..])
}

#[test]
fn every_node_type_hung_in_realtime_stops_the_robot_and_is_replaced() {
    let _one = alone();
    let dir = TestDir::new("hang-realtime");
    let report = dir.path("report.json");
    let args = [
        "run",
        "--realtime",
        "--quiet",
        "--report",
        report.to_str().unwrap(),
    ];
    let (mut child, mut log, lines) = spawn_ready(&dir, &args);
    let sup = child.id();
    let ready = Instant::now();
    // (when, node, stop?) in time order.
    let mut events: Vec<(f64, &str, bool)> = SCHEDULE
        .iter()
        .flat_map(|h| [(h.at_s, h.node, true), (h.at_s + h.hold_s, h.node, false)])
        .collect();
    let (stall_at, stall_for) = SUPERVISOR_STALL;
    events.push((stall_at, "supervisor", true));
    events.push((stall_at + stall_for, "supervisor", false));
    events.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut stopped = std::collections::HashMap::new();
    for (at, node, stop) in events {
        let due = ready + Duration::from_secs_f64(at);
        std::thread::sleep(due.saturating_duration_since(Instant::now()));
        if node == "supervisor" {
            let sig = if stop { libc::SIGSTOP } else { libc::SIGCONT };
            assert!(signal(sup, sig), "signal the supervisor");
        } else if stop {
            let pid = node_pid(sup, node).unwrap_or_else(|| panic!("no {node} at {at} s"));
            assert!(signal(pid, libc::SIGSTOP), "SIGSTOP {node}");
            stopped.insert(node, pid);
        } else {
            let pid = stopped[node];
            // Declared dead means SIGKILLed and reaped: nothing is left to wake.
            assert!(!alive(pid), "the hung {node} ({pid}) still exists");
            signal(pid, libc::SIGCONT);
            // Its successor may be between a kill and a respawn of its own just now (a
            // loaded machine can make a first start miss its deadline): give it a moment.
            let give_up = Instant::now() + Duration::from_secs(5);
            let mut now = node_pid(sup, node);
            while now.is_none_or(|p| p == pid) && Instant::now() < give_up {
                std::thread::sleep(Duration::from_millis(50));
                now = node_pid(sup, node);
            }
            if now.is_none_or(|p| p == pid) {
                log.extend(lines.try_iter());
                panic!("{node} was not replaced: {now:?}; log: {log:#?}");
            }
        }
    }
    let status = wait_exit(&mut child, Duration::from_secs(180)).expect("the run ends");
    log.extend(lines.try_iter());
    let text = std::fs::read_to_string(&report).expect("a report");
    let r: aisle_supervisor::report::RunReport = serde_json::from_str(&text).unwrap();
    assert!(status.success(), "exit {status:?}: {log:#?}");
    assert!(r.success, "{:?}", r.failure);
    assert_eq!(r.collisions, 0);
    assert!(r.restarts >= 5, "{} restarts", r.restarts);
    for leg in &r.legs {
        // The goal tolerance is 0.2 m along and across the goal: at most 0.29 m.
        assert!(
            leg.reached && leg.final_error_m < 0.29,
            "leg `{}` ended {:.3} m from its goal",
            leg.name,
            leg.final_error_m
        );
    }
    let rack = r
        .bodies_final
        .iter()
        .find(|b| b.name == "rack2b")
        .expect("rack2b");
    // The seed's rack stands at (2, 13) and is carried to (6, -7).
    assert!(
        (rack.x - 6.0).hypot(rack.y + 7.0) < 0.5,
        "rack2b was not carried: it ends at ({:.2}, {:.2})",
        rack.x,
        rack.y
    );
    for hang in &SCHEDULE {
        let (node, t, silent) = log
            .iter()
            .filter_map(|l| parse_stop(l))
            .find(|(n, _, _)| n == hang.node)
            .unwrap_or_else(|| panic!("no stop for the hung {}: {log:#?}", hang.node));
        // Its last heartbeat came `silent` before t: it hung no earlier than that.
        let rest_by = t - silent + 0.3;
        assert_eq!(
            moved_after(&r.driven_path, rest_by),
            Some(false),
            "{node} hung at t >= {:.2} s: the robot still moved after {rest_by:.2} s; \
             path from there: {:?}; log: {log:#?}",
            t - silent,
            r.driven_path
                .iter()
                .filter(|p| p[0] >= t - silent - 0.3)
                .take(12)
                .collect::<Vec<_>>()
        );
    }
}

/// Spawns `aisle run <args>` with info logs and waits until its group is ready;
/// returns the child, its stderr lines so far and the rest to come.
fn spawn_ready(
    dir: &TestDir,
    args: &[&str],
) -> (std::process::Child, Vec<String>, mpsc::Receiver<String>) {
    let mut child = command(&dir.run_dir(), args)
        .env("AISLE_LOG", "info")
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("aisle starts");
    let lines = stderr_lines(&mut child);
    let mut log = Vec::new();
    let deadline = Instant::now() + Duration::from_secs(60);
    while !log.iter().any(|l: &String| l.contains("nodes ready")) {
        let left = deadline.saturating_duration_since(Instant::now());
        match lines.recv_timeout(left) {
            Ok(l) => log.push(l),
            Err(_) => panic!("the group did not get ready: {log:#?}"),
        }
    }
    (child, log, lines)
}

#[test]
fn a_hung_mapper_in_lockstep_is_replaced_and_the_run_is_exact() {
    let _one = alone();
    let dir = TestDir::new("hang-lockstep");
    let report = dir.path("report.json");
    let (mut child, mut log, lines) = spawn_ready(
        &dir,
        &["run", "--quiet", "--report", report.to_str().unwrap()],
    );
    let sup = child.id();
    // Under way: the lockstep mission takes a few seconds of wall time.
    std::thread::sleep(Duration::from_millis(300));
    let pid = node_pid(sup, "mapper").expect("a mapper");
    assert!(signal(pid, libc::SIGSTOP));
    let status = wait_exit(&mut child, Duration::from_secs(180)).expect("the run ends");
    log.extend(lines.try_iter());
    assert!(!alive(pid), "the hung mapper ({pid}) still exists");
    signal(pid, libc::SIGCONT);
    assert!(status.success(), "exit {status:?}: {log:#?}");
    assert!(log.iter().any(|l| l.contains("declared hung")), "{log:#?}");
    let r: aisle_supervisor::report::RunReport =
        serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    assert!(r.success && r.restarts >= 1, "{:?}", r.failure);
    let (digest, _) = seed_baseline();
    assert_eq!(
        path_digest(&r.driven_path),
        digest,
        "the run with a hung mapper left the seed's driven path"
    );
}
