//! `aisle instance`, `aisle topics`, `aisle echo` and `aisle hz`: looking at a running
//! instance from outside its group. Finding the instance is `aisle_bus::discovery`'s;
//! listing, decoding and timing samples is `aisle_tools::inspect`'s. This module only
//! turns arguments into calls and results into lines and exit codes.

use aisle_bus::discovery::{self, Found, LiveInstance};
use aisle_bus::{Bus, Instance, run_dir};
use aisle_messages::NodeKind;
use aisle_tools::inspect::{self, EchoOptions, rate::RateStats, text::TextOptions};
use std::io::Write;
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
    /// The live topics of an instance: message type, publishers and subscribers, and
    /// the rate measured over --window.
    #[command(after_help = "Exit: 0 listed, 2 could not (no instance, bus error).")]
    Topics {
        #[command(flatten)]
        target: Target,
        /// How long to measure rates (e.g. 1s, 500ms).
        #[arg(long, default_value = "1s", value_parser = parse_duration)]
        window: Duration,
    },
    /// Print the samples of a topic as text (field names and values, long arrays cut).
    #[command(
        after_help = "Exit: 0 printed (--count reached, or Ctrl-C), 1 --timeout \
passed before --count samples, or the instance ended (its owner stopped the group), 2 \
could not (no instance, unknown topic)."
    )]
    Echo {
        /// The topic, e.g. aisle/robot_state (`aisle topics` lists them).
        topic: String,
        #[command(flatten)]
        target: Target,
        /// Stop after N samples.
        #[arg(long)]
        count: Option<u64>,
        /// Stop after one sample (--count 1).
        #[arg(long, conflicts_with = "count")]
        once: bool,
        /// Give up after this long (e.g. 10s).
        #[arg(long, value_parser = parse_duration)]
        timeout: Option<Duration>,
        /// Elements shown of an array of numbers.
        #[arg(long, default_value_t = 8)]
        max_values: usize,
    },
    /// The rate of a topic and the min/max/std of its period, per --window.
    #[command(
        after_help = "Exit: 0 measured (--count windows, or Ctrl-C), 1 the instance \
ended first (its owner stopped the group), 2 could not (no instance, unknown topic)."
    )]
    Hz {
        /// The topic, e.g. aisle/lidar/points (`aisle topics` lists them).
        topic: String,
        #[command(flatten)]
        target: Target,
        /// Length of one measurement window (e.g. 1s, 500ms).
        #[arg(long, default_value = "1s", value_parser = parse_duration)]
        window: Duration,
        /// Stop after N windows.
        #[arg(long)]
        count: Option<u64>,
    },
}

pub fn main(cmd: InspectCommand) -> ExitCode {
    match cmd {
        InspectCommand::Instance { env, prefix } => instance(env, prefix.as_deref()),
        InspectCommand::Topics { target, window } => topics(&target, window),
        InspectCommand::Echo {
            topic,
            target,
            count,
            once,
            timeout,
            max_values,
        } => {
            let opts = EchoOptions {
                count: if once { Some(1) } else { count },
                timeout,
                text: TextOptions {
                    numbers: max_values,
                    ..TextOptions::default()
                },
            };
            echo(&target, &topic, &opts)
        }
        InspectCommand::Hz {
            topic,
            target,
            window,
            count,
        } => hz(&target, &topic, window, count),
    }
}

/// `1s`, `250ms`, `2.5` (seconds): positive and finite.
fn parse_duration(s: &str) -> Result<Duration, String> {
    let (num, scale) = match s.strip_suffix("ms") {
        Some(n) => (n, 1e-3),
        None => (s.strip_suffix('s').unwrap_or(s), 1.0),
    };
    match num.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 && v * scale < 1e6 => {
            Ok(Duration::from_secs_f64(v * scale))
        }
        _ => Err(format!(
            "`{s}` is not a positive duration (e.g. 1s, 500ms, 2.5)"
        )),
    }
}

/// Joins the target instance as an observer.
fn join(target: &Target) -> anyhow::Result<Bus> {
    let found = target.resolve()?;
    let (bus, _) = Bus::join(&found.instance, NodeKind::Replay, Duration::from_secs(2))?;
    Ok(bus)
}

fn topics(target: &Target, window: Duration) -> ExitCode {
    let rows = match join(target).and_then(|bus| Ok(inspect::topics(&bus, window)?)) {
        Ok(r) => r,
        Err(e) => return crate::exit::fail(format!("{e:#}")),
    };
    println!(
        "{:<30} {:<26} {:>9} {:>4} {:>4}",
        "topic", "type", "rate/s", "pub", "sub"
    );
    for r in &rows {
        let rate = r.rate_hz.map_or("-".into(), |h| format!("{h:.1}"));
        let (p, s) = r.ports.map_or(("-".into(), "-".into()), |(p, s)| {
            (p.to_string(), s.to_string())
        });
        println!("{:<30} {:<26} {rate:>9} {p:>4} {s:>4}", r.name, r.type_name);
    }
    ExitCode::SUCCESS
}

fn echo(target: &Target, topic: &str, opts: &EchoOptions) -> ExitCode {
    let mut print = |text: &str| {
        let mut out = std::io::stdout().lock();
        let _ = writeln!(out, "{text}---");
        let _ = out.flush();
    };
    let printed =
        match join(target).and_then(|bus| Ok(inspect::echo(&bus, topic, opts, &mut print)?)) {
            Ok(n) => n,
            Err(e) => return failed(&e),
        };
    match opts.count {
        Some(c) if printed < c && !aisle_bus::signals::stop_requested() => {
            eprintln!("error: {printed} of {c} samples of {topic} before the timeout");
            crate::exit::negative()
        }
        _ => ExitCode::SUCCESS,
    }
}

fn hz(target: &Target, topic: &str, window: Duration, count: Option<u64>) -> ExitCode {
    let mut report = |s: Option<RateStats>| match s {
        Some(s) => println!(
            "average rate: {:.3}\n\tmin: {:.4}s max: {:.4}s std dev: {:.5}s window: {}",
            s.rate_hz, s.min_period_s, s.max_period_s, s.std_period_s, s.samples
        ),
        None => println!("no new messages"),
    };
    match join(target).and_then(|bus| Ok(inspect::hz(&bus, topic, window, count, &mut report)?)) {
        Ok(_) => ExitCode::SUCCESS,
        Err(e) => failed(&e),
    }
}

/// The exit of a failed `echo` or `hz`: 1 when the instance ended under it (the group
/// it watched is over, as `--timeout` passing is), else 2.
fn failed(e: &anyhow::Error) -> ExitCode {
    if let Some(ended @ inspect::InspectError::Ended(..)) = e.downcast_ref() {
        eprintln!("error: {ended}");
        return crate::exit::negative();
    }
    crate::exit::fail(format!("{e:#}"))
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
        assert_eq!(parse_duration("1s"), Ok(Duration::from_secs(1)));
        assert_eq!(parse_duration("250ms"), Ok(Duration::from_millis(250)));
        assert_eq!(parse_duration("2.5"), Ok(Duration::from_millis(2500)));
        for bad in ["0", "-1s", "x", "nanms", "1e9"] {
            assert!(parse_duration(bad).is_err(), "{bad}");
        }
    }
}
