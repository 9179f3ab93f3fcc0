//! `aisle record`, `aisle replay` and `aisle render`: the command-line side of the MCAP
//! tools in aisle-tools (which hold the formats and the algorithms).

use crate::mission::MissionConfig;
use aisle_bus::{Bus, Instance, NodeArgs};
use aisle_messages::NodeKind;
use aisle_messages::topics::names as s;
use aisle_tools::lockstep::{LockstepOptions, LockstepPorts};
use aisle_tools::{RecordFile, RecorderOptions};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Duration;

/// `aisle replay` as asked on the command line (see `cli` for each option's meaning).
#[derive(Debug, Clone)]
pub struct ReplayRequest {
    pub file: PathBuf,
    pub prefix: Option<String>,
    pub root: Option<PathBuf>,
    pub rate: f64,
    pub fast: bool,
    pub topics: Vec<String>,
    pub start: f64,
    pub lockstep: bool,
    pub wait_for: Vec<String>,
    pub check: bool,
    pub config_dir: Option<PathBuf>,
    pub looping: bool,
    pub wait_subscribers: usize,
}

/// `aisle record` as asked on the command line, with the config directory resolved.
#[derive(Debug, Clone)]
pub struct RecordRequest {
    pub prefix: String,
    pub root: PathBuf,
    pub output: PathBuf,
    pub config_dir: PathBuf,
    pub mission: Option<PathBuf>,
    pub idle_stop: f64,
}

/// An error and its causes, each said once (a library error that already names its
/// cause is not followed by the cause again).
fn causes(e: &anyhow::Error) -> String {
    let mut out = String::new();
    for cause in e.chain() {
        let text = cause.to_string();
        if !out.contains(&text) {
            if !out.is_empty() {
                out.push_str(": ");
            }
            out.push_str(&text);
        }
    }
    out
}

/// Every failure of these commands is "could not do what was asked" (exit 2); only
/// `--check` has a negative verdict (see [`crate::exit`]).
fn fail(e: impl std::fmt::Display) -> ExitCode {
    crate::exit::fail(e)
}

pub fn replay(a: &ReplayRequest) -> ExitCode {
    if a.check {
        return replay_check(a);
    }
    if !(a.start.is_finite() && a.start >= 0.0) {
        return fail(format!("--start must be >= 0 seconds, got {}", a.start));
    }
    let instance = match (a.prefix.clone(), a.root.clone()) {
        (Some(prefix), Some(root)) => match Instance::new(prefix, root) {
            Ok(i) => Some(i),
            Err(e) => return fail(e),
        },
        _ => None,
    };
    if a.lockstep {
        return replay_lockstep(a, instance);
    }
    if !(a.rate.is_finite() && a.rate > 0.0) {
        return fail(format!("--rate must be positive, got {}", a.rate));
    }
    let create = instance.is_none();
    let instance = match instance {
        Some(i) => i,
        None => match own_instance() {
            Ok(i) => i,
            Err(e) => return fail(e),
        },
    };
    let mut opts = aisle_tools::replay::ReplayOptions::new(&a.file, instance);
    opts.rate = (!a.fast).then_some(a.rate);
    opts.topics = a.topics.clone();
    opts.start_offset_ns = (a.start * 1e9).round() as u64;
    opts.create = create;
    opts.looping = a.looping;
    opts.wait_subscribers = a.wait_subscribers;
    match aisle_tools::replay::replay(&opts) {
        Ok(s) => {
            let total: u64 = s.published.values().sum();
            println!("replayed {total} messages from {}", a.file.display());
            print_replayed(&s.published, s.truncated.as_deref(), s.stopped);
            if let Some(why) = &s.ended {
                return fail(format!("{why}: the replay stopped after {total} messages"));
            }
            if let Some(t) = &s.truncated {
                // Replayed what could be read, but not the file it was asked to.
                return fail(t);
            }
            if total == 0 && !s.stopped {
                // Nothing was replayed: not what was asked (exit 2), said so.
                return fail(published_nothing(a));
            }
            ExitCode::SUCCESS
        }
        Err(e) => fail(e),
    }
}

/// Why a timed replay published nothing: what it was asked to replay.
fn published_nothing(a: &ReplayRequest) -> String {
    let topics = if a.topics.is_empty() {
        "on the replayed topics".to_string()
    } else {
        format!("on --topics {}", a.topics.join(" "))
    };
    format!(
        "published nothing: {} holds no message {topics} from --start {} s",
        a.file.display(),
        a.start
    )
}

/// A new instance in the run directory for a replay without a supervisor (what dead
/// instances left there is swept first, as `aisle run` does).
fn own_instance() -> anyhow::Result<Instance> {
    let dir = aisle_bus::run_dir::run_dir()?;
    crate::clean::sweep_before_run(&dir);
    aisle_bus::discovery::set_creator("replay", None);
    Ok(Instance::unique(&dir))
}

/// `aisle record`: the recorder node attached to a running group, from this process.
pub fn record(a: &RecordRequest) -> ExitCode {
    let config_dir = a.config_dir.as_path();
    if !(a.idle_stop.is_finite() && a.idle_stop > 0.0) {
        return fail(format!(
            "--idle-stop must be positive seconds, got {}",
            a.idle_stop
        ));
    }
    let instance = match Instance::new(a.prefix.clone(), a.root.clone()) {
        Ok(i) => i,
        Err(e) => return fail(e),
    };
    let mission_path = a
        .mission
        .clone()
        .unwrap_or_else(|| config_dir.join("mission.toml"));
    let mission = aisle_config::scene::Scene::load(&config_dir.join("warehouse.toml"))
        .map_err(anyhow::Error::from)
        .and_then(|scene| Ok(MissionConfig::load(&mission_path, &scene)?));
    let mission = match mission {
        Ok(m) => m,
        Err(e) => return fail(causes(&e)),
    };
    let args = NodeArgs {
        instance,
        config_dir: config_dir.to_path_buf(),
        dt_ns: mission.dt_ns(),
        controller_every: mission.controller_every(),
        start: mission.start,
        lidar_off: false,
        restarted: false,
        recorded: false,
    };
    let options = RecorderOptions {
        idle_stop: Some(Duration::from_secs_f64(a.idle_stop)),
        ..RecorderOptions::default()
    };
    // Held until the record is finalised: a second command writing this file is refused.
    let _lock = match aisle_tools::output_lock::OutputLock::acquire("-o", &a.output) {
        Ok(l) => l,
        Err(e) => return fail(e),
    };
    match aisle_tools::run_recorder_with(&args, &a.output, &options) {
        Ok(s) => {
            let total: u64 = s.written.values().sum();
            println!(
                "wrote {} samples and {} viewer messages to {}",
                total,
                s.viewer_messages,
                s.path.display()
            );
            if s.lost() > 0 {
                println!(
                    "lost {} samples (a recorder not launched with the group is not waited for)",
                    s.lost()
                );
            }
            ExitCode::SUCCESS
        }
        Err(e) => fail(e),
    }
}

/// Samples published per service, and how the replay ended if not at the file's end.
fn print_replayed(published: &BTreeMap<String, u64>, truncated: Option<&str>, stopped: bool) {
    for (service, n) in published {
        println!("  {service:<28} {n}");
    }
    if let Some(t) = truncated {
        println!("the file is damaged: replayed what could be read; {t}");
    }
    if stopped {
        println!("stopped early (interrupted)");
    }
}

/// `--lockstep`: tick by tick, paced by the `--wait-for` nodes, into the live instance
/// named by `--prefix`/`--root`, or into those nodes launched here.
fn replay_lockstep(a: &ReplayRequest, instance: Option<Instance>) -> ExitCode {
    let mut consumers = Vec::new();
    for name in &a.wait_for {
        match NodeKind::from_name(name).filter(|k| NodeKind::LAUNCHED.contains(k)) {
            // The clock is no consumer: it steps only on the supervisor's start command
            // and every node's acknowledgement, which a replay does not publish, so
            // waiting for it would wait for a tick it never makes.
            Some(k) if aisle_tools::catalog::producer(s::TICK) == Some(k) => {
                return fail(format!(
                    "--wait-for {name}: the {name} is the group's clock (it makes the ticks and \
                     steps on the acknowledgements of the others), so a lockstep replay \
                     cannot drive it; wait for nodes that act on ticks: {}",
                    lockstep_consumers().join(", ")
                ));
            }
            Some(k) => consumers.push(k),
            None => {
                return fail(format!(
                    "--wait-for: no node named `{name}`; nodes: {}",
                    lockstep_consumers().join(", ")
                ));
            }
        }
    }
    let publish = a.topics.clone();
    let start_offset_ns = (a.start * 1e9).round() as u64;
    let result = match instance {
        Some(instance) => lockstep_into_live(a, instance, consumers, publish, start_offset_ns),
        None => {
            let plan = crate::replay_check::FreshGroup {
                nodes: consumers,
                publish,
                compare: Vec::new(),
                start_offset_ns,
            };
            crate::replay_check::replay_into_fresh_group(&a.file, a.config_dir.as_deref(), &plan)
        }
    };
    match result {
        Ok(s) => {
            let total: u64 = s.published.values().sum();
            println!(
                "replayed {} ticks ({total} messages) from {} in lockstep",
                s.ticks,
                a.file.display()
            );
            print_replayed(&s.published, s.truncated.as_deref(), s.stopped);
            ExitCode::SUCCESS
        }
        Err(e) => fail(causes(&e)),
    }
}

/// `--lockstep` into the live instance `instance`: its `consumers` must be live there,
/// and the replay ends as soon as one leaves it (or its owner ends it) rather than
/// waiting out the acknowledgement timeout tick after tick.
fn lockstep_into_live(
    a: &ReplayRequest,
    instance: Instance,
    consumers: Vec<NodeKind>,
    publish: Vec<String>,
    start_offset_ns: u64,
) -> anyhow::Result<aisle_tools::lockstep::LockstepSummary> {
    let opts = LockstepOptions {
        file: a.file.clone(),
        publish,
        consumers,
        compare: Vec::new(),
        start_offset_ns,
        ack_timeout: Duration::from_secs(60),
    };
    let file = RecordFile::open(&a.file)?;
    let (bus, _) = Bus::join(&instance, NodeKind::Replay, Duration::from_secs(10))?;
    let absent = |k: &NodeKind| {
        !instance
            .live_nodes()
            .iter()
            .any(|(name, _)| name == k.name())
    };
    if let Some(k) = opts.consumers.iter().find(|k| absent(k)) {
        anyhow::bail!(
            "--wait-for {}: no live {} in instance {}: its acknowledgements would never come",
            k.name(),
            k.name(),
            instance.prefix
        );
    }
    let mut ports = LockstepPorts::open(&bus, &file, &opts)?;
    // Let the live subscribers connect to the new publishers.
    std::thread::sleep(Duration::from_millis(200));
    let mut watch = aisle_bus::OwnerWatch::new(&instance);
    let mut alive = || {
        if let Some(why) = watch.ended() {
            return Err(why.to_string());
        }
        match opts.consumers.iter().find(|k| absent(k)) {
            Some(k) => Err(format!(
                "node `{}` left instance {}",
                k.name(),
                instance.prefix
            )),
            None => Ok(()),
        }
    };
    Ok(aisle_tools::lockstep::replay_lockstep(
        &mut ports, &file, &opts, &mut alive,
    )?)
}

/// The nodes a lockstep replay can wait for: the launched ones but the clock.
fn lockstep_consumers() -> Vec<&'static str> {
    let clock = aisle_tools::catalog::producer(s::TICK);
    NodeKind::LAUNCHED
        .iter()
        .filter(|k| Some(**k) != clock)
        .map(|k| k.name())
        .collect()
}

/// `--check`: exit 0 identical, 1 diverged, 2 the check could not run.
fn replay_check(a: &ReplayRequest) -> ExitCode {
    let summary = match crate::replay_check::check(&a.file, a.config_dir.as_deref()) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("error: {}", causes(&e));
            return crate::exit::could_not();
        }
    };
    // Damage found while replaying (the file changed since the first read): the ticks
    // it cut would look divergent, so it is no verdict either way.
    if let Some(t) = &summary.truncated {
        eprintln!("error: damaged record: {t}");
        return crate::exit::could_not();
    }
    println!(
        "replayed {} ticks of {} into a live mapper and teb_controller",
        summary.ticks,
        a.file.display()
    );
    for (service, n) in &summary.compared {
        let bad = summary.diverged.get(service).copied().unwrap_or(0);
        println!("  {service:<28} {n:>5} compared  {bad:>5} differ");
    }
    for node in &summary.cut_short {
        println!(
            "  not compared: {}'s outputs of the last tick (the recording ended before it acknowledged it)",
            node.name()
        );
    }
    if let Some(d) = &summary.first {
        let total: u64 = summary.diverged.values().sum();
        println!("DIVERGED: {total} samples differ; first: {d}");
        return ExitCode::from(1);
    }
    if summary.stopped {
        eprintln!("error: stopped early (interrupted)");
        return ExitCode::from(2);
    }
    if summary.identical() {
        println!("identical: every compared output matches the recording");
        ExitCode::SUCCESS
    } else {
        eprintln!(
            "error: nothing was compared: the recording holds no mapper or controller outputs"
        );
        ExitCode::from(2)
    }
}

pub fn render(file: &Path, out: &Path, pixels_per_metre: f64, band_every: usize) -> ExitCode {
    use aisle_tools::render::OutputFormat;
    // Decided by the extension, before the record is read: a .jpg never holds PNG bytes.
    let format = match OutputFormat::of(out) {
        Ok(f) => f,
        Err(e) => return fail(format!("-o {e}")),
    };
    if !(pixels_per_metre.is_finite() && (1.0..=200.0).contains(&pixels_per_metre)) {
        return fail(format!(
            "--pixels-per-metre must be within 1..=200, got {pixels_per_metre}"
        ));
    }
    if let Err(e) = crate::file_roles::distinct(&[("the record", file)], &[("-o", out)]) {
        return fail(e);
    }
    // Held until the output is written: a second command writing this file is refused.
    let _lock = match aisle_tools::output_lock::OutputLock::acquire("-o", out) {
        Ok(l) => l,
        Err(e) => return fail(e),
    };
    let opts = aisle_tools::render::RenderOptions {
        pixels_per_metre,
        band_every,
        driven: true,
    };
    if format == OutputFormat::Html {
        return animate(file, out, &opts);
    }
    match aisle_tools::render::render(file, out, &opts) {
        Ok(_) => {
            println!("wrote {}", out.display());
            ExitCode::SUCCESS
        }
        Err(e) => fail(e),
    }
}

/// `render -o page.html`: the playback page.
fn animate(file: &Path, out: &Path, opts: &aisle_tools::render::RenderOptions) -> ExitCode {
    match aisle_tools::animate::animate(file, out, opts) {
        Ok(a) => {
            println!(
                "wrote {} ({} ticks, {} bands, {} KB)",
                out.display(),
                a.frames,
                a.bands,
                a.bytes / 1024
            );
            if let Some(t) = &a.truncated {
                // Drawn, but of a damaged record: exit 2, as for every command.
                eprintln!("error: damaged record: drew what could be read; {t}");
                return crate::exit::could_not();
            }
            ExitCode::SUCCESS
        }
        Err(e) => fail(e),
    }
}
