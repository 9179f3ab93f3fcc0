//! Bad input ends in a clear error naming the file, key or value, with the documented
//! exit code (0 success, 1 negative verdict, 2 could not do what was asked), and, where
//! the error is known before launch, without a node launched or an instance created.
//! Every command here must end within a generous hang guard; no compute time is
//! asserted.

mod support;

use std::path::{Path, PathBuf};
use std::process::{Output, Stdio};
use std::time::Duration;
use support::{TestDir, command, config_dir, run_dir_leftovers, shm_leftovers, wait_exit};

/// A command that must end on its own: it is killed after this and the test fails.
const HANG_GUARD: Duration = Duration::from_secs(10);

/// `aisle <args>` in `dir`'s run directory, ended within the hang guard; asserts that it
/// created no instance (nothing in the run directory, nothing in /dev/shm) and launched
/// no node (the nodes would have left an instance; a node that outlived the supervisor
/// would show up as a child of init with the instance's prefix in its command line).
fn run_refused(dir: &TestDir, args: &[&str]) -> (Option<i32>, String) {
    let mut child = command(&dir.run_dir(), args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("aisle starts");
    let pid = child.id();
    let out = support::stderr_reader(&mut child);
    let status = wait_exit(&mut child, HANG_GUARD);
    if status.is_none() {
        let _ = child.kill();
        let _ = child.wait();
        panic!(
            "`aisle {}` did not end within {HANG_GUARD:?}",
            args.join(" ")
        );
    }
    let text = out.join().unwrap();
    assert!(
        run_dir_leftovers(&dir.run_dir()).is_empty(),
        "an instance was created: {:?}",
        run_dir_leftovers(&dir.run_dir())
    );
    assert!(shm_leftovers(pid).is_empty(), "{:?}", shm_leftovers(pid));
    assert!(!text.contains("nodes ready"), "{text}");
    (status.unwrap().code(), text)
}

/// A copy of the shipped config directory with `file`'s `from` replaced by `to`.
fn config_with(dir: &TestDir, name: &str, file: &str, from: &str, to: &str) -> PathBuf {
    let out = dir.path(name);
    std::fs::create_dir_all(&out).unwrap();
    for e in std::fs::read_dir(config_dir()).unwrap().flatten() {
        if e.path().is_file() {
            std::fs::copy(e.path(), out.join(e.file_name())).unwrap();
        }
    }
    let text = std::fs::read_to_string(out.join(file)).unwrap();
    let changed = text.replace(from, to);
    assert_ne!(text, changed, "`{from}` is not in {file}");
    std::fs::write(out.join(file), changed).unwrap();
    out
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// `check` says 1 (invalid) and `run` says 2 (could not run) with the same message.
fn refused_by_check_and_run(dir: &TestDir, cfg: &Path, wanted: &[&str]) {
    let (code, err) = run_refused(dir, &["check", "--config-dir", s(cfg)]);
    assert_eq!(code, Some(1), "{err}");
    for w in wanted {
        assert!(err.contains(w), "check: `{w}` not in: {err}");
    }
    let (code, err) = run_refused(dir, &["run", "--quiet", "--config-dir", s(cfg)]);
    assert_eq!(code, Some(2), "{err}");
    for w in wanted {
        assert!(err.contains(w), "run: `{w}` not in: {err}");
    }
}

#[test]
fn a_lidar_that_cannot_see_as_far_as_the_robot_needs_to_stop_is_refused() {
    let dir = TestDir::new("blind-range");
    let cfg = config_with(
        &dir,
        "cfg",
        "lidar.toml",
        "max_range = 12.0",
        "max_range = 1e-300",
    );
    refused_by_check_and_run(
        &dir,
        &cfg,
        &["lidar.toml:5: key `max_range`", "1e-300 m", "v·T + v²/(2a)"],
    );
}

#[test]
fn a_lidar_with_one_column_pointing_away_from_the_travel_is_refused() {
    let dir = TestDir::new("blind-sector");
    let cfg = config_with(
        &dir,
        "cfg",
        "lidar.toml",
        "azimuth_max_deg = 120.0",
        "azimuth_max_deg = -120.0",
    );
    refused_by_check_and_run(
        &dir,
        &cfg,
        &[
            "lidar.toml:9: key `azimuth_max_deg`",
            "1 column(s)",
            "is not scanned",
        ],
    );
}

#[test]
fn a_lidar_with_rays_too_sparse_for_the_smallest_part_is_refused() {
    let dir = TestDir::new("blind-sparse");
    let cfg = config_with(
        &dir,
        "cfg",
        "lidar.toml",
        "azimuth_step_deg = 0.2",
        "azimuth_step_deg = 2.0",
    );
    refused_by_check_and_run(&dir, &cfg, &["key `azimuth_step_deg`", "0.05 m wide"]);
}

#[test]
fn a_start_pose_inside_a_body_is_refused_before_launch() {
    let dir = TestDir::new("start-in-body");
    let from = "start = [0.0, 0.0, 0.0]";
    let to = "start = [5.0, 13.25, 0.0]";
    let cfg = config_with(&dir, "cfg", "mission.toml", from, to);
    refused_by_check_and_run(
        &dir,
        &cfg,
        &["mission.toml:", "key `start`", "overlaps body `rack_row_2`"],
    );
    // The same through --mission with the shipped config directory.
    let mission = cfg.join("mission.toml");
    let (code, err) = run_refused(&dir, &["run", "--quiet", "--mission", s(&mission)]);
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("overlaps body `rack_row_2`"), "{err}");
}

#[test]
fn a_goal_outside_the_map_is_refused_as_outside_the_map() {
    let dir = TestDir::new("goal-outside");
    let mission = support::mission_file(
        &dir,
        "far.toml",
        "[[leg]]\nname = \"far away\"\ngoal = [500.0, 0.0, 0.0]\n",
    );
    let (code, err) = run_refused(&dir, &["run", "--quiet", "--mission", s(&mission)]);
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("far.toml:"), "{err}");
    assert!(err.contains("key `leg[0].goal`"), "{err}");
    assert!(err.contains("outside the map"), "{err}");
    assert!(!err.contains("collision"), "{err}");
}

#[test]
fn a_goal_inside_a_static_body_is_refused_before_launch() {
    let dir = TestDir::new("goal-in-body");
    let mission = support::mission_file(
        &dir,
        "walled.toml",
        "[[leg]]\nname = \"into the rack\"\ngoal = [5.0, 13.25, 0.0]\n",
    );
    let (code, err) = run_refused(&dir, &["run", "--quiet", "--mission", s(&mission)]);
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("walled.toml:"), "{err}");
    assert!(err.contains("key `leg[0].goal`"), "{err}");
    assert!(err.contains("leg `into the rack`"), "{err}");
    assert!(err.contains("overlaps body `rack_row_2`"), "{err}");
}

#[test]
fn a_rack_set_down_onto_another_is_refused_before_launch_naming_both() {
    let dir = TestDir::new("drop-on-rack");
    let mission = support::mission_file(
        &dir,
        "drop.toml",
        "[[leg]]\nname = \"to pick\"\napproach = \"rack2b\"\n\n\
         [[leg]]\nname = \"onto rack2a\"\ngoal = [2.0, 16.5, 0.0]\ncarry = \"rack2b\"\n",
    );
    let (code, err) = run_refused(&dir, &["run", "--quiet", "--mission", s(&mission)]);
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("drop.toml:"), "{err}");
    assert!(err.contains("key `leg[1].goal`"), "{err}");
    assert!(
        err.contains("leg `onto rack2a` sets `rack2b` down"),
        "{err}"
    );
    assert!(err.contains("overlaps body `rack2a`"), "{err}");
}

#[test]
fn a_goal_the_static_map_cannot_reach_is_refused_by_check() {
    // Static walls closing a 2 m room around the seed's drop pose.
    let dir = TestDir::new("goal-walled-in");
    let room: String = [
        ("south", 6.0, -8.1, 2.4, 0.2),
        ("north", 6.0, -5.9, 2.4, 0.2),
    ]
    .iter()
    .chain(&[("west", 4.9, -7.0, 0.2, 2.4), ("east", 7.1, -7.0, 0.2, 2.4)])
    .map(|(n, x, y, sx, sy)| {
        format!(
            "[[body]]\nname = \"room_{n}\"\nkind = \"wall\"\nstatic = true\n\
                 pose = [{x}, {y}, 0.0]\nsize = [{sx}, {sy}, 1.0]\n\n"
        )
    })
    .collect();
    let anchor = "# ---- Movable: pallet racks";
    let cfg = config_with(&dir, "cfg", "warehouse.toml", anchor, &(room + anchor));
    let (code, err) = run_refused(&dir, &["check", "--config-dir", s(&cfg)]);
    assert_eq!(code, Some(1), "{err}");
    assert!(err.contains("mission.toml:"), "{err}");
    assert!(err.contains("key `leg[2].goal`"), "{err}");
    assert!(
        err.contains("leg `carry to drop` is unreachable on the static map"),
        "{err}"
    );
}

#[test]
fn output_paths_are_refused_before_launch_naming_path_and_os_error() {
    let dir = TestDir::new("outputs");
    let (code, err) = run_refused(&dir, &["run", "--report", "/nonexistent/dir/x.json"]);
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("--report /nonexistent/dir/x.json"), "{err}");
    assert!(err.contains("No such file or directory"), "{err}");
    let here = dir.path("");
    let (code, err) = run_refused(&dir, &["run", "--record", s(&here)]);
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("is a directory"), "{err}");
    // An output over another output or over an input: nothing is written.
    let both = dir.path("both.json");
    let (code, err) = run_refused(&dir, &["run", "--report", s(&both), "--record", s(&both)]);
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("each output needs a file of its own"), "{err}");
    assert!(!both.exists());
    let mission = dir.path("m.toml");
    std::fs::copy(config_dir().join("mission.toml"), &mission).unwrap();
    let before = std::fs::read(&mission).unwrap();
    let (code, err) = run_refused(
        &dir,
        &["run", "--mission", s(&mission), "--report", s(&mission)],
    );
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("which the command reads"), "{err}");
    assert_eq!(std::fs::read(&mission).unwrap(), before);
}

#[test]
fn a_mission_that_is_a_device_or_a_fifo_is_refused_at_once() {
    let dir = TestDir::new("mission-device");
    let (code, err) = run_refused(&dir, &["run", "--mission", "/dev/zero"]);
    assert_eq!(code, Some(2), "{err}");
    assert!(
        err.contains("/dev/zero") && err.contains("character device"),
        "{err}"
    );
    let fifo = dir.path("mission.fifo");
    let made = std::process::Command::new("mkfifo").arg(&fifo).status();
    assert!(made.is_ok_and(|s| s.success()), "mkfifo");
    // Nobody ever writes to it: reading it would block forever.
    let (code, err) = run_refused(&dir, &["run", "--mission", s(&fifo)]);
    assert_eq!(code, Some(2), "{err}");
    assert!(
        err.contains("mission.fifo") && err.contains("FIFO"),
        "{err}"
    );
    // Nor is a record read from one (profile, render, export and replay hung).
    let (png, bag) = (dir.path("x.png"), dir.path("x.mcap"));
    for args in [
        vec!["profile", s(&fifo)],
        vec!["render", s(&fifo), "-o", s(&png)],
        vec!["export", "--ros2", s(&fifo), s(&bag)],
        vec!["replay", s(&fifo), "--check"],
    ] {
        let (code, err) = run_refused(&dir, &args);
        assert_eq!(code, Some(2), "{args:?}: {err}");
        assert!(err.contains("not a regular file"), "{args:?}: {err}");
    }
}

#[test]
fn a_config_file_over_sixteen_mebibytes_is_refused_naming_it() {
    let dir = TestDir::new("big-config");
    let cfg = config_with(&dir, "cfg", "budgets.toml", "[", "\n[");
    let budgets = cfg.join("budgets.toml");
    let mut text = std::fs::read_to_string(&budgets).unwrap();
    text.push_str(&"# padding\n".repeat(1_700_000));
    std::fs::write(&budgets, text).unwrap();
    let (code, err) = run_refused(&dir, &["check", "--config-dir", s(&cfg)]);
    assert_eq!(code, Some(1), "{err}");
    assert!(
        err.contains("budgets.toml") && err.contains("larger than 16384 KiB"),
        "{err}"
    );
    let (code, err) = run_refused(&dir, &["run", "--config-dir", s(&cfg)]);
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("budgets.toml"), "{err}");
}

#[test]
fn usage_errors_and_missing_inputs_exit_2_and_help_documents_the_codes() {
    let dir = TestDir::new("usage");
    let (code, err) = run_refused(&dir, &["run", "--no-such-flag"]);
    assert_eq!(code, Some(2), "{err}");
    let (code, err) = run_refused(&dir, &["check", "--config-dir", "/nonexistent/config"]);
    assert_eq!(code, Some(2), "{err}");
    assert!(
        err.contains("/nonexistent/config: not a directory"),
        "{err}"
    );
    let (code, err) = run_refused(&dir, &["profile", "/nonexistent/run.mcap"]);
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("/nonexistent/run.mcap"), "{err}");
    let help = command(&dir.run_dir(), &["--help"]).output().unwrap();
    let text = String::from_utf8_lossy(&help.stdout);
    assert!(text.contains("Exit codes"), "{text}");
    for sub in [
        "run", "check", "replay", "record", "profile", "render", "map",
    ] {
        let help = command(&dir.run_dir(), &[sub, "--help"]).output().unwrap();
        let text = String::from_utf8_lossy(&help.stdout);
        assert!(text.contains("Exit: 0"), "{sub}: {text}");
    }
}

/// A synthetic record with some bytes in the middle of its chunk data overwritten.
fn damaged_record(dir: &TestDir) -> PathBuf {
    let good = dir.path("good.mcap");
    let file = std::fs::File::create(&good).unwrap();
    let options = aisle_tools::WriterOptions {
        chunk_size: 64 * 1024,
        ..aisle_tools::WriterOptions::default()
    };
    aisle_tools::synthetic::write_synthetic(file, 120, options).unwrap();
    let mut bytes = std::fs::read(&good).unwrap();
    let mid = bytes.len() / 3;
    for b in &mut bytes[mid..mid + 64] {
        *b ^= 0x5a;
    }
    let bad = dir.path("damaged.mcap");
    std::fs::write(&bad, bytes).unwrap();
    // The damage is where the reader sees it.
    let f = aisle_tools::RecordFile::open(&bad).unwrap();
    assert!(
        f.raw_messages().any(|m| m.is_err()),
        "the damage went unnoticed"
    );
    bad
}

#[test]
fn replay_check_of_a_damaged_record_is_exit_2_never_diverged() {
    let dir = TestDir::new("damaged");
    let bad = damaged_record(&dir);
    let (code, err) = run_refused(&dir, &["replay", s(&bad), "--check"]);
    assert_eq!(code, Some(2), "{err}");
    assert!(
        err.contains("damaged record:") && err.contains("damaged.mcap"),
        "{err}"
    );
    assert!(!err.contains("DIVERGED"), "{err}");
}

/// Runs the seed mission without the lidar; returns the output and the report.
fn no_lidar(name: &str, extra: &[&str]) -> (Output, aisle_supervisor::report::RunReport) {
    let mut args = vec!["--no-lidar"];
    args.extend_from_slice(extra);
    support::run_report(name, &args)
}

#[test]
fn without_the_lidar_the_first_collision_fails_the_mission_naming_the_body() {
    let (out, r) = no_lidar("no-lidar-fails", &[]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_eq!(out.status.code(), Some(1), "{stdout}");
    let first = r.collision_events.first().expect("a collision is reported");
    let line = format!("mission FAILED: collision with `{}` at t = ", first.body);
    assert!(stdout.contains(&line), "{stdout}");
    assert!(!r.success);
    assert_eq!(r.collisions, 1, "the robot stops at the first collision");
    assert_eq!(r.collision_events.len(), 1);
    assert!(
        first.body != aisle_supervisor::collisions::UNSEEN_BODY,
        "{first:?}"
    );
    // Halted: after the collision the robot drives at most the tick the stop needs.
    let at = r
        .driven_path
        .iter()
        .position(|p| p[0] >= first.t_s - 1e-9)
        .unwrap();
    let tail = &r.driven_path[at..];
    let moved: f64 = tail
        .windows(2)
        .map(|w| (w[1][1] - w[0][1]).hypot(w[1][2] - w[0][2]))
        .sum();
    assert!(
        moved < 0.25,
        "the robot drove {moved} m after the collision"
    );
}

#[test]
fn without_the_lidar_and_with_collisions_allowed_the_mission_goes_on() {
    let (out, r) = no_lidar("no-lidar-allowed", &["--allow-collisions"]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_eq!(
        out.status.code(),
        Some(0),
        "{stdout}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(r.success, "{:?}", r.failure);
    assert!(r.collisions > 0, "no collision without the lidar");
    assert_eq!(r.collision_events.len() as u32, r.collisions);
    for e in &r.collision_events {
        assert!(stdout.contains(&e.to_string()), "{e} not in {stdout}");
    }
}

#[test]
fn a_scene_with_more_movable_bodies_than_ground_truth_holds_is_refused_naming_it() {
    // Static bodies may be any number; the ones that can move are listed every tick.
    let dir = TestDir::new("too-many-movable");
    let boxes: String = (0..=aisle_simulator::MAX_MOVABLE_BODIES)
        .map(|i| {
            format!(
                "[[body]]\nname = \"crate_{i}\"\nkind = \"box\"\nstatic = false\n\
                 pose = [{}, 9.5, 0.0]\nsize = [0.05, 0.05, 0.5]\n\n",
                -4.0 + 0.06 * i as f64
            )
        })
        .collect();
    let anchor = "# ---- Movable: pallet racks";
    let cfg = config_with(&dir, "cfg", "warehouse.toml", anchor, &(boxes + anchor));
    refused_by_check_and_run(
        &dir,
        &cfg,
        &[
            "warehouse.toml",
            "movable bodies (`static = false`), more than the 224",
            "static bodies: any number",
        ],
    );
}

#[test]
fn render_to_an_extension_it_cannot_write_is_refused_before_reading_the_record() {
    let dir = TestDir::new("render-ext");
    let jpg = dir.path("x.jpg");
    // The record does not exist: the extension is refused first, naming it and what
    // is supported, and nothing is written.
    let (code, err) = run_refused(&dir, &["render", "/nonexistent/run.mcap", "-o", s(&jpg)]);
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("x.jpg") && err.contains(".jpg file"), "{err}");
    assert!(err.contains(".png") && err.contains(".html"), "{err}");
    assert!(!err.contains("/nonexistent/run.mcap"), "{err}");
    assert!(!jpg.exists(), "nothing written");
}

#[test]
fn a_timed_replay_that_publishes_nothing_says_so_and_exits_2() {
    let dir = TestDir::new("replay-nothing");
    let rec = synthetic_record(&dir);
    // Every message is before --start: nothing is replayed.
    let (code, err) = run_refused(
        &dir,
        &[
            "replay",
            s(&rec),
            "--fast",
            "--topics",
            "aisle/robot_state",
            "--start",
            "9999",
        ],
    );
    assert_eq!(code, Some(2), "{err}");
    assert!(
        err.contains("published nothing") && err.contains("run.mcap"),
        "{err}"
    );
    assert!(err.contains("--topics aisle/robot_state"), "{err}");
}

#[test]
fn a_timed_replay_of_a_damaged_record_publishes_what_it_can_and_exits_2() {
    let dir = TestDir::new("replay-damaged");
    let rec = dir.path("run.mcap");
    let out = support::run(&dir.run_dir(), &["run", "--quiet", "--record", s(&rec)]);
    assert!(out.status.success());
    // Cut in the middle of its messages.
    let bytes = std::fs::read(&rec).unwrap();
    std::fs::write(&rec, &bytes[..bytes.len() / 2]).unwrap();
    let (code, err) = run_refused(&dir, &["replay", s(&rec), "--fast"]);
    assert_eq!(code, Some(2), "{err}");
    assert!(
        err.contains("run.mcap is damaged") && err.contains("the file is cut short"),
        "{err}"
    );
}

#[test]
fn render_profile_and_export_refuse_an_output_another_command_writes_now() {
    let dir = TestDir::new("locked-outputs");
    let rec = synthetic_record(&dir);
    let (png, json, svg, bag) = (
        dir.path("x.png"),
        dir.path("x.json"),
        dir.path("x.svg"),
        dir.path("x.mcap"),
    );
    for (args, out) in [
        (vec!["render", s(&rec), "-o", s(&png)], &png),
        (vec!["profile", s(&rec), "--json", s(&json)], &json),
        (vec!["profile", s(&rec), "--samples", s(&json)], &json),
        (vec!["profile", s(&rec), "--svg", s(&svg)], &svg),
        (vec!["export", "--ros2", s(&rec), s(&bag)], &bag),
    ] {
        std::fs::write(out, b"the other command's").unwrap();
        // Another command writing the file now: this process holds its lock.
        let held = aisle_tools::output_lock::OutputLock::acquire("-o", out).unwrap();
        let (code, err) = run_refused(&dir, &args);
        assert_eq!(code, Some(2), "{args:?}: {err}");
        assert!(
            err.contains("another command") && err.contains(s(out)),
            "{args:?}: {err}"
        );
        assert!(
            err.contains(&format!("pid {}", std::process::id())),
            "{args:?}: {err}"
        );
        assert_eq!(
            std::fs::read(out).unwrap(),
            b"the other command's",
            "{args:?}"
        );
        drop(held);
    }
}

/// A small whole record (20 synthetic ticks) in `dir`, for the tools' refusals.
fn synthetic_record(dir: &TestDir) -> std::path::PathBuf {
    let rec = dir.path("run.mcap");
    let file = std::fs::File::create(&rec).unwrap();
    aisle_tools::synthetic::write_synthetic(file, 20, aisle_tools::WriterOptions::default())
        .unwrap();
    rec
}
