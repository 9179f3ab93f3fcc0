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

//!
//! Modules: [`drain`] (the node thread), [`write`] (the writer thread), [`seq`] (losses
//! from sequence numbers), [`answer`] (when to acknowledge a lockstep tick),
//! [`run_info`] (metadata and attachments), [`log_clock`] (which clock `log_time` is
//! on: sim time in lockstep, Unix time in realtime). This module joins and finalises.
//! Its errors do not name the recorder: whoever runs it does (`error: recorder: ...`).

mod answer;
mod drain;
pub mod log_clock;
mod run_info;
mod seq;
mod write;

pub use run_info::config_files;

use crate::catalog::services;
use crate::live::LiveSummary;
use crate::raw_ports::{RawSource, open_source};
use crate::viewer::ViewerOptions;
use crate::writer::WriterOptions;
use aisle_bus::{Bus, BusError, NodeArgs, NodeError};
use aisle_messages::{NodeKind, NodeState, TickMode, topics};
use aisle_node::Graph;
use answer::AnswerRule;
use drain::{DrainPorts, drain};
use log_clock::LogClock;
use run_info::{loss_metadata, queue_run_info};
use std::collections::BTreeMap;
use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::time::Duration;
use write::{Job, WriterThread};

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
    /// Longest sleep while no data arrives: the sleeps grow from 1 ms to it while passes
    /// find nothing, and a tick's acknowledgement ends one sooner.
    pub poll_period: Duration,
    /// Finalise once no other process published anything for this long (a recorder
    /// attached to a running group ends with it); `None`: only on a stop request.
    pub idle_stop: Option<Duration>,
    /// Serve the viewer channels live over the Foxglove WebSocket protocol here.
    pub live: Option<SocketAddr>,
}

impl Default for RecorderOptions {
    fn default() -> Self {
        Self {
            writer: WriterOptions::default(),
            viewer: ViewerOptions::default(),
            queue_bytes: 512 * 1024 * 1024,
            flush_period: Duration::from_secs(1),
            poll_period: Duration::from_millis(20),
            idle_stop: None,
            live: None,
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
    /// What the live view served and dropped, when there was one.
    pub live: Option<LiveSummary>,
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

/// Like [`run_recorder`], with options, returning what was recorded and lost.
pub fn run_recorder_with(
    args: &NodeArgs,
    out: &Path,
    options: &RecorderOptions,
) -> Result<RecordSummary, NodeError> {
    record(args, Some(out), options)
}

/// The recorder node serving the live view (`options.live`), writing `out` when given;
/// returns what it recorded and served.
pub fn run_recorder_live(
    args: &NodeArgs,
    out: Option<&Path>,
    options: &RecorderOptions,
) -> Result<RecordSummary, NodeError> {
    record(args, out, options)
}

fn record(
    args: &NodeArgs,
    out: Option<&Path>,
    options: &RecorderOptions,
) -> Result<RecordSummary, NodeError> {
    // Joining: the graph's answer rule, the bus, one subscriber per topic.
    let parent = std::os::unix::process::parent_id();
    let graph = Graph::load_dir(&args.config_dir).map_err(|e| NodeError::setup("the graph", e))?;
    let answer = AnswerRule::of(&graph);
    let (bus, info) = Bus::join(&args.instance, NodeKind::Recorder, NodeArgs::JOIN_TIMEOUT)?;
    let sources = subscribe_all(&bus)?;
    let mut heartbeat = bus.heartbeat()?;
    let mut acks = bus.publisher(topics::TICK_DONE)?;

    // The file: the writer thread, then the run's description.
    let names: Vec<&'static str> = services().iter().map(|i| i.service).collect();
    let mode = TickMode::from_u32(info.mode).unwrap_or(TickMode::Lockstep);
    let log_clock = LogClock::of_mode(mode);
    // The node's real-time options (`config/realtime.toml`), before the writer thread
    // starts: it inherits the CPUs and locked memory, then leaves any real-time
    // priority for SCHED_IDLE (`write.rs`), so compressing never competes with a stage.
    aisle_node::realtime::apply_for(
        "recorder",
        &args.config_dir,
        &graph,
        aisle_node::realtime::Forks::Inherit,
    )
    .map_err(|e| NodeError::setup("real-time options", e))?;
    let models = crate::viewer::ViewerModels {
        robot: robot_model(&args.config_dir),
        scene: scene(&args.config_dir),
    };
    let writer = WriterThread::start(out, options, &names, log_clock, models)?;
    queue_run_info(&writer.jobs, args, &info, log_clock.name());
    heartbeat.send(NodeState::Ready, "")?;

    // Recording until the end.
    let mut summary = RecordSummary {
        path: out.map(Path::to_path_buf).unwrap_or_default(),
        ..RecordSummary::default()
    };
    let ports = DrainPorts {
        sources: &sources,
        acks: &mut acks,
        heartbeat: &mut heartbeat,
        jobs: &writer.jobs,
        free: &writer.free,
        queued: &writer.queued,
        names: &names,
        options,
        parent,
    };
    let loop_result = drain(ports, answer, &mut summary);
    let _ = heartbeat.send(NodeState::Stopping, "");
    // Leave the instance before finalising the file: a group's supervisor waits for the
    // processes attached to its instance to leave before it removes the instance's
    // files (what iceoryx2 would otherwise report here as a corrupted system).
    drop((sources, acks, heartbeat, bus));

    // Finalising: the losses into the file, then wait for the writer.
    let stats = loss_metadata(&summary, &loop_result);
    let _ = writer
        .jobs
        .send(Job::Metadata("aisle.recorder".into(), stats));
    let written = writer.finish(&summary.path)?;
    summary.written = written.counts.raw;
    summary.viewer_messages = written.counts.viewer;
    summary.attachments = written.counts.attachments;
    summary.live = written.live;
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

/// Every subscriber, with its index in the catalogue.
type Sources = Vec<(usize, Box<dyn RawSource>)>;

/// One source per topic with its index, in the order of `topics::all()` (the order of
/// the writer's raw channels; the graph's user topics last).
fn subscribe_all(bus: &Bus) -> Result<Sources, BusError> {
    let all = topics::all();
    let mut sources = Vec::with_capacity(all.len());
    for (i, t) in all.iter().enumerate() {
        if let Some(source) = open_source(bus, t.name)? {
            sources.push((i, source));
        }
    }
    Ok(sources)
}

/// The scene, for the static bodies of the viewer's `/viz/scene` (ground truth lists
/// only the bodies that can move). Without it the view just has no static bodies.
fn scene(config_dir: &Path) -> Option<aisle_config::scene::Scene> {
    match aisle_config::scene::Scene::load(&config_dir.join("warehouse.toml")) {
        Ok(scene) => Some(scene),
        Err(e) => {
            tracing::warn!("recorder: no static bodies in the viewer channels: {e}");
            None
        }
    }
}

/// The robot model for the viewer's `/viz/robot`, from the group's `robot.toml` and the
/// URDF it names. Without it the record and the live view just have no robot model:
/// `aisle check` already refuses a config whose robot cannot be read, so this only
/// says why once.
fn robot_model(config_dir: &Path) -> Option<aisle_robot::RobotModel> {
    match aisle_robot::load_robot(&config_dir.join("robot.toml")) {
        Ok((_, model)) => Some(model),
        Err(e) => {
            tracing::warn!("recorder: no robot model in the viewer channels: {e}");
            None
        }
    }
}
