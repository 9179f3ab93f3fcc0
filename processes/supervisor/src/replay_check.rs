//! `aisle replay <file> --check`: a regression check of the mapper and the controller
//! against a lockstep recording; and `--lockstep` replays into nodes launched here.
//!
//! Launches a fresh mapper and teb_controller (this build) in their own instance, with
//! the config files attached to the recording (or `--config-dir`), replays the recorded
//! ticks, robot states, point clouds, mapper controls and goals into them tick by tick
//! (aisle_tools::lockstep), and compares their maps, trajectories, bands and
//! acknowledgements with the recorded ones. Knows processes and files; the comparison is
//! the tools crate's.

use crate::launch::{LaunchSpec, ProcessGroup, current_exe, describe};
use aisle_bus::{Bus, Instance, Publisher, Subscriber, WaitOutcome};
use aisle_messages::topics::names as s;
use aisle_messages::{Heartbeat, InstanceInfo, NodeKind, NodeState, TickMode, topics};
use aisle_tools::RecordFile;
use aisle_tools::lockstep::{LockstepOptions, LockstepPorts, LockstepSummary, replay_lockstep};
use anyhow::{Context, anyhow, bail};
use std::path::{Component, Path, PathBuf};
use std::time::{Duration, Instant};

/// The live nodes under test.
const NODES: [NodeKind; 2] = [NodeKind::Mapper, NodeKind::TebController];
const READY_TIMEOUT: Duration = Duration::from_secs(60);
const ACK_TIMEOUT: Duration = Duration::from_secs(60);
const GRACE: Duration = Duration::from_millis(1500);

/// What `--check` replays: the inputs of the mapper and the controller.
pub fn inputs() -> Vec<String> {
    [
        s::TICK,
        s::ROBOT_STATE,
        s::POINT_CLOUD,
        s::MAPPER_CONTROL,
        s::CONTROLLER_GOAL,
    ]
    .map(String::from)
    .to_vec()
}

/// What `--check` compares, with the node that writes it.
pub fn outputs() -> Vec<(String, NodeKind)> {
    vec![
        (s::GLOBAL_MAP.to_string(), NodeKind::Mapper),
        (s::GLOBAL_MAP_CHANGES.to_string(), NodeKind::Mapper),
        (s::LOCAL_MAP.to_string(), NodeKind::Mapper),
        (s::TRAJECTORY.to_string(), NodeKind::TebController),
        (s::CONTROLLER_BAND.to_string(), NodeKind::TebController),
    ]
}

/// The config files of a recording written into `dir` (created); attachment names
/// that would leave `dir` are refused.
fn extract_config(file: &RecordFile, dir: &Path) -> anyhow::Result<usize> {
    let attachments = file.attachments().with_context(|| {
        format!(
            "reading the config files attached to {}",
            file.path().display()
        )
    })?;
    if attachments.is_empty() {
        bail!(
            "{} has no config files attached; give the directory with --config-dir",
            file.path().display()
        );
    }
    for a in &attachments {
        let rel = Path::new(&a.name);
        if a.name.is_empty() || !rel.components().all(|c| matches!(c, Component::Normal(_))) {
            bail!(
                "{}: attachment `{}` is not a relative path inside the config directory",
                file.path().display(),
                a.name
            );
        }
        let out = dir.join(rel);
        if let Some(parent) = out.parent() {
            std::fs::create_dir_all(parent)
                .with_context(|| format!("creating {}", parent.display()))?;
        }
        std::fs::write(&out, &a.data).with_context(|| format!("writing {}", out.display()))?;
    }
    Ok(attachments.len())
}

/// A directory removed when dropped.
struct TempDir(PathBuf);

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// A lockstep replay into nodes this command launches.
pub struct FreshGroup {
    /// The nodes launched; their acknowledgements pace the replay.
    pub nodes: Vec<NodeKind>,
    /// Services published from the file.
    pub publish: Vec<String>,
    /// Outputs compared with the recording (empty: a plain replay).
    pub compare: Vec<(String, NodeKind)>,
    pub start_offset_ns: u64,
}

/// Why `--check` could not judge a recording (exit 2, never a verdict).
#[derive(Debug)]
pub struct DamagedRecord(pub String);

impl std::fmt::Display for DamagedRecord {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "damaged record: {}", self.0)
    }
}

impl std::error::Error for DamagedRecord {}

/// Reads every message of the recording once, before anything is launched: a file
/// that cannot be read to its end is refused as damaged. Checking only what the replay
/// reaches would compare the ticks cut by the damage and call them divergent.
pub fn refuse_damaged(file: &RecordFile) -> Result<(), DamagedRecord> {
    for m in file.raw_messages() {
        if let Err(e) = m {
            return Err(DamagedRecord(e.to_string()));
        }
    }
    if !file.is_finalised() {
        return Err(DamagedRecord(format!(
            "{} has no summary: the recording was not finished",
            file.path().display()
        )));
    }
    Ok(())
}

/// Runs the check; `Ok` holds the comparison (identical or not), `Err` a setup failure
/// or a [`DamagedRecord`].
pub fn check(file_path: &Path, config_dir: Option<&Path>) -> anyhow::Result<LockstepSummary> {
    let file = RecordFile::open(file_path)?;
    refuse_damaged(&file)?;
    drop(file);
    let plan = FreshGroup {
        nodes: NODES.to_vec(),
        publish: inputs(),
        compare: outputs(),
        start_offset_ns: 0,
    };
    replay_into_fresh_group(file_path, config_dir, &plan)
}

/// Launches `plan.nodes` in a new instance with the recording's config (or
/// `config_dir`), replays the file into them in lockstep, stops them and removes the
/// instance.
pub fn replay_into_fresh_group(
    file_path: &Path,
    config_dir: Option<&Path>,
    plan: &FreshGroup,
) -> anyhow::Result<LockstepSummary> {
    let file = RecordFile::open(file_path)?;
    let meta = file.run_metadata();
    let base = crate::session::run_base_dir()?;
    let instance = Instance::unique(&base);
    let _extracted;
    let config_dir = match config_dir {
        Some(d) => {
            std::fs::canonicalize(d).with_context(|| format!("config directory {}", d.display()))?
        }
        None => {
            let dir = std::env::temp_dir().join(format!("{}config", instance.prefix));
            _extracted = TempDir(dir.clone());
            let n = extract_config(&file, &dir)?;
            tracing::info!(
                "using the {n} config files recorded in {}",
                file_path.display()
            );
            dir
        }
    };
    let get = |key: &str, default: &str| meta.get(key).cloned().unwrap_or(default.to_string());
    let seed: u64 = get("seed", "0").parse().unwrap_or(0);
    let dt_ns = get("dt_ns", "100000000");
    let every = get("controller_every", "5");
    let start = get("start", "0 0 0")
        .split_whitespace()
        .collect::<Vec<_>>()
        .join(",");

    let opts = LockstepOptions {
        file: file_path.to_path_buf(),
        publish: plan.publish.clone(),
        consumers: plan.nodes.clone(),
        compare: plan.compare.clone(),
        start_offset_ns: plan.start_offset_ns,
        ack_timeout: ACK_TIMEOUT,
    };
    let nodes = &plan.nodes;
    let result = (|| -> anyhow::Result<LockstepSummary> {
        let (bus, info) = Bus::create_instance(&instance, seed, TickMode::Lockstep)
            .with_context(|| format!("creating an instance under {}", base.display()))?;
        let heartbeats = bus.subscriber(topics::HEARTBEAT)?;
        let mut ports = LockstepPorts::open(&bus, &file, &opts)?;
        let spec = LaunchSpec {
            exe: current_exe().map_err(|e| anyhow!(e))?,
            instance: instance.clone(),
            config_dir: config_dir.clone(),
            extra: Box::new(move |_| {
                vec![
                    "--dt-ns".into(),
                    dt_ns.clone(),
                    "--controller-every".into(),
                    every.clone(),
                    format!("--start={start}"),
                ]
            }),
            // Only the mapper and the controller are checked: no external node runs.
            external: Default::default(),
            dt_ns: 0,
            controller_every: 1,
        };
        let mut group = ProcessGroup::new(spec);
        for &kind in nodes {
            group.spawn(kind, false).map_err(|e| anyhow!(e))?;
        }
        wait_ready(nodes, &mut group, &info, &heartbeats)?;
        let summary = replay_lockstep(&mut ports, &file, &opts, &mut || gone(&mut group));
        group.stop(GRACE);
        Ok(summary?)
    })();
    if let Err(e) = instance.remove() {
        tracing::warn!("could not remove instance {}: {e}", instance.prefix);
    }
    result
}

/// A node of the group that exited, as an error naming it and its last words.
fn gone(group: &mut ProcessGroup) -> Result<(), String> {
    match group.poll_exit() {
        Some((kind, status)) => Err(format!(
            "node `{}` {}{}",
            kind.name(),
            describe(&status),
            group
                .last_line(kind)
                .map(|l| format!(": {l}"))
                .unwrap_or_default()
        )),
        None => Ok(()),
    }
}

/// Waits until every node of `nodes` reported ready (or one exited, or time ran out).
fn wait_ready(
    nodes: &[NodeKind],
    group: &mut ProcessGroup,
    info: &Publisher<InstanceInfo>,
    heartbeats: &Subscriber<Heartbeat>,
) -> anyhow::Result<()> {
    let mut ready = Vec::new();
    let started = Instant::now();
    while nodes.iter().any(|k| !ready.contains(k)) {
        gone(group).map_err(|e| anyhow!(e))?;
        // Joining nodes receive the announcement (history) when we look for them.
        info.update_connections()?;
        if started.elapsed() > READY_TIMEOUT {
            let missing: Vec<&str> = nodes
                .iter()
                .filter(|k| !ready.contains(k))
                .map(|k| k.name())
                .collect();
            bail!("not ready within {READY_TIMEOUT:?}: {}", missing.join(", "));
        }
        if let (WaitOutcome::Matched, Some(hb)) =
            heartbeats.wait_for(Duration::from_millis(100), |_| true, || {})?
            && hb.state == NodeState::Ready as u32
            && let Some(kind) = NodeKind::from_u32(hb.node)
        {
            ready.push(kind);
        }
    }
    Ok(())
}
