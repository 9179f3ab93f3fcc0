//! The small subcommands whose whole logic is a call and its exit code: `check`,
//! `map export`, `run`.

use crate::session::{self, RunOptions};
use crate::{check, exit};
use std::path::Path;
use std::process::ExitCode;

/// `aisle check`: 1 for an invalid config, 2 when there is no directory to check.
pub fn check(dir: &Path) -> ExitCode {
    if !dir.is_dir() {
        return exit::fail(format!("{}: not a directory", dir.display()));
    }
    match check::check_dir(dir) {
        Ok(files) => {
            for f in &files {
                println!("ok  {}", f.display());
            }
            println!("{} config files valid in {}", files.len(), dir.display());
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {e}");
            exit::negative()
        }
    }
}

/// `aisle map export`.
pub fn export_map(config_dir: &Path, dir: &Path, name: &str) -> ExitCode {
    match aisle_mapper::export_from_config_dir(config_dir, dir, name) {
        Ok(files) => {
            println!(
                "wrote {} and {}",
                files.yaml.display(),
                files.image.display()
            );
            ExitCode::SUCCESS
        }
        Err(e) => exit::fail(e),
    }
}

/// `aisle run`.
pub fn run(opts: &RunOptions) -> ExitCode {
    aisle_bus::discovery::set_creator("run", Some(&opts.config_dir));
    match session::run(opts) {
        Ok(outcome) => {
            if outcome.succeeded {
                ExitCode::SUCCESS
            } else {
                exit::negative()
            }
        }
        Err(e) => exit::fail(format!("{e:#}")),
    }
}
