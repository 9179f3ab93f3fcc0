//! The exit codes of every `aisle` subcommand, and their text for `--help`.
//!
//! One rule: 0 the command did what was asked and the verdict is positive; 1 it did
//! what was asked and the verdict is negative (a mission that failed, a config `check`
//! found invalid, a replay that diverged); 2 it could not do what was asked (usage,
//! unreadable or invalid input, a setup failure, a damaged record, a group that could
//! not run or was interrupted). clap's own usage errors are 2 as well.

use std::process::ExitCode;

/// The command did what was asked; the verdict is positive.
pub const SUCCESS: u8 = 0;
/// The command did what was asked; the verdict is negative.
pub const NEGATIVE: u8 = 1;
/// The command could not do what was asked.
pub const COULD_NOT: u8 = 2;

/// The table printed at the end of `aisle --help` (and README's).
pub const TABLE: &str = "\
Exit codes (every subcommand):
  0  success: the mission succeeded, the config is valid, the replay is identical,
     the command did what was asked
  1  the verdict is negative: the mission failed (a collision, an unreachable goal,
     a timeout), `check` found an invalid config, `replay --check` diverged,
     `instance` found no live instance, the instance `echo` or `hz` watched ended
     (its owner stopped the group)
  2  could not do what was asked: usage error, unreadable or invalid input (config,
     mission, record), output path not writable or naming an input or another
     output or being written by another command now, a replay into a live group
     of a topic the group publishes itself (refused before anything is published),
     a replay that published nothing or whose live instance ended under it, setup
     failure, damaged record, the group could not run or was interrupted";

pub fn negative() -> ExitCode {
    ExitCode::from(NEGATIVE)
}

pub fn could_not() -> ExitCode {
    ExitCode::from(COULD_NOT)
}

/// Prints `error: <e>` (naming the files an assembled config was copied from) and
/// returns exit code 2.
pub fn fail(e: impl std::fmt::Display) -> ExitCode {
    eprintln!(
        "error: {}",
        crate::cli::config::name_sources(&e.to_string())
    );
    could_not()
}
