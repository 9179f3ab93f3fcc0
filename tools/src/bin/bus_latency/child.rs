//! The child: joins the parent's instance, receives every message (sleeping on the
//! event service or busy polling) and reports the latencies as one JSON line.
//!
//! Knows the bus and the clock; not how the parent publishes.

use crate::args::{ChildArgs, Mode, Payload};
use crate::stats::Percentiles;
use crate::{CLOUD_COLS, CLOUD_ROWS, IDLE_TIMEOUT, JOIN_TIMEOUT};
use aisle_bus::{Bus, WaitOutcome, clock};
use aisle_messages::{Message, NodeKind, NodeState, PointCloud, TickDone, Topic, topics};
use anyhow::{Result, bail};
use serde::{Deserialize, Serialize};
use std::time::Instant;

/// What a child reports on its single stdout line.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub(crate) struct ChildReport {
    pub(crate) message: Payload,
    pub(crate) mode: Mode,
    /// Messages received.
    pub(crate) count: usize,
    /// Messages sent but never received (overwritten or timed out).
    pub(crate) lost: usize,
    pub(crate) p50_ns: u64,
    pub(crate) p99_ns: u64,
    pub(crate) max_ns: u64,
}

pub(crate) fn run_child(args: &ChildArgs) -> Result<()> {
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
