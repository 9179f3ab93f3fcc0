//! Tools attached to a live group from outside: a replay never publishes what the group
//! publishes itself (it would impersonate the supervisor, the simulator, ...), a lockstep
//! replay refuses to wait for the clock, `echo` and `hz` leave when the group ends, and
//! two commands never write one output file at once.

mod support;

use std::process::{Child, Output};
use std::time::{Duration, Instant};
use support::*;

fn text(o: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

fn short_mission(dir: &TestDir) -> String {
    let p = mission_file(
        dir,
        "short.toml",
        "[[leg]]\nname = \"short hop\"\ngoal = [3.0, -2.0, 0.0]\n",
    );
    p.to_str().unwrap().to_string()
}

/// `(prefix, root)` of the newest live instance, once there is one.
fn wait_for_instance(run_dir: &std::path::Path) -> (String, String) {
    let start = Instant::now();
    loop {
        let out = run(run_dir, &["instance", "--env"]);
        if out.status.success() {
            let line = String::from_utf8_lossy(&out.stdout).trim().to_string();
            let mut p = None;
            let mut r = None;
            for part in line.trim_start_matches("export ").split(' ') {
                match part.split_once('=') {
                    Some(("AISLE_PREFIX", v)) => p = Some(v.to_string()),
                    Some(("AISLE_ROOT", v)) => r = Some(v.to_string()),
                    _ => {}
                }
            }
            return (p.unwrap(), r.unwrap());
        }
        assert!(
            start.elapsed() < Duration::from_secs(30),
            "no live instance"
        );
        std::thread::sleep(Duration::from_millis(50));
    }
}

fn exits_within(child: &mut Child, timeout: Duration, what: &str) -> (i32, String) {
    let status = wait_exit(child, timeout);
    if status.is_none() {
        let _ = child.kill();
    }
    let out = std::mem::replace(child, std::process::Command::new("true").spawn().unwrap());
    let out = out.wait_with_output().unwrap();
    let status = status.unwrap_or_else(|| panic!("{what} still runs: {}", text(&out)));
    (status.code().unwrap_or(-1), text(&out))
}

#[test]
fn a_replay_into_a_live_group_publishes_none_of_its_topics_and_observers_leave_with_it() {
    let dir = TestDir::new("live-tools");
    let run_dir = dir.run_dir();
    let mission = short_mission(&dir);
    let record = dir.path("run.mcap");
    let rec = record.to_str().unwrap();
    let out = run(
        &run_dir,
        &["run", "--quiet", "--mission", &mission, "--record", rec],
    );
    assert!(out.status.success(), "{}", text(&out));

    // The simulator is the clock: a lockstep replay cannot drive it (it used to wait
    // for an acknowledgement that never came).
    let started = Instant::now();
    let out = run(
        &run_dir,
        &["replay", rec, "--lockstep", "--wait-for", "simulator"],
    );
    let t = text(&out);
    assert_eq!(out.status.code(), Some(2), "{t}");
    assert!(
        t.contains("--wait-for simulator") && t.contains("clock"),
        "{t}"
    );
    assert!(started.elapsed() < Duration::from_secs(10), "{t}");

    let mut group = spawn(
        &run_dir,
        &["run", "--realtime", "--quiet", "--mission", &mission],
    );
    let group_pid = group.id();
    let (prefix, root) = wait_for_instance(&run_dir);
    let mut echo = spawn(&run_dir, &["echo", "aisle/robot_state"]);
    let mut hz = spawn(&run_dir, &["hz", "aisle/robot_state", "--window", "500ms"]);

    // Into the live group: its own topics are refused, each naming its publisher, and
    // nothing is published.
    let target = ["--prefix", prefix.as_str(), "--root", root.as_str()];
    for (topic, publisher) in [
        ("aisle/sim_command", format!("supervisor (pid {group_pid})")),
        ("aisle/robot_state", "simulator (pid ".to_string()),
        (
            "aisle/controller/goal",
            format!("supervisor (pid {group_pid})"),
        ),
    ] {
        let mut args = vec!["replay", rec, "--topics", topic];
        args.extend_from_slice(&target);
        let out = run(&run_dir, &args);
        let t = text(&out);
        assert_eq!(out.status.code(), Some(2), "{t}");
        assert!(
            t.contains(&format!("`{topic}` (published by {publisher}")),
            "{t}"
        );
        assert!(!t.contains("messages from"), "nothing is published: {t}");
    }
    let mut args = vec![
        "replay",
        rec,
        "--lockstep",
        "--wait-for",
        "teb_controller",
        "--topics",
        "aisle/tick",
        "aisle/map/local",
    ];
    args.extend_from_slice(&target);
    let out = run(&run_dir, &args);
    let t = text(&out);
    assert_eq!(out.status.code(), Some(2), "{t}");
    assert!(t.contains("`aisle/tick` (published by simulator"), "{t}");

    // The group ends: the observers notice and leave (exit 1), without iceoryx2's
    // complaints about storage removed from under them.
    let (code, t) = exits_within(&mut group, Duration::from_secs(120), "the group");
    assert_eq!(code, 0, "{t}");
    for (child, what) in [(&mut echo, "echo"), (&mut hz, "hz")] {
        let (code, t) = exits_within(child, Duration::from_secs(10), what);
        assert_eq!(code, 1, "{what}: {t}");
        assert!(
            t.contains(&format!("owner of instance {prefix}")) && t.contains("aisle/robot_state"),
            "{what}: {t}"
        );
        assert!(!t.contains("corrupted"), "{what}: {t}");
    }
    assert!(run_dir_leftovers(&run_dir).is_empty());
}

#[test]
fn a_second_command_writing_the_same_output_is_refused_before_launch() {
    let dir = TestDir::new("same-output");
    let run_dir = dir.run_dir();
    let mission = short_mission(&dir);
    let record = dir.path("same.mcap");
    let report = dir.path("same.json");
    let (rec, rep) = (record.to_str().unwrap(), report.to_str().unwrap());
    let outputs = ["--mission", &mission, "--record", rec, "--report", rep];
    let mut first = spawn(
        &run_dir,
        &[&["run", "--realtime", "--quiet"], &outputs[..]].concat(),
    );
    let first_pid = first.id();
    // Its outputs are locked before its instance exists.
    wait_for_instance(&run_dir);
    let other = dir.path("other.mcap");
    for (flag, args) in [
        ("--record", vec!["--record", rec]),
        (
            "--report",
            vec!["--record", other.to_str().unwrap(), "--report", rep],
        ),
    ] {
        let mut all = vec!["run", "--quiet", "--mission", &mission];
        all.extend_from_slice(&args);
        let out = run(&run_dir, &all);
        let t = text(&out);
        assert_eq!(out.status.code(), Some(2), "{t}");
        assert!(
            t.contains(&format!("{flag} ")) && t.contains(&format!("(pid {first_pid})")),
            "{t}"
        );
        assert!(!other.exists(), "refused before the recorder ran: {t}");
    }
    let out = run(
        &run_dir,
        &["record", "--prefix", "x", "--root", "/tmp/x", "-o", rec],
    );
    assert_eq!(out.status.code(), Some(2), "{}", text(&out));

    let (code, t) = exits_within(&mut first, Duration::from_secs(120), "the first run");
    assert_eq!(code, 0, "{t}");
    let out = run(&run_dir, &["profile", rec]);
    let t = text(&out);
    assert_eq!(out.status.code(), Some(0), "the record is whole: {t}");
    assert!(!t.contains("damaged"), "{t}");
    // Once the first run ended, its files may be written over, as before.
    let out = run(&run_dir, &[&["run", "--quiet"], &outputs[..]].concat());
    assert!(out.status.success(), "{}", text(&out));
    assert!(run_dir_leftovers(&run_dir).is_empty());
}

/// A timed replay into a live instance stops when the instance's owner ends it (here a
/// looping replay that made its own instance), says why and exits 2, instead of
/// publishing into an instance being removed.
#[test]
fn a_timed_replay_stops_when_its_live_instance_ends() {
    let dir = TestDir::new("replay-ends");
    let run_dir = dir.run_dir();
    let record = dir.path("run.mcap");
    let rec = record.to_str().unwrap();
    let out = run(&run_dir, &["run", "--quiet", "--record", rec]);
    assert!(out.status.success(), "{}", text(&out));

    // The owner: a replay of the robot state into an instance of its own, looping.
    let mut owner = spawn(
        &run_dir,
        &["replay", rec, "--topics", "aisle/robot_state", "--loop"],
    );
    let (prefix, root) = wait_for_instance(&run_dir);
    // Into it, at recorded speed (the record lasts tens of seconds): the local map,
    // which nothing there publishes.
    let mut guest = spawn(
        &run_dir,
        &[
            "replay",
            rec,
            "--topics",
            "aisle/map/local",
            "--prefix",
            &prefix,
            "--root",
            &root,
        ],
    );
    std::thread::sleep(Duration::from_secs(2));
    assert!(
        guest.try_wait().unwrap().is_none(),
        "the guest replay ended early"
    );
    // SAFETY: a signal to our own child; it stops and removes its instance.
    unsafe { libc::kill(owner.id() as i32, libc::SIGINT) };
    let (code, t) = exits_within(&mut owner, Duration::from_secs(30), "the owner");
    assert_eq!(code, 0, "{t}");
    let (code, t) = exits_within(&mut guest, Duration::from_secs(10), "the guest");
    assert_eq!(code, 2, "{t}");
    assert!(
        t.contains(&format!("instance {prefix}")) && t.contains("the replay stopped after"),
        "{t}"
    );
    // (A replay's own instance is removed at once, not after its observers left as
    // `aisle run` does, so iceoryx2 may warn here as the guest closes its ports.)
    assert!(run_dir_leftovers(&run_dir).is_empty());
}
