//! Helpers for the system tests: run the real `aisle` binary in a private run directory
//! (its iceoryx2 instance root lives there), find its children, and check that nothing
//! of an instance is left behind.

#![allow(dead_code)]

pub mod machine;
pub mod netns;
pub mod records;

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

pub fn aisle() -> &'static str {
    env!("CARGO_BIN_EXE_aisle")
}

pub fn config_dir() -> PathBuf {
    aisle_config::testing::shipped_dir().canonicalize().unwrap()
}

/// A fresh directory for one test (reports, missions) and a run directory for its
/// instances, both removed on drop. The run directory is short and under /tmp whatever
/// TMPDIR says: iceoryx2 limits the length of an instance's root path
/// (`aisle_bus::MAX_ROOT_AND_PREFIX`).
pub struct TestDir(pub PathBuf, PathBuf);

static RUN_DIRS: std::sync::atomic::AtomicU32 = std::sync::atomic::AtomicU32::new(0);

impl TestDir {
    pub fn new(name: &str) -> TestDir {
        let dir = std::env::temp_dir().join(format!("aisle-test-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let k = RUN_DIRS.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let run = PathBuf::from(format!("/tmp/aisle-t{}-{k}", std::process::id()));
        let _ = std::fs::remove_dir_all(&run);
        std::fs::create_dir_all(&run).unwrap();
        TestDir(dir, run)
    }
    pub fn path(&self, name: &str) -> PathBuf {
        self.0.join(name)
    }
    pub fn run_dir(&self) -> PathBuf {
        self.1.clone()
    }
}

impl Drop for TestDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
        let _ = std::fs::remove_dir_all(&self.1);
    }
}

/// `aisle <args>` with its instances under `run_dir`.
pub fn command(run_dir: &Path, args: &[&str]) -> Command {
    let mut c = Command::new(aisle());
    c.args(args)
        .env("AISLE_RUN_DIR", run_dir)
        .env("AISLE_LOG", "warn")
        .stdin(Stdio::null());
    c
}

pub fn run(run_dir: &Path, args: &[&str]) -> Output {
    command(run_dir, args).output().expect("aisle runs")
}

pub fn spawn(run_dir: &Path, args: &[&str]) -> Child {
    command(run_dir, args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("aisle starts")
}

/// Pids of the direct children of `pid` (Linux /proc).
pub fn children(pid: u32) -> Vec<u32> {
    let mut out = Vec::new();
    if let Ok(tasks) = std::fs::read_dir(format!("/proc/{pid}/task")) {
        for t in tasks.flatten() {
            if let Ok(s) = std::fs::read_to_string(t.path().join("children")) {
                out.extend(s.split_whitespace().filter_map(|p| p.parse::<u32>().ok()));
            }
        }
    }
    out
}

/// The command line of a process, arguments joined by spaces.
pub fn cmdline(pid: u32) -> String {
    std::fs::read(format!("/proc/{pid}/cmdline"))
        .map(|b| {
            b.split(|&c| c == 0)
                .map(|s| String::from_utf8_lossy(s).into_owned())
                .collect::<Vec<_>>()
                .join(" ")
        })
        .unwrap_or_default()
}

/// A process that exists and is not a zombie.
pub fn alive(pid: u32) -> bool {
    match std::fs::read_to_string(format!("/proc/{pid}/stat")) {
        Ok(s) => !s
            .rsplit(')')
            .next()
            .unwrap_or("")
            .trim_start()
            .starts_with('Z'),
        Err(_) => false,
    }
}

/// Waits until `aisle` (pid) has all five nodes running; returns node name -> pid.
pub fn wait_for_nodes(pid: u32, timeout: Duration) -> Vec<(String, u32)> {
    let start = Instant::now();
    loop {
        let nodes: Vec<(String, u32)> = children(pid)
            .into_iter()
            .filter_map(|c| {
                let cl = cmdline(c);
                let mut parts = cl.split(' ');
                while let Some(p) = parts.next() {
                    if p == "node" {
                        return parts.next().map(|n| (n.to_string(), c));
                    }
                }
                None
            })
            .collect();
        if nodes.len() == 5 || start.elapsed() > timeout {
            return nodes;
        }
        std::thread::sleep(Duration::from_millis(50));
    }
}

/// Shared-memory files of instances started by supervisor `pid` (their prefix starts
/// with `aisle<pid>x`).
pub fn shm_leftovers(pid: u32) -> Vec<String> {
    let prefix = format!("aisle{pid}x");
    std::fs::read_dir("/dev/shm")
        .map(|d| {
            d.flatten()
                .filter_map(|e| e.file_name().into_string().ok())
                .filter(|n| n.contains(&prefix))
                .collect()
        })
        .unwrap_or_default()
}

/// Entries left in a run directory (instance roots).
pub fn run_dir_leftovers(run_dir: &Path) -> Vec<PathBuf> {
    std::fs::read_dir(run_dir)
        .map(|d| d.flatten().map(|e| e.path()).collect())
        .unwrap_or_default()
}

pub fn wait_exit(child: &mut Child, timeout: Duration) -> Option<std::process::ExitStatus> {
    let start = Instant::now();
    loop {
        if let Ok(Some(s)) = child.try_wait() {
            return Some(s);
        }
        if start.elapsed() > timeout {
            return None;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// Writes a mission file: the seed's settings with other legs.
pub fn mission_file(dir: &TestDir, name: &str, legs: &str) -> PathBuf {
    let text = format!(
        "start = [0.0, 0.0, 0.0]\nleg_timeout_s = 60.0\nmax_replans_per_leg = 12\nreplan_cooldown_steps = 2\n{legs}"
    );
    let p = dir.path(name);
    std::fs::write(&p, text).unwrap();
    p
}

/// `aisle run --quiet --report <tmp> <args>` in a fresh test directory: its output and
/// its report. Checks that the run left no instance behind.
pub fn run_report(name: &str, args: &[&str]) -> (Output, aisle_supervisor::report::RunReport) {
    let dir = TestDir::new(name);
    let report = dir.path("report.json");
    let mut all = vec!["run", "--quiet", "--report", report.to_str().unwrap()];
    all.extend_from_slice(args);
    let out = run(&dir.run_dir(), &all);
    let text = std::fs::read_to_string(&report).unwrap_or_else(|e| {
        panic!(
            "no report ({e}); stderr: {}",
            String::from_utf8_lossy(&out.stderr)
        )
    });
    assert!(run_dir_leftovers(&dir.run_dir()).is_empty());
    (out, serde_json::from_str(&text).unwrap())
}

/// Drains a child's stderr on a thread from now on (a full pipe would stall the child)
/// and hands the text over when joined.
pub fn stderr_reader(child: &mut Child) -> std::thread::JoinHandle<String> {
    let mut pipe = child.stderr.take().expect("stderr is piped");
    std::thread::spawn(move || {
        use std::io::Read;
        let mut text = String::new();
        let _ = pipe.read_to_string(&mut text);
        text
    })
}

/// After a run of supervisor `pid`: none of its nodes lives on, and nothing of its
/// instances is left in /dev/shm or in the run directory.
pub fn assert_group_gone(pid: u32, nodes: &[(String, u32)], run_dir: &Path) {
    for (name, p) in nodes {
        assert!(!alive(*p), "{name} ({p}) is still alive");
    }
    assert!(shm_leftovers(pid).is_empty(), "{:?}", shm_leftovers(pid));
    assert!(
        run_dir_leftovers(run_dir).is_empty(),
        "{:?}",
        run_dir_leftovers(run_dir)
    );
}

/// FNV-1a 64 over the little-endian bytes of every value of `path`, in order.
pub fn path_digest(path: &[[f64; 4]]) -> String {
    let mut h = 0xcbf2_9ce4_8422_2325_u64;
    for b in path.iter().flatten().flat_map(|v| v.to_le_bytes()) {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    format!("{h:016x}")
}

/// The seed mission's driven path as pinned in `tests/data/seed_baseline.toml`: its
/// digest ([`path_digest`]) and its number of poses.
pub fn seed_baseline() -> (String, usize) {
    let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/seed_baseline.toml");
    let v: toml::Value = toml::from_str(&std::fs::read_to_string(file).unwrap()).unwrap();
    (
        v["driven_path_fnv1a"].as_str().unwrap().to_string(),
        v["driven_path_poses"].as_integer().unwrap() as usize,
    )
}

/// The shipped configuration copied to `dir/config`, with `extra` appended to its
/// `graph.toml` (external nodes, user topics).
pub fn config_with_graph(dir: &TestDir, extra: &str) -> PathBuf {
    let config = dir.path("config");
    std::fs::create_dir_all(&config).unwrap();
    for entry in std::fs::read_dir(config_dir()).unwrap() {
        let path = entry.unwrap().path();
        // Files only: `large/` is a config directory of its own.
        if path.is_file() {
            std::fs::copy(&path, config.join(path.file_name().unwrap())).unwrap();
        }
    }
    let mut graph = std::fs::read_to_string(config.join("graph.toml")).unwrap();
    graph.push_str(extra);
    std::fs::write(config.join("graph.toml"), graph).unwrap();
    config
}

/// `aisle run --quiet` with `config`, recorded to `dir/<tag>.mcap` and reported: the
/// report, the record and stderr. Asserts exit 0 and nothing left in the run directory.
pub fn run_recorded(
    dir: &TestDir,
    config: &Path,
    tag: &str,
    extra: &[&str],
) -> (aisle_supervisor::report::RunReport, PathBuf, String) {
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
    assert!(run_dir_leftovers(&dir.run_dir()).is_empty());
    (serde_json::from_str(&text).unwrap(), record, err)
}

/// Sends `signal` to `child` and reaps it, SIGKILLing it after `grace`.
pub fn signal_and_reap(child: &mut Child, signal: i32, grace: Duration) {
    // SAFETY: kill(2) on our own child's pid; no memory is involved.
    unsafe { libc::kill(child.id() as i32, signal) };
    if wait_exit(child, grace).is_none() {
        let _ = child.kill();
        let _ = child.wait();
    }
}
