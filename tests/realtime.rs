//! Real-time options the OS refuses: with `config/realtime.toml` asking every node for
//! SCHED_FIFO priority 80 and locked memory, on a machine that allows neither, the seed
//! mission still completes on the baseline path, and every process (the five nodes and
//! the supervisor) says exactly once what it could not apply and why, and nothing about
//! what it could (a stack pre-fault needs no privilege).
//!
//! The refusal is made here whoever runs the test: `prlimit` sets RLIMIT_RTPRIO to 0 and
//! RLIMIT_MEMLOCK to 64 KiB, and when this process holds CAP_SYS_NICE or CAP_IPC_LOCK
//! (root ignores both limits with them), `setpriv` drops both from the bounding and
//! inheritable sets first. Both tools are util-linux (Debian: essential).
//!
//! Under a finite RLIMIT_MEMLOCK a process locks what fits of what it maps, its own
//! memory first (`aisle_node::realtime`, `lock.rs`): at 8 MiB, the default of many
//! distributions, every process locks megabytes of it, never more than the limit.

mod support;

use std::process::Command;
use support::*;

const CAP_IPC_LOCK: u32 = 14;
const CAP_SYS_NICE: u32 = 23;

/// Whether this process's effective capabilities include `cap` (/proc/self/status).
fn has_capability(cap: u32) -> bool {
    let status = std::fs::read_to_string("/proc/self/status").unwrap();
    let eff = status
        .lines()
        .find_map(|l| l.strip_prefix("CapEff:"))
        .expect("CapEff in /proc/self/status");
    let mask = u64::from_str_radix(eff.trim(), 16).unwrap();
    mask & (1 << cap) != 0
}

/// `aisle <args>` under limits (and capabilities) that refuse a real-time priority and
/// allow `memlock` bytes of locked memory.
fn refusing(run_dir: &std::path::Path, memlock: u64, args: &[&str]) -> Command {
    let mut c = if has_capability(CAP_SYS_NICE) || has_capability(CAP_IPC_LOCK) {
        let mut c = Command::new("setpriv");
        c.args([
            "--inh-caps=-sys_nice,-ipc_lock",
            "--bounding-set=-sys_nice,-ipc_lock",
            "prlimit",
        ]);
        c
    } else {
        Command::new("prlimit")
    };
    c.arg("--rtprio=0")
        .arg(format!("--memlock={memlock}"))
        .args(["--", aisle()])
        .args(args)
        .env("AISLE_RUN_DIR", run_dir)
        .env("AISLE_LOG", "warn")
        .stdin(std::process::Stdio::null());
    c
}

/// The seed mission run with `options` as `realtime.toml`, refused as [`refusing`] says
/// with `memlock` bytes of locked memory allowed: its stderr and report, after checking
/// that it succeeded.
fn run_refused(
    dir: &TestDir,
    options: &str,
    memlock: u64,
) -> (String, aisle_supervisor::report::RunReport) {
    let config = config_with_graph(dir, "");
    std::fs::write(config.join("realtime.toml"), options).unwrap();
    let report = dir.path("report.json");
    let out = refusing(
        &dir.run_dir(),
        memlock,
        &[
            "run",
            "--quiet",
            "--config-dir",
            config.to_str().unwrap(),
            "--report",
            report.to_str().unwrap(),
        ],
    )
    .output()
    .expect("setpriv / prlimit (util-linux) run aisle");
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(out.status.success(), "exit {:?}: {stderr}", out.status);
    let r: aisle_supervisor::report::RunReport =
        serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    assert!(r.success, "{:?}", r.failure);
    (stderr, r)
}

#[test]
fn refused_options_are_warned_once_per_process_and_the_mission_completes() {
    let dir = TestDir::new("realtime");
    let (stderr, r) = run_refused(
        &dir,
        "[default]\npriority = 80\nlock_memory = true\nprefault_stack_kb = 64\n",
        64 * 1024,
    );
    let (digest, poses) = seed_baseline();
    assert_eq!(r.driven_path.len(), poses);
    assert_eq!(path_digest(&r.driven_path), digest);

    let warnings: Vec<&str> = stderr
        .lines()
        .filter(|l| l.contains("real-time options refused"))
        .collect();
    let processes = [
        "simulator",
        "lidar",
        "mapper",
        "global_planner",
        "teb_controller",
        "supervisor",
    ];
    for p in processes {
        let mine: Vec<&&str> = warnings
            .iter()
            .filter(|l| l.contains(&format!("{p}: real-time options refused")))
            .collect();
        assert_eq!(mine.len(), 1, "{p}: {warnings:#?}");
        let w = mine[0];
        assert!(
            w.contains("priority = 80") && w.contains("RLIMIT_RTPRIO"),
            "{w}"
        );
        assert!(
            w.contains("lock_memory = true") && w.contains("RLIMIT_MEMLOCK"),
            "{w}"
        );
        assert!(
            !w.contains("prefault_stack_kb"),
            "applied, not refused: {w}"
        );
    }
    assert_eq!(warnings.len(), processes.len(), "{warnings:#?}");
    for p in &r.processes {
        assert!(
            p.locked_kib <= 64,
            "{}: {} KiB locked",
            p.process,
            p.locked_kib
        );
    }
    assert!(run_dir_leftovers(&dir.run_dir()).is_empty());
}

/// The hard RLIMIT_MEMLOCK of this process in bytes (`None`: unlimited).
fn memlock_hard_limit() -> Option<u64> {
    let limits = std::fs::read_to_string("/proc/self/limits").unwrap();
    let line = limits
        .lines()
        .find(|l| l.starts_with("Max locked memory"))
        .expect("Max locked memory in /proc/self/limits");
    line.split_whitespace().nth(4).unwrap().parse().ok()
}

#[test]
fn under_a_finite_memlock_limit_every_process_locks_what_fits_and_no_more() {
    const LIMIT: u64 = 8 << 20;
    if memlock_hard_limit().is_some_and(|hard| hard < LIMIT) {
        eprintln!("skipped: the hard RLIMIT_MEMLOCK here is below 8 MiB");
        return;
    }
    let dir = TestDir::new("realtime-memlock");
    let (stderr, r) = run_refused(
        &dir,
        "[default]\nlock_memory = true\nprefault_stack_kb = 64\n",
        LIMIT,
    );
    // Mapped, each process has 0.05-1.7 GiB: it used to lock nothing at all. Now the
    // stack, the heap and the smaller private mappings, within the limit.
    assert_eq!(r.processes.len(), 6, "{:?}", r.processes);
    for p in &r.processes {
        assert!(
            p.locked_kib >= 1024 && p.locked_kib <= LIMIT / 1024,
            "{}: {} KiB locked",
            p.process,
            p.locked_kib
        );
    }
    let warnings: Vec<&str> = stderr
        .lines()
        .filter(|l| l.contains("real-time options refused"))
        .collect();
    assert_eq!(warnings.len(), 6, "one per process: {warnings:#?}");
    for w in warnings {
        assert!(
            w.contains("RLIMIT_MEMLOCK is 8192 KiB") && w.contains("later mappings are not locked"),
            "{w}"
        );
    }
}

/// The value the kernel applies now: the least wake-up latency any process holds, in
/// µs (its default, with no request, is 2,000,000,000). None when this process may not
/// read the device (it is root's).
fn wakeup_latency_now() -> Option<i32> {
    let bytes = std::fs::read("/dev/cpu_dma_latency").ok()?;
    Some(i32::from_ne_bytes(bytes.get(..4)?.try_into().ok()?))
}

#[test]
fn a_wakeup_latency_request_holds_while_the_group_runs_and_ends_with_it() {
    let Some(before) = wakeup_latency_now() else {
        eprintln!("skipped: /dev/cpu_dma_latency is not readable here (not root)");
        return;
    };
    // The test asks for 0; with another request of 0 already held, no change could show.
    if before == 0 {
        eprintln!("skipped: another process already holds a wake-up latency of 0");
        return;
    }
    let dir = TestDir::new("realtime-wakeup");
    let config = config_with_graph(&dir, "");
    std::fs::write(
        config.join("realtime.toml"),
        "[default]\nmax_wakeup_latency_us = 0\n",
    )
    .unwrap();
    let mut child = spawn(
        &dir.run_dir(),
        &["run", "--quiet", "--config-dir", config.to_str().unwrap()],
    );
    let stderr = stderr_reader(&mut child);
    let mut least = before;
    let status = loop {
        if let Some(v) = wakeup_latency_now() {
            least = least.min(v);
        }
        if let Ok(Some(s)) = child.try_wait() {
            break s;
        }
        std::thread::sleep(std::time::Duration::from_millis(20));
    };
    let stderr = stderr.join().unwrap();
    assert!(status.success(), "{status:?}: {stderr}");
    assert!(!stderr.contains("refused"), "applied as root: {stderr}");
    assert_eq!(least, 0, "the request was never in force");
    assert_eq!(
        wakeup_latency_now(),
        Some(before),
        "every request is dropped with its process"
    );
}
