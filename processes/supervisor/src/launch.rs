//! The process group: spawning the nodes by re-executing this binary, noticing when
//! one dies, and stopping all of them (SIGTERM, a grace period, SIGKILL), reaping each.
//!
//! Knows processes and signals, not what the nodes do.

use aisle_bus::Instance;
use aisle_messages::NodeKind;
use std::collections::HashMap;
use std::io::{BufRead, BufReader};
use std::os::unix::process::{CommandExt, ExitStatusExt};
use std::path::PathBuf;
use std::process::{Child, Command, ExitStatus, Stdio};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// How a child ended, in words a person can act on.
pub fn describe(status: &ExitStatus) -> String {
    match (status.code(), status.signal()) {
        (Some(c), _) => format!("exited with code {c}"),
        (None, Some(s)) => format!("was killed by signal {s} ({})", signal_name(s)),
        _ => "ended for an unknown reason".to_string(),
    }
}

fn signal_name(s: i32) -> &'static str {
    match s {
        libc::SIGKILL => "SIGKILL",
        libc::SIGTERM => "SIGTERM",
        libc::SIGINT => "SIGINT",
        libc::SIGSEGV => "SIGSEGV",
        libc::SIGABRT => "SIGABRT",
        libc::SIGBUS => "SIGBUS",
        _ => "other",
    }
}

pub struct RunningChild {
    pub kind: NodeKind,
    pub child: Child,
    pub exited: Option<ExitStatus>,
}

/// Everything a child needs on its command line.
pub struct LaunchSpec {
    pub exe: PathBuf,
    pub instance: Instance,
    pub config_dir: PathBuf,
    /// Extra arguments per node (clock, start pose, the lidar switched off, faults).
    pub extra: Box<dyn Fn(NodeKind) -> Vec<String>>,
    /// The external nodes' commands (program and arguments), from the graph.
    pub external: HashMap<NodeKind, Vec<String>>,
    /// The clock, for external nodes' environment: simulated time per tick, and every
    /// how many ticks the controller acts.
    pub dt_ns: u64,
    pub controller_every: u32,
}

impl LaunchSpec {
    /// The command that starts `kind`: this binary as `aisle node <name>`, or an
    /// external node's own program, run in the directory of the graph file (the
    /// user's, for an overlay: so the graph's relative paths are relative to it) with
    /// the instance in its environment.
    fn command(&self, kind: NodeKind, restarted: bool) -> Command {
        if let Some(argv) = self.external.get(&kind) {
            // A path (not a name looked up on PATH) is relative to the graph's directory:
            // where the user's graph.toml is, not an overlay's assembled copy of it.
            let graph_dir = crate::check::external::graph_dir(&self.config_dir);
            let program = std::path::Path::new(&argv[0]);
            let mut cmd = if argv[0].contains('/') && program.is_relative() {
                Command::new(graph_dir.join(program))
            } else {
                Command::new(program)
            };
            let env = aisle_node::external::Env {
                prefix: self.instance.prefix.clone(),
                root: self.instance.root.clone(),
                config_dir: self.config_dir.clone(),
                node: kind.name().to_string(),
                restarted,
                dt_ns: self.dt_ns,
                controller_every: self.controller_every,
            };
            cmd.args(&argv[1..])
                .current_dir(&graph_dir)
                .envs(env.vars());
            return cmd;
        }
        let mut cmd = Command::new(&self.exe);
        cmd.arg("node")
            .arg(kind.name())
            .arg("--prefix")
            .arg(&self.instance.prefix)
            .arg("--root")
            .arg(&self.instance.root)
            .arg("--config-dir")
            .arg(&self.config_dir)
            .args((self.extra)(kind));
        if restarted {
            cmd.arg("--restarted");
        }
        cmd
    }
}

/// The launched nodes. Dropping the group stops it.
pub struct ProcessGroup {
    pub children: Vec<RunningChild>,
    spec: LaunchSpec,
    /// The last line each node wrote to stderr (its last error), forwarded as it comes,
    /// with the incarnation that wrote it.
    last_lines: Arc<Mutex<HashMap<NodeKind, (u64, String)>>>,
    /// How many times each node was started: a restarted node that dies silently must
    /// not be reported with its predecessor's last words.
    incarnations: HashMap<NodeKind, u64>,
    /// The nodes placed on other hosts (`aisle run --hosts`).
    remote: Option<crate::remote::RemoteNodes>,
}

impl ProcessGroup {
    pub fn new(spec: LaunchSpec) -> Self {
        ProcessGroup {
            children: Vec::new(),
            spec,
            last_lines: Arc::default(),
            incarnations: HashMap::new(),
            remote: None,
        }
    }

    /// From now on, the nodes placed on other hosts are started, killed and watched
    /// through `remote`.
    pub fn attach_remote(&mut self, remote: crate::remote::RemoteNodes) {
        self.remote = Some(remote);
    }

    /// The nodes on other hosts, in a spread run.
    pub fn remote(&self) -> Option<&crate::remote::RemoteNodes> {
        self.remote.as_ref()
    }

    /// The extra arguments `kind` is started with.
    pub fn args_of(&self, kind: NodeKind) -> Vec<String> {
        (self.spec.extra)(kind)
    }

    /// Whether `kind` runs on this host.
    pub fn is_local(&self, kind: NodeKind) -> bool {
        self.remote
            .as_ref()
            .is_none_or(|r| r.host_of(kind).is_none())
    }

    /// Starts one node; `restarted` tells it to resume from the state its predecessor
    /// published. On failure the caller stops the group.
    pub fn spawn(&mut self, kind: NodeKind, restarted: bool) -> Result<(), String> {
        if let Some((r, host)) = self
            .remote
            .as_ref()
            .and_then(|r| Some((r, r.host_of(kind)?)))
        {
            return r.spawn(host, kind, restarted);
        }
        let mut cmd = self.spec.command(kind, restarted);
        cmd.stdin(Stdio::null())
            .stderr(Stdio::piped())
            // Its own process group: a terminal's Ctrl-C reaches the supervisor, which
            // stops the children in order.
            .process_group(0);
        // The CPUs the supervisor had before its own `cpus` (realtime.toml) narrowed
        // them: a node's affinity is its own option.
        let cpus = aisle_node::realtime::inherited_affinity();
        // SAFETY: prctl, getppid and sched_setaffinity are async-signal-safe; `cpus` is
        // a copy owned by the closure; nothing else runs between fork and exec.
        unsafe {
            let parent = libc::getpid();
            cmd.pre_exec(move || {
                // If the supervisor dies without stopping us, we get SIGTERM.
                libc::prctl(libc::PR_SET_PDEATHSIG, libc::SIGTERM);
                if libc::getppid() != parent {
                    libc::_exit(1);
                }
                if let Some(set) = &cpus {
                    libc::sched_setaffinity(0, std::mem::size_of::<libc::cpu_set_t>(), set);
                }
                Ok(())
            });
        }
        let mut child = cmd.spawn().map_err(|e| {
            format!(
                "cannot start {} ({}): {e}",
                kind.name(),
                std::path::Path::new(cmd.get_program()).display()
            )
        })?;
        let incarnation = self.incarnations.entry(kind).or_default();
        *incarnation += 1;
        let incarnation = *incarnation;
        if let Some(err) = child.stderr.take() {
            let lines = Arc::clone(&self.last_lines);
            // Forward the node's stderr and remember its last line, so that a node that
            // dies is reported with its own last words.
            std::thread::spawn(move || {
                for line in BufReader::new(err).lines().map_while(Result::ok) {
                    eprintln!("{line}");
                    // A predecessor's late lines never cover its successor's.
                    if let Ok(mut m) = lines.lock()
                        && m.get(&kind).is_none_or(|(by, _)| *by <= incarnation)
                    {
                        m.insert(kind, (incarnation, line));
                    }
                }
            });
        }
        self.children
            .retain(|c| c.kind != kind || c.exited.is_none());
        self.children.push(RunningChild {
            kind,
            child,
            exited: None,
        });
        Ok(())
    }

    /// The last line `kind` wrote to stderr, without terminal colour codes.
    pub fn last_line(&self, kind: NodeKind) -> Option<String> {
        let m = self.last_lines.lock().ok()?;
        let (written_by, line) = m.get(&kind)?;
        if self.incarnations.get(&kind) != Some(written_by) {
            return None;
        }
        let mut out = String::with_capacity(line.len());
        let mut chars = line.chars();
        while let Some(c) = chars.next() {
            if c == '\u{1b}' {
                // Skip an escape sequence up to its final letter.
                for d in chars.by_ref() {
                    if d.is_ascii_alphabetic() {
                        break;
                    }
                }
            } else {
                out.push(c);
            }
        }
        Some(out.trim().to_string())
    }

    /// SIGKILL to a live node (a fault injected on purpose, or a node that stopped
    /// sending heartbeats); it is reaped by the next [`ProcessGroup::poll_exit`].
    pub fn kill(&self, kind: NodeKind) {
        if let Some((r, host)) = self
            .remote
            .as_ref()
            .and_then(|r| Some((r, r.host_of(kind)?)))
        {
            return r.kill(host, kind);
        }
        if let Some(pid) = self.pid_of(kind) {
            // SAFETY: sending a signal to our own child's pid.
            unsafe { libc::kill(pid as i32, libc::SIGKILL) };
        }
    }

    /// The first child found dead since the last call (it is reaped).
    pub fn poll_exit(&mut self) -> Option<(NodeKind, ExitStatus)> {
        for c in &mut self.children {
            if c.exited.is_none()
                && let Ok(Some(status)) = c.child.try_wait()
            {
                c.exited = Some(status);
                return Some((c.kind, status));
            }
        }
        self.remote.as_ref().and_then(|r| r.poll_exit())
    }

    pub fn pid_of(&self, kind: NodeKind) -> Option<u32> {
        self.children
            .iter()
            .find(|c| c.kind == kind && c.exited.is_none())
            .map(|c| c.child.id())
    }

    /// SIGTERM to every live child, up to `grace` for them to exit, then SIGKILL; every
    /// child is reaped before this returns. A recorder goes last, so it records the
    /// others to their end, and it gets [`RECORDER_GRACE`] to finalise its file.
    /// Returns how each ended.
    pub fn stop(&mut self, grace: Duration) -> Vec<(NodeKind, ExitStatus)> {
        self.stop_where(grace, |k| k != NodeKind::Recorder);
        if let Some(r) = self.remote.take() {
            r.stop(grace);
        }
        self.stop_where(RECORDER_GRACE.max(grace), |k| k == NodeKind::Recorder);
        self.children
            .iter()
            .filter_map(|c| c.exited.map(|s| (c.kind, s)))
            .collect()
    }

    fn stop_where(&mut self, grace: Duration, which: impl Fn(NodeKind) -> bool) {
        for c in &self.children {
            if c.exited.is_none() && which(c.kind) {
                // SAFETY: sending a signal to our own child's pid.
                unsafe { libc::kill(c.child.id() as i32, libc::SIGTERM) };
            }
        }
        let deadline = Instant::now() + grace;
        loop {
            let mut alive = 0;
            for c in self.children.iter_mut().filter(|c| which(c.kind)) {
                if c.exited.is_none() {
                    match c.child.try_wait() {
                        Ok(Some(s)) => c.exited = Some(s),
                        _ => alive += 1,
                    }
                }
            }
            if alive == 0 || Instant::now() >= deadline {
                break;
            }
            std::thread::sleep(Duration::from_millis(10));
        }
        for c in self.children.iter_mut().filter(|c| which(c.kind)) {
            if c.exited.is_none() {
                if c.kind == NodeKind::Recorder {
                    // What it had not written is lost: say so, the file is not finalised.
                    tracing::error!(
                        "the recorder had not finalised its file {} s after the group stopped \
                         and was killed: the record is cut short",
                        grace.as_secs()
                    );
                }
                let _ = c.child.kill();
                c.exited = c.child.wait().ok();
            }
        }
    }
}

/// Time a recorder gets to write out its queue and finalise the file.
pub const RECORDER_GRACE: Duration = Duration::from_secs(30);

impl Drop for ProcessGroup {
    fn drop(&mut self) {
        self.stop(Duration::from_millis(1500));
    }
}

/// The external nodes' commands (program and arguments), from the graph.
pub fn external_commands(graph: &aisle_node::Graph) -> HashMap<NodeKind, Vec<String>> {
    graph
        .external()
        .filter_map(|n| Some((n.kind(), n.command.clone()?)))
        .collect()
}

/// The binary to re-execute for the nodes: this one.
pub fn current_exe() -> Result<PathBuf, String> {
    std::env::current_exe()
        .map_err(|e| format!("cannot find this executable to start the nodes: {e}"))
}
