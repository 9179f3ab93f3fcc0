//! External nodes: a process of the user's own declared in `graph.toml` with its
//! command (here the Rust example `examples/safety_monitor`) is launched, waited for in
//! lockstep, recorded and restarted like a built-in node.

mod support;

use std::path::{Path, PathBuf};
use support::{TestDir, run};

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
    let config = dir.path("config");
    std::fs::create_dir_all(&config).unwrap();
    for entry in std::fs::read_dir(support::config_dir()).unwrap() {
        let path = entry.unwrap().path();
        std::fs::copy(&path, config.join(path.file_name().unwrap())).unwrap();
    }
    let mut graph = std::fs::read_to_string(config.join("graph.toml")).unwrap();
    graph.push_str(&format!(
        r#"
[[node]]
name = "safety_monitor"
command = ["{}"]
publishes = ["aisle/sim_command"]
subscribes = ["aisle/lidar/points", "aisle/robot_state", "aisle/controller/goal"]
acknowledges = "every_tick"
"#,
        monitor_bin().display()
    ));
    std::fs::write(config.join("graph.toml"), graph).unwrap();
    config
}

fn run_with_monitor(
    dir: &TestDir,
    tag: &str,
    extra: &[&str],
) -> (aisle_supervisor::report::RunReport, PathBuf, String) {
    let config = config_with_monitor(dir);
    let report = dir.path(&format!("{tag}.json"));
    let record = dir.path(&format!("{tag}.mcap"));
    let mut args = vec![
        "run",
        "--quiet",
        "--config-dir",
        config.to_str().unwrap(),
        "--report",
        report.to_str().unwrap(),
        "--record",
        record.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    let out = run(&dir.run_dir(), &args);
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(out.status.success(), "{err}");
    let text = std::fs::read_to_string(&report).unwrap();
    assert!(support::run_dir_leftovers(&dir.run_dir()).is_empty());
    (serde_json::from_str(&text).unwrap(), record, err)
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
    let (n, acks) = same_records(&rec_a, &rec_b, monitor, a.ticks.saturating_sub(1));
    assert!(
        acks + 2 >= a.ticks as usize,
        "{acks} acknowledgements of the monitor recorded"
    );
    // At least tick, robot state, world truth, points and local map per tick.
    assert!(n >= 5 * acks, "{n} messages compared");
}

/// Both records hold the same messages, topic by topic in the same order (publishers
/// of one topic ordered by tick and source: what arrives from two processes within a
/// tick may interleave either way), byte for byte except the fields measured on the
/// wall clock (`aisle_tools::diff::WALL_CLOCK_FIELDS`) and the heartbeats (sent on the
/// wall clock), up to `before_tick` (the run's last tick ends as the group is stopped:
/// what of it is recorded depends on when each process got its SIGTERM); returns how
/// many, and how many are `TickDone`s of the node `code`.
fn same_records(a: &Path, b: &Path, code: u32, before_tick: u64) -> (usize, usize) {
    let (ta, tb) = (by_topic(a, before_tick), by_topic(b, before_tick));
    assert_eq!(ta.keys().collect::<Vec<_>>(), tb.keys().collect::<Vec<_>>());
    let mut n = 0;
    for ((topic, ma), mb) in ta
        .iter()
        .zip(tb.values())
        .filter(|((t, _), _)| *t != "aisle/tick_done")
    {
        let per_source = |l: &[Keyed]| {
            let mut m = std::collections::BTreeMap::<(u32, u32), usize>::new();
            l.iter()
                .for_each(|(_, k, _)| *m.entry((k.2, k.3)).or_default() += 1);
            m
        };
        assert_eq!(
            ma.len(),
            mb.len(),
            "{topic}: message counts per (source, node) {:?} vs {:?}",
            per_source(ma),
            per_source(mb)
        );
        for (i, ((ty, ka, da), (_, kb, db))) in ma.iter().zip(mb).enumerate() {
            assert_eq!(ka, kb, "{topic} message {i}: log time, tick, source");
            let d = aisle_tools::diff::first_difference(
                ty,
                da,
                db,
                &aisle_tools::diff::WALL_CLOCK_FIELDS,
            );
            assert!(d.is_none(), "{topic} message {i}: {}", d.unwrap());
            n += 1;
        }
    }
    // Acknowledgements: who acknowledged which tick is the protocol (the same in both);
    // the order in which the recorder took them from two processes is not.
    let acked = |t: &std::collections::BTreeMap<String, Vec<Keyed>>| {
        let mut v: Vec<(u64, u32)> = t["aisle/tick_done"]
            .iter()
            .map(|(_, k, _)| (k.1, k.3))
            .collect();
        v.sort_unstable();
        v
    };
    let (aa, ab) = (acked(&ta), acked(&tb));
    assert!(aa == ab, "the acknowledgements differ");
    let mut ticks: Vec<u64> = aa
        .iter()
        .filter(|(_, node)| *node == code)
        .map(|(t, _)| *t)
        .collect();
    let acks = ticks.len();
    ticks.dedup();
    assert_eq!(
        ticks.len(),
        acks,
        "a tick acknowledged twice by the external node"
    );
    (n, acks)
}

type Keyed = (String, (u64, u64, u32, u32), Vec<u8>);

/// A record's messages per topic before `before_tick`, heartbeats and idle
/// acknowledgements left out, each sorted by (log time, tick,
/// source, and for `TickDone` the acknowledging node).
fn by_topic(path: &Path, before_tick: u64) -> std::collections::BTreeMap<String, Vec<Keyed>> {
    use aisle_messages::{Header, TickDone};
    let file = aisle_tools::reader::RecordFile::open(path).unwrap();
    let mut topics: std::collections::BTreeMap<String, Vec<Keyed>> = Default::default();
    let u64_at = |d: &[u8], at: usize| u64::from_le_bytes(d[at..at + 8].try_into().unwrap());
    let u32_at = |d: &[u8], at: usize| u32::from_le_bytes(d[at..at + 4].try_into().unwrap());
    for m in file.raw_messages() {
        let m = m.unwrap();
        let topic = m.channel.topic.clone();
        let idle = topic == "aisle/tick_done"
            && u32_at(&m.data, std::mem::offset_of!(TickDone, status))
                == aisle_messages::StageStatus::Idle as u32;
        // Heartbeats go by the wall clock; an idle acknowledgement (a tick nobody waits
        // for this node on, such as the controller's off ticks) may be skipped when a
        // newer tick is already there.
        if topic == "aisle/heartbeat" || idle {
            continue;
        }
        let node = if topic == "aisle/tick_done" {
            u32_at(&m.data, std::mem::offset_of!(TickDone, node))
        } else {
            0
        };
        let key = (
            m.log_time,
            u64_at(&m.data, std::mem::offset_of!(Header, tick)),
            u32_at(&m.data, std::mem::offset_of!(Header, source)),
            node,
        );
        if key.1 >= before_tick {
            continue;
        }
        let ty = m.channel.schema_name.clone().unwrap_or_default();
        topics.entry(topic).or_default().push((ty, key, m.data));
    }
    for list in topics.values_mut() {
        list.sort_by_key(|(_, k, _)| *k);
    }
    topics
}

#[test]
fn a_killed_external_node_is_restarted_and_the_mission_goes_on() {
    let dir = TestDir::new("ext-kill");
    let (r, _, err) = run_with_monitor(&dir, "k", &["--kill", "safety_monitor@30"]);
    assert!(r.success, "{:?}", r.failure);
    assert_eq!(r.restarts, 1, "{err}");
    assert_eq!(r.collisions, 0);
}
