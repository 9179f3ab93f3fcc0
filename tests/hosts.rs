//! The process group spread over two hosts (issue 19). The hosts are Linux network
//! namespaces on one bridge, each process with a mount namespace of its own in which
//! /dev/shm and the run directory are private, so shared memory cannot carry what the
//! Zenoh link must (`support/netns.rs`). The test creates them and removes them
//! afterwards, also when it fails.
//!
//! Needs root and `ip netns`: without them each test says so on stderr and passes
//! without running (CI runs as root).

mod support;

use std::path::PathBuf;
use std::process::Child;
use std::time::Duration;
use support::netns::Hosts;
use support::*;

/// The acceptance placement: simulator and supervisor on `a`, the pipeline on `b`.
fn hosts_file(dir: &TestDir) -> PathBuf {
    let (a, b) = (Hosts::addr(0), Hosts::addr(1));
    let text = format!(
        "[[host]]\nname = \"a\"\nlisten = [\"tcp/{a}:7447\"]\nnodes = [\"supervisor\", \"simulator\"]\n\n\
         [[host]]\nname = \"b\"\nlisten = [\"tcp/{b}:7447\"]\nconnect = [\"tcp/{a}:7447\"]\n\
         nodes = [\"lidar\", \"mapper\", \"global_planner\", \"teb_controller\"]\n"
    );
    let p = dir.path("hosts.toml");
    std::fs::write(&p, text).unwrap();
    p
}

/// A host daemon that is stopped (SIGTERM, then SIGKILL) when dropped.
struct Daemon(Child);

impl Drop for Daemon {
    fn drop(&mut self) {
        signal_and_reap(&mut self.0, libc::SIGTERM, Duration::from_secs(10));
    }
}

/// What one spread run gave: the supervisor's output, host `b`'s stderr, the report
/// (when the run wrote one).
struct Spread {
    out: std::process::Output,
    b_err: String,
    report: Option<aisle_supervisor::report::RunReport>,
}

/// The seed mission with the acceptance placement; `b_args` go to `aisle host` on `b`.
fn spread_run(name: &str, b_args: &[&str]) -> Spread {
    let hosts = Hosts::new(2);
    let dir = TestDir::new(name);
    // A second short run directory: iceoryx2 limits the length of an instance root.
    let run_b = TestDir::new(&format!("{name}-b"));
    let file = hosts_file(&dir);
    let config = config_dir();
    let (file_s, config_s) = (file.to_str().unwrap(), config.to_str().unwrap());
    let mut args = vec![
        "host",
        "--name",
        "b",
        "--hosts",
        file_s,
        "--config-dir",
        config_s,
    ];
    args.extend_from_slice(b_args);
    let mut b = Daemon(hosts.aisle(1, &run_b.run_dir(), &args));
    let b_err = stderr_reader(&mut b.0);
    let report = dir.path("report.json");
    let run = hosts.aisle(
        0,
        &dir.run_dir(),
        &[
            "run",
            "--quiet",
            "--hosts",
            file_s,
            "--config-dir",
            config_s,
            "--report",
            report.to_str().unwrap(),
        ],
    );
    let out = run.wait_with_output().unwrap();
    drop(b);
    let b_err = b_err.join().unwrap();
    let report = std::fs::read_to_string(&report)
        .ok()
        .map(|t| serde_json::from_str(&t).unwrap());
    Spread { out, b_err, report }
}

/// The spread seed mission: its report, or a panic with both sides' stderr.
fn spread_seed(name: &str) -> aisle_supervisor::report::RunReport {
    let s = spread_run(name, &[]);
    let r = s.report.unwrap_or_else(|| {
        panic!(
            "no report\nsupervisor: {}\nhost b: {}",
            String::from_utf8_lossy(&s.out.stderr),
            s.b_err
        )
    });
    assert!(r.success, "{:?}\nhost b: {}", r.failure, s.b_err);
    assert_eq!(r.restarts, 0, "host b: {}", s.b_err);
    r
}

/// The acceptance run: simulator and supervisor on `a`, the pipeline on `b`, lockstep;
/// the driven path is the single-host one to the bit.
#[test]
fn the_seed_mission_spread_over_two_hosts_drives_the_single_host_path() {
    needs_netns!();
    let r = spread_seed("hosts-seed");
    assert_eq!(r.collisions, 0);
    let (digest, poses) = seed_baseline();
    assert_eq!(r.driven_path.len(), poses);
    assert_eq!(path_digest(&r.driven_path), digest);
}

#[test]
fn a_host_of_another_schema_is_refused_with_both_hashes() {
    needs_netns!();
    let other = "0123456789abcdef";
    let s = spread_run("hosts-schema", &["--pretend-schema", other]);
    let err = String::from_utf8_lossy(&s.out.stderr);
    assert_eq!(s.out.status.code(), Some(2), "{err}");
    let ours = format!("{:016x}", aisle_messages::schema_hash());
    assert!(err.contains("host `b` refused"), "{err}");
    assert!(err.contains(other) && err.contains(&ours), "{err}");
}
