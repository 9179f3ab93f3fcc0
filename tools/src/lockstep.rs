//! Lockstep replay: a recorded lockstep run published again tick by tick, each tick only
//! once the live consumers acknowledged the one before, as the simulator would have
//! waited for them. With a list of outputs it is also a regression check: after each
//! tick the consumers' outputs are compared, field by field, with the recorded ones.
//!
//! Same inputs in the same order give a deterministic node the same outputs, so on an
//! unchanged build every compared payload is identical except the wall-clock fields
//! (`diff::WALL_CLOCK_FIELDS`). The first difference is reported by service, tick,
//! simulated time and field; the replay goes on to the end and counts the rest.
//!
//! Knows the bus and the file; the caller brings the live consumers (it may have
//! launched them) and a liveness probe for them. Into a live group it publishes none of
//! the group's own topics (`trust.rs`).

use crate::ack_rules::AckRules;
use crate::catalog::service_info;
use crate::diff::{WALL_CLOCK_FIELDS, first_difference};
use crate::payload_fields::{SOURCE_AT, u32_at};
use crate::raw_ports::{RawSink, RawSource, open_sink, open_source};
use crate::reader::ChannelInfo;
use crate::reader::RecordFile;
use crate::replay::{ReplayError, check_channel, recorded_channel};
use crate::tick_batches::{BatchOptions, TickBatch, TickBatches};
use aisle_bus::{Bus, BusError, Subscriber, signals};
use aisle_messages::topics::names as s;
use aisle_messages::{NodeKind, TickDone, topics};
use aisle_node::tick::Awaited;
use std::collections::BTreeMap;
use std::path::PathBuf;
use std::time::{Duration, Instant};

#[derive(Debug, Clone)]
pub struct LockstepOptions {
    pub file: PathBuf,
    /// Services published from the file; empty: every recorded service but the bus's
    /// own and those the consumers produce.
    pub publish: Vec<String>,
    /// Live nodes whose acknowledgement of a tick lets the next one go (those that
    /// acknowledged that tick in the recording).
    pub consumers: Vec<NodeKind>,
    /// Outputs compared with the recording, with the node that writes each; empty for a
    /// plain replay.
    pub compare: Vec<(String, NodeKind)>,
    /// Skip this much simulated time; the newest sample of each state service (history
    /// > 0) from the skipped part is published first, as a late subscriber would get it.
    pub start_offset_ns: u64,
    /// How long one tick may wait for its acknowledgements.
    pub ack_timeout: Duration,
}

/// The services a lockstep replay publishes when none are named: every recorded one
/// except the bus's own (announcement, heartbeats, acknowledgements) and those the
/// consumers produce themselves.
fn default_publish(
    recorded: &BTreeMap<String, ChannelInfo>,
    consumers: &[NodeKind],
) -> Vec<String> {
    recorded
        .keys()
        .filter(|t| ![s::INSTANCE, s::HEARTBEAT, s::TICK_DONE].contains(&t.as_str()))
        .filter(|t| !crate::catalog::producer(t).is_some_and(|p| consumers.contains(&p)))
        .cloned()
        .collect()
}

/// Where a live output first differed from the recording.
#[derive(Debug, Clone, PartialEq)]
pub struct Divergence {
    pub service: String,
    pub tick: u64,
    /// Simulated time of the tick.
    pub stamp_ns: u64,
    /// The field and both values, or how the sample counts differ.
    pub detail: String,
}

impl std::fmt::Display for Divergence {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} at tick {} (t = {:.1} s): {}",
            self.service,
            self.tick,
            self.stamp_ns as f64 * 1e-9,
            self.detail
        )
    }
}

#[derive(Debug, Clone, Default, PartialEq)]
pub struct LockstepSummary {
    /// Ticks replayed.
    pub ticks: u64,
    /// Samples published, per service.
    pub published: BTreeMap<String, u64>,
    /// Samples compared, per service (and `aisle/tick_done` statuses).
    pub compared: BTreeMap<String, u64>,
    /// Samples that differed, per service.
    pub diverged: BTreeMap<String, u64>,
    /// The first difference, in replay order.
    pub first: Option<Divergence>,
    /// Where a damaged file stops being readable.
    pub truncated: Option<String>,
    /// SIGINT/SIGTERM ended the replay early.
    pub stopped: bool,
    /// Consumers whose outputs of the record's last tick were not compared: the
    /// recording stopped before they acknowledged it, so it holds an unknown part of
    /// what they published for it.
    pub cut_short: Vec<NodeKind>,
}

impl LockstepSummary {
    /// Something was compared and nothing differed.
    pub fn identical(&self) -> bool {
        self.first.is_none() && self.compared.values().sum::<u64>() > 0
    }

    fn diverge(&mut self, batch: &TickBatch, service: &str, detail: String) {
        *self.diverged.entry(service.to_string()).or_default() += 1;
        if self.first.is_none() {
            self.first = Some(Divergence {
                service: service.to_string(),
                tick: batch.tick,
                stamp_ns: batch.stamp_ns,
                detail,
            });
        }
    }
}

/// Appends the payload of every sample waiting on `source` that `writer` published.
fn drain_from(
    source: &dyn RawSource,
    writer: NodeKind,
    out: &mut Vec<Vec<u8>>,
) -> Result<(), BusError> {
    let writer = writer.code();
    while source.receive_raw(&mut |bytes| {
        if u32_at(bytes, SOURCE_AT) == writer {
            out.push(bytes.to_vec());
        }
    })? {}
    Ok(())
}

/// Ports of a lockstep replay, created before any consumer starts so that nothing it
/// publishes is missed.
pub struct LockstepPorts {
    sinks: BTreeMap<String, Box<dyn RawSink>>,
    sources: Vec<(String, NodeKind, Box<dyn RawSource>)>,
    acks: Subscriber<TickDone>,
}

impl LockstepPorts {
    /// Checks every published and compared service of `file` against this build (a
    /// different layout is refused naming the service), refuses the topics a live group
    /// of the instance publishes itself, and opens the ports.
    pub fn open(
        bus: &Bus,
        file: &RecordFile,
        opts: &LockstepOptions,
    ) -> Result<LockstepPorts, ReplayError> {
        let recorded = file.recorded_raw_channels();
        let path = file.path();
        if file.run_metadata().get("mode").is_some_and(|m| m != "0") {
            return Err(ReplayError::NotLockstep {
                file: path.to_path_buf(),
            });
        }
        let publish = if opts.publish.is_empty() {
            default_publish(&recorded, &opts.consumers)
        } else {
            opts.publish.clone()
        };
        for t in &publish {
            if t == s::INSTANCE || t == s::TICK_DONE || t == s::HEARTBEAT {
                return Err(ReplayError::NotReplayable(t.clone()));
            }
            check_channel(path, recorded_channel(path, &recorded, t)?)?;
        }
        // Into a live group, none of its own topics (an instance this process created
        // and launched the consumers into has none of them yet).
        crate::replay::refuse_group_topics(bus, &publish)?;
        let mut sinks = BTreeMap::new();
        for t in &publish {
            if let Some(sink) = open_sink(bus, t)? {
                sinks.insert(t.clone(), sink);
            }
        }
        let mut sources = Vec::new();
        for (t, node) in &opts.compare {
            check_channel(path, recorded_channel(path, &recorded, t)?)?;
            if let Some(src) = open_source(bus, t)? {
                sources.push((t.clone(), *node, src));
            }
        }
        Ok(LockstepPorts {
            sinks,
            sources,
            acks: bus.subscriber(topics::TICK_DONE)?,
        })
    }
}

/// Replays `file` tick by tick through `ports`; `alive` is asked while waiting whether
/// the consumers still run (an `Err` names the one that died and ends the replay).
pub fn replay_lockstep(
    ports: &mut LockstepPorts,
    file: &RecordFile,
    opts: &LockstepOptions,
    alive: &mut dyn FnMut() -> Result<(), String>,
) -> Result<LockstepSummary, ReplayError> {
    let batch_opts = BatchOptions {
        publish: ports.sinks.keys().cloned().collect(),
        outputs: opts.compare.clone(),
    };
    let mut batches = TickBatches::new(file, batch_opts);
    let rules = AckRules::of_record(file);
    let mut summary = LockstepSummary::default();
    let mut first_stamp = None;
    let mut latched: BTreeMap<String, Vec<u8>> = BTreeMap::new();
    let mut latched_done = opts.start_offset_ns == 0;
    let mut live: Vec<Vec<u8>> = Vec::new();
    // One batch ahead, to know the last: a group stopped at the end of a mission may
    // have been recorded part-way through its final tick.
    let mut next = batches.next();
    while let Some(batch) = next.take() {
        next = batches.next();
        let last = next.is_none();
        if signals::stop_requested() {
            summary.stopped = true;
            break;
        }
        // Before the start offset: only the newest state is kept, to go out first.
        let first = *first_stamp.get_or_insert(batch.stamp_ns);
        if batch.stamp_ns < first.saturating_add(opts.start_offset_ns) {
            for m in &batch.publish {
                if topics::info(&m.channel.topic).is_some_and(|t| t.qos.history > 0) {
                    latched.insert(m.channel.topic.clone(), m.data.clone());
                }
            }
            continue;
        }
        if !latched_done {
            latched_done = true;
            for (topic, data) in std::mem::take(&mut latched) {
                publish(ports, &mut summary, &topic, &data)?;
            }
        }
        // The tick: its inputs, the consumers' acknowledgements, their outputs.
        for m in &batch.publish {
            publish(ports, &mut summary, &m.channel.topic, &m.data)?;
        }
        // What the live simulator waited for: an acknowledgement the record holds of a
        // tick the node need not answer is timing (`ack_rules.rs`).
        let pending: Vec<(NodeKind, u32)> = batch
            .acked
            .iter()
            .filter(|(n, _)| opts.consumers.contains(n) && rules.awaited(*n, batch.stages))
            .copied()
            .collect();
        let statuses = wait_acks(ports, &batch, &pending, opts.ack_timeout, alive)?;
        if !opts.compare.is_empty() {
            compare_statuses(&mut summary, &batch, &statuses);
        }
        for (service, writer, source) in &ports.sources {
            live.clear();
            drain_from(source.as_ref(), *writer, &mut live)?;
            if last && !batch.acked.iter().any(|(n, _)| n == writer) {
                if !summary.cut_short.contains(writer) {
                    summary.cut_short.push(*writer);
                }
                continue;
            }
            compare_outputs(&mut summary, &batch, service, *writer, &live);
        }
        summary.ticks += 1;
    }
    if let Some(e) = batches.take_failure() {
        summary.truncated = Some(e.to_string());
    }
    Ok(summary)
}

/// Compares the statuses the live consumers acknowledged `batch` with the recorded ones.
fn compare_statuses(
    summary: &mut LockstepSummary,
    batch: &TickBatch,
    statuses: &[(NodeKind, u32)],
) {
    for &(node, status) in statuses {
        let recorded = batch.acked.iter().find(|(n, _)| *n == node).map(|a| a.1);
        *summary
            .compared
            .entry(s::TICK_DONE.to_string())
            .or_default() += 1;
        if recorded != Some(status) {
            summary.diverge(
                batch,
                s::TICK_DONE,
                format!(
                    "{} status: recorded {}, live {status}",
                    node.name(),
                    recorded.map_or("none".to_string(), |r| r.to_string())
                ),
            );
        }
    }
}

/// Compares what `writer` published live on `service` during `batch` with the
/// recording: first the sample counts, then each pair field by field.
fn compare_outputs(
    summary: &mut LockstepSummary,
    batch: &TickBatch,
    service: &str,
    writer: NodeKind,
    live: &[Vec<u8>],
) {
    let type_name = service_info(service).map_or("", |i| i.type_name);
    let recorded = distinct(
        type_name,
        batch
            .outputs
            .iter()
            .filter(|m| m.channel.topic == service)
            .map(|m| &m.data),
    );
    let live = distinct(type_name, live.iter());
    *summary.compared.entry(service.to_string()).or_default() +=
        recorded.len().max(live.len()) as u64;
    if recorded.len() != live.len() {
        summary.diverge(
            batch,
            service,
            format!(
                "recorded {} samples, live {} (from {})",
                recorded.len(),
                live.len(),
                writer.name()
            ),
        );
        return;
    }
    for (r, l) in recorded.iter().zip(&live) {
        if let Some(d) = first_difference(type_name, r, l, &WALL_CLOCK_FIELDS) {
            summary.diverge(batch, service, d.to_string());
        }
    }
}

/// The samples in order, each one that repeats an earlier one but for its wall-clock
/// fields left out: a restarted node may send its output of the tick it resumed after
/// once more, unchanged (the controller's trajectory, to a simulator restarted with it),
/// and that is still one output.
fn distinct<'a>(type_name: &str, samples: impl Iterator<Item = &'a Vec<u8>>) -> Vec<&'a Vec<u8>> {
    let mut out: Vec<&Vec<u8>> = Vec::new();
    for s in samples {
        let seen = out
            .iter()
            .any(|o| first_difference(type_name, o, s, &WALL_CLOCK_FIELDS).is_none());
        if !seen {
            out.push(s);
        }
    }
    out
}

fn publish(
    ports: &mut LockstepPorts,
    summary: &mut LockstepSummary,
    topic: &str,
    data: &[u8],
) -> Result<(), ReplayError> {
    if let Some(sink) = ports.sinks.get_mut(topic) {
        sink.publish_raw(data)?;
        *summary.published.entry(topic.to_string()).or_default() += 1;
    }
    Ok(())
}

/// Waits until every node in `pending` acknowledged `batch.tick`; returns the statuses
/// they reported.
fn wait_acks(
    ports: &LockstepPorts,
    batch: &TickBatch,
    pending: &[(NodeKind, u32)],
    timeout: Duration,
    alive: &mut dyn FnMut() -> Result<(), String>,
) -> Result<Vec<(NodeKind, u32)>, ReplayError> {
    let mut awaited = Awaited::new();
    awaited.expect(batch.tick, pending.iter().map(|(n, _)| *n));
    let mut got = Vec::with_capacity(pending.len());
    let started = Instant::now();
    awaited.wait(
        &ports.acks,
        Duration::from_millis(100),
        |d| {
            if d.header.tick == batch.tick
                && let Some(node) = NodeKind::from_u32(d.node)
                && pending.iter().any(|(n, _)| *n == node)
                && !got.iter().any(|(n, _)| *n == node)
            {
                got.push((node, d.status));
            }
        },
        |a| {
            let waited = started.elapsed();
            if waited >= timeout {
                return Err(ReplayError::NoAck {
                    nodes: a.pending().iter().map(|n| n.name()).collect(),
                    tick: batch.tick,
                    waited_ms: waited.as_millis() as u64,
                    published: batch
                        .publish
                        .iter()
                        .map(|m| m.channel.topic.clone())
                        .collect(),
                });
            }
            alive().map_err(ReplayError::ConsumerGone)
        },
    )?;
    Ok(got)
}
