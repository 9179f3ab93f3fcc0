//! Two-process latency benchmark of the aisle bus.
//!
//! The parent creates a fresh, isolated instance per measurement, re-executes this binary
//! as a child subscriber, waits for the child's `Ready` heartbeat (so the subscriber is
//! connected), then publishes `--count` messages about 1 ms apart, so each one is
//! measured on its own rather than queued behind the previous one. The child takes
//! `monotonic_ns()` at receipt minus `header.publish_wall_ns` (CLOCK_MONOTONIC is
//! system-wide, so the two processes' stamps can be subtracted) and prints p50/p99/max as
//! one JSON line. Four measurements are made: a 447 KB point cloud and a 72-byte
//! `TickDone`, each with the child sleeping on the event service (`wakeup`) or busy
//! polling `receive()` (`poll`).
//!
//! This tool knows the bus API and the two message types only; it does not know what
//! the navigation processes do with them. Every instance is removed afterwards and the
//! run fails if anything is left in /dev/shm or under the root directory.
//!
//! Usage: `bus_latency [--quick] [--count N] [--json]`. `--quick` is `--count 200`;
//! `--json` prints one JSON object per measurement instead of the table.
//!
//! Modules: [`args`] (command lines), [`parent`] (publisher and driver), [`child`]
//! (subscriber), [`stats`] (percentiles).

mod args;
mod child;
mod parent;
mod stats;

use std::process::ExitCode;
use std::time::Duration;

/// Messages per measurement unless told otherwise.
pub(crate) const DEFAULT_COUNT: usize = 2000;
/// Messages per measurement with `--quick`.
pub(crate) const QUICK_COUNT: usize = 200;
/// Gap between two sends: long enough for the child to take each message before the next.
pub(crate) const SEND_GAP: Duration = Duration::from_millis(1);
/// Lidar geometry of the scenario: 31 channels x 1201 azimuth steps.
pub(crate) const CLOUD_ROWS: u32 = 31;
pub(crate) const CLOUD_COLS: u32 = 1201;
pub(crate) const CLOUD_POINTS: usize = (CLOUD_ROWS * CLOUD_COLS) as usize;
const _: () = assert!(CLOUD_POINTS <= aisle_messages::MAX_CLOUD_POINTS);
/// How long the parent waits for a child to join, and a child for the supervisor.
pub(crate) const JOIN_TIMEOUT: Duration = Duration::from_secs(10);
/// A child gives up when no message arrived for this long (lost messages, dead parent).
pub(crate) const IDLE_TIMEOUT: Duration = Duration::from_secs(5);

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let result = if args.iter().any(|a| a == "--child") {
        args::child_args(&args).and_then(|c| child::run_child(&c))
    } else {
        args::parent_args(&args).and_then(|p| parent::run_parent(&p))
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("bus_latency: {e:#}");
            ExitCode::FAILURE
        }
    }
}
