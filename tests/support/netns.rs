//! Hosts for the spread-group tests: Linux network namespaces, each joined by a veth
//! pair to one bridge that lives in a namespace of its own (nothing is added to the
//! test machine's own network), each process started in a mount namespace of its own in
//! which /dev/shm and the run directory are private, so shared memory cannot carry what
//! the Zenoh link must. [`Hosts`] removes everything it made when dropped, also when a
//! test fails.
//!
//! Needs root and `ip netns`: [`unavailable`] says why not, and the tests skip with that
//! reason (CI runs as root).

use super::{TestDir, config_dir, signal_and_reap, stderr_reader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::Duration;

/// Why network-namespace hosts cannot be made here, if they cannot.
pub fn unavailable() -> Option<String> {
    // SAFETY: geteuid has no preconditions.
    if unsafe { libc::geteuid() } != 0 {
        return Some("not root".into());
    }
    match Command::new("ip").args(["netns", "list"]).output() {
        Ok(o) if o.status.success() => None,
        Ok(o) => Some(format!(
            "`ip netns` fails: {}",
            String::from_utf8_lossy(&o.stderr)
        )),
        Err(e) => Some(format!("no `ip` command: {e}")),
    }
}

/// Returns from the test (passing, with the reason on stderr) where hosts cannot be made.
#[macro_export]
macro_rules! needs_netns {
    () => {
        if let Some(why) = $crate::support::netns::unavailable() {
            eprintln!(
                "skipping: the hosts are network namespaces, which need root and `ip netns`: {why}"
            );
            return;
        }
    };
}

/// Runs `ip args`, panicking with its stderr when it fails.
pub fn ip(args: &[&str]) {
    let out = Command::new("ip").args(args).output().expect("ip runs");
    assert!(
        out.status.success(),
        "ip {args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// `n` network namespaces on one bridge, host `i` at `10.77.0.(i+1)/24`.
pub struct Hosts {
    id: String,
    switch: String,
    names: Vec<String>,
}

impl Hosts {
    pub fn new(n: usize) -> Hosts {
        static COUNT: std::sync::atomic::AtomicU32 = std::sync::atomic::AtomicU32::new(0);
        let k = COUNT.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let id = format!("{}x{k}", std::process::id());
        let switch = format!("aisle-s{id}");
        // The guard exists before the first namespace, so a failure half-way removes
        // what was made.
        let mut hosts = Hosts {
            id: id.clone(),
            switch: switch.clone(),
            names: Vec::new(),
        };
        ip(&["netns", "add", &switch]);
        ip(&["-n", &switch, "link", "add", "br0", "type", "bridge"]);
        ip(&["-n", &switch, "link", "set", "br0", "up"]);
        for i in 0..n {
            let name = format!("aisle-{i}h{id}");
            ip(&["netns", "add", &name]);
            hosts.names.push(name.clone());
            let (dev, port) = (hosts.device(i), format!("p{i}"));
            ip(&[
                "link", "add", &dev, "netns", &name, "type", "veth", "peer", "name", &port,
                "netns", &switch,
            ]);
            ip(&["-n", &switch, "link", "set", &port, "master", "br0"]);
            ip(&["-n", &switch, "link", "set", &port, "up"]);
            let addr = format!("{}/24", Hosts::addr(i));
            ip(&["-n", &name, "addr", "add", &addr, "dev", &dev]);
            ip(&["-n", &name, "link", "set", &dev, "up"]);
            ip(&["-n", &name, "link", "set", "lo", "up"]);
        }
        hosts
    }

    /// Host `i`'s address.
    pub fn addr(i: usize) -> String {
        format!("10.77.0.{}", i + 1)
    }

    /// Host `i`'s network device (the host end of its veth pair).
    pub fn device(&self, i: usize) -> String {
        format!("v{i}h{}", self.id)
    }

    /// Host `i`'s network namespace.
    pub fn namespace(&self, i: usize) -> &str {
        &self.names[i]
    }

    /// Takes host `i`'s only link down (`up = false`) or up again: the host is cut off.
    pub fn set_link(&self, i: usize, up: bool) {
        let state = if up { "up" } else { "down" };
        ip(&["-n", &self.names[i], "link", "set", &self.device(i), state]);
    }

    /// `program args` in host `i`, with a private /dev/shm and `run_dir`, and
    /// `AISLE_RUN_DIR` set to it.
    pub fn command(&self, i: usize, run_dir: &Path, program: &str, args: &[&str]) -> Command {
        let script = format!(
            "mount -t tmpfs -o mode=1777 tmpfs /dev/shm && mount -t tmpfs -o mode=0700 tmpfs {run} && exec \"$0\" \"$@\"",
            run = run_dir.display()
        );
        let mut cmd = Command::new("ip");
        cmd.args([
            "netns",
            "exec",
            &self.names[i],
            "unshare",
            "-m",
            "--propagation",
            "private",
        ])
        .args(["sh", "-c", &script, program])
        .args(args)
        .env("AISLE_RUN_DIR", run_dir)
        .env("AISLE_LOG", "warn")
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
        cmd
    }

    /// `aisle args` in host `i` (see [`Hosts::command`]).
    pub fn aisle(&self, i: usize, run_dir: &Path, args: &[&str]) -> Child {
        self.command(i, run_dir, super::aisle(), args)
            .spawn()
            .expect("ip netns exec runs")
    }
}

impl Drop for Hosts {
    fn drop(&mut self) {
        // Deleting a namespace deletes its end of each veth pair, and so the pair.
        for n in self.names.iter().chain(std::iter::once(&self.switch)) {
            let _ = Command::new("ip").args(["netns", "del", n]).status();
        }
    }
}

/// The acceptance placement: simulator and supervisor on `a`, the pipeline on `b`.
pub fn placement_file(dir: &TestDir) -> PathBuf {
    let (a, b) = (Hosts::addr(0), Hosts::addr(1));
    let text = format!(
        "[[host]]\nname = \"a\"\nlisten = [\"tcp/{a}:7447\"]\nnodes = [\"supervisor\", \"simulator\"]\n\n\
         [[host]]\nname = \"b\"\nlisten = [\"tcp/{b}:7447\"]\nconnect = [\"tcp/{a}:7447\"]\n\
         nodes = [\"lidar\", \"mapper\", \"global_planner\", \"teb_controller\"]\n"
    );
    let p = dir.path("hosts.toml");
    std::fs::write(&p, text).unwrap();
    p
}

/// How long the link-cut test keeps host `b` cut off.
pub const CUT: Duration = Duration::from_secs(2);

/// A host daemon that is stopped (SIGTERM, then SIGKILL) when dropped.
pub struct Daemon(pub Child);

impl Drop for Daemon {
    fn drop(&mut self) {
        signal_and_reap(&mut self.0, libc::SIGTERM, Duration::from_secs(10));
    }
}

/// What one spread run gave: the supervisor's output, host `b`'s stderr, the report
/// (when the run wrote one).
pub struct Spread {
    pub out: std::process::Output,
    pub b_err: String,
    pub report: Option<aisle_supervisor::report::RunReport>,
}

/// The seed mission with the acceptance placement on hosts 0 (`a`) and 1 (`b`) of
/// `hosts`; `b_args` go to `aisle host` on `b`, `run_args` to `aisle run` on `a`. `cut`:
/// host `b`'s link goes down this long after the run started, for [`CUT`].
pub fn spread_run(
    hosts: &Hosts,
    name: &str,
    b_args: &[&str],
    run_args: &[&str],
    cut: Option<Duration>,
) -> Spread {
    let dir = TestDir::new(name);
    // A second short run directory: iceoryx2 limits the length of an instance root.
    let run_b = TestDir::new(&format!("{name}-b"));
    let file = placement_file(&dir);
    let config = config_dir();
    let (file_s, config_s) = (file.to_str().unwrap(), config.to_str().unwrap());
    let mut args = vec![
        "host",
        "--name",
        "b",
        "--hosts",
        file_s,
        "--config-dir",
        config_s,
    ];
    args.extend_from_slice(b_args);
    let mut b = Daemon(hosts.aisle(1, &run_b.run_dir(), &args));
    let b_err = stderr_reader(&mut b.0);
    let report = dir.path("report.json");
    let mut args = vec![
        "run",
        "--quiet",
        "--hosts",
        file_s,
        "--config-dir",
        config_s,
        "--report",
        report.to_str().unwrap(),
    ];
    args.extend_from_slice(run_args);
    let run = hosts.aisle(0, &dir.run_dir(), &args);
    let out = std::thread::scope(|s| {
        if let Some(at) = cut {
            s.spawn(move || {
                std::thread::sleep(at);
                hosts.set_link(1, false);
                std::thread::sleep(CUT);
                hosts.set_link(1, true);
            });
        }
        run.wait_with_output().unwrap()
    });
    drop(b);
    let b_err = b_err.join().unwrap();
    let report = std::fs::read_to_string(&report)
        .ok()
        .map(|t| serde_json::from_str(&t).unwrap());
    Spread { out, b_err, report }
}
