//! The Python SDK (`python/`) against the real binary: `aisle gen python --check` on the
//! checked-in module and on a stale copy, and the README's script, installed with
//! `pip install ./python` in a fresh venv, printing poses of a running realtime group;
//! the example Python node declared in the graph, in lockstep: waited for, recorded,
//! repeatable and restarted.
//!
//! Needs `python3 -m venv` and a reachable package index: without them the venv test
//! skips, saying why, unless `AISLE_REQUIRE_PYTHON_SDK=1` (as `.ci/run` sets it).

mod support;

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};
use support::*;

fn checkout() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../..")
        .canonicalize()
        .unwrap()
}

#[test]
fn gen_python_check_passes_on_the_checked_in_module_and_names_a_stale_line() {
    let dir = TestDir::new("pygen");
    let module = checkout().join("python/aisle/_generated.py");
    let ok = run(
        &dir.run_dir(),
        &[
            "gen",
            "python",
            "--check",
            "--out",
            module.to_str().unwrap(),
        ],
    );
    assert!(
        ok.status.success(),
        "{}",
        String::from_utf8_lossy(&ok.stderr)
    );
    let stale = dir.path("stale.py");
    let text = std::fs::read_to_string(&module).unwrap();
    std::fs::write(
        &stale,
        text.replacen("\"aisle.RobotState.v1\"", "\"aisle.RobotState.v0\"", 1),
    )
    .unwrap();
    let out = run(
        &dir.run_dir(),
        &["gen", "python", "--check", "--out", stale.to_str().unwrap()],
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(
        err.contains("is stale (line ") && err.contains("aisle.RobotState.v0"),
        "{err}"
    );
}

/// Skips (returns None) or fails, as `AISLE_REQUIRE_PYTHON_SDK` says.
fn unavailable(what: &str) -> Option<PathBuf> {
    if std::env::var("AISLE_REQUIRE_PYTHON_SDK").as_deref() == Ok("1") {
        panic!("{what} (AISLE_REQUIRE_PYTHON_SDK=1)");
    }
    eprintln!("skipped: {what}");
    None
}

/// A copy of `python/` in `dir` without build output: pip builds in the source tree
/// (`build/`, `*.egg-info`), so two tests installing the checkout at once race there.
fn sdk_copy(dir: &Path) -> PathBuf {
    fn copy(from: &Path, to: &Path) {
        std::fs::create_dir_all(to).unwrap();
        for entry in std::fs::read_dir(from).unwrap().flatten() {
            let name = entry.file_name();
            let name_text = name.to_string_lossy();
            if name_text == "build"
                || name_text == "__pycache__"
                || name_text.ends_with(".egg-info")
            {
                continue;
            }
            let path = entry.path();
            if path.is_dir() {
                copy(&path, &to.join(&name));
            } else {
                std::fs::copy(&path, to.join(&name)).unwrap();
            }
        }
    }
    let to = dir.join("sdk");
    copy(&checkout().join("python"), &to);
    to
}

/// A fresh venv with `pip install ./python numpy` (from a private copy) in `dir`; its
/// python.
fn venv(dir: &Path) -> Option<PathBuf> {
    let env = dir.join("venv");
    let made = Command::new("python3")
        .args(["-m", "venv"])
        .arg(&env)
        .stdin(Stdio::null())
        .output();
    match made {
        Ok(o) if o.status.success() => {}
        _ => return unavailable("`python3 -m venv` failed: install python3-venv"),
    }
    let python = env.join("bin/python");
    let pip = Command::new(&python)
        .args([
            "-m",
            "pip",
            "install",
            "--quiet",
            "--disable-pip-version-check",
        ])
        .arg(sdk_copy(dir))
        .arg("numpy")
        .stdin(Stdio::null())
        .output()
        .unwrap();
    if !pip.status.success() {
        let err = String::from_utf8_lossy(&pip.stderr);
        let tail: Vec<&str> = err.lines().rev().take(3).collect();
        return unavailable(&format!(
            "`pip install ./python numpy` failed (no package index?): {}",
            tail.join(" | ")
        ));
    }
    Some(python)
}

/// The script between the README's "```python" and "```" after "pip install ./python".
fn readme_script() -> String {
    let readme = std::fs::read_to_string(checkout().join("README.md")).unwrap();
    let at = readme
        .find("pip install ./python")
        .expect("README: the SDK section");
    let start = readme[at..]
        .find("```python\n")
        .expect("README: the script")
        + at
        + 10;
    let end = readme[start..].find("```").unwrap() + start;
    readme[start..end].to_string()
}

#[test]
fn the_readme_script_prints_moving_poses_of_a_running_group() {
    let dir = TestDir::new("pysdk");
    let Some(python) = venv(&dir.0) else { return };
    // The SDK's own unit tests (layouts, discovery, NumPy views), in the venv.
    let unit = Command::new(&python)
        .args(["-m", "unittest", "-q"])
        .current_dir(checkout().join("python"))
        .stdin(Stdio::null())
        .output()
        .unwrap();
    assert!(
        unit.status.success(),
        "{}",
        String::from_utf8_lossy(&unit.stderr)
    );
    let script = dir.path("poses.py");
    std::fs::write(&script, readme_script()).unwrap();
    let mut group = spawn(&dir.run_dir(), &["run", "--realtime", "--quiet"]);
    // The instance appears in the run directory once the supervisor claimed it.
    let start = Instant::now();
    let root = loop {
        let found = std::fs::read_dir(dir.run_dir())
            .unwrap()
            .flatten()
            .map(|e| e.path())
            .find(|p| p.join("aisle-owner").exists());
        if let Some(r) = found {
            break r;
        }
        assert!(start.elapsed() < Duration::from_secs(20), "no instance");
        std::thread::sleep(Duration::from_millis(50));
    };
    let mut cmd = Command::new(&python);
    cmd.arg(&script).env("AISLE_RUN_DIR", dir.run_dir());
    if !root.join("aisle-instance.toml").exists() {
        // A build without discovery files: name the instance.
        let prefix = root.file_name().unwrap().to_string_lossy().into_owned();
        cmd.env("AISLE_PREFIX", prefix).env("AISLE_ROOT", &root);
    }
    let out = cmd.stdin(Stdio::null()).output().unwrap();
    // SIGTERM: the supervisor stops its nodes and removes the instance.
    signal_and_reap(&mut group, libc::SIGTERM, Duration::from_secs(15));
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{stdout}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let poses: Vec<&str> = stdout
        .lines()
        .filter_map(|l| l.split_once(": ").map(|(_, p)| p))
        .collect();
    assert!(poses.len() >= 10, "{stdout}");
    let mut distinct = poses.clone();
    distinct.dedup();
    assert!(distinct.len() > 1, "the robot did not move:\n{stdout}");
}

/// The shipped configuration with the example Python node (`pose_republisher`, run by
/// the venv's `python`) and its user topic added to the graph.
fn config_with_republisher(dir: &TestDir, python: &Path) -> PathBuf {
    config_with_graph(
        dir,
        &format!(
            r#"
[[topic]]
name = "user/robot_pose"
type = "{}"

[[node]]
name = "pose_republisher"
command = ["{}", "{}"]
publishes = ["user/robot_pose"]
subscribes = ["aisle/tick", "aisle/robot_state"]
acknowledges = "every_tick"
"#,
            aisle_messages::RobotState::TYPE_NAME,
            python.display(),
            checkout()
                .join("python/examples/pose_republisher.py")
                .display()
        ),
    )
}

#[test]
fn a_python_node_in_the_graph_is_waited_for_recorded_and_restarted() {
    let dir = TestDir::new("pynode");
    let Some(python) = venv(&dir.0) else { return };
    let config = config_with_republisher(&dir, &python);
    let run_once = |tag: &str, extra: &[&str]| {
        let (r, record, err) = run_recorded(&dir, &config, tag, extra);
        assert!(r.success, "{:?}\n{err}", r.failure);
        assert_eq!(r.collisions, 0);
        (r, record, err)
    };
    let (a, rec_a, _) = run_once("a", &[]);
    let (b, rec_b, _) = run_once("b", &[]);
    assert_eq!(a.driven_path, b.driven_path);
    let code = aisle_messages::external_code("pose_republisher");
    let (_, acks) = records::same_records(&rec_a, &rec_b, code, a.ticks.saturating_sub(1));
    assert!(
        acks + 2 >= a.ticks as usize,
        "{acks} acknowledgements of {} ticks",
        a.ticks
    );
    // Its output is in the record: one republished pose per tick, equal to the state.
    let file = aisle_tools::reader::RecordFile::open(&rec_a).unwrap();
    let poses = file
        .raw_messages()
        .filter(|m| {
            m.as_ref()
                .is_ok_and(|m| m.channel.topic == "user/robot_pose")
        })
        .count();
    assert!(
        poses + 2 >= a.ticks as usize,
        "{poses} poses of {} ticks",
        a.ticks
    );
    let (k, _, err) = run_once("k", &["--kill", "pose_republisher@30"]);
    assert_eq!(k.restarts, 1, "{err}");
    readme_script_against_a_replay(&dir, &python, &rec_a);
}

/// The README's script, unchanged, against `aisle replay` of a record (no supervisor):
/// it finds the replay's instance and prints the recorded poses.
fn readme_script_against_a_replay(dir: &TestDir, python: &Path, record: &Path) {
    let script = dir.path("poses.py");
    std::fs::write(&script, readme_script()).unwrap();
    let mut replay = spawn(
        &dir.run_dir(),
        &["replay", record.to_str().unwrap(), "--rate", "4", "--loop"],
    );
    let errors = stderr_reader(&mut replay);
    let start = Instant::now();
    while !std::fs::read_dir(dir.run_dir())
        .unwrap()
        .flatten()
        .any(|e| e.path().join("aisle-instance.toml").exists())
    {
        if start.elapsed() > Duration::from_secs(20) || replay.try_wait().unwrap().is_some() {
            let _ = replay.kill();
            let _ = replay.wait();
            panic!("no replay instance: {}", errors.join().unwrap());
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    let out = Command::new(python)
        .arg(&script)
        .env("AISLE_RUN_DIR", dir.run_dir())
        .stdin(Stdio::null())
        .output()
        .unwrap();
    signal_and_reap(&mut replay, libc::SIGINT, Duration::from_secs(15));
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{stdout}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert_eq!(
        stdout.lines().filter(|l| l.starts_with("tick ")).count(),
        20,
        "{stdout}"
    );
    assert!(run_dir_leftovers(&dir.run_dir()).is_empty());
}
