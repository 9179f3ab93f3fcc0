//! Losing the recorder never fails the mission: a record that cannot be written (a
//! full disk, a read-only directory) ends in one clear warning naming the OS error, the
//! lockstep mission goes on without waiting for the recorder, and what was written
//! stays readable. Needs root (it mounts small tmpfs file systems); says so and passes
//! without checking anything when not root.

mod support;

use std::path::{Path, PathBuf};
use std::process::Command;
use support::*;

/// A tmpfs mounted for one test, unmounted on drop.
struct Tmpfs(PathBuf);

impl Tmpfs {
    fn mount(at: &Path, options: &str) -> Option<Tmpfs> {
        std::fs::create_dir_all(at).unwrap();
        let ok = Command::new("mount")
            .args(["-t", "tmpfs", "-o", options, "tmpfs"])
            .arg(at)
            .status()
            .is_ok_and(|s| s.success());
        ok.then(|| Tmpfs(at.to_path_buf()))
    }
}

impl Drop for Tmpfs {
    fn drop(&mut self) {
        let _ = Command::new("umount").arg(&self.0).status();
    }
}

fn is_root() -> bool {
    // SAFETY: geteuid has no preconditions.
    unsafe { libc::geteuid() == 0 }
}

/// Runs the seed mission recording into `out`; returns its stderr after checking that
/// the mission succeeded and that exactly one line says the run goes on unrecorded.
fn run_with_lost_record(dir: &TestDir, out: &Path) -> String {
    let report = dir.path("report.json");
    let output = run(
        &dir.run_dir(),
        &[
            "run",
            "--quiet",
            "--record",
            out.to_str().unwrap(),
            "--report",
            report.to_str().unwrap(),
        ],
    );
    let err = String::from_utf8_lossy(&output.stderr).into_owned();
    assert!(output.status.success(), "{:?}: {err}", output.status);
    let r: aisle_supervisor::report::RunReport =
        serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    assert!(r.success, "{:?}", r.failure);
    let warnings: Vec<&str> = err.lines().filter(|l| l.contains("unrecorded")).collect();
    assert_eq!(warnings.len(), 1, "{err}");
    err
}

#[test]
fn a_full_disk_loses_the_record_not_the_mission() {
    if !is_root() {
        eprintln!("skipped: mounting a tmpfs needs root");
        return;
    }
    let dir = TestDir::new("record-full");
    let Some(fs) = Tmpfs::mount(&dir.path("full"), "size=2m,mode=0700") else {
        panic!("cannot mount a tmpfs as root");
    };
    let out = fs.0.join("run.mcap");
    let err = run_with_lost_record(&dir, &out);
    assert!(err.contains("No space left on device"), "{err}");
    // The part written before the disk filled is a readable record.
    let profile = run(&dir.run_dir(), &["profile", out.to_str().unwrap()]);
    let text = String::from_utf8_lossy(&profile.stdout);
    assert!(
        text.contains("lidar"),
        "{text}\n{}",
        String::from_utf8_lossy(&profile.stderr)
    );
}

#[test]
fn a_read_only_directory_loses_the_record_not_the_mission() {
    if !is_root() {
        eprintln!("skipped: mounting a tmpfs needs root");
        return;
    }
    let dir = TestDir::new("record-ro");
    let Some(fs) = Tmpfs::mount(&dir.path("ro"), "size=1m,ro") else {
        panic!("cannot mount a tmpfs as root");
    };
    let err = run_with_lost_record(&dir, &fs.0.join("run.mcap"));
    assert!(err.contains("Read-only file system"), "{err}");
}
