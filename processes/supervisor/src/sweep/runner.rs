//! One `aisle run` of a scenario as a child process of this same binary: its own
//! process group, a wall-clock limit (SIGTERM to the group, then SIGKILL), the report
//! it wrote, and what a killed run left in the run directory and /dev/shm swept away.
//! Knows how to run and classify one run, not what a sweep does with it.

use crate::report::RunReport;
use serde::Serialize;
use std::os::unix::process::CommandExt;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// What became of one run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Outcome {
    /// Exit 0 with no collision.
    Success,
    /// Exit 1: a collision or a clean failure; the report says which.
    Failure,
    /// Exit 2, a crash, a timeout, or no report: a bug.
    Error,
}

/// One run, summarised.
#[derive(Debug, Clone, Serialize)]
pub struct RunSummary {
    pub outcome: Outcome,
    pub exit_code: Option<i32>,
    pub reason: Option<String>,
    pub collisions: u32,
    pub sim_time_s: Option<f64>,
    pub path_length_m: Option<f64>,
    pub replans: Option<u32>,
    pub wall_s: f64,
    /// The run's stdout and stderr.
    pub log: PathBuf,
}

/// How to run one child.
pub struct RunSpec<'a> {
    pub exe: &'a Path,
    pub config_dir: &'a Path,
    pub report: &'a Path,
    pub log: &'a Path,
    pub record: Option<&'a Path>,
    pub timeout: Duration,
}

/// Runs `aisle run --config-dir D --quiet --report R [--record M]` and classifies it.
pub fn run(spec: &RunSpec) -> RunSummary {
    let _ = std::fs::remove_file(spec.report);
    let started = Instant::now();
    let waited = spawn_and_wait(spec);
    let wall_s = started.elapsed().as_secs_f64();
    let report: Option<RunReport> = std::fs::read_to_string(spec.report)
        .ok()
        .and_then(|t| serde_json::from_str(&t).ok());
    let mut s = RunSummary {
        outcome: Outcome::Error,
        exit_code: None,
        reason: None,
        collisions: 0,
        sim_time_s: None,
        path_length_m: None,
        replans: None,
        wall_s,
        log: spec.log.to_path_buf(),
    };
    if let Some(r) = &report {
        s.collisions = r.collisions;
        s.sim_time_s = Some(r.sim_time_s);
        s.path_length_m = Some(r.path_length_m);
        s.replans = Some(r.replans);
        s.reason = r.failure.clone();
    }
    match waited {
        Ok(code) => {
            s.exit_code = code;
            s.outcome = match (code, &report) {
                (Some(0), Some(r)) if r.success && r.collisions == 0 => Outcome::Success,
                (Some(0), Some(_)) => Outcome::Failure,
                (Some(1), Some(_)) => Outcome::Failure,
                _ => Outcome::Error,
            };
            if s.outcome == Outcome::Error && s.reason.is_none() {
                s.reason = Some(match code {
                    Some(c) => format!("exit {c}: {}", last_line(spec.log)),
                    None => format!("killed by a signal: {}", last_line(spec.log)),
                });
            }
        }
        Err(why) => s.reason = Some(why),
    }
    s
}

/// The last non-empty line of a log, for an error's reason.
fn last_line(log: &Path) -> String {
    std::fs::read_to_string(log)
        .unwrap_or_default()
        .lines()
        .rev()
        .find(|l| !l.trim().is_empty())
        .unwrap_or("no output")
        .trim()
        .to_string()
}

/// The exit code (None: a signal), or why there is none (could not start, timed out).
fn spawn_and_wait(spec: &RunSpec) -> Result<Option<i32>, String> {
    let log = std::fs::File::create(spec.log)
        .map_err(|e| format!("cannot write {}: {e}", spec.log.display()))?;
    let err = log
        .try_clone()
        .map_err(|e| format!("cannot write {}: {e}", spec.log.display()))?;
    let mut cmd = Command::new(spec.exe);
    cmd.arg("run")
        .arg("--config-dir")
        .arg(spec.config_dir)
        .arg("--quiet")
        .arg("--report")
        .arg(spec.report)
        .stdin(Stdio::null())
        .stdout(log)
        .stderr(err)
        // Its own group, so that a timeout can stop it and whatever it started.
        .process_group(0);
    if let Some(m) = spec.record {
        cmd.arg("--record").arg(m);
    }
    // SAFETY: prctl is async-signal-safe; nothing else runs between fork and exec.
    unsafe {
        cmd.pre_exec(|| {
            // A sweep that dies (Ctrl-C) takes its runs with it: they get SIGTERM and
            // stop their groups in order.
            libc::prctl(libc::PR_SET_PDEATHSIG, libc::SIGTERM);
            Ok(())
        });
    }
    let mut child = cmd
        .spawn()
        .map_err(|e| format!("cannot start {}: {e}", spec.exe.display()))?;
    let started = Instant::now();
    loop {
        match child.try_wait() {
            Ok(Some(status)) => return Ok(status.code()),
            Ok(None) => {}
            Err(e) => return Err(format!("waiting for the run: {e}")),
        }
        if started.elapsed() > spec.timeout {
            let pid = child.id();
            stop_group(pid, &mut child);
            let left = sweep_leftovers(pid);
            return Err(format!(
                "timeout: no verdict after {:.0} s wall, stopped{left}",
                spec.timeout.as_secs_f64()
            ));
        }
        std::thread::sleep(Duration::from_millis(25));
    }
}

/// SIGTERM to the run's process group (the supervisor stops its nodes in order), then
/// SIGKILL to what is left after 5 s.
fn stop_group(pid: u32, child: &mut std::process::Child) {
    let group = -(pid as i32);
    // SAFETY: kill(2) on a process group this sweep created.
    unsafe { libc::kill(group, libc::SIGTERM) };
    let until = Instant::now() + Duration::from_secs(5);
    while Instant::now() < until {
        if let Ok(Some(_)) = child.try_wait() {
            return;
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    // SAFETY: as above.
    unsafe { libc::kill(group, libc::SIGKILL) };
    let _ = child.wait();
}

/// Removes what a stopped run left (its instance root, /dev/shm files); returns a note
/// when something of it is still there.
fn sweep_leftovers(pid: u32) -> String {
    // Its nodes die with it (their parent-death signal); give them a moment.
    std::thread::sleep(Duration::from_millis(500));
    if let Ok(dir) = aisle_bus::run_dir::run_dir() {
        aisle_bus::sweep::sweep(&dir, false);
    }
    let prefix = format!("aisle{pid}x");
    let left = std::fs::read_dir("/dev/shm")
        .map(|d| {
            d.flatten()
                .filter(|e| e.file_name().to_string_lossy().contains(&prefix))
                .count()
        })
        .unwrap_or(0);
    if left == 0 {
        String::new()
    } else {
        format!("; {left} /dev/shm files of it are left (`aisle clean`)")
    }
}
