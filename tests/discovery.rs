//! A record replayed without a supervisor: `aisle replay` creates its own instance,
//! consumers find it by discovery (no --prefix/--root anywhere) and read it with
//! `aisle echo`, `topics` and `hz`; when the replay ends (file end or Ctrl-C) nothing of
//! the instance is left.

mod support;

use std::process::Output;
use std::time::Duration;
use support::*;

fn text(o: &Output) -> (String, String) {
    (
        String::from_utf8_lossy(&o.stdout).into_owned(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

#[test]
fn a_replay_without_a_supervisor_is_discovered_echoed_and_removed() {
    let dir = TestDir::new("discovery");
    let run_dir = dir.run_dir();
    let mission = mission_file(
        &dir,
        "short.toml",
        "[[leg]]\nname = \"short hop\"\ngoal = [3.0, -2.0, 0.0]\n",
    );
    let file = dir.path("run.mcap");
    let (m, f) = (mission.to_str().unwrap(), file.to_str().unwrap());
    let out = run(&run_dir, &["run", "--quiet", "--mission", m, "--record", f]);
    assert!(out.status.success(), "{}", text(&out).1);

    // Nothing live yet: a negative verdict, said.
    let out = run(&run_dir, &["instance"]);
    assert_eq!(out.status.code(), Some(1));
    assert!(
        text(&out).1.contains("no live aisle instance"),
        "{}",
        text(&out).1
    );

    // As fast as it can, once a subscriber is there: echo finds it by discovery.
    let mut replay = spawn(
        &run_dir,
        &["replay", f, "--fast", "--wait-subscribers", "1"],
    );
    let pid = replay.id();
    wait_for_instance(&run_dir);
    // A fast replay overwrites what a subscriber has not taken yet beyond the topic's
    // buffer (4 for robot_state), so at most that many samples are certain to arrive.
    let echo = run(
        &run_dir,
        &[
            "echo",
            "aisle/robot_state",
            "--count",
            "4",
            "--timeout",
            "20s",
        ],
    );
    let (stdout, stderr) = text(&echo);
    assert!(echo.status.success(), "{stderr}");
    assert_eq!(stdout.matches("---\n").count(), 4, "{stdout}");
    assert!(stdout.starts_with("header:\n  seq: "), "{stdout}");
    assert!(stdout.contains("\npose:\n  x: "), "{stdout}");
    let status = wait_exit(&mut replay, Duration::from_secs(30)).expect("the replay ends");
    let out = replay.wait_with_output().unwrap();
    assert!(status.success(), "{}", text(&out).1);
    assert!(
        text(&out).0.contains("aisle/robot_state"),
        "{}",
        text(&out).0
    );
    assert!(shm_leftovers(pid).is_empty(), "{:?}", shm_leftovers(pid));
    assert!(
        run_dir_leftovers(&run_dir).is_empty(),
        "{:?}",
        run_dir_leftovers(&run_dir)
    );

    // Looping until Ctrl-C: listed by `instance`, its topics measured, then removed.
    let mut replay = spawn(&run_dir, &["replay", f, "--loop", "--rate", "2"]);
    let pid = replay.id();
    let env = wait_for_instance(&run_dir);
    assert!(
        env.starts_with("export AISLE_PREFIX=aisle") && env.contains(" AISLE_ROOT=/"),
        "{env}"
    );
    let out = run(&run_dir, &["instance"]);
    let listed = text(&out).0;
    let row: Vec<&str> = listed
        .lines()
        .nth(1)
        .unwrap_or_default()
        .split_whitespace()
        .collect();
    assert_eq!(
        row[1..4],
        ["lockstep", &pid.to_string(), "replay"],
        "{listed}"
    );
    let out = run(&run_dir, &["topics", "--window", "500ms"]);
    let (topics, stderr) = text(&out);
    assert!(out.status.success(), "{stderr}");
    let row = topics
        .lines()
        .find(|l| l.starts_with("aisle/robot_state "))
        .unwrap_or_else(|| panic!("{topics}"));
    let cols: Vec<&str> = row.split_whitespace().collect();
    assert_eq!(cols[1], "aisle.RobotState.v1", "{row}");
    assert_eq!(
        (cols[3], cols[4]),
        ("1", "0"),
        "one publisher, nobody else: {row}"
    );
    let out = run(
        &run_dir,
        &["hz", "aisle/robot_state", "--window", "1s", "--count", "1"],
    );
    let (hz, stderr) = text(&out);
    assert!(out.status.success(), "{stderr}");
    assert!(
        hz.starts_with("average rate: ") && hz.contains("std dev: "),
        "{hz}"
    );
    let out = run(&run_dir, &["echo", "aisle/nope", "--once"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(
        text(&out)
            .1
            .contains("no topic `aisle/nope`; topics: aisle/instance")
    );

    // SAFETY: kill has no memory preconditions; the pid is our child's.
    unsafe { libc::kill(pid as i32, libc::SIGINT) };
    let status = wait_exit(&mut replay, Duration::from_secs(10)).expect("Ctrl-C ends it");
    assert!(status.success());
    assert!(shm_leftovers(pid).is_empty(), "{:?}", shm_leftovers(pid));
    assert!(
        run_dir_leftovers(&run_dir).is_empty(),
        "{:?}",
        run_dir_leftovers(&run_dir)
    );
    assert_eq!(run(&run_dir, &["instance", "--env"]).status.code(), Some(1));
}

/// The `aisle instance --env` line once the replay's instance is live.
fn wait_for_instance(run_dir: &std::path::Path) -> String {
    let start = std::time::Instant::now();
    loop {
        let out = run(run_dir, &["instance", "--env"]);
        if out.status.success() || start.elapsed() > Duration::from_secs(20) {
            return text(&out).0;
        }
        std::thread::sleep(Duration::from_millis(50));
    }
}
