//! The command line of `aisle scenario generate` and `aisle sweep`: their arguments
//! (clap) and how they become [`crate::scenario::GenerateOptions`] and
//! [`crate::sweep::SweepOptions`], and their exit codes. Part of [`crate::cli`], kept
//! apart so that each file stays small.

use crate::exit;
use clap::{Args, Subcommand};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

#[derive(Debug, Subcommand)]
pub enum ScenarioCommand {
    /// Write a config directory: a copy of the base one with warehouse.toml and
    /// mission.toml varied by (seed, family); the header of each says what changed.
    /// Families: moved, extra, start, gap, mission, infeasible. On a base whose mission
    /// does not fit its scene (a scene of `aisle scene generate`), `mission` draws a
    /// start and a mission of its own; the others are refused.
    #[command(
        after_help = "Exit: 0 written, 2 could not (an unknown family, --out exists and is \
not empty and no --force, no valid draw, the output not writable, a family that varies \
a base mission that does not fit its scene)."
    )]
    Generate {
        /// Seed of the draw: the same seed and family give the same directory.
        #[arg(long)]
        seed: u64,
        /// What to vary: moved, extra, start, gap, mission or infeasible.
        #[arg(long)]
        family: String,
        /// The directory to write (created; one that exists must be empty).
        #[arg(long)]
        out: PathBuf,
        /// Write into --out even if it holds files (those of a config are overwritten).
        #[arg(long)]
        force: bool,
        /// The base config directory (default: the built-in one).
        #[arg(long)]
        config_dir: Option<PathBuf>,
    },
}

#[derive(Debug, Clone, Args)]
pub struct SweepArgs {
    /// Number of scenarios.
    #[arg(long, default_value_t = 200)]
    pub count: usize,
    /// Seed of the sweep (scenario i gets seed * 1000000 + i).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Runs at a time (default: the number of cores).
    #[arg(long)]
    pub jobs: Option<usize>,
    /// Families to spread the scenarios over, round-robin (default: all).
    #[arg(long, value_delimiter = ',')]
    pub families: Vec<String>,
    /// Output directory.
    #[arg(long, default_value = "sweep")]
    pub out: PathBuf,
    /// The base config directory (default: the built-in one).
    #[arg(long)]
    pub config_dir: Option<PathBuf>,
    /// Wall-clock limit of one run, seconds (then its group is stopped: an error).
    #[arg(long, default_value_t = 120.0)]
    pub timeout: f64,
}

/// `aisle scenario generate`.
pub fn generate(seed: u64, family: &str, out: PathBuf, force: bool, base: &Path) -> ExitCode {
    if let Err(e) = writable_out(&out, force) {
        return exit::fail(e);
    }
    let family = match crate::scenario::Family::parse(family) {
        Ok(f) => f,
        Err(e) => return exit::fail(e),
    };
    let opts = crate::scenario::GenerateOptions {
        seed,
        family,
        out,
        base: base.to_path_buf(),
    };
    match crate::scenario::generate(&opts) {
        Ok(g) => {
            println!("wrote {} ({} seed {seed})", g.dir.display(), family.name());
            for v in &g.varied {
                println!("  {v}");
            }
            ExitCode::SUCCESS
        }
        Err(e) => exit::fail(e),
    }
}

/// Refuses an `--out` that exists and is not an empty directory, unless `force` (and a
/// file, which no `--force` makes a directory): a config directory written over keeps
/// files of its own beside the generated ones, and the user's edits are lost.
pub fn writable_out(out: &Path, force: bool) -> Result<(), String> {
    let Ok(meta) = out.symlink_metadata() else {
        return Ok(()); // created
    };
    if !meta.is_dir() && !out.is_dir() {
        return Err(format!(
            "--out {}: exists and is not a directory",
            out.display()
        ));
    }
    let mut entries =
        std::fs::read_dir(out).map_err(|e| format!("--out {}: {e}", out.display()))?;
    if entries.next().is_some() && !force {
        return Err(format!(
            "--out {}: exists and is not empty; nothing written (--force writes into it, \
             overwriting the config files there)",
            out.display()
        ));
    }
    Ok(())
}

/// `aisle sweep`.
pub fn sweep(a: SweepArgs, base: &Path) -> ExitCode {
    use crate::scenario::Family;
    let families = if a.families.is_empty() {
        Ok(Family::ALL.to_vec())
    } else {
        a.families.iter().map(|f| Family::parse(f)).collect()
    };
    let families = match families {
        Ok(f) => f,
        Err(e) => return exit::fail(e),
    };
    if a.count == 0 || a.jobs == Some(0) || !(a.timeout.is_finite() && a.timeout > 0.0) {
        return exit::fail("--count and --jobs must be at least 1, --timeout positive");
    }
    let jobs = a
        .jobs
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    let opts = crate::sweep::SweepOptions {
        count: a.count,
        seed: a.seed,
        jobs,
        families,
        out: a.out,
        base: base.to_path_buf(),
        timeout: std::time::Duration::from_secs_f64(a.timeout),
    };
    let report = match crate::sweep::sweep(&opts) {
        Ok(r) => r,
        Err(e) => return exit::fail(e),
    };
    match crate::sweep::write(&opts, &report) {
        Ok(md) => print!("{md}"),
        Err(e) => return exit::fail(e),
    }
    if report.all_as_expected {
        ExitCode::SUCCESS
    } else {
        exit::negative()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_existing_non_empty_out_needs_force() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("scenario");
        writable_out(&out, false).unwrap(); // missing: created
        std::fs::create_dir(&out).unwrap();
        writable_out(&out, false).unwrap(); // empty
        std::fs::write(out.join("mission.toml"), "mine").unwrap();
        let e = writable_out(&out, false).unwrap_err();
        assert!(
            e.contains("--out") && e.contains("not empty") && e.contains("--force"),
            "{e}"
        );
        writable_out(&out, true).unwrap();
        let e = writable_out(&out.join("mission.toml"), true).unwrap_err();
        assert!(e.contains("not a directory"), "{e}");
    }
}
