//! `aisle clean`, and the sweep every `aisle run` does before it creates its instance:
//! what dead instances of this user left in the run directory and in /dev/shm is
//! removed, a live group's instance never (`aisle_bus::sweep` decides which is which);
//! and the private config directories (`cli/config.rs`) of this user's commands that no
//! longer run (a SIGKILL leaves them behind), told by the pid and start time in their
//! names.
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
    let configs = sweep_config_dirs(dry_run);
    for d in &configs.removed {
        println!(
            "{verb} config directory {} (its command no longer runs)",
            d.display()
        );
    }
    for e in &configs.errors {
        eprintln!("error: could not remove {e}");
    }
    let done = if dry_run { "to remove" } else { "removed" };
    println!(
        "{} stale instance(s) {done}, {} kept, in {} and /dev/shm",
        report.removed.len(),
        report.kept.len(),
        dir.display()
    );
    if report.errors.is_empty() && configs.errors.is_empty() {
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
    let configs = sweep_config_dirs(false);
    for d in &configs.removed {
        tracing::info!("removed stale config directory {}", d.display());
    }
    for e in &configs.errors {
        tracing::warn!("could not remove {e}");
    }
    report
}

/// Config directories removed (or, dry, to remove) and the removals that failed.
#[derive(Debug, Default)]
pub struct ConfigSweep {
    pub removed: Vec<std::path::PathBuf>,
    pub errors: Vec<String>,
}

/// This user's private config directories in the temporary directory whose command (the
/// pid and start time in the name) no longer runs. Directories of older binaries,
/// without them in the name, are left alone: nothing tells whether they are in use.
pub fn sweep_config_dirs(dry_run: bool) -> ConfigSweep {
    use std::os::unix::fs::MetadataExt;
    let mut out = ConfigSweep::default();
    let Ok(entries) = std::fs::read_dir(std::env::temp_dir()) else {
        return out;
    };
    // SAFETY: geteuid has no preconditions and cannot fail.
    let uid = unsafe { libc::geteuid() };
    for e in entries.flatten() {
        let name = e.file_name();
        let Some(owner) = name.to_str().and_then(config_dir_owner) else {
            continue;
        };
        let path = e.path();
        let mine = std::fs::symlink_metadata(&path).is_ok_and(|m| m.is_dir() && m.uid() == uid);
        if !mine || owner.is_alive() {
            continue;
        }
        if !dry_run && let Err(err) = std::fs::remove_dir_all(&path) {
            out.errors.push(format!("{}: {err}", path.display()));
            continue;
        }
        out.removed.push(path);
    }
    out
}

/// The command that owns a config directory named `name`, if it is one.
fn config_dir_owner(name: &str) -> Option<aisle_bus::owner::Owner> {
    let rest = name.strip_prefix(crate::cli::config::CONFIG_DIR_PREFIX)?;
    let mut parts = rest.splitn(3, '-');
    let pid = parts.next()?.parse().ok()?;
    let start = parts.next()?.parse().ok()?;
    parts.next()?;
    Some(aisle_bus::owner::Owner { pid, start })
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_config_directory_names_its_owner() {
        let o = config_dir_owner("aisle-config-1234-5678-AbCdEf").unwrap();
        assert_eq!((o.pid, o.start), (1234, 5678));
        // Older binaries' names carry no owner: never swept.
        assert!(config_dir_owner("aisle-config-AbCdEf").is_none());
        assert!(config_dir_owner("aisle-config-12-AbCdEf").is_none());
        assert!(config_dir_owner("other-1234-5678-x").is_none());
    }

    #[test]
    fn only_the_directories_of_commands_that_ended_are_swept() {
        let me = aisle_bus::owner::Owner::current().unwrap();
        let tmp = std::env::temp_dir();
        let live = tmp.join(format!("aisle-config-{}-{}-testlive", me.pid, me.start));
        // This process's pid with another start time: a command that ended long ago.
        let dead = tmp.join(format!("aisle-config-{}-{}-testdead", me.pid, me.start + 1));
        for d in [&live, &dead] {
            std::fs::create_dir_all(d).unwrap();
        }
        let swept = sweep_config_dirs(false);
        assert!(swept.removed.contains(&dead), "{swept:?}");
        assert!(!dead.exists());
        assert!(live.exists(), "a live command's directory was removed");
        std::fs::remove_dir_all(&live).unwrap();
    }
}
