//! The parent: one fresh instance per measurement, the child started in it, the
//! messages published about [`SEND_GAP`] apart, and the children's reports as a table or
//! JSON lines.
//!
//! Knows the bus and how to start and read a child; not how the child measures.

use crate::args::{Choice, Mode, ParentArgs, Payload};
use crate::child::ChildReport;
use crate::{CLOUD_COLS, CLOUD_POINTS, CLOUD_ROWS, JOIN_TIMEOUT, SEND_GAP};
use aisle_bus::{Bus, Instance, Stamp, Subscriber, WaitOutcome};
use aisle_messages::{Heartbeat, NodeKind, NodeState, PointCloud, TickDone, TickMode, topics};
use anyhow::{Context, Result, bail};
use serde::Serialize;
use std::io::Write as _;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

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

pub(crate) fn run_parent(args: &ParentArgs) -> Result<()> {
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
            |h| h.node == NodeKind::Replay.code() && h.state == NodeState::Ready as u32,
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
                    m.node = NodeKind::Supervisor.code();
                    m.compute_ns = i;
                })?;
            }
        }
        Ok(())
    }
}
