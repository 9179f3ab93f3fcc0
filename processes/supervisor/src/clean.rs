//! `aisle clean`, and the sweep every `aisle run` does before it creates its instance:
//! what dead instances of this user left in the run directory and in /dev/shm is
//! removed, a live group's instance never (`aisle_bus::sweep` decides which is which).
//!
//! Knows the run directory and how to word a sweep, not iceoryx2.

use aisle_bus::run_dir;
use aisle_bus::sweep::{StaleInstance, SweepReport, sweep};
use std::path::Path;
use std::process::ExitCode;

/// `aisle clean [--dry-run]`: 0 when everything stale is gone (or, dry, listed), 2 when
/// the run directory is refused or a removal failed.
pub fn clean(dry_run: bool) -> ExitCode {
    let dir = match run_dir::run_dir() {
        Ok(d) => d,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(2);
        }
    };
    let report = sweep(&dir, dry_run);
    let verb = if dry_run { "would remove" } else { "removed" };
    for s in &report.removed {
        println!("{verb} {}", describe(s));
    }
    for (prefix, why) in &report.kept {
        println!("kept    {prefix}: {why}");
    }
    for e in &report.errors {
        eprintln!("error: could not remove {e}");
    }
    let done = if dry_run { "to remove" } else { "removed" };
    println!(
        "{} stale instance(s) {done}, {} kept, in {} and /dev/shm",
        report.removed.len(),
        report.kept.len(),
        dir.display()
    );
    if report.errors.is_empty() {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(2)
    }
}

/// The sweep of `aisle run`: removes stale instances of `dir`, one log line each.
pub fn sweep_before_run(dir: &Path) -> SweepReport {
    let report = sweep(dir, false);
    for s in &report.removed {
        tracing::info!("removed stale {}", describe(s));
    }
    for e in &report.errors {
        tracing::warn!("could not remove a stale instance's {e}");
    }
    report
}

fn describe(s: &StaleInstance) -> String {
    let root = match &s.root {
        Some(r) => format!("root {}, ", r.display()),
        None => String::new(),
    };
    format!(
        "instance {} ({}): {root}{} shared-memory file(s)",
        s.prefix,
        s.why,
        s.shm_files.len()
    )
}
