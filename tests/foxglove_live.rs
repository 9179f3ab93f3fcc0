//! The live view: `aisle run --realtime --foxglove 127.0.0.1:<port>` serves the Foxglove
//! WebSocket protocol while the mission runs, and an independent client
//! (`foxglove_live.py`: the `websockets` package and `google.protobuf`) subscribes to the
//! scene, the point cloud, the transforms, the robot model (protobuf) and the odometry
//! plot (JSON) and decodes them with the advertised schemas: messages arrive, clouds have
//! points, the robot's pose lies in the warehouse, the robot model is a frame-locked
//! `base_link` entity, every odometry field is in its JSON Schema. The run
//! still succeeds and says at its end what the live view served and dropped.
//!
//! Skipped with a note when python3 lacks `websockets` or `protobuf`, unless
//! AISLE_REQUIRE_PYTHON_SDK is set (CI installs both: `.ci/run`).

mod support;

use std::process::Command;
use std::time::Duration;
use support::*;

fn python_has_client() -> bool {
    Command::new("python3")
        .args(["-c", "import websockets, google.protobuf"])
        .output()
        .is_ok_and(|o| o.status.success())
}

/// A port nobody listens on now (the OS picks it; released before the run binds it).
fn free_port() -> u16 {
    let l = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    l.local_addr().unwrap().port()
}

#[test]
fn a_foxglove_client_watches_a_realtime_run_live() {
    if !python_has_client() {
        assert!(
            std::env::var_os("AISLE_REQUIRE_PYTHON_SDK").is_none(),
            "AISLE_REQUIRE_PYTHON_SDK is set but python3 lacks websockets or protobuf"
        );
        eprintln!(
            "note: SKIPPED: python3 with `websockets` and `protobuf` is not available \
             (pip install websockets protobuf)"
        );
        return;
    }
    let dir = TestDir::new("foxglove-live");
    // A short mission: turning in place keeps the lidar and the robot state flowing.
    let mission = mission_file(
        &dir,
        "turn.toml",
        "[[leg]]\nname = \"turn\"\ngoal = [0.0, 0.0, 3.14159]\nrotate = true\n",
    );
    let addr = format!("127.0.0.1:{}", free_port());
    let mut child = spawn(
        &dir.run_dir(),
        &[
            "run",
            "--realtime",
            "--quiet",
            "--mission",
            mission.to_str().unwrap(),
            "--foxglove",
            &addr,
        ],
    );
    let stderr = stderr_reader(&mut child);
    let script =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/foxglove_live.py");
    // The warehouse: x in [-5, 15] m, y in [-10, 20] m (config/warehouse.toml).
    let client = Command::new("python3")
        .arg(&script)
        .args([&format!("ws://{addr}"), "60", "-5", "15", "-10", "20"])
        .output()
        .unwrap();
    let status = wait_exit(&mut child, Duration::from_secs(120));
    if status.is_none() {
        let _ = child.kill();
        let _ = child.wait();
    }
    let err = stderr.join().unwrap();
    let out = String::from_utf8_lossy(&client.stdout);
    assert!(
        client.status.success(),
        "client: {out}\n{}\naisle: {err}",
        String::from_utf8_lossy(&client.stderr)
    );
    assert!(out.contains("\"problems\": []"), "{out}");
    assert!(
        status.is_some_and(|s| s.success()),
        "aisle: {status:?}\n{err}"
    );
    let line = err
        .lines()
        .find(|l| l.contains("foxglove live view"))
        .unwrap_or_else(|| panic!("no live view summary: {err}"));
    let served: u64 = line
        .split(": ")
        .nth(1)
        .and_then(|t| t.split_whitespace().next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("unreadable summary: {line}"));
    assert!(served > 0, "{line}");
    assert!(run_dir_leftovers(&dir.run_dir()).is_empty());
}
