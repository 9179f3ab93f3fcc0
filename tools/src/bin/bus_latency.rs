//! Two-process latency benchmark of the aisle bus.
//!
//! The parent creates a fresh, isolated instance per measurement, re-executes this binary
//! as a child subscriber, waits for the child's `Ready` heartbeat (so the subscriber is
//! connected), then publishes `--count` messages about 1 ms apart, so each one is
//! measured on its own rather than queued behind the previous one. The child takes
//! `monotonic_ns()` at receipt minus `header.publish_wall_ns` (CLOCK_MONOTONIC is
//! system-wide, so the two processes' stamps can be subtracted) and prints p50/p99/max as
//! one JSON line. Four measurements are made: a 447 KB point cloud and a 64-byte
//! `TickDone`, each with the child sleeping on the event service (`wakeup`) or busy
//! polling `receive()` (`poll`).
//!
//! This tool knows the bus API and the two message types only; it does not know what
//! the navigation processes do with them. Every instance is removed afterwards and the
//! run fails if anything is left in /dev/shm or under the root directory.
//!
//! Usage: `bus_latency [--quick] [--count N] [--json]`. `--quick` is `--count 200`;
//! `--json` prints one JSON object per measurement instead of the table.

use aisle_bus::{Bus, Instance, Stamp, Subscriber, WaitOutcome, clock};
use aisle_messages::{
    Heartbeat, Message, NodeKind, NodeState, PointCloud, TickDone, TickMode, Topic, topics,
};
use anyhow::{Context, Result, bail};
use serde::{Deserialize, Serialize};
use std::io::Write as _;
use std::path::PathBuf;
use std::process::{Command, ExitCode, Stdio};
use std::time::{Duration, Instant};

/// Messages per measurement unless told otherwise.
const DEFAULT_COUNT: usize = 2000;
/// Messages per measurement with `--quick`.
const QUICK_COUNT: usize = 200;
/// Gap between two sends: long enough for the child to take each message before the next.
const SEND_GAP: Duration = Duration::from_millis(1);
/// Lidar geometry of the scenario: 31 channels x 1201 azimuth steps.
const CLOUD_ROWS: u32 = 31;
const CLOUD_COLS: u32 = 1201;
const CLOUD_POINTS: usize = (CLOUD_ROWS * CLOUD_COLS) as usize;
const _: () = assert!(CLOUD_POINTS <= aisle_messages::MAX_CLOUD_POINTS);
/// How long the parent waits for a child to join, and a child for the supervisor.
const JOIN_TIMEOUT: Duration = Duration::from_secs(10);
/// A child gives up when no message arrived for this long (lost messages, dead parent).
const IDLE_TIMEOUT: Duration = Duration::from_secs(5);

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let result = if args.iter().any(|a| a == "--child") {
        child_args(&args).and_then(|c| run_child(&c))
    } else {
        parent_args(&args).and_then(|p| run_parent(&p))
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("bus_latency: {e:#}");
            ExitCode::FAILURE
        }
    }
}

/// Which message is sent.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
enum Payload {
    Cloud,
    Small,
}

impl Payload {
    fn name(self) -> &'static str {
        match self {
            Payload::Cloud => "cloud",
            Payload::Small => "small",
        }
    }

    fn parse(s: &str) -> Result<Payload> {
        match s {
            "cloud" => Ok(Payload::Cloud),
            "small" => Ok(Payload::Small),
            _ => bail!("--message must be cloud or small, not {s:?}"),
        }
    }

    /// Bytes the publisher writes per message: the used points for the cloud, the whole
    /// message for the small one.
    fn bytes(self) -> usize {
        match self {
            Payload::Cloud => CLOUD_POINTS * std::mem::size_of::<[f32; 3]>(),
            Payload::Small => std::mem::size_of::<TickDone>(),
        }
    }
}

/// How the child waits for a message.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
enum Mode {
    Wakeup,
    Poll,
}

impl Mode {
    fn name(self) -> &'static str {
        match self {
            Mode::Wakeup => "wakeup",
            Mode::Poll => "poll",
        }
    }

    fn parse(s: &str) -> Result<Mode> {
        match s {
            "wakeup" => Ok(Mode::Wakeup),
            "poll" => Ok(Mode::Poll),
            _ => bail!("--mode must be wakeup or poll, not {s:?}"),
        }
    }
}

/// What a child reports on its single stdout line.
#[derive(Debug, Clone, Serialize, Deserialize)]
struct ChildReport {
    message: Payload,
    mode: Mode,
    /// Messages received.
    count: usize,
    /// Messages sent but never received (overwritten or timed out).
    lost: usize,
    p50_ns: u64,
    p99_ns: u64,
    max_ns: u64,
}

/// One row of the parent's output.
#[derive(Debug, Serialize)]
struct Row {
    message: Payload,
    bytes: usize,
    mode: Mode,
    count: usize,
    lost: usize,
    p50_us: f64,
    p99_us: f64,
    max_us: f64,
}

// ---------------------------------------------------------------------------------------
// Command lines

struct ParentArgs {
    count: usize,
    json: bool,
}

struct ChildArgs {
    instance: Instance,
    mode: Mode,
    message: Payload,
    count: usize,
}

fn parent_args(args: &[String]) -> Result<ParentArgs> {
    let mut out = ParentArgs {
        count: DEFAULT_COUNT,
        json: false,
    };
    let mut it = args.iter();
    while let Some(a) = it.next() {
        match a.as_str() {
            "--quick" => out.count = QUICK_COUNT,
            "--json" => out.json = true,
            "--count" => out.count = parse_count(it.next())?,
            _ => {
                bail!("unknown argument {a:?} (usage: bus_latency [--quick] [--count N] [--json])")
            }
        }
    }
    Ok(out)
}

fn child_args(args: &[String]) -> Result<ChildArgs> {
    let (mut prefix, mut root, mut mode, mut message, mut count) = (None, None, None, None, None);
    let mut it = args.iter();
    while let Some(a) = it.next() {
        let mut value = || it.next().with_context(|| format!("{a} needs a value"));
        match a.as_str() {
            "--child" => {}
            "--prefix" => prefix = Some(value()?.clone()),
            "--root" => root = Some(PathBuf::from(value()?)),
            "--mode" => mode = Some(Mode::parse(value()?)?),
            "--message" => message = Some(Payload::parse(value()?)?),
            "--count" => count = Some(parse_count(Some(value()?))?),
            _ => bail!("unknown child argument {a:?}"),
        }
    }
    let instance = Instance::new(
        prefix.context("--prefix is required")?,
        root.context("--root is required")?,
    )?;
    Ok(ChildArgs {
        instance,
        mode: mode.context("--mode is required")?,
        message: message.context("--message is required")?,
        count: count.context("--count is required")?,
    })
}

fn parse_count(v: Option<&String>) -> Result<usize> {
    let v = v.context("--count needs a value")?;
    let n: usize = v
        .parse()
        .with_context(|| format!("--count {v:?} is not a number"))?;
    if n == 0 {
        bail!("--count must be at least 1");
    }
    Ok(n)
}

// ---------------------------------------------------------------------------------------
// Parent: publisher and driver

fn run_parent(args: &ParentArgs) -> Result<()> {
    let base = std::env::temp_dir().join("aisle-bench");
    let mut rows = Vec::new();
    for message in [Payload::Cloud, Payload::Small] {
        for mode in [Mode::Wakeup, Mode::Poll] {
            let report = measure(&base, message, mode, args.count)
                .with_context(|| format!("{} / {}", message.name(), mode.name()))?;
            rows.push(Row {
                message,
                bytes: message.bytes(),
                mode,
                count: report.count,
                lost: report.lost,
                p50_us: report.p50_ns as f64 / 1e3,
                p99_us: report.p99_ns as f64 / 1e3,
                max_us: report.max_ns as f64 / 1e3,
            });
        }
    }
    // Only succeeds when empty, i.e. when no other run is using it.
    let _ = std::fs::remove_dir(&base);
    print_rows(&rows, args.json)?;
    // Losses are a result (the subscriber fell more than a buffer behind, e.g. a busy
    // poller preempted on a loaded machine), not a failure of the run: report them.
    for r in rows.iter().filter(|r| r.lost > 0) {
        eprintln!(
            "bus_latency: {} / {}: {} of {} messages lost",
            r.message.name(),
            r.mode.name(),
            r.lost,
            args.count
        );
    }
    Ok(())
}

fn print_rows(rows: &[Row], json: bool) -> Result<()> {
    let mut out = std::io::stdout().lock();
    if json {
        for r in rows {
            writeln!(out, "{}", serde_json::to_string(r)?)?;
        }
        return Ok(());
    }
    writeln!(
        out,
        "{:<8} {:>8} {:<7} {:>6} {:>5} {:>9} {:>9} {:>9}",
        "message", "bytes", "mode", "count", "lost", "p50 us", "p99 us", "max us"
    )?;
    for r in rows {
        writeln!(
            out,
            "{:<8} {:>8} {:<7} {:>6} {:>5} {:>9.1} {:>9.1} {:>9.1}",
            r.message.name(),
            r.bytes,
            r.mode.name(),
            r.count,
            r.lost,
            r.p50_us,
            r.p99_us,
            r.max_us
        )?;
    }
    Ok(())
}

/// One measurement in its own instance, removed afterwards whatever happened.
fn measure(
    base: &std::path::Path,
    message: Payload,
    mode: Mode,
    count: usize,
) -> Result<ChildReport> {
    let instance = Instance::unique(base);
    let result = measure_in(&instance, message, mode, count);
    instance
        .remove()
        .with_context(|| format!("removing instance {}", instance.prefix))?;
    if !instance.is_gone() {
        bail!(
            "instance {} left files behind: {:?}",
            instance.prefix,
            instance.shm_files()
        );
    }
    result
}

fn measure_in(
    instance: &Instance,
    message: Payload,
    mode: Mode,
    count: usize,
) -> Result<ChildReport> {
    let (bus, info) = Bus::create_instance(instance, 0, TickMode::Lockstep)?;
    let heartbeats = bus.subscriber(topics::HEARTBEAT)?;
    let mut sender = Sender::new(&bus, message)?;

    let mut child = Command::new(std::env::current_exe().context("locating this binary")?)
        .args(["--child", "--prefix", &instance.prefix, "--root"])
        .arg(&instance.root)
        .args(["--mode", mode.name(), "--message", message.name()])
        .args(["--count", &count.to_string()])
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
        .spawn()
        .context("starting the child")?;

    // The child's heartbeat proves its subscriber exists; meanwhile keep handing the
    // instance announcement (history) to the child's late subscriber.
    let ready = wait_ready(&heartbeats, &info, &mut child);
    let sent = ready.and_then(|()| {
        sender.update_connections()?;
        for i in 1..=count as u64 {
            sender.send(i)?;
            std::thread::sleep(SEND_GAP);
        }
        Ok(())
    });
    if let Err(e) = sent {
        let _ = child.kill();
        let _ = child.wait();
        return Err(e);
    }

    let output = child.wait_with_output().context("waiting for the child")?;
    if !output.status.success() {
        bail!("the child failed: {}", output.status);
    }
    let stdout = String::from_utf8_lossy(&output.stdout);
    let line = stdout.lines().last().context("the child printed nothing")?;
    let report: ChildReport =
        serde_json::from_str(line).with_context(|| format!("the child printed {line:?}"))?;
    if report.message != message || report.mode != mode {
        bail!("the child measured {line}");
    }
    // Drop every port and the node before the instance's files are removed.
    drop((sender, heartbeats, info, bus));
    Ok(report)
}

fn wait_ready(
    heartbeats: &Subscriber<Heartbeat>,
    info: &aisle_bus::Publisher<aisle_messages::InstanceInfo>,
    child: &mut std::process::Child,
) -> Result<()> {
    let start = Instant::now();
    while start.elapsed() < JOIN_TIMEOUT {
        info.update_connections()?;
        let (outcome, _) = heartbeats.wait_for(
            Duration::from_millis(20),
            |h| h.node == NodeKind::Replay as u32 && h.state == NodeState::Ready as u32,
            || {},
        )?;
        if outcome == WaitOutcome::Matched {
            return Ok(());
        }
        if let Some(status) = child.try_wait()? {
            bail!("the child exited before it was ready: {status}");
        }
    }
    bail!("the child was not ready within {JOIN_TIMEOUT:?}")
}

/// The parent's publisher of the measured message.
enum Sender {
    Cloud(aisle_bus::Publisher<PointCloud>),
    Small(aisle_bus::Publisher<TickDone>),
}

impl Sender {
    fn new(bus: &Bus, message: Payload) -> Result<Sender> {
        Ok(match message {
            Payload::Cloud => Sender::Cloud(bus.publisher(topics::POINT_CLOUD)?),
            Payload::Small => Sender::Small(bus.publisher(topics::TICK_DONE)?),
        })
    }

    fn update_connections(&self) -> Result<()> {
        match self {
            Sender::Cloud(p) => p.update_connections()?,
            Sender::Small(p) => p.update_connections()?,
        }
        Ok(())
    }

    /// Publishes message `i` (carried in `header.tick`); the bus stamps the send time.
    fn send(&mut self, i: u64) -> Result<()> {
        let stamp = Stamp {
            tick: i,
            ..Stamp::default()
        };
        match self {
            Sender::Cloud(p) => {
                p.publish(stamp, |m| {
                    m.rows = CLOUD_ROWS;
                    m.cols = CLOUD_COLS;
                    // Write every used point so the payload really is touched.
                    let v = i as f32;
                    for (k, pt) in m.points[..CLOUD_POINTS].iter_mut().enumerate() {
                        *pt = [v, k as f32, 1.0];
                    }
                })?;
            }
            Sender::Small(p) => {
                p.publish(stamp, |m| {
                    m.node = NodeKind::Supervisor as u32;
                    m.compute_ns = i;
                })?;
            }
        }
        Ok(())
    }
}

// ---------------------------------------------------------------------------------------
// Child: subscriber and statistics

fn run_child(args: &ChildArgs) -> Result<()> {
    let (bus, _info) = Bus::join(&args.instance, NodeKind::Replay, JOIN_TIMEOUT)?;
    let report = match args.message {
        Payload::Cloud => receive_all(&bus, topics::POINT_CLOUD, args, |m: &PointCloud| {
            m.rows == CLOUD_ROWS && m.cols == CLOUD_COLS
        })?,
        Payload::Small => receive_all(&bus, topics::TICK_DONE, args, |_: &TickDone| true)?,
    };
    println!("{}", serde_json::to_string(&report)?);
    Ok(())
}

/// Receives until message `count` arrived or nothing came for [`IDLE_TIMEOUT`], and
/// summarises the latencies. `valid` checks that the payload is what the parent wrote.
fn receive_all<M: Message>(
    bus: &Bus,
    topic: Topic<M>,
    args: &ChildArgs,
    valid: impl Fn(&M) -> bool,
) -> Result<ChildReport> {
    let sub = bus.subscriber(topic)?;
    // Kept until the end: the parent maps the heartbeat from this publisher's memory.
    let mut heartbeat = bus.heartbeat()?;
    heartbeat.send(NodeState::Ready, "")?;

    let mut latencies = Vec::with_capacity(args.count);
    let last = args.count as u64;
    let mut newest = 0;
    let mut idle_since = Instant::now();
    while newest < last {
        let sample = match args.mode {
            Mode::Wakeup => match sub.wait_for(IDLE_TIMEOUT, |_| true, || {})? {
                (WaitOutcome::Matched, s) => s,
                (WaitOutcome::TimedOut, _) => None,
            },
            Mode::Poll => sub.receive()?,
        };
        // Read the clock before anything else touches the sample.
        let now = clock::monotonic_ns();
        let Some(sample) = sample else {
            if idle_since.elapsed() >= IDLE_TIMEOUT {
                break;
            }
            std::hint::spin_loop();
            continue;
        };
        idle_since = Instant::now();
        let header = Message::header(&*sample);
        if !valid(&sample) {
            bail!("message {} has an unexpected payload", header.tick);
        }
        latencies.push(now.saturating_sub(header.publish_wall_ns));
        newest = newest.max(header.tick);
    }
    drop(heartbeat);
    let stats = Percentiles::of(&mut latencies);
    Ok(ChildReport {
        message: args.message,
        mode: args.mode,
        count: latencies.len(),
        lost: args.count - latencies.len(),
        p50_ns: stats.p50,
        p99_ns: stats.p99,
        max_ns: stats.max,
    })
}

/// Nearest-rank percentiles of a set of samples (all zero when empty).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Percentiles {
    p50: u64,
    p99: u64,
    max: u64,
}

impl Percentiles {
    fn of(samples: &mut [u64]) -> Percentiles {
        samples.sort_unstable();
        let rank = |p: f64| -> u64 {
            if samples.is_empty() {
                return 0;
            }
            let k = (p * samples.len() as f64).ceil() as usize;
            samples[k.clamp(1, samples.len()) - 1]
        };
        Percentiles {
            p50: rank(0.50),
            p99: rank(0.99),
            max: samples.last().copied().unwrap_or(0),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn percentiles_use_nearest_rank() {
        let mut v: Vec<u64> = (1..=100).rev().collect();
        assert_eq!(
            Percentiles::of(&mut v),
            Percentiles {
                p50: 50,
                p99: 99,
                max: 100
            }
        );
        let mut one = vec![7];
        assert_eq!(Percentiles::of(&mut one).p99, 7);
        assert_eq!(Percentiles::of(&mut []).max, 0);
    }

    #[test]
    fn cloud_payload_is_the_scenario_scan() {
        assert_eq!(CLOUD_POINTS, 37_231);
        assert_eq!(Payload::Cloud.bytes(), 446_772);
        assert_eq!(Payload::Small.bytes(), 64);
    }

    #[test]
    fn arguments_parse_and_reject() {
        let s = |v: &[&str]| v.iter().map(|x| x.to_string()).collect::<Vec<_>>();
        assert_eq!(parent_args(&s(&["--quick"])).unwrap().count, QUICK_COUNT);
        assert!(parent_args(&s(&["--count", "0"])).is_err());
        assert!(parent_args(&s(&["--bogus"])).is_err());
        let c = child_args(&s(&[
            "--child",
            "--prefix",
            "abc_",
            "--root",
            "/tmp/x",
            "--mode",
            "poll",
            "--message",
            "small",
            "--count",
            "5",
        ]))
        .unwrap();
        assert_eq!(
            (c.mode, c.message, c.count),
            (Mode::Poll, Payload::Small, 5)
        );
        assert!(child_args(&s(&["--child", "--prefix", "abc_"])).is_err());
    }
}
