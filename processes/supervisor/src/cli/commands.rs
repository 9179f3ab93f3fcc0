//! The small subcommands whose whole logic is a call and its exit code: `check`,
//! `map export`, `run`.

use crate::cli::config::name_sources;
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
            let named = |p: &Path| name_sources(&p.display().to_string());
            for f in &files {
                println!("ok  {}", named(f));
            }
            println!("{} config files valid in {}", files.len(), named(dir));
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {}", name_sources(&e.to_string()));
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
