//! System tests of the process group: the real `aisle` binary, its five node processes,
//! each run in its own iceoryx2 instance so the tests run in parallel.

mod support;

use aisle_bus::{Bus, Instance};
use aisle_messages::{TickMode, topics};
use std::time::Duration;
use support::*;

/// A short mission: one leg a few metres from the start.
fn short_mission(dir: &TestDir, name: &str) -> std::path::PathBuf {
    mission_file(
        dir,
        name,
        "[[leg]]\nname = \"short hop\"\ngoal = [3.0, -2.0, 0.0]\n",
    )
}

#[test]
fn two_groups_run_in_parallel_each_in_its_own_instance() {
    let dir = TestDir::new("parallel");
    let mission = short_mission(&dir, "short.toml");
    let run_dir = dir.run_dir();
    let reports = [dir.path("a.json"), dir.path("b.json")];
    let mut children: Vec<_> = reports
        .iter()
        .map(|r| {
            spawn(
                &run_dir,
                &[
                    "run",
                    "--quiet",
                    "--mission",
                    mission.to_str().unwrap(),
                    "--report",
                    r.to_str().unwrap(),
                ],
            )
        })
        .collect();
    let pids: Vec<u32> = children.iter().map(|c| c.id()).collect();
    let errs: Vec<_> = children.iter_mut().map(stderr_reader).collect();
    for (i, (c, err)) in children.iter_mut().zip(errs).enumerate() {
        let out = c.wait().unwrap();
        let err = err.join().unwrap();
        assert!(out.success(), "group {i} failed: {err}");
    }
    for r in &reports {
        let report: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(r).unwrap()).unwrap();
        assert_eq!(report["success"], true, "{r:?}");
        assert!(report["ticks"].as_u64().unwrap() > 10);
        assert_eq!(report["collisions"], 0);
    }
    for pid in pids {
        assert!(shm_leftovers(pid).is_empty(), "{:?}", shm_leftovers(pid));
    }
    assert!(
        run_dir_leftovers(&run_dir).is_empty(),
        "{:?}",
        run_dir_leftovers(&run_dir)
    );
}

#[test]
fn a_killed_node_is_named_restarted_and_the_mission_goes_on() {
    let dir = TestDir::new("sigkill");
    let run_dir = dir.run_dir();
    let report = dir.path("r.json");
    // Realtime: the run lasts as long as the mission's sim time, so it is surely still
    // going when the lidar dies.
    let mut aisle = spawn(
        &run_dir,
        &[
            "run",
            "--quiet",
            "--realtime",
            "--report",
            report.to_str().unwrap(),
        ],
    );
    let aisle_err = stderr_reader(&mut aisle);
    let pid = aisle.id();
    let nodes = wait_for_nodes(pid, Duration::from_secs(30));
    assert_eq!(nodes.len(), 5, "{nodes:?}");
    // Let the run get going, then kill the lidar as a crash would.
    std::thread::sleep(Duration::from_millis(1500));
    // Meanwhile: the instance's shared memory is its owner's only.
    let shm = shm_leftovers(pid);
    assert!(!shm.is_empty());
    for f in &shm {
        use std::os::unix::fs::PermissionsExt;
        let mode = std::fs::metadata(format!("/dev/shm/{f}"))
            .unwrap()
            .permissions()
            .mode();
        assert_eq!(mode & 0o077, 0, "/dev/shm/{f} has mode {mode:o}");
    }
    let lidar = nodes.iter().find(|(n, _)| n == "lidar").unwrap().1;
    unsafe { libc::kill(lidar as i32, libc::SIGKILL) };
    let status = wait_exit(&mut aisle, Duration::from_secs(120)).expect("the supervisor exits");
    let err = aisle_err.join().unwrap();
    assert!(status.success(), "{err}");
    assert!(
        err.contains("node `lidar` was killed by signal 9 (SIGKILL): restarting it"),
        "{err}"
    );
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    assert_eq!(r["success"], true);
    assert_eq!(r["restarts"], 1);
    assert_eq!(r["collisions"], 0);
    assert_group_gone(pid, &nodes, &run_dir);
}

#[test]
fn a_node_that_always_crashes_at_start_ends_the_run_within_the_restart_limit() {
    let dir = TestDir::new("crashloop");
    let run_dir = dir.run_dir();
    let mut aisle = spawn(&run_dir, &["run", "--quiet", "--crash-on-start", "mapper"]);
    let aisle_err = stderr_reader(&mut aisle);
    let pid = aisle.id();
    let status = wait_exit(&mut aisle, Duration::from_secs(60)).expect("the supervisor exits");
    let err = aisle_err.join().unwrap();
    assert_eq!(status.code(), Some(2), "{err}");
    assert!(
        err.contains(
            "node `mapper` exited with code 1; its last words: error: mapper: failing at start"
        ),
        "{err}"
    );
    assert!(err.contains("restarted 3 times within 60 s"), "{err}");
    assert!(shm_leftovers(pid).is_empty(), "{:?}", shm_leftovers(pid));
    assert!(
        run_dir_leftovers(&run_dir).is_empty(),
        "{:?}",
        run_dir_leftovers(&run_dir)
    );
}

/// `sig` to the supervisor of a realtime run: every process stops, nothing is left.
fn signal_stops_every_process_and_leaves_nothing_behind(sig: libc::c_int, name: &str) {
    let dir = TestDir::new(name);
    let run_dir = dir.run_dir();
    let mut cmd = command(&run_dir, &["run", "--quiet", "--realtime"]);
    cmd.stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped());
    // Whatever the test runner ignores (a `nohup` ignores SIGHUP), the run sees the
    // signal as a terminal would send it.
    unsafe {
        use std::os::unix::process::CommandExt;
        cmd.pre_exec(|| {
            libc::signal(libc::SIGHUP, libc::SIG_DFL);
            Ok(())
        });
    }
    let mut aisle = cmd.spawn().expect("aisle starts");
    let stderr = stderr_reader(&mut aisle);
    let pid = aisle.id();
    let nodes = wait_for_nodes(pid, Duration::from_secs(30));
    assert_eq!(nodes.len(), 5, "{nodes:?}");
    std::thread::sleep(Duration::from_millis(1000));
    unsafe { libc::kill(pid as i32, sig) };
    // The acceptance figure is 2 s; the bound here only catches a hang on a loaded machine.
    let status = wait_exit(&mut aisle, Duration::from_secs(15))
        .unwrap_or_else(|| panic!("the supervisor exits after {name}"));
    assert_eq!(status.code(), Some(2), "{status:?}");
    assert!(stderr.join().unwrap().contains("interrupted"));
    assert_group_gone(pid, &nodes, &run_dir);
}

#[test]
fn sigint_stops_every_process_and_leaves_nothing_behind() {
    signal_stops_every_process_and_leaves_nothing_behind(libc::SIGINT, "sigint");
}

/// The terminal closed: as SIGINT (it used to end the supervisor at once, exit 129,
/// its instance and config directory left behind).
#[test]
fn sighup_stops_every_process_and_leaves_nothing_behind() {
    signal_stops_every_process_and_leaves_nothing_behind(libc::SIGHUP, "sighup");
}

#[test]
fn a_node_built_with_another_schema_is_refused() {
    let dir = TestDir::new("schema");
    let instance = Instance::unique(&dir.run_dir());
    // Removed even when an assertion below fails.
    struct Remove(Instance);
    impl Drop for Remove {
        fn drop(&mut self) {
            let _ = self.0.remove();
        }
    }
    let _guard = Remove(instance.clone());
    let foreign = aisle_messages::schema_hash() ^ 0xdead_beef;
    let (bus, info) = Bus::announce(&instance, foreign, 1, TickMode::Lockstep).unwrap();
    // The node joins from another process; keep the announcement's history served.
    let mut child = command(
        &dir.run_dir(),
        &[
            "node",
            "lidar",
            "--prefix",
            &instance.prefix,
            "--root",
            instance.root.to_str().unwrap(),
            "--config-dir",
            config_dir().to_str().unwrap(),
        ],
    )
    .stderr(std::process::Stdio::piped())
    .spawn()
    .unwrap();
    let child_err = stderr_reader(&mut child);
    let status = loop {
        info.update_connections().unwrap();
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    let err = child_err.join().unwrap();
    assert_eq!(status.code(), Some(1), "{err}");
    assert!(err.contains("schema mismatch"), "{err}");
    assert!(err.contains(&format!("{foreign:016x}")), "{err}");
    assert!(err.contains(&aisle_messages::schema_hash_hex()), "{err}");
    drop(info);
    drop(bus);
    instance.remove().unwrap();
}

#[test]
fn check_accepts_the_shipped_config_and_names_file_line_and_key() {
    // Not "check": the replay check's test dir has that name, and a test removes its
    // directory when it ends.
    let dir = TestDir::new("check-config");
    let ok = run(
        &dir.run_dir(),
        &["check", "--config-dir", config_dir().to_str().unwrap()],
    );
    assert!(
        ok.status.success(),
        "{}",
        String::from_utf8_lossy(&ok.stderr)
    );
    let bad = dir.path("config");
    std::fs::create_dir_all(&bad).unwrap();
    for e in std::fs::read_dir(config_dir()).unwrap().flatten() {
        if e.path().is_file() {
            std::fs::copy(e.path(), bad.join(e.file_name())).unwrap();
        }
    }
    let teb = std::fs::read_to_string(bad.join("mission.toml")).unwrap();
    std::fs::write(
        bad.join("mission.toml"),
        teb.replace("carry = \"rack2b\"", "carry = \"rack9z\""),
    )
    .unwrap();
    let out = run(
        &dir.run_dir(),
        &["check", "--config-dir", bad.to_str().unwrap()],
    );
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("mission.toml:"), "{err}");
    assert!(err.contains("carry"), "{err}");
    assert!(err.contains("rack9z"), "{err}");
}

#[test]
fn map_export_writes_the_static_map_as_a_ros_map() {
    let dir = TestDir::new("export");
    let out_dir = dir.path("maps");
    let out = run(
        &dir.run_dir(),
        &[
            "map",
            "export",
            out_dir.to_str().unwrap(),
            "--config-dir",
            config_dir().to_str().unwrap(),
        ],
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let read = aisle_mapper::ros_map::read_ros_map(&out_dir.join("warehouse.yaml")).unwrap();
    let cfg =
        aisle_config::load::<aisle_mapper::MapConfig>(&config_dir().join("mapper.toml")).unwrap();
    let expected =
        aisle_mapper::load_static_map(&cfg, &config_dir().join("warehouse.toml")).unwrap();
    assert_eq!((read.width, read.height), (expected.width, expected.height));
    assert!(
        (read.origin_x - expected.origin_x).abs() < 1e-9
            && (read.origin_y - expected.origin_y).abs() < 1e-9
    );
    let occupied = |c: &[u8]| c.iter().map(|&v| v != 0).collect::<Vec<_>>();
    assert_eq!(occupied(&read.cells), occupied(&expected.cells));
    assert!(expected.cells.iter().any(|&c| c != 0));
}

/// The short mission recorded to `run.mcap` in `dir`.
fn record_short_run(dir: &TestDir) -> (std::path::PathBuf, std::process::Output) {
    let mission = short_mission(dir, "short.toml");
    let file = dir.path("run.mcap");
    let out = run(
        &dir.run_dir(),
        &[
            "run",
            "--quiet",
            "--mission",
            mission.to_str().unwrap(),
            "--record",
            file.to_str().unwrap(),
            "--report",
            dir.path("run.json").to_str().unwrap(),
            "--samples",
            dir.path("run.csv").to_str().unwrap(),
        ],
    );
    (file, out)
}

/// One measurement, two views: `aisle profile` on the record of a lockstep run gives the
/// run's own latency table (same samples, same quantiles, the same attached budgets).
fn assert_profile_matches_the_run(dir: &TestDir, file: &std::path::Path) {
    let (json, csv) = (dir.path("profile.json"), dir.path("profile.csv"));
    let args = ["profile", file.to_str().unwrap(), "--json"];
    let p = run(
        &dir.run_dir(),
        &[
            &args[..],
            &[json.to_str().unwrap(), "--samples", csv.to_str().unwrap()],
        ]
        .concat(),
    );
    assert!(p.status.success(), "{}", String::from_utf8_lossy(&p.stderr));
    let read = |p: std::path::PathBuf| std::fs::read_to_string(p).unwrap();
    let report: aisle_supervisor::report::RunReport =
        serde_json::from_str(&read(dir.path("run.json"))).unwrap();
    let profiled: aisle_tools::latency::LatencyTable = serde_json::from_str(&read(json)).unwrap();
    let stages: Vec<&str> = report.latency.iter().map(|s| s.stage.as_str()).collect();
    for must in [
        "lidar",
        "mapper",
        "teb_controller",
        "supervisor",
        "end_to_end",
    ] {
        assert!(stages.contains(&must), "{must} missing from {stages:?}");
    }
    for s in &report.latency {
        let twin = profiled.stages.iter().find(|p| p.stage == s.stage);
        assert_eq!(Some(s), twin, "run and profile disagree on {}", s.stage);
        assert!(s.budget_ms.is_some(), "{} not scored", s.stage);
    }
    assert_eq!(report.tick_release, profiled.tick_release);
    let lidar = report.latency.iter().find(|s| s.stage == "lidar").unwrap();
    assert!(
        lidar.cpu_p50_ms.is_some_and(|c| c > 0.0),
        "the lidar's CPU time"
    );
    let node = report.processes.iter().find(|p| p.process == "mapper");
    assert!(
        node.is_some_and(|p| p.peak_rss_kib > 0 && p.minor_faults > 0),
        "{node:?}"
    );
    assert!(report.tick_release.unwrap().lateness.is_none(), "lockstep");
    // Every sample, once, in both exports.
    let sorted = |text: String, keep: &dyn Fn(&str) -> bool| {
        let mut v: Vec<String> = text.lines().filter(|l| keep(l)).map(String::from).collect();
        v.sort();
        v
    };
    let from_run = sorted(read(dir.path("run.csv")), &|_| true);
    let from_profile = sorted(read(csv), &|l| !l.starts_with("latency "));
    assert_eq!(from_run, from_profile);
    let total: usize = report.latency.iter().map(|s| s.samples).sum();
    assert_eq!(from_run.len(), 1 + total);
}

/// Ticks recorded in a file.
fn rec_ticks(file: &std::path::Path) -> usize {
    aisle_tools::reader::RecordFile::open(file)
        .unwrap()
        .raw_messages()
        .filter(|m| {
            m.as_ref()
                .is_ok_and(|m| m.channel.topic == topics::TICK.name)
        })
        .count()
}

#[test]
fn a_recorded_run_profiles_renders_and_survives_truncation() {
    let dir = TestDir::new("record");
    let (file, out) = record_short_run(&dir);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(!err.contains("lost"), "the recorder lost samples: {err}");
    // Every tick the simulator announced is in the file, once.
    let ticks = rec_ticks(&file);
    assert!(ticks > 10, "{ticks} ticks recorded");

    assert_profile_matches_the_run(&dir, &file);
    // A lockstep record is on the sim clock: each message logged at its own sim time.
    let rec = aisle_tools::reader::RecordFile::open(&file).unwrap();
    assert_eq!(
        rec.run_metadata().get("log_time").map(String::as_str),
        Some("sim time")
    );
    let raw: Vec<_> = rec.raw_messages().filter_map(Result::ok).collect();
    assert!(raw.iter().any(|m| m.log_time > 1_000_000_000));
    let off = raw
        .iter()
        .find(|m| m.publish_time != 0 && m.log_time != m.publish_time);
    assert!(off.is_none(), "not logged at its sim time: {off:?}");
    let prof = run(&dir.run_dir(), &["profile", file.to_str().unwrap()]);
    let table = String::from_utf8_lossy(&prof.stdout);
    assert!(
        prof.status.success(),
        "{}",
        String::from_utf8_lossy(&prof.stderr)
    );
    assert!(table.contains("end_to_end"), "{table}");
    assert!(table.contains("the record's budgets.toml"), "{table}");
    let png = dir.path("run.png");
    let r = run(
        &dir.run_dir(),
        &[
            "render",
            file.to_str().unwrap(),
            "-o",
            png.to_str().unwrap(),
        ],
    );
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    assert_eq!(&std::fs::read(&png).unwrap()[..8], b"\x89PNG\r\n\x1a\n");
    // The playback page: one file, background and every tick inside.
    let page = dir.path("run.html");
    let r = run(
        &dir.run_dir(),
        &[
            "render",
            file.to_str().unwrap(),
            "-o",
            page.to_str().unwrap(),
        ],
    );
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let html = std::fs::read_to_string(&page).unwrap();
    assert!(html.starts_with("<!DOCTYPE html>"));
    assert!(html.contains("data:image/png;base64,iVBORw0KGgo"));
    assert!(!html.contains("http"), "self-contained: no links");
    let frames = html.matches("],[").count();
    assert!(frames >= ticks, "{frames} frames for {ticks} ticks");

    // A truncated file: a clear answer, never a panic.
    let bytes = std::fs::read(&file).unwrap();
    let cut = dir.path("cut.mcap");
    std::fs::write(&cut, &bytes[..bytes.len() * 2 / 3]).unwrap();
    let p = run(&dir.run_dir(), &["profile", cut.to_str().unwrap()]);
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&p.stdout),
        String::from_utf8_lossy(&p.stderr)
    );
    assert_eq!(
        p.status.code(),
        Some(2),
        "a damaged record is exit 2: {text}"
    );
    assert!(
        text.contains("damaged") || text.contains("truncated"),
        "{text}"
    );
    // The damage said once (it was in the table's note and again after the table).
    assert_eq!(
        text.matches("the readable part ends").count(),
        1,
        "one damage note: {text}"
    );
    // Every message readable but no summary (cut in its summary): said, once, exit 2.
    std::fs::write(&cut, &bytes[..bytes.len() - 100]).unwrap();
    let p = run(&dir.run_dir(), &["profile", cut.to_str().unwrap()]);
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&p.stdout),
        String::from_utf8_lossy(&p.stderr)
    );
    assert_eq!(p.status.code(), Some(2), "{text}");
    assert_eq!(text.matches("no summary").count(), 1, "{text}");
    assert_eq!(
        text.matches("profiled what could be read").count(),
        1,
        "{text}"
    );
}

#[test]
fn replay_check_finds_a_recorded_run_identical_and_a_changed_controller_divergent() {
    let dir = TestDir::new("check");
    let (file, out) = record_short_run(&dir);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = |o: &std::process::Output| {
        format!(
            "{}{}",
            String::from_utf8_lossy(&o.stdout),
            String::from_utf8_lossy(&o.stderr)
        )
    };
    // Unchanged build, the recorded config: identical, every output kind compared.
    let same = run(
        &dir.run_dir(),
        &["replay", file.to_str().unwrap(), "--check"],
    );
    let t = text(&same);
    assert_eq!(same.status.code(), Some(0), "{t}");
    assert!(t.contains("identical"), "{t}");
    for service in [
        "aisle/map/local",
        "aisle/map/global",
        "aisle/map/global_changes",
        "aisle/controller/trajectory",
        "aisle/controller/band",
    ] {
        let line = t.lines().find(|l| l.contains(service)).unwrap_or_default();
        assert!(line.contains(" 0 differ"), "{service}: {t}");
        assert!(!line.contains(" 0 compared"), "{service}: {t}");
    }
    assert!(run_dir_leftovers(&dir.run_dir()).is_empty());

    // The controller changed (a smoothness weight): the first divergence is named.
    let changed = dir.path("changed");
    std::fs::create_dir_all(&changed).unwrap();
    for e in std::fs::read_dir(config_dir()).unwrap() {
        let p = e.unwrap().path();
        if p.is_file() {
            std::fs::copy(&p, changed.join(p.file_name().unwrap())).unwrap();
        }
    }
    let teb = std::fs::read_to_string(changed.join("teb.toml")).unwrap();
    let teb2 = teb.replace("smoothness = 0.2 ", "smoothness = 0.3 ");
    assert_ne!(teb, teb2, "teb.toml has the smoothness weight");
    std::fs::write(changed.join("teb.toml"), teb2).unwrap();
    let diff = run(
        &dir.run_dir(),
        &[
            "replay",
            file.to_str().unwrap(),
            "--check",
            "--config-dir",
            changed.to_str().unwrap(),
        ],
    );
    let t = text(&diff);
    assert_eq!(diff.status.code(), Some(1), "{t}");
    let first = t
        .lines()
        .find(|l| l.contains("DIVERGED"))
        .unwrap_or_default();
    assert!(first.contains("aisle/controller/"), "{t}");
    assert!(
        first.contains("at tick") && first.contains("recorded"),
        "{t}"
    );
    // The mapper did not change: its maps still match.
    let local = t.lines().find(|l| l.contains("aisle/map/local")).unwrap();
    assert!(local.contains(" 0 differ"), "{t}");

    // Lockstep replay of the recorded local maps, goals and states into a new
    // controller launched from this build: every recorded tick goes through.
    let ticks = rec_ticks(&file);
    let l = run(
        &dir.run_dir(),
        &[
            "replay",
            file.to_str().unwrap(),
            "--lockstep",
            "--wait-for",
            "teb_controller",
            "--topics",
            "aisle/tick",
            "aisle/robot_state",
            "aisle/map/local",
            "aisle/controller/goal",
        ],
    );
    let t = text(&l);
    assert_eq!(l.status.code(), Some(0), "{t}");
    let published = t
        .lines()
        .find(|l| l.trim_start().starts_with("aisle/tick "))
        .and_then(|l| l.split_whitespace().nth(1))
        .and_then(|n| n.parse::<usize>().ok());
    assert_eq!(published, Some(ticks), "{t}");

    // A damaged recording: a clear answer, never a pass, never a panic.
    let bytes = std::fs::read(&file).unwrap();
    let cut = dir.path("cut.mcap");
    std::fs::write(&cut, &bytes[..bytes.len() / 2]).unwrap();
    let c = run(
        &dir.run_dir(),
        &["replay", cut.to_str().unwrap(), "--check"],
    );
    let t = text(&c);
    assert_eq!(c.status.code(), Some(2), "{t}");
    assert!(t.contains("damaged"), "{t}");
    assert!(run_dir_leftovers(&dir.run_dir()).is_empty());
}

#[test]
fn a_recorder_attached_to_a_running_group_records_until_the_group_ends() {
    let dir = TestDir::new("attach");
    let mission = short_mission(&dir, "short.toml");
    let run_dir = dir.run_dir();
    let mut group = spawn(
        &run_dir,
        &[
            "run",
            "--realtime",
            "--quiet",
            "--mission",
            mission.to_str().unwrap(),
        ],
    );
    let group_err = stderr_reader(&mut group);
    // The group's instance is the one directory that appears in the run directory.
    let deadline = std::time::Instant::now() + Duration::from_secs(30);
    let prefix = loop {
        let found = std::fs::read_dir(&run_dir)
            .unwrap()
            .filter_map(Result::ok)
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .next();
        if let Some(p) = found {
            break p;
        }
        assert!(std::time::Instant::now() < deadline, "no instance appeared");
        std::thread::sleep(Duration::from_millis(20));
    };
    let file = dir.path("attached.mcap");
    let root = run_dir.join(&prefix);
    let rec = run(
        &run_dir,
        &[
            "record",
            "--prefix",
            &prefix,
            "--root",
            root.to_str().unwrap(),
            "-o",
            file.to_str().unwrap(),
            "--idle-stop",
            "1",
        ],
    );
    let status = wait_exit(&mut group, Duration::from_secs(120)).expect("the run ends");
    let err = group_err.join().unwrap();
    assert!(status.success(), "{err}");
    let text = String::from_utf8_lossy(&rec.stdout);
    assert!(
        rec.status.success(),
        "{text}{}",
        String::from_utf8_lossy(&rec.stderr)
    );
    assert!(text.contains("wrote"), "{text}");
    // The group's end leaves the recorder's ports intact until it has closed them.
    let rec_err = String::from_utf8_lossy(&rec.stderr);
    assert!(!rec_err.contains("corrupted"), "{rec_err}");
    let ticks = rec_ticks(&file);
    assert!(ticks > 10, "{ticks} ticks recorded");
    let f = aisle_tools::reader::RecordFile::open(&file).unwrap();
    assert!(f.is_finalised());
    assert!(
        f.attachments()
            .unwrap()
            .iter()
            .any(|a| a.name == "teb.toml")
    );
}
