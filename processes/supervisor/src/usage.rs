//! What each process of the group cost the machine over its life: peak resident memory,
//! memory locked at the end (`lock_memory`, `realtime.toml`), voluntary and involuntary context switches, minor and major page faults and CPU
//! time, read from `/proc/<pid>/status` and `/proc/<pid>/stat` just before the
//! supervisor stops the node (a restarted node: its last incarnation only).
//!
//! Knows the `/proc` formats; not the bus or the run. A process whose entry cannot be
//! read or parsed is left out, never an error.

use serde::{Deserialize, Serialize};
use std::fmt::Write as _;

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ProcessUsage {
    pub process: String,
    pub pid: u32,
    /// Peak resident set size (`VmHWM`), KiB.
    pub peak_rss_kib: u64,
    /// Locked memory (`VmLck`) when read, KiB: what the kernel charges against
    /// RLIMIT_MEMLOCK, whole mappings whether touched or not.
    #[serde(default)]
    pub locked_kib: u64,
    pub voluntary_switches: u64,
    pub involuntary_switches: u64,
    pub minor_faults: u64,
    pub major_faults: u64,
    /// User plus system CPU time, seconds.
    pub cpu_s: f64,
}

/// The usage of process `pid` so far, named `name`.
pub fn read(name: &str, pid: u32) -> Option<ProcessUsage> {
    let status = std::fs::read_to_string(format!("/proc/{pid}/status")).ok()?;
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).ok()?;
    // SAFETY: sysconf only reads a configuration value.
    let ticks = unsafe { libc::sysconf(libc::_SC_CLK_TCK) };
    parse(name, pid, &status, &stat, ticks.max(1) as f64)
}

/// Parses the two files; `ticks_per_s` is the clock tick of `stat`'s times.
fn parse(name: &str, pid: u32, status: &str, stat: &str, ticks_per_s: f64) -> Option<ProcessUsage> {
    let key = |k: &str| {
        status.lines().find_map(|l| {
            let v = l.strip_prefix(k)?.strip_prefix(':')?;
            v.split_whitespace().next()?.parse::<u64>().ok()
        })
    };
    // The fields after the command name (which may hold spaces and parentheses):
    // state is field 3, so field n is at index n - 3.
    let rest: Vec<&str> = stat
        .get(stat.rfind(')')? + 1..)?
        .split_whitespace()
        .collect();
    let field = |n: usize| rest.get(n - 3)?.parse::<u64>().ok();
    Some(ProcessUsage {
        process: name.to_string(),
        pid,
        peak_rss_kib: key("VmHWM")?,
        locked_kib: key("VmLck").unwrap_or(0),
        voluntary_switches: key("voluntary_ctxt_switches")?,
        involuntary_switches: key("nonvoluntary_ctxt_switches")?,
        minor_faults: field(10)?,
        major_faults: field(12)?,
        cpu_s: (field(14)? + field(15)?) as f64 / ticks_per_s,
    })
}

/// The table as text, one process a line.
pub fn format_table(rows: &[ProcessUsage]) -> String {
    let mut out = format!(
        "{:<16} {:>12} {:>10} {:>9} {:>11} {:>13} {:>12} {:>12}\n",
        "process",
        "peak RSS MiB",
        "locked MiB",
        "cpu s",
        "vol. switch",
        "invol. switch",
        "minor faults",
        "major faults"
    );
    for r in rows {
        let _ = writeln!(
            out,
            "{:<16} {:>12.1} {:>10.1} {:>9.2} {:>11} {:>13} {:>12} {:>12}",
            r.process,
            r.peak_rss_kib as f64 / 1024.0,
            r.locked_kib as f64 / 1024.0,
            r.cpu_s,
            r.voluntary_switches,
            r.involuntary_switches,
            r.minor_faults,
            r.major_faults
        );
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    const STATUS: &str = "Name:\taisle\nVmPeak:\t  100 kB\nVmLck:\t  2048 kB\nVmHWM:\t   20480 kB\n\
        voluntary_ctxt_switches:\t17\nnonvoluntary_ctxt_switches:\t3\n";
    // A command name with a space and a parenthesis.
    const STAT: &str = "4242 (ai) sle) S 1 4242 4242 0 -1 4194304 120 0 7 0 250 50 0 0 20 0 3";

    #[test]
    fn status_and_stat_are_parsed() {
        let u = parse("lidar", 4242, STATUS, STAT, 100.0).unwrap();
        assert_eq!(u.peak_rss_kib, 20480);
        assert_eq!(u.locked_kib, 2048);
        assert_eq!((u.voluntary_switches, u.involuntary_switches), (17, 3));
        assert_eq!((u.minor_faults, u.major_faults), (120, 7));
        assert_eq!(u.cpu_s, 3.0);
        assert!(format_table(&[u]).contains("lidar"));
        assert!(parse("x", 1, "VmHWM:\t1 kB\n", STAT, 100.0).is_none());
        assert!(parse("x", 1, STATUS, "garbage", 100.0).is_none());
    }

    #[test]
    fn this_process_can_be_read() {
        let u = read("self", std::process::id()).unwrap();
        assert!(u.peak_rss_kib > 0 && u.minor_faults > 0);
    }
}
