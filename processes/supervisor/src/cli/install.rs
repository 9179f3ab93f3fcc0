//! What an installed binary needs beyond running: `aisle init DIR` (the built-in config
//! written out to edit), `aisle completions SHELL`, and the `--version` line (crate
//! version, git commit, message schema hash). Knows nothing of what the config means.

use crate::exit;
use clap::Subcommand;
use clap_complete::Shell;
use std::path::PathBuf;
use std::process::ExitCode;

/// Subcommands flattened into `aisle`'s own.
#[derive(Debug, Subcommand)]
pub enum InstallCommand {
    /// Write the built-in config (every file `aisle run` uses without --config-dir) to
    /// DIR, to edit and pass back with `--config-dir DIR`.
    #[command(
        after_help = "Exit: 0 written, 2 could not (a file exists and no --force, the \
directory is not writable)."
    )]
    Init {
        /// The directory to write (created if missing).
        dir: PathBuf,
        /// Overwrite config files that exist already.
        #[arg(long)]
        force: bool,
    },
    /// Print a completion script for a shell, e.g.
    /// `aisle completions bash > ~/.local/share/bash-completion/completions/aisle`.
    #[command(after_help = "Exit: 0 printed, 2 could not (unknown shell).")]
    Completions {
        /// The shell to complete for.
        #[arg(value_enum)]
        shell: Shell,
    },
}

pub fn main(cmd: InstallCommand) -> ExitCode {
    match cmd {
        InstallCommand::Init { dir, force } => match super::config::write_embedded(&dir, force) {
            Ok(files) => {
                println!("wrote {} config files to {}", files.len(), dir.display());
                println!("use them with: aisle run --config-dir {}", dir.display());
                ExitCode::SUCCESS
            }
            Err(e) => exit::fail(format!("{e:#}")),
        },
        InstallCommand::Completions { shell } => {
            clap_complete::generate(
                shell,
                &mut super::command(),
                "aisle",
                &mut std::io::stdout(),
            );
            ExitCode::SUCCESS
        }
    }
}

/// `aisle --version`: `0.1.0 (commit 1a2b3c4d5e6f, message schema 0123456789abcdef)`.
/// The schema hash is the one every process checks when it joins a group: two binaries
/// with the same one can share an instance.
pub fn version() -> &'static str {
    static TEXT: std::sync::OnceLock<String> = std::sync::OnceLock::new();
    TEXT.get_or_init(|| {
        format!(
            "{} (commit {}, message schema {})",
            env!("CARGO_PKG_VERSION"),
            env!("AISLE_GIT_COMMIT"),
            aisle_messages::schema_hash_hex()
        )
    })
}
