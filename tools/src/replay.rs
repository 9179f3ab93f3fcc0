//! Publishes the raw payloads of a recorded file into a live instance, byte for byte.
//!
//! Before anything is published, every selected channel is checked against this build:
//! same message type, size and layout hash, else the file is refused naming the service.
//! Pacing follows the recorded `log_time` (sim time in a lockstep record, so it plays at
//! the speed of the mission; the receive time in a realtime one) scaled by a rate, against
//! absolute deadlines on the monotonic clock so errors do not accumulate; without a rate
//! messages go out as fast as possible. A start offset skips the beginning but first
//! publishes the newest sample of each state service (history > 0: maps, goals, band),
//! as a late subscriber would have received it. A truncated file is replayed as far as
//! it can be read, and the summary says where it ends. Publishers hand their history to
//! late subscribers, as live ones do. Into a live instance it publishes no topic that
//! the instance's group publishes itself (`trust.rs`). Without a supervisor the replay
//! creates the instance itself (`replay_own.rs`). Lockstep replay (waiting for the consumers'
//! acknowledgements) is not done here.

use crate::catalog::{ServiceInfo, service_info, services};
use crate::raw_ports::{RawSink, open_sink};
use crate::reader::{ChannelInfo, ReadError, RecordFile};
use aisle_bus::{Bus, BusError, Instance, OwnerWatch, clock, signals};
use aisle_messages::topics::names as s;
use aisle_messages::{NodeKind, topics};
use std::collections::BTreeMap;
use std::path::PathBuf;
use std::time::Duration;

#[derive(Debug, Clone)]
pub struct ReplayOptions {
    pub file: PathBuf,
    /// The live instance to publish into.
    pub instance: Instance,
    /// Speed relative to the recording (2.0 = twice as fast); `None` = as fast as possible.
    pub rate: Option<f64>,
    /// Services to publish; empty = every recorded service except the instance
    /// announcement and heartbeats (those belong to the live processes).
    pub topics: Vec<String>,
    /// Skip this much recorded time from the first message on.
    pub start_offset_ns: u64,
    /// How long to wait for the live supervisor's announcement.
    pub join_timeout: Duration,
    /// Pause after creating the publishers, so live subscribers connect before the
    /// first sample goes out.
    pub settle: Duration,
    /// Create `instance` rather than join it (no supervisor needed): announced with the
    /// record's seed and clock mode, and removed when the replay ends (`replay_own.rs`).
    pub create: bool,
    /// Play the file again from its start when it ends, until a stop request.
    pub looping: bool,
    /// Before the first sample, wait until the replayed topics have at least this many
    /// subscribers together (0: do not wait).
    pub wait_subscribers: usize,
}

impl ReplayOptions {
    pub fn new(file: impl Into<PathBuf>, instance: Instance) -> Self {
        Self {
            file: file.into(),
            instance,
            rate: Some(1.0),
            topics: Vec::new(),
            start_offset_ns: 0,
            join_timeout: Duration::from_secs(10),
            settle: Duration::from_millis(200),
            create: false,
            looping: false,
            wait_subscribers: 0,
        }
    }
}

#[derive(Debug, Clone, Default, PartialEq)]
pub struct ReplaySummary {
    /// Samples published, per service.
    pub published: BTreeMap<String, u64>,
    /// Samples before the start offset that were not published.
    pub skipped: u64,
    /// State samples published first because of the start offset.
    pub latched: u64,
    /// Largest delay behind the paced deadline.
    pub max_lateness_ns: u64,
    /// Where a damaged file stops being readable (`None` when read to the end).
    pub truncated: Option<String>,
    /// True when SIGINT/SIGTERM ended the replay early.
    pub stopped: bool,
    /// The file was written by a build with another schema hash, but every replayed
    /// service has the same layout as ours.
    pub foreign_schema_hash: Option<String>,
    /// Passes over the file begun (more than one with `looping`).
    pub passes: u64,
    /// A live instance's owner ended it under the replay: why (the replay stopped there).
    pub ended: Option<String>,
}

impl ReplaySummary {
    pub fn total(&self) -> u64 {
        self.published.values().sum()
    }
}

#[derive(Debug, thiserror::Error)]
pub enum ReplayError {
    #[error(transparent)]
    Read(#[from] ReadError),
    #[error(
        "refusing {}: service `{}` was recorded as {} ({} bytes, layout {}) but this build has {} ({} bytes, layout {}); replay it with the build that recorded it",
        .0.file.display(), .0.service, .0.file_type, .0.file_size, .0.file_layout, .0.our_type, .0.our_size, .0.our_layout
    )]
    LayoutMismatch(Box<LayoutMismatch>),
    #[error("{file}: topic `{topic}` is not an aisle service this build knows")]
    UnknownTopic { file: PathBuf, topic: String },
    #[error("{file} has no recorded samples of `{topic}`")]
    TopicNotRecorded { file: PathBuf, topic: String },
    #[error("`{0}` is not replayed: the live supervisor announces the instance itself")]
    NotReplayable(String),
    #[error("invalid replay rate {0}: give a positive finite number")]
    InvalidRate(f64),
    #[error(transparent)]
    Bus(#[from] BusError),
    #[error(
        "{file} was recorded in realtime: a lockstep replay needs a lockstep recording (`aisle run` without --realtime)"
    )]
    NotLockstep { file: PathBuf },
    #[error(
        "no acknowledgement of tick {tick} from {} after {waited_ms} ms (the tick published {})",
        nodes.join(", "),
        if published.is_empty() { "nothing".to_string() } else { published.join(", ") }
    )]
    NoAck {
        nodes: Vec<&'static str>,
        tick: u64,
        waited_ms: u64,
        /// The services the tick's samples went to, in order: what the node was given.
        published: Vec<String>,
    },
    #[error("{0}")]
    ConsumerGone(String),
    #[error(
        "refusing to publish into instance {prefix}: its live group publishes {}; its subscribers would take the replayed samples for that publisher's own. Leave these out of --topics, or replay without --prefix/--root into an instance of the replay's own",
        crate::trust::describe(.refused)
    )]
    GroupTopics {
        prefix: String,
        refused: Vec<crate::trust::GroupTopic>,
    },
}

/// A recorded channel whose layout differs from this build's.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LayoutMismatch {
    pub file: PathBuf,
    pub service: String,
    pub file_type: String,
    pub file_size: String,
    pub file_layout: String,
    pub our_type: &'static str,
    pub our_size: usize,
    pub our_layout: String,
}

/// Checks a recorded raw channel against this build.
pub fn check_channel(file: &std::path::Path, c: &ChannelInfo) -> Result<ServiceInfo, ReplayError> {
    if service_info(&c.topic).is_none()
        && let Some(type_name) = c.meta("type_name")
    {
        // A user topic of the recorded run's graph (`[[topic]]`): declared as the record
        // says, its layout then checked below like any other. A name or type that
        // cannot be a user topic stays unknown.
        let _ = aisle_messages::user_topics::declare(&c.topic, type_name);
    }
    let ours = service_info(&c.topic).ok_or_else(|| ReplayError::UnknownTopic {
        file: file.to_path_buf(),
        topic: c.topic.clone(),
    })?;
    let file_type = c.meta("type_name").unwrap_or("<none>");
    let file_size = c.meta("size").unwrap_or("<none>");
    let file_layout = c.meta("layout_hash").unwrap_or("<none>");
    if file_type != ours.type_name
        || file_size != ours.size.to_string()
        || file_layout != ours.layout_hash_hex()
    {
        return Err(ReplayError::LayoutMismatch(Box::new(LayoutMismatch {
            file: file.to_path_buf(),
            service: c.topic.clone(),
            file_type: file_type.to_string(),
            file_size: file_size.to_string(),
            file_layout: file_layout.to_string(),
            our_type: ours.type_name,
            our_size: ours.size,
            our_layout: ours.layout_hash_hex(),
        })));
    }
    Ok(ours)
}

/// The recorded channel of `topic`: a service of this build that the file holds.
pub(crate) fn recorded_channel<'a>(
    path: &std::path::Path,
    recorded: &'a BTreeMap<String, ChannelInfo>,
    topic: &str,
) -> Result<&'a ChannelInfo, ReplayError> {
    if service_info(topic).is_none() {
        return Err(ReplayError::UnknownTopic {
            file: path.to_path_buf(),
            topic: topic.to_string(),
        });
    }
    recorded
        .get(topic)
        .ok_or_else(|| ReplayError::TopicNotRecorded {
            file: path.to_path_buf(),
            topic: topic.to_string(),
        })
}

/// The services a replay publishes, after checking each against this build.
pub fn plan(
    file: &RecordFile,
    topics: &[String],
) -> Result<(Vec<String>, Option<String>), ReplayError> {
    let recorded = file.recorded_raw_channels();
    let path = file.path();
    let selected: Vec<String> = if topics.is_empty() {
        recorded
            .keys()
            .filter(|t| *t != s::INSTANCE && *t != s::HEARTBEAT)
            .cloned()
            .collect()
    } else {
        for t in topics {
            if t == s::INSTANCE {
                return Err(ReplayError::NotReplayable(t.clone()));
            }
            recorded_channel(path, &recorded, t)?;
        }
        topics.to_vec()
    };
    let mut foreign = None;
    for t in &selected {
        let c = &recorded[t];
        check_channel(path, c)?;
        if let Some(h) = c.meta("schema_hash")
            && h != aisle_messages::schema_hash_hex()
        {
            foreign = Some(h.to_string());
        }
    }
    Ok((selected, foreign))
}

/// Replays a recorded file into a live instance, or into one of its own with
/// `opts.create` (see the module docs).
pub fn replay(opts: &ReplayOptions) -> Result<ReplaySummary, ReplayError> {
    if let Some(r) = opts.rate
        && !(r.is_finite() && r > 0.0)
    {
        return Err(ReplayError::InvalidRate(r));
    }
    let file = RecordFile::open(&opts.file)?;
    let (selected, foreign) = plan(&file, &opts.topics)?;
    if opts.create {
        return crate::replay_own::replay_own(opts, &file, &selected, foreign);
    }
    let (bus, _info) = Bus::join(&opts.instance, NodeKind::Replay, opts.join_timeout)?;
    refuse_group_topics(&bus, &selected)?;
    publish_file(&bus, &file, &selected, opts, foreign, None)
}

/// Refuses, before anything is published, the topics the live group of `bus`'s
/// instance publishes itself (`trust.rs`).
pub fn refuse_group_topics(bus: &Bus, topics: &[String]) -> Result<(), ReplayError> {
    let refused = crate::trust::live_group_topics(bus, topics)?;
    if refused.is_empty() {
        return Ok(());
    }
    Err(ReplayError::GroupTopics {
        prefix: bus.instance().prefix.clone(),
        refused,
    })
}

/// Opens a publisher per selected service and plays the file through them, once or
/// (`looping`) until a stop request. `announcement`: the instance's announcement when
/// this process created it, handed to joiners along with the state history.
pub(crate) fn publish_file(
    bus: &Bus,
    file: &RecordFile,
    selected: &[String],
    opts: &ReplayOptions,
    foreign: Option<String>,
    announcement: Option<&dyn RawSink>,
) -> Result<ReplaySummary, ReplayError> {
    let catalog = services();
    let mut sinks: Vec<Option<Box<dyn RawSink>>> = Vec::with_capacity(catalog.len());
    for info in &catalog {
        sinks.push(if selected.iter().any(|t| t == info.service) {
            open_sink(bus, info.service)?
        } else {
            None
        });
    }
    let mut pass = Pass {
        sinks,
        catalog,
        announcement,
        refreshed_ns: 0,
        // Into a live group: stop when its owner ends it, as `echo` does, instead of
        // publishing into an instance being removed.
        watch: announcement
            .is_none()
            .then(|| OwnerWatch::new(bus.instance())),
        ended: None,
    };
    let mut summary = ReplaySummary {
        foreign_schema_hash: foreign,
        ..ReplaySummary::default()
    };
    let settled = pass.sleep_until(clock::monotonic_ns() + opts.settle.as_nanos() as u64)?;
    if !settled || !pass.wait_for_subscribers(bus, selected, opts.wait_subscribers)? {
        summary.stopped = true;
    } else {
        loop {
            summary.passes += 1;
            pass.play(file, opts, &mut summary)?;
            if !opts.looping || summary.stopped || summary.truncated.is_some() {
                break;
            }
        }
    }
    // Stopped by the instance's end, not by a signal.
    if let Some(why) = pass.ended.take() {
        summary.ended = Some(why);
        summary.stopped = false;
    }
    Ok(summary)
}

/// The publishers of one replay, and when they last handed history to new subscribers.
struct Pass<'a> {
    sinks: Vec<Option<Box<dyn RawSink>>>,
    catalog: Vec<ServiceInfo>,
    announcement: Option<&'a dyn RawSink>,
    refreshed_ns: u64,
    watch: Option<OwnerWatch>,
    /// Why the watched instance ended, once it has.
    ended: Option<String>,
}

impl Pass<'_> {
    /// Connects subscribers that joined since the last call (at most every 20 ms), so a
    /// late one receives the newest state sample as from a live publisher.
    fn refresh(&mut self) -> Result<(), BusError> {
        let now = clock::monotonic_ns();
        if now.saturating_sub(self.refreshed_ns) >= 20_000_000 {
            self.refreshed_ns = now;
            for s in self.sinks.iter().flatten() {
                s.update_connections()?;
            }
            if let Some(a) = self.announcement {
                a.update_connections()?;
            }
        }
        Ok(())
    }

    fn publish(
        &mut self,
        i: usize,
        data: &[u8],
        summary: &mut ReplaySummary,
    ) -> Result<(), BusError> {
        if let Some(sink) = self.sinks[i].as_mut() {
            sink.publish_raw(data)?;
            *summary
                .published
                .entry(self.catalog[i].service.to_string())
                .or_default() += 1;
        }
        Ok(())
    }

    /// Whether the watched live instance has ended (its reason kept in `ended`).
    fn instance_ended(&mut self) -> bool {
        if self.ended.is_none()
            && let Some(why) = self.watch.as_mut().and_then(|w| w.ended())
        {
            self.ended = Some(why.to_string());
        }
        self.ended.is_some()
    }

    /// One pass over the file.
    fn play(
        &mut self,
        file: &RecordFile,
        opts: &ReplayOptions,
        summary: &mut ReplaySummary,
    ) -> Result<(), ReplayError> {
        let mut first_log_time = None;
        let mut pacing: Option<(u64, u64)> = None; // (recorded t0, wall t0)
        let mut latched: BTreeMap<usize, Vec<u8>> = BTreeMap::new();
        let mut latched_done = opts.start_offset_ns == 0;
        for m in file.raw_messages() {
            let m = match m {
                Ok(m) => m,
                Err(e) => {
                    summary.truncated = Some(e.to_string());
                    break;
                }
            };
            if signals::stop_requested() || self.instance_ended() {
                summary.stopped = true;
                break;
            }
            let Some(i) = self
                .catalog
                .iter()
                .position(|c| c.service == m.channel.topic)
            else {
                continue;
            };
            let first = *first_log_time.get_or_insert(m.log_time);
            if self.sinks[i].is_none() {
                continue;
            }
            if m.log_time < first.saturating_add(opts.start_offset_ns) {
                summary.skipped += 1;
                if topics::info(&m.channel.topic).is_some_and(|t| t.qos.history > 0) {
                    latched.insert(i, m.data);
                }
                continue;
            }
            if !latched_done {
                latched_done = true;
                for (li, data) in std::mem::take(&mut latched) {
                    self.publish(li, &data, summary)?;
                    summary.latched += 1;
                }
            }
            if let Some(rate) = opts.rate {
                let (t0, w0) = *pacing.get_or_insert((m.log_time, clock::monotonic_ns()));
                let due = w0 + ((m.log_time.saturating_sub(t0)) as f64 / rate) as u64;
                if !self.sleep_until(due)? {
                    summary.stopped = true;
                    break;
                }
                summary.max_lateness_ns = summary
                    .max_lateness_ns
                    .max(clock::monotonic_ns().saturating_sub(due));
            }
            self.refresh()?;
            self.publish(i, &m.data, summary)?;
        }
        Ok(())
    }

    /// Waits until the `selected` services have at least `n` subscribers together;
    /// false when a stop was requested first.
    fn wait_for_subscribers(
        &mut self,
        bus: &Bus,
        selected: &[String],
        n: usize,
    ) -> Result<bool, BusError> {
        if n > 0 {
            tracing::info!("waiting for {n} subscriber(s) of the replayed topics");
        }
        loop {
            let subscribers: usize = bus
                .services()?
                .iter()
                .filter(|s| selected.contains(&s.name))
                .filter_map(|s| s.ports.map(|(_, sub)| sub))
                .sum();
            if subscribers >= n {
                return Ok(true);
            }
            if !self.sleep_until(clock::monotonic_ns() + 20_000_000)? {
                return Ok(false);
            }
        }
    }

    /// Sleeps until the monotonic clock reaches `due`, connecting late subscribers
    /// meanwhile; false when a stop was requested.
    fn sleep_until(&mut self, due: u64) -> Result<bool, BusError> {
        loop {
            if signals::stop_requested() || self.instance_ended() {
                return Ok(false);
            }
            self.refresh()?;
            let now = clock::monotonic_ns();
            if now >= due {
                return Ok(true);
            }
            std::thread::sleep(Duration::from_nanos((due - now).min(20_000_000)));
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

    fn file() -> RecordFile {
        let bytes = write_synthetic(Cursor::new(Vec::new()), 12, WriterOptions::default())
            .unwrap()
            .into_inner();
        RecordFile::from_bytes(Path::new("run.mcap"), bytes).unwrap()
    }

    #[test]
    fn plan_selects_recorded_services_and_checks_names() {
        let f = file();
        let (all, foreign) = plan(&f, &[]).unwrap();
        assert!(foreign.is_none());
        assert!(all.contains(&s::POINT_CLOUD.to_string()));
        assert!(!all.contains(&s::HEARTBEAT.to_string()));
        let (one, _) = plan(&f, &[s::TICK.to_string()]).unwrap();
        assert_eq!(one, [s::TICK]);
        let e = plan(&f, &["aisle/nope".to_string()]).unwrap_err();
        assert!(e.to_string().contains("aisle/nope"), "{e}");
        let e = plan(&f, &[s::SIM_COMMAND.to_string()]).unwrap_err();
        assert!(matches!(e, ReplayError::TopicNotRecorded { .. }), "{e}");
        assert!(matches!(
            plan(&f, &[s::INSTANCE.to_string()]),
            Err(ReplayError::NotReplayable(_))
        ));
    }

    #[test]
    fn a_different_layout_is_refused_naming_the_service() {
        let mut c = ChannelInfo {
            id: 1,
            topic: s::TRAJECTORY.to_string(),
            message_encoding: crate::writer::LEGACY_RAW_ENCODING.into(),
            schema_name: None,
            metadata: BTreeMap::new(),
        };
        let ours = service_info(s::TRAJECTORY).unwrap();
        c.metadata.insert("type_name".into(), ours.type_name.into());
        c.metadata.insert("size".into(), ours.size.to_string());
        c.metadata
            .insert("layout_hash".into(), ours.layout_hash_hex());
        assert!(check_channel(Path::new("a.mcap"), &c).is_ok());
        c.metadata
            .insert("layout_hash".into(), "0123456789abcdef".into());
        let e = check_channel(Path::new("a.mcap"), &c).unwrap_err();
        let text = e.to_string();
        assert!(text.contains("aisle/controller/trajectory"), "{text}");
        assert!(text.contains("0123456789abcdef"), "{text}");
        c.metadata
            .insert("layout_hash".into(), ours.layout_hash_hex());
        c.metadata.insert("size".into(), "28785".into());
        assert!(check_channel(Path::new("a.mcap"), &c).is_err());
    }
}
