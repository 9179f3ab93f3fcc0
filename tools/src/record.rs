//! The recorder node: joins an instance, subscribes to every service and writes one MCAP
//! file (raw channels, Foxglove viewer channels, config files as attachments).
//!
//! Two threads: the node thread only drains the subscribers and copies each payload into
//! a reused buffer (so the small iceoryx2 buffers never overflow while a chunk is being
//! compressed); a writer thread converts and writes. Lost data is counted, never silent:
//! gaps in a publisher's sequence numbers (the recorder fell behind and iceoryx2 overwrote
//! samples) and samples refused because the writer queue was full are logged and written
//! into the file's `aisle.recorder` metadata. The file is finalised on SIGINT/SIGTERM, on
//! a bus error and when the parent process goes away.

use crate::aligned::AlignedBuf;
use crate::catalog::services;
use crate::viewer::{ViewerConverter, ViewerOptions};
use crate::writer::{RecordWriter, WriteError, WriterOptions, media_type, trimmed_len};
use aisle_bus::{Bus, BusError, NodeArgs, NodeError, Publisher, Stamp, Subscriber, clock, signals};
use aisle_messages::topics::{Topic, TopicVisitor};
use aisle_messages::{InstanceInfo, Message, NodeKind, NodeState, StageStatus, TickDone, topics};
use aisle_node::Graph;
use std::collections::{BTreeMap, HashMap};
use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::mpsc;
use std::time::Duration;

/// How the recorder writes and how much it may buffer.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RecorderOptions {
    pub writer: WriterOptions,
    pub viewer: ViewerOptions,
    /// Payload bytes that may wait for the writer thread; beyond, samples are dropped
    /// (and counted).
    pub queue_bytes: usize,
    /// Wall time between flushes (each closes a chunk, so a killed recorder still leaves
    /// a readable prefix).
    pub flush_period: Duration,
    /// Longest sleep while no data arrives.
    pub poll_period: Duration,
    /// Finalise once no other process published anything for this long (a recorder
    /// attached to a running group ends with it); `None`: only on a stop request.
    pub idle_stop: Option<Duration>,
}

impl Default for RecorderOptions {
    fn default() -> Self {
        Self {
            writer: WriterOptions::default(),
            viewer: ViewerOptions::default(),
            queue_bytes: 512 * 1024 * 1024,
            flush_period: Duration::from_secs(1),
            poll_period: Duration::from_millis(1),
            idle_stop: None,
        }
    }
}

/// What a recording contains and what it lost.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct RecordSummary {
    pub path: PathBuf,
    /// Samples written, per service.
    pub written: BTreeMap<&'static str, u64>,
    /// Samples missing from a publisher's sequence (overwritten before the recorder read
    /// them), per service.
    pub lost_in_bus: BTreeMap<&'static str, u64>,
    /// Samples dropped because the writer queue was full, per service.
    pub lost_in_queue: BTreeMap<&'static str, u64>,
    pub viewer_messages: u64,
    pub attachments: u64,
}

impl RecordSummary {
    pub fn lost(&self) -> u64 {
        self.lost_in_bus.values().sum::<u64>() + self.lost_in_queue.values().sum::<u64>()
    }
}

/// The node body with default options: returns when SIGINT/SIGTERM arrives (the file
/// is then complete), or with an error (the file is finalised all the same when it
/// was created).
pub fn run_recorder(args: &NodeArgs, out: &Path) -> Result<(), NodeError> {
    let summary = run_recorder_with(args, out, &RecorderOptions::default())?;
    tracing::info!(
        "recorder: {} finalised: {} samples, {} viewer messages, {} lost",
        summary.path.display(),
        summary.written.values().sum::<u64>(),
        summary.viewer_messages,
        summary.lost()
    );
    Ok(())
}

enum Job {
    /// A payload without its trailing zeros, and its full length.
    Raw {
        index: usize,
        log_time: u64,
        buf: AlignedBuf,
        full_len: usize,
    },
    Metadata(String, BTreeMap<String, String>),
    Attach {
        name: String,
        media_type: &'static str,
        data: Vec<u8>,
        time: u64,
    },
}

/// A subscriber whose samples are handed over as bytes.
trait RawSource {
    fn index(&self) -> usize;
    /// Calls `f` with the next sample's bytes; false when there was none.
    fn next_bytes(&self, f: &mut dyn FnMut(&[u8])) -> Result<bool, BusError>;
}

struct Source<M: Message> {
    index: usize,
    sub: Subscriber<M>,
}

impl<M: Message> RawSource for Source<M> {
    fn index(&self) -> usize {
        self.index
    }

    fn next_bytes(&self, f: &mut dyn FnMut(&[u8])) -> Result<bool, BusError> {
        match self.sub.receive()? {
            Some(sample) => {
                f(crate::aligned::message_bytes::<M>(&sample));
                Ok(true)
            }
            None => Ok(false),
        }
    }
}

struct Subscribe<'b> {
    bus: &'b Bus,
    sources: Vec<Box<dyn RawSource>>,
    error: Option<BusError>,
}

impl TopicVisitor for Subscribe<'_> {
    fn visit<T: Message>(&mut self, topic: Topic<T>) {
        if self.error.is_some() {
            return;
        }
        match self.bus.subscriber(topic) {
            Ok(sub) => self.sources.push(Box::new(Source::<T> {
                index: self.sources.len(),
                sub,
            })),
            Err(e) => self.error = Some(e),
        }
    }
}

/// One source per topic, in the order of `topics::ALL`.
fn subscribe_all(bus: &Bus) -> Result<Vec<Box<dyn RawSource>>, BusError> {
    let mut visitor = Subscribe {
        bus,
        sources: Vec::new(),
        error: None,
    };
    topics::for_each(&mut visitor);
    match visitor.error {
        Some(e) => Err(e),
        None => Ok(visitor.sources),
    }
}

/// Tracks each publisher's sequence numbers to find lost and repeated samples.
#[derive(Debug, Default)]
struct SeqTracker {
    last: HashMap<(usize, u32), u64>,
}

enum SeqVerdict {
    New { lost: u64 },
    Repeat,
}

impl SeqTracker {
    fn check(&mut self, index: usize, bytes: &[u8]) -> SeqVerdict {
        let word = |at: usize| {
            let mut b = [0u8; 8];
            b.copy_from_slice(&bytes[at..at + 8]);
            u64::from_le_bytes(b)
        };
        let seq = word(0);
        // Header.source sits after seq, stamp_ns, tick, tick_wall_ns, publish_wall_ns.
        let source = word(40) as u32;
        match self.last.insert((index, source), seq) {
            // A redelivered history sample (the same one we already have).
            Some(last) if last == seq => SeqVerdict::Repeat,
            Some(last) if seq > last => SeqVerdict::New {
                lost: seq - last - 1,
            },
            // First sample of this publisher, or it restarted its count.
            _ => SeqVerdict::New { lost: 0 },
        }
    }
}

/// Like [`run_recorder`], with options, returning what was recorded and lost.
pub fn run_recorder_with(
    args: &NodeArgs,
    out: &Path,
    options: &RecorderOptions,
) -> Result<RecordSummary, NodeError> {
    let parent = std::os::unix::process::parent_id();
    let graph = Graph::load_dir(&args.config_dir).map_err(|e| NodeError::setup("recorder", e))?;
    let mut answer = AnswerRule::of(&graph);
    let (bus, info) = Bus::join(&args.instance, NodeKind::Recorder, NodeArgs::JOIN_TIMEOUT)?;
    let sources = subscribe_all(&bus)?;
    let mut heartbeat = bus.heartbeat()?;
    let mut acks = bus.publisher(topics::TICK_DONE)?;

    let file = File::create(out)
        .map_err(|e| NodeError::setup(format!("recorder: output {}", out.display()), e))?;
    let writer = RecordWriter::new(BufWriter::with_capacity(1 << 20, file), options.writer)
        .map_err(|e| NodeError::setup(format!("recorder: output {}", out.display()), e))?;
    let catalog = services();
    let names: Vec<&'static str> = catalog.iter().map(|i| i.service).collect();
    let (jobs, job_rx) = mpsc::channel::<Job>();
    let (free_tx, free_rx) = mpsc::channel::<(usize, AlignedBuf)>();
    let queued = Arc::new(AtomicUsize::new(0));
    let writer_thread = {
        let queued = queued.clone();
        let names = names.clone();
        let viewer = options.viewer;
        let flush_period = options.flush_period.as_nanos() as u64;
        std::thread::Builder::new()
            .name("recorder-writer".into())
            .spawn(move || {
                write_loop(
                    writer,
                    job_rx,
                    free_tx,
                    &queued,
                    &names,
                    viewer,
                    flush_period,
                )
            })
            .map_err(|e| NodeError::setup("recorder: writer thread", e))?
    };

    let now = clock::monotonic_ns();
    let _ = jobs.send(Job::Metadata("aisle".into(), run_metadata(args, &info)));
    for (name, path) in config_files(&args.config_dir) {
        match std::fs::read(&path) {
            Ok(data) => {
                let _ = jobs.send(Job::Attach {
                    name,
                    media_type: media_type(&path),
                    data,
                    time: now,
                });
            }
            Err(e) => tracing::warn!("recorder: cannot attach {}: {e}", path.display()),
        }
    }
    heartbeat.send(NodeState::Ready, "")?;

    let mut summary = RecordSummary {
        path: out.to_path_buf(),
        ..RecordSummary::default()
    };
    let loop_result = drain_loop(
        &mut acks,
        &sources,
        &jobs,
        &free_rx,
        &queued,
        options,
        &names,
        &mut summary,
        &mut heartbeat,
        parent,
        &mut answer,
    );
    let _ = heartbeat.send(NodeState::Stopping, "");

    let mut stats = BTreeMap::new();
    for (name, map) in [
        ("lost_in_bus", &summary.lost_in_bus),
        ("lost_in_queue", &summary.lost_in_queue),
    ] {
        for (service, n) in map {
            stats.insert(format!("{name}:{service}"), n.to_string());
        }
    }
    stats.insert("lost_total".into(), summary.lost().to_string());
    if let Err(e) = &loop_result {
        stats.insert("ended_by".into(), e.to_string());
    }
    let _ = jobs.send(Job::Metadata("aisle.recorder".into(), stats));
    drop(jobs);
    let written = writer_thread
        .join()
        .map_err(|_| NodeError::Protocol("recorder: the writer thread panicked".into()))?
        .map_err(|e| NodeError::Protocol(format!("recorder: writing {}: {e}", out.display())))?;
    summary.written = written.raw;
    summary.viewer_messages = written.viewer;
    summary.attachments = written.attachments;
    if summary.lost() > 0 {
        tracing::warn!(
            "recorder: lost {} samples (bus: {:?}, queue: {:?})",
            summary.lost(),
            summary.lost_in_bus,
            summary.lost_in_queue
        );
    }
    match loop_result {
        Ok(()) => Ok(summary),
        Err(NodeError::Bus(BusError::StopRequested)) => Ok(summary),
        Err(e) => Err(e),
    }
}

/// When the recorder acknowledges tick t: once every node its graph entry lists in
/// `after` acknowledged t (raw `TickDone` payloads: node code and tick).
#[derive(Debug)]
struct AnswerRule {
    after: Vec<u32>,
    /// Ticks with some but not all of those acknowledgements, and who gave them.
    partial: BTreeMap<u64, Vec<u32>>,
}

impl AnswerRule {
    fn of(graph: &Graph) -> AnswerRule {
        let after = graph
            .node(NodeKind::Recorder)
            .map(|d| d.after.iter().filter_map(|a| NodeKind::from_name(a)))
            .into_iter()
            .flatten()
            .map(|k| k as u32)
            .collect();
        AnswerRule {
            after,
            partial: BTreeMap::new(),
        }
    }

    /// Notes `node`'s acknowledgement of `tick`; true when that completes the tick.
    fn note(&mut self, tick: u64, node: u32) -> bool {
        if !self.after.contains(&node) {
            return false;
        }
        let seen = self.partial.entry(tick).or_default();
        if !seen.contains(&node) {
            seen.push(node);
        }
        if seen.len() < self.after.len() {
            return false;
        }
        self.partial.remove(&tick);
        // Older incomplete ticks will not complete any more.
        self.partial.retain(|t, _| *t > tick);
        true
    }
}

/// Offsets in a `TickDone` payload: the header's tick and the acknowledging node.
const TICK_DONE_TICK_AT: usize = 16;
const TICK_DONE_NODE_AT: usize = 48;
/// Offset of `Header.source` in every payload.
const HEADER_SOURCE_AT: usize = std::mem::offset_of!(aisle_messages::Header, source);

fn le_u64(b: &[u8], at: usize) -> Option<u64> {
    b.get(at..at + 8)
        .map(|w| u64::from_le_bytes(w.try_into().unwrap_or([0; 8])))
}

fn le_u32(b: &[u8], at: usize) -> Option<u32> {
    b.get(at..at + 4)
        .map(|w| u32::from_le_bytes(w.try_into().unwrap_or([0; 4])))
}

#[allow(clippy::too_many_arguments)]
fn drain_loop(
    acks: &mut Publisher<TickDone>,
    sources: &[Box<dyn RawSource>],
    jobs: &mpsc::Sender<Job>,
    free: &mpsc::Receiver<(usize, AlignedBuf)>,
    queued: &AtomicUsize,
    options: &RecorderOptions,
    names: &[&'static str],
    summary: &mut RecordSummary,
    heartbeat: &mut aisle_bus::HeartbeatSender,
    parent: u32,
    answer: &mut AnswerRule,
) -> Result<(), NodeError> {
    let mut pool: Vec<Vec<AlignedBuf>> = vec![Vec::new(); sources.len()];
    let mut seqs = SeqTracker::default();
    let mut warned: Vec<bool> = vec![false; sources.len()];
    let mut writer_gone = false;
    let tick_done = names.iter().position(|n| *n == topics::TICK_DONE.name);
    // The acknowledgements of the recorder's `after` nodes (the supervisor's) are the
    // last messages of tick k; once everything before them is drained, the recorder
    // acknowledges k too, and a lockstep simulator that waits for it loses nothing.
    // A repeated one is answered too: a restarted simulator repeats the tick it died in
    // and waits for everyone again.
    let mut unanswered: Option<u64> = None;
    let mut last_traffic = std::time::Instant::now();
    loop {
        if signals::stop_requested() {
            return Err(BusError::StopRequested.into());
        }
        if std::os::unix::process::parent_id() != parent {
            tracing::warn!("recorder: the parent process exited; finalising");
            return Ok(());
        }
        while let Ok((i, buf)) = free.try_recv() {
            pool[i].push(buf);
        }
        let mut received = 0usize;
        for src in sources {
            let i = src.index();
            loop {
                let log_time = clock::monotonic_ns();
                let mut job = None;
                let got = src.next_bytes(&mut |bytes| {
                    if le_u32(bytes, HEADER_SOURCE_AT) != Some(NodeKind::Recorder as u32) {
                        last_traffic = std::time::Instant::now();
                    }
                    if Some(i) == tick_done
                        && let Some(node) = le_u32(bytes, TICK_DONE_NODE_AT)
                        && let Some(t) = le_u64(bytes, TICK_DONE_TICK_AT)
                        && answer.note(t, node)
                    {
                        unanswered = Some(unanswered.map_or(t, |s: u64| s.max(t)));
                    }
                    match seqs.check(i, bytes) {
                        SeqVerdict::Repeat => return,
                        SeqVerdict::New { lost } if lost > 0 => {
                            *summary.lost_in_bus.entry(names[i]).or_default() += lost;
                            if !warned[i] {
                                warned[i] = true;
                                tracing::warn!(
                                    "recorder: {} lost {lost} samples on {} (counting on)",
                                    "fell behind:",
                                    names[i]
                                );
                            }
                        }
                        SeqVerdict::New { .. } => {}
                    }
                    // Only the used part is copied out of shared memory (the unused
                    // capacity of clouds and grids is zero): less time in this thread.
                    let used = &bytes[..trimmed_len(bytes)];
                    if queued.load(Ordering::Relaxed) + used.len() > options.queue_bytes {
                        *summary.lost_in_queue.entry(names[i]).or_default() += 1;
                        return;
                    }
                    let mut buf = pool[i].pop().unwrap_or_default();
                    buf.set(used);
                    queued.fetch_add(used.len(), Ordering::Relaxed);
                    job = Some(Job::Raw {
                        index: i,
                        log_time,
                        buf,
                        full_len: bytes.len(),
                    });
                })?;
                if !got {
                    break;
                }
                received += 1;
                if let Some(job) = job
                    && jobs.send(job).is_err()
                {
                    writer_gone = true;
                }
            }
        }
        if writer_gone {
            // The writer stopped on an error; it is reported when the thread is joined.
            return Err(NodeError::Protocol("recorder: the writer stopped".into()));
        }
        heartbeat.tick(NodeState::Running)?;
        if received == 0 {
            if let Some(t) = unanswered.take() {
                acks.publish(
                    Stamp {
                        tick: t,
                        ..Stamp::default()
                    },
                    |m| {
                        m.node = NodeKind::Recorder as u32;
                        m.status = StageStatus::Done as u32;
                    },
                )?;
            }
            if let Some(idle) = options.idle_stop
                && last_traffic.elapsed() >= idle
            {
                tracing::info!(
                    "recorder: nothing published for {:.1} s; the group has ended, finalising",
                    idle.as_secs_f64()
                );
                return Ok(());
            }
            std::thread::sleep(options.poll_period);
        }
    }
}

fn write_loop<W: std::io::Write + std::io::Seek>(
    mut writer: RecordWriter<W>,
    jobs: mpsc::Receiver<Job>,
    free: mpsc::Sender<(usize, AlignedBuf)>,
    queued: &AtomicUsize,
    names: &[&'static str],
    viewer_options: ViewerOptions,
    flush_period_ns: u64,
) -> Result<crate::writer::WriteCounts, WriteError> {
    let mut viewer = ViewerConverter::new(viewer_options);
    let mut converted = Vec::new();
    let mut full = AlignedBuf::new();
    let mut last_flush = clock::monotonic_ns();
    for job in jobs {
        match job {
            Job::Raw {
                index,
                log_time,
                buf,
                full_len,
            } => {
                queued.fetch_sub(buf.len(), Ordering::Relaxed);
                full.set_padded(buf.bytes(), full_len);
                writer.write_raw_at(index, log_time, full.bytes())?;
                converted.clear();
                viewer.convert(names[index], &full, &mut converted);
                for m in &converted {
                    writer.write_viewer(m, log_time)?;
                }
                let _ = free.send((index, buf));
            }
            Job::Metadata(name, entries) => writer.write_metadata(&name, entries)?,
            Job::Attach {
                name,
                media_type,
                data,
                time,
            } => writer.attach(&name, media_type, &data, time)?,
        }
        let now = clock::monotonic_ns();
        if now.saturating_sub(last_flush) >= flush_period_ns {
            writer.flush()?;
            last_flush = now;
        }
    }
    Ok(writer.finish()?.1)
}

fn run_metadata(args: &NodeArgs, info: &InstanceInfo) -> BTreeMap<String, String> {
    BTreeMap::from([
        ("schema_hash".into(), aisle_messages::schema_hash_hex()),
        (
            "announced_schema_hash".into(),
            format!("{:016x}", info.schema_hash),
        ),
        ("seed".into(), info.seed.to_string()),
        ("mode".into(), info.mode.to_string()),
        ("instance".into(), args.instance.prefix.clone()),
        ("dt_ns".into(), args.dt_ns.to_string()),
        ("controller_every".into(), args.controller_every.to_string()),
        (
            "start".into(),
            format!("{} {} {}", args.start[0], args.start[1], args.start[2]),
        ),
        ("config_dir".into(), args.config_dir.display().to_string()),
    ])
}

/// Regular files of the config directory and its direct subdirectories, sorted, named
/// relative to it.
pub fn config_files(dir: &Path) -> Vec<(String, PathBuf)> {
    let mut out = Vec::new();
    let mut dirs = vec![(dir.to_path_buf(), 0)];
    while let Some((d, depth)) = dirs.pop() {
        let Ok(entries) = std::fs::read_dir(&d) else {
            continue;
        };
        for e in entries.filter_map(Result::ok) {
            let path = e.path();
            let Ok(ft) = e.file_type() else { continue };
            if ft.is_dir() && depth < 1 {
                dirs.push((path, depth + 1));
            } else if ft.is_file() {
                let name = path
                    .strip_prefix(dir)
                    .unwrap_or(&path)
                    .to_string_lossy()
                    .into_owned();
                out.push((name, path));
            }
        }
    }
    out.sort();
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn header_bytes(seq: u64, source: u32) -> Vec<u8> {
        let mut b = vec![0u8; 72];
        b[0..8].copy_from_slice(&seq.to_le_bytes());
        b[40..44].copy_from_slice(&source.to_le_bytes());
        b
    }

    #[test]
    fn sequence_gaps_count_as_lost_and_repeats_are_skipped() {
        let mut t = SeqTracker::default();
        assert!(matches!(
            t.check(0, &header_bytes(5, 1)),
            SeqVerdict::New { lost: 0 }
        ));
        assert!(matches!(
            t.check(0, &header_bytes(6, 1)),
            SeqVerdict::New { lost: 0 }
        ));
        assert!(matches!(
            t.check(0, &header_bytes(9, 1)),
            SeqVerdict::New { lost: 2 }
        ));
        assert!(matches!(
            t.check(0, &header_bytes(9, 1)),
            SeqVerdict::Repeat
        ));
        // Another publisher on the same service has its own count.
        assert!(matches!(
            t.check(0, &header_bytes(1, 2)),
            SeqVerdict::New { lost: 0 }
        ));
        // A restarted publisher counts from 1 again: not a loss.
        assert!(matches!(
            t.check(0, &header_bytes(1, 1)),
            SeqVerdict::New { lost: 0 }
        ));
    }

    #[test]
    fn header_offsets_match_the_message_crate() {
        let f = aisle_messages::Header::FIELDS;
        let at = |n: &str| f.iter().find(|x| x.name == n).unwrap().offset;
        assert_eq!(at("seq"), 0);
        assert_eq!(at("stamp_ns"), 8);
        assert_eq!(at("source"), 40);
    }

    #[test]
    fn config_files_are_listed_sorted_and_relative() {
        let dir = std::env::temp_dir().join(format!("aisle-tools-cfg-{}", std::process::id()));
        std::fs::create_dir_all(dir.join("maps")).unwrap();
        std::fs::write(dir.join("b.toml"), "x").unwrap();
        std::fs::write(dir.join("a.urdf"), "y").unwrap();
        std::fs::write(dir.join("maps/m.pgm"), "z").unwrap();
        let files = config_files(&dir);
        let names: Vec<_> = files.iter().map(|(n, _)| n.as_str()).collect();
        assert_eq!(names, ["a.urdf", "b.toml", "maps/m.pgm"]);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
