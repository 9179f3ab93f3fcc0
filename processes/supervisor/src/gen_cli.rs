//! The arguments of `aisle gen` (bindings generated from the Rust catalogue) and their
//! exit codes; the rendering is `pygen`'s.

use crate::{exit, pygen};
use clap::Subcommand;
use std::path::PathBuf;
use std::process::ExitCode;

/// Subcommands flattened into `aisle`'s own.
#[derive(Debug, Subcommand)]
pub enum GenCommand {
    /// Generate language bindings from the Rust message catalogue.
    #[command(
        after_help = "Exit: 0 written (--check: up to date), 1 --check found the file stale \
(the first difference is printed), 2 could not (unreadable or unwritable file)."
    )]
    Gen {
        #[command(subcommand)]
        target: GenTarget,
    },
}

#[derive(Debug, Subcommand)]
pub enum GenTarget {
    /// The Python SDK's message layouts, topic table and wire codes.
    Python {
        /// Compare the file with what this build generates instead of writing it.
        #[arg(long)]
        check: bool,
        /// The file to write (or to compare with --check).
        #[arg(long, default_value = pygen::DEFAULT_OUT)]
        out: PathBuf,
    },
}

pub fn main(cmd: GenCommand) -> ExitCode {
    let GenCommand::Gen {
        target: GenTarget::Python { check, out },
    } = cmd;
    if !check {
        return match pygen::write(&out) {
            Ok(()) => {
                println!("wrote {}", out.display());
                ExitCode::SUCCESS
            }
            Err(e) => exit::fail(format!("{e:#}")),
        };
    }
    match pygen::check(&out) {
        Ok(None) => {
            println!("{} is up to date", out.display());
            ExitCode::SUCCESS
        }
        Ok(Some(diff)) => {
            eprintln!(
                "error: {} is stale ({diff}); run `aisle gen python`",
                out.display()
            );
            exit::negative()
        }
        Err(e) => exit::fail(format!("{e:#}")),
    }
}
