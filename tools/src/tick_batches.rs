//! A lockstep recording regrouped tick by tick, in the order the inputs of each tick
//! must be published again to reproduce it.
//!
//! In lockstep every message carries the tick that caused it. Within tick k the
//! simulator publishes first (state, then the `Tick`), then the lidar; the supervisor
//! acts only after the pipeline acknowledged tick k, so what it publishes stamped k is
//! an input of tick k + 1. The file's own order is the recorder's receive order, which
//! may interleave the channels of one tick differently, so a batch is ordered by these
//! rules, keeping file order among samples of equal rank.
//!
//! Streams: a batch is handed out once the file has reached two ticks later (or ended),
//! so only a few ticks are held in memory. Knows the file and the message headers; it
//! does not publish anything.

use crate::payload_fields::{
    DONE_NODE_AT, DONE_STATUS_AT, SOURCE_AT, STAMP_AT, TICK_AT, TICK_STAGES_AT, u32_at, u64_at,
};
use crate::reader::{FileMessage, Messages, ReadError, RecordFile};
use aisle_messages::NodeKind;
use aisle_messages::topics::names as s;
use std::collections::BTreeMap;

/// What to take out of the file.
#[derive(Debug, Clone, Default)]
pub struct BatchOptions {
    /// Services whose samples are published again.
    pub publish: Vec<String>,
    /// Services whose samples are expected again from a live node, with that node
    /// (samples other writers published, like the supervisor's copies, are left out).
    pub outputs: Vec<(String, NodeKind)>,
}

/// Everything recorded about one tick.
#[derive(Debug, Clone, Default)]
pub struct TickBatch {
    pub tick: u64,
    /// Simulated time of the tick (of its first sample that carries one).
    pub stamp_ns: u64,
    /// Samples to publish, in publish order.
    pub publish: Vec<FileMessage>,
    /// Recorded outputs of this tick, in file order.
    pub outputs: Vec<FileMessage>,
    /// Nodes that acknowledged this tick, with the status they reported (first per node).
    pub acked: Vec<(NodeKind, u32)>,
    /// The stage flags of the tick's `Tick`, if the record holds it.
    pub stages: Option<u32>,
}

/// The header fields a batch needs, read from a payload that may have been stored
/// without its trailing zeros.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct HeaderFields {
    pub stamp_ns: u64,
    pub tick: u64,
    pub source: u32,
}

pub fn header_fields(payload: &[u8]) -> HeaderFields {
    HeaderFields {
        stamp_ns: u64_at(payload, STAMP_AT),
        tick: u64_at(payload, TICK_AT),
        source: u32_at(payload, SOURCE_AT),
    }
}

/// Publish rank inside a tick: the supervisor's samples of the tick before, then the
/// simulator's state, its `Tick`, the lidar, and the rest.
fn rank(service: &str, source: u32) -> u8 {
    match NodeKind::from_u32(source) {
        Some(NodeKind::Supervisor) => 0,
        Some(NodeKind::Simulator) if service == s::TICK => 2,
        Some(NodeKind::Simulator) => 1,
        Some(NodeKind::Lidar) => 3,
        _ => 4,
    }
}

/// True for writers that act after the pipeline finished a tick.
fn acts_after_tick(source: u32) -> bool {
    NodeKind::from_u32(source) == Some(NodeKind::Supervisor)
}

/// Iterator over the [`TickBatch`]es of a file, in tick order.
pub struct TickBatches<'a> {
    messages: Messages<'a>,
    opts: BatchOptions,
    pending: BTreeMap<u64, TickBatch>,
    /// Newest tick taken for publishing per (service, source): a simulator restarted
    /// mid-run repeats the tick it died in, and that input is published once.
    taken: BTreeMap<(String, u32), u64>,
    max_tick: Option<u64>,
    ended: bool,
    failure: Option<ReadError>,
}

impl<'a> TickBatches<'a> {
    pub fn new(file: &'a RecordFile, opts: BatchOptions) -> Self {
        Self {
            messages: file.raw_messages(),
            opts,
            pending: BTreeMap::new(),
            taken: BTreeMap::new(),
            max_tick: None,
            ended: false,
            failure: None,
        }
    }

    /// Why reading stopped early, once the iterator returned its last batch.
    pub fn take_failure(&mut self) -> Option<ReadError> {
        self.failure.take()
    }

    fn batch(&mut self, tick: u64, stamp_ns: u64) -> &mut TickBatch {
        self.pending.entry(tick).or_insert_with(|| TickBatch {
            tick,
            stamp_ns,
            ..TickBatch::default()
        })
    }

    fn take(&mut self, m: FileMessage) {
        let h = header_fields(&m.data);
        self.max_tick = Some(self.max_tick.map_or(h.tick, |t| t.max(h.tick)));
        let topic = m.channel.topic.as_str();
        if topic == s::TICK && NodeKind::from_u32(h.source) == Some(NodeKind::Simulator) {
            let stages = u32_at(&m.data, TICK_STAGES_AT);
            self.batch(h.tick, h.stamp_ns).stages.get_or_insert(stages);
        }
        if topic == s::TICK_DONE {
            let node = NodeKind::from_u32(u32_at(&m.data, DONE_NODE_AT));
            let status = u32_at(&m.data, DONE_STATUS_AT);
            let b = self.batch(h.tick, h.stamp_ns);
            if let Some(node) = node
                && !b.acked.iter().any(|(n, _)| *n == node)
            {
                b.acked.push((node, status));
            }
            return;
        }
        if self.opts.publish.iter().any(|p| p == topic) {
            let tick = if acts_after_tick(h.source) {
                h.tick + 1
            } else {
                let key = (topic.to_string(), h.source);
                if self.taken.get(&key).is_some_and(|&t| t >= h.tick) {
                    return;
                }
                self.taken.insert(key, h.tick);
                h.tick
            };
            self.batch(tick, h.stamp_ns).publish.push(m);
            return;
        }
        if self
            .opts
            .outputs
            .iter()
            .any(|(svc, node)| svc == topic && node.code() == h.source)
        {
            self.batch(h.tick, h.stamp_ns).outputs.push(m);
        }
    }

    fn finish(mut b: TickBatch) -> TickBatch {
        b.publish
            .sort_by_key(|m| rank(&m.channel.topic, header_fields(&m.data).source));
        b
    }
}

impl Iterator for TickBatches<'_> {
    type Item = TickBatch;

    fn next(&mut self) -> Option<TickBatch> {
        loop {
            if let Some((&first, _)) = self.pending.first_key_value() {
                let complete = self.ended || self.max_tick.is_some_and(|t| t >= first + 2);
                if complete {
                    let b = self.pending.pop_first().map(|(_, b)| b)?;
                    return Some(Self::finish(b));
                }
            } else if self.ended {
                return None;
            }
            match self.messages.next() {
                Some(Ok(m)) => self.take(m),
                Some(Err(e)) => {
                    self.failure = Some(e);
                    self.ended = true;
                }
                None => self.ended = true,
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synthetic::write_synthetic;
    use crate::writer::WriterOptions;
    use std::io::Cursor;
    use std::path::Path;

    fn bytes(ticks: u64) -> Vec<u8> {
        let small_chunks = WriterOptions {
            chunk_size: 64 * 1024,
            ..WriterOptions::default()
        };
        write_synthetic(Cursor::new(Vec::new()), ticks, small_chunks)
            .unwrap()
            .into_inner()
    }

    fn file(ticks: u64) -> RecordFile {
        RecordFile::from_bytes(Path::new("run.mcap"), bytes(ticks)).unwrap()
    }

    fn opts() -> BatchOptions {
        BatchOptions {
            publish: [s::TICK, s::ROBOT_STATE, s::POINT_CLOUD, s::CONTROLLER_GOAL]
                .map(String::from)
                .to_vec(),
            outputs: vec![
                (s::LOCAL_MAP.to_string(), NodeKind::Mapper),
                (s::TRAJECTORY.to_string(), NodeKind::TebController),
            ],
        }
    }

    #[test]
    fn every_tick_once_in_order_with_its_inputs_ranked() {
        let f = file(12);
        let batches: Vec<TickBatch> = TickBatches::new(&f, opts()).collect();
        let ticks: Vec<u64> = batches.iter().map(|b| b.tick).collect();
        assert_eq!(ticks, (0..12).collect::<Vec<_>>());
        for b in &batches {
            let topics: Vec<&str> = b.publish.iter().map(|m| m.channel.topic.as_str()).collect();
            let tick_at = topics.iter().position(|t| *t == s::TICK).unwrap();
            let state_at = topics.iter().position(|t| *t == s::ROBOT_STATE).unwrap();
            let cloud_at = topics.iter().position(|t| *t == s::POINT_CLOUD).unwrap();
            assert!(state_at < tick_at && tick_at < cloud_at, "{topics:?}");
            for m in &b.publish {
                let h = header_fields(&m.data);
                // Supervisor samples of tick k-1 open batch k; everything else is of k.
                if acts_after_tick(h.source) {
                    assert_eq!(h.tick + 1, b.tick);
                    assert_eq!(rank(&m.channel.topic, h.source), 0);
                } else {
                    assert_eq!(h.tick, b.tick);
                }
            }
            assert!(b.acked.iter().any(|(n, _)| *n == NodeKind::Mapper));
            assert!(
                b.outputs
                    .iter()
                    .all(|m| header_fields(&m.data).tick == b.tick)
            );
        }
        let with_traj = batches
            .iter()
            .filter(|b| b.outputs.iter().any(|m| m.channel.topic == s::TRAJECTORY))
            .count();
        assert!(with_traj > 0 && with_traj < batches.len());
    }

    #[test]
    fn a_truncated_file_gives_the_ticks_before_the_damage_and_says_so() {
        let whole = bytes(60);
        let data_end = mcap::read::footer(&whole).unwrap().summary_start as usize;
        let cut =
            RecordFile::from_bytes(Path::new("cut.mcap"), whole[..data_end / 2].to_vec()).unwrap();
        let mut it = TickBatches::new(&cut, opts());
        let n = it.by_ref().count();
        assert!(n > 0 && n < 60, "{n}");
        let e = it.take_failure().expect("the damage is reported");
        assert!(e.to_string().contains("cut.mcap"), "{e}");
    }

    #[test]
    fn header_fields_read_trimmed_payloads() {
        let mut b = vec![0u8; 20];
        b[TICK_AT..TICK_AT + 4].copy_from_slice(&7u32.to_le_bytes());
        let h = header_fields(&b);
        assert_eq!((h.tick, h.source, h.stamp_ns), (7, 0, 0));
        assert_eq!(header_fields(&[]), HeaderFields::default());
    }
}
