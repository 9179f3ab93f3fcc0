//! `aisle instance`, `aisle topics`, `aisle echo` and `aisle hz`: looking at a running
//! instance from outside its group. Finding the instance is `aisle_bus::discovery`'s;
//! listing, decoding and timing samples is `aisle_tools::inspect`'s. This module only
//! turns arguments into calls and results into lines and exit codes.

use aisle_bus::discovery::{self, Found, LiveInstance};
use aisle_bus::{Instance, run_dir};
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Duration;

#[derive(Debug, clap::Subcommand)]
pub enum InspectCommand {
    /// The live instances of the run directory (newest first), or `--env` the shell
    /// variables that name the newest one (for scripts: `eval "$(aisle instance --env)"`).
    #[command(
        after_help = "Exit: 0 listed, 1 no instance is live, 2 could not (the run \
directory is refused)."
    )]
    Instance {
        /// Print `export AISLE_PREFIX=... AISLE_ROOT=...` for the newest live instance
        /// (or the one called --prefix).
        #[arg(long)]
        env: bool,
        /// With --env: this instance rather than the newest.
        #[arg(long)]
        prefix: Option<String>,
    },
}

pub fn main(cmd: InspectCommand) -> ExitCode {
    match cmd {
        InspectCommand::Instance { env, prefix } => instance(env, prefix.as_deref()),
    }
}

/// Where to look: `--prefix` and `--root` both given, else discovery (`AISLE_PREFIX`/
/// `AISLE_ROOT`, then the newest live instance of the run directory).
#[derive(Debug, Clone, clap::Args)]
pub struct Target {
    /// Instance prefix (default: discovered).
    #[arg(long, requires = "root")]
    pub prefix: Option<String>,
    /// Instance root (with --prefix).
    #[arg(long, requires = "prefix")]
    pub root: Option<PathBuf>,
}

impl Target {
    pub fn resolve(&self) -> anyhow::Result<Found> {
        Ok(match (&self.prefix, &self.root) {
            (Some(p), Some(r)) => {
                let instance = Instance::new(p.clone(), r.clone())?;
                let record = discovery::read(&instance.root).ok();
                Found { instance, record }
            }
            _ => discovery::find(None)?,
        })
    }
}

fn instance(env: bool, prefix: Option<&str>) -> ExitCode {
    let dir = match run_dir::run_dir() {
        Ok(d) => d,
        Err(e) => return crate::exit::fail(e),
    };
    if env {
        return match discovery::find_in(&dir, prefix) {
            Ok(f) => {
                println!(
                    "export {}={} {}={}",
                    discovery::PREFIX_VAR,
                    f.instance.prefix,
                    discovery::ROOT_VAR,
                    shell_quote(&f.instance.root.to_string_lossy())
                );
                ExitCode::SUCCESS
            }
            Err(e) => none_live(e),
        };
    }
    let listing = discovery::list(&dir);
    for u in &listing.unreadable {
        eprintln!("warning: {u}");
    }
    if listing.live.is_empty() {
        return none_live(discovery::find_in(&dir, None).err());
    }
    println!(
        "{:<28} {:<9} {:>8} {:<8} {:>9}  root",
        "prefix", "mode", "pid", "by", "age"
    );
    for l in &listing.live {
        println!("{}", row(l));
    }
    ExitCode::SUCCESS
}

fn row(l: &LiveInstance) -> String {
    let r = &l.record;
    format!(
        "{:<28} {:<9} {:>8} {:<8} {:>9}  {}",
        r.prefix,
        r.mode.name(),
        r.pid,
        r.by,
        age(l.age),
        r.root.display()
    )
}

fn age(d: Duration) -> String {
    let s = d.as_secs();
    match s {
        0..60 => format!("{:.1}s", d.as_secs_f64()),
        60..3600 => format!("{}m{:02}s", s / 60, s % 60),
        _ => format!("{}h{:02}m", s / 3600, (s % 3600) / 60),
    }
}

/// No live instance: the verdict is negative (exit 1), said on stderr.
fn none_live(e: impl Into<Option<discovery::DiscoveryError>>) -> ExitCode {
    match e.into() {
        Some(discovery::DiscoveryError::RunDir(e)) => crate::exit::fail(e),
        Some(e) => {
            eprintln!("error: {e}");
            crate::exit::negative()
        }
        None => crate::exit::negative(),
    }
}

/// Single quotes for a shell, unless the text needs none.
fn shell_quote(s: &str) -> String {
    if s.chars()
        .all(|c| c.is_ascii_alphanumeric() || "/._-+=:,".contains(c))
    {
        s.to_string()
    } else {
        format!("'{}'", s.replace('\'', r"'\''"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ages_and_quotes() {
        assert_eq!(age(Duration::from_millis(2500)), "2.5s");
        assert_eq!(age(Duration::from_secs(125)), "2m05s");
        assert_eq!(age(Duration::from_secs(7260)), "2h01m");
        assert_eq!(shell_quote("/tmp/aisle-0/p_"), "/tmp/aisle-0/p_");
        assert_eq!(shell_quote("/tmp/a b'c"), r"'/tmp/a b'\''c'");
    }
}
