//! System tests of the run directory and of instance privacy: an untrusted run
//! directory is refused before any node starts, another local user can open no file of
//! a running instance at any moment, and what a SIGKILLed supervisor left is swept by
//! the next `aisle run` or by `aisle clean`, never a live group's instance.

mod support;

use std::os::unix::fs::PermissionsExt;
use std::os::unix::process::CommandExt;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::Duration;
use support::*;

fn is_root() -> bool {
    // SAFETY: geteuid has no preconditions.
    unsafe { libc::geteuid() == 0 }
}

/// `aisle run` with `AISLE_RUN_DIR` set to `value` (raw) and info logs, so that an
/// instance, had one been made, would be named on stderr.
fn run_with_run_dir(value: &str) -> Output {
    let dir = TestDir::new("rd-refused");
    let report = dir.path("report.json");
    Command::new(aisle())
        .args(["run", "--quiet", "--report", report.to_str().unwrap()])
        .env("AISLE_RUN_DIR", value)
        .env("AISLE_LOG", "info")
        .current_dir(&dir.0)
        .stdin(Stdio::null())
        .output()
        .expect("aisle runs")
}

/// Refused with exit 2 and `needles` in the message, before any instance or node.
fn assert_refused(out: &Output, needles: &[&str]) {
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    for n in needles {
        assert!(err.contains(n), "`{n}` not in: {err}");
    }
    // The instance is logged before the first node is launched; nodes log their joins.
    assert!(!err.contains("instance --prefix"), "{err}");
    assert!(!err.contains("restart"), "{err}");
}

#[test]
fn relative_and_empty_run_dirs_are_refused_without_launching_anything() {
    let out = run_with_run_dir("");
    assert_refused(&out, &["AISLE_RUN_DIR is set but empty"]);
    let out = run_with_run_dir("runs/here");
    assert_refused(
        &out,
        &["AISLE_RUN_DIR=\"runs/here\" is not an absolute path"],
    );
}

#[test]
fn a_run_dir_writable_by_group_or_others_is_refused() {
    for mode in [0o777, 0o770] {
        let dir = TestDir::new("rd-open");
        let rd = dir.run_dir();
        std::fs::set_permissions(&rd, std::fs::Permissions::from_mode(mode)).unwrap();
        let out = run_with_run_dir(rd.to_str().unwrap());
        assert_refused(
            &out,
            &[
                &rd.display().to_string(),
                &format!("mode {mode:04o}"),
                "other users may write into it",
            ],
        );
        assert!(run_dir_leftovers(&rd).is_empty());
    }
}

#[test]
fn a_run_dir_of_another_user_is_refused() {
    if !is_root() {
        println!("skipped: only root can make a directory another user's");
        return;
    }
    let dir = TestDir::new("rd-foreign");
    let rd = dir.run_dir();
    std::os::unix::fs::chown(&rd, Some(54_321), Some(54_321)).unwrap();
    let out = run_with_run_dir(rd.to_str().unwrap());
    assert_refused(
        &out,
        &[
            &rd.display().to_string(),
            "owner uid 54321",
            "belongs to another user",
        ],
    );
    assert!(run_dir_leftovers(&rd).is_empty());
}

/// A local user made for one test, removed on drop (also when the test fails).
struct LocalUser {
    name: String,
    uid: u32,
    gid: u32,
}

impl LocalUser {
    fn create(tag: &str) -> Option<LocalUser> {
        if !is_root() {
            println!("skipped: creating a second local user needs root");
            return None;
        }
        let name = format!("aisle{tag}{}", std::process::id() % 100_000);
        let made = Command::new("useradd")
            .args(["--system", "--no-create-home", "--user-group"])
            .args(["--shell", "/bin/sh", &name])
            .status();
        match made {
            Err(e) => {
                println!("skipped: useradd is not available ({e})");
                return None;
            }
            Ok(s) => assert!(s.success(), "useradd {name} failed"),
        }
        let id = |flag: &str| -> u32 {
            let out = Command::new("id").args([flag, &name]).output().unwrap();
            String::from_utf8_lossy(&out.stdout).trim().parse().unwrap()
        };
        let mut user = LocalUser {
            name: name.clone(),
            uid: u32::MAX,
            gid: u32::MAX,
        };
        user.uid = id("-u");
        user.gid = id("-g");
        Some(user)
    }
}

impl Drop for LocalUser {
    fn drop(&mut self) {
        let _ = Command::new("userdel").arg(&self.name).status();
        let _ = Command::new("groupdel").arg(&self.name).status();
    }
}

/// Tries to open, read-only and read-write (never creating: a shell's `<>` would), every
/// /dev/shm entry starting with `argv[2]` and everything under the run directory
/// `argv[3]`, round after round, until `argv[1]` exists. Prints `ready` before its first
/// round, each success, and its totals at the end.
const PROBER: &str = r#"
import os, sys
stop, pat, run = sys.argv[1:4]
rounds = seen = 0
print("ready", flush=True)
while not os.path.exists(stop):
    names = []
    try:
        names += ["/dev/shm/" + n for n in os.listdir("/dev/shm") if n.startswith(pat)]
    except OSError:
        pass
    for d, subdirs, files in os.walk(run):
        names += [os.path.join(d, n) for n in subdirs + files]
    for f in names:
        seen += 1
        for flags in (os.O_RDONLY, os.O_RDWR):
            try:
                fd = os.open(f, flags | os.O_NONBLOCK | os.O_NOFOLLOW)
            except OSError:
                continue
            os.close(fd)
            print("opened", "read-write" if flags else "read-only", f, flush=True)
    rounds += 1
print("rounds", rounds, "seen", seen, flush=True)
"#;

/// A python3 another user can run (not a shim under root's home).
fn system_python() -> Option<&'static str> {
    ["/usr/bin/python3", "/usr/local/bin/python3", "/bin/python3"]
        .into_iter()
        .find(|p| Path::new(p).exists())
}

#[test]
fn another_user_can_open_no_instance_file_at_any_moment_of_a_run() {
    let Some(python) = system_python() else {
        println!("skipped: the prober needs python3 in /usr/bin, /usr/local/bin or /bin");
        return;
    };
    let Some(user) = LocalUser::create("p") else {
        return;
    };
    let dir = TestDir::new("rd-probe");
    let rd = dir.run_dir();
    // The supervisor's pid, hence its instance prefix, is known before it starts: a
    // shell waits for a line, then becomes `aisle run`.
    let mut sup = Command::new("/bin/sh")
        .args(["-c", "read _ && exec \"$0\" \"$@\""])
        .arg(aisle())
        .args(["run", "--quiet"])
        .env("AISLE_RUN_DIR", &rd)
        .env("AISLE_LOG", "warn")
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let pid = sup.id();
    let stop = PathBuf::from(format!("/tmp/aisle-probe-stop-{pid}"));
    let _ = std::fs::remove_file(&stop);
    let mut prober = Command::new(python)
        .args(["-c", PROBER])
        .arg(&stop)
        .arg(format!("aisle{pid}x"))
        .arg(&rd)
        .uid(user.uid)
        .gid(user.gid)
        .current_dir("/")
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    let mut out = std::io::BufReader::new(prober.stdout.take().unwrap());
    let mut first = String::new();
    std::io::BufRead::read_line(&mut out, &mut first).unwrap();
    assert_eq!(first.trim(), "ready", "the prober did not start");
    {
        use std::io::Write;
        writeln!(sup.stdin.take().unwrap()).unwrap();
    }
    let run_out = sup.wait_with_output().unwrap();
    std::fs::write(&stop, b"").unwrap();
    let mut rest = String::new();
    std::io::Read::read_to_string(&mut out, &mut rest).unwrap();
    prober.wait().unwrap();
    let _ = std::fs::remove_file(&stop);
    println!("prober as uid {}: {}", user.uid, rest.trim());
    assert!(
        run_out.status.success(),
        "{}",
        String::from_utf8_lossy(&run_out.stderr)
    );
    assert!(!rest.contains("opened"), "another user opened: {rest}");
    let seen: u64 = rest
        .split_whitespace()
        .skip_while(|w| *w != "seen")
        .nth(1)
        .and_then(|n| n.parse().ok())
        .expect("the prober's totals");
    assert!(seen > 0, "the prober never saw an instance file: {rest}");
}

/// A started group: its supervisor's pid and child, its stderr (read to the end when the
/// supervisor exits) and its five nodes.
struct Group {
    pid: u32,
    child: std::process::Child,
    stderr: std::thread::JoinHandle<String>,
    nodes: Vec<(String, u32)>,
}

/// Starts `aisle run <args>` in `run`, waits for its five nodes.
fn start_group(rd: &Path, args: &[&str]) -> Group {
    let mut all = vec!["run", "--quiet"];
    all.extend_from_slice(args);
    let mut child = spawn(rd, &all);
    let stderr = stderr_reader(&mut child);
    let pid = child.id();
    let nodes = wait_for_nodes(pid, Duration::from_secs(30));
    assert_eq!(nodes.len(), 5, "{nodes:?}");
    Group {
        pid,
        child,
        stderr,
        nodes,
    }
}

/// An overlay of the built-in config whose realtime heartbeat timeout is 10 s: a group
/// that must run on while parallel tests load both cores is not declared hung and
/// restarted (new pids) because the machine, not the node, was slow.
fn load_tolerant_config(dir: &TestDir) -> PathBuf {
    let config = dir.path("tolerant");
    std::fs::create_dir_all(&config).unwrap();
    std::fs::write(config.join("overlay.toml"), "base = \"built-in\"\n").unwrap();
    let restart = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config/restart.toml"),
    )
    .unwrap();
    let tolerant = restart.replace(
        "realtime_heartbeat_timeout_s = 0.2",
        "realtime_heartbeat_timeout_s = 10.0",
    );
    assert_ne!(
        tolerant, restart,
        "config/restart.toml changed its timeout line"
    );
    std::fs::write(config.join("restart.toml"), tolerant).unwrap();
    config
}

/// SIGKILLs the group's supervisor; its nodes must follow (they get SIGTERM when it dies).
fn kill_supervisor(group: &mut Group) {
    // SAFETY: a signal to our own child.
    unsafe { libc::kill(group.pid as i32, libc::SIGKILL) };
    group.child.wait().unwrap();
    for _ in 0..200 {
        if group.nodes.iter().all(|(_, p)| !alive(*p)) {
            break;
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    for (name, p) in &group.nodes {
        assert!(!alive(*p), "{name} ({p}) outlived its SIGKILLed supervisor");
    }
}

fn root_of(rd: &Path, pid: u32) -> Vec<PathBuf> {
    run_dir_leftovers(rd)
        .into_iter()
        .filter(|p| {
            p.file_name()
                .is_some_and(|n| n.to_string_lossy().starts_with(&format!("aisle{pid}x")))
        })
        .collect()
}

#[test]
fn a_killed_supervisors_instance_is_swept_by_the_next_run() {
    let dir = TestDir::new("rd-sweep");
    let rd = dir.run_dir();
    let mut group = start_group(&rd, &[]);
    kill_supervisor(&mut group);
    let pid = group.pid;
    // Its root (with the owner record) is left; its /dev/shm files too, unless a run of
    // a parallel test already swept them (a dead creator pid's files go from anywhere).
    assert_eq!(root_of(&rd, pid).len(), 1, "the killed run left its root");

    let out = run(&rd, &["run", "--quiet"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(root_of(&rd, pid).is_empty(), "{:?}", root_of(&rd, pid));
    assert!(shm_leftovers(pid).is_empty(), "{:?}", shm_leftovers(pid));
    assert!(run_dir_leftovers(&rd).is_empty());
}

#[test]
fn aisle_clean_removes_a_dead_instance_and_never_a_live_one() {
    let dir = TestDir::new("rd-clean");
    let rd = dir.run_dir();
    let config = load_tolerant_config(&dir);
    let realtime = ["--realtime", "--config-dir", config.to_str().unwrap()];
    let live_group = start_group(&rd, &realtime);
    let live = live_group.pid;
    // A second group beside it: its start sweeps, and must leave the live one alone.
    let mut dead_group = start_group(&rd, &realtime);
    let dead = dead_group.pid;
    assert_eq!(root_of(&rd, live).len(), 1);
    kill_supervisor(&mut dead_group);

    let dry = run(&rd, &["clean", "--dry-run"]);
    let text = String::from_utf8_lossy(&dry.stdout);
    assert!(dry.status.success(), "{text}");
    assert!(
        text.contains(&format!("would remove instance aisle{dead}x")),
        "{text}"
    );
    assert!(
        text.contains(&format!("owner pid {dead} is gone")),
        "{text}"
    );
    assert!(
        text.contains(&format!("owner pid {live} is running")),
        "{text}"
    );
    assert_eq!(root_of(&rd, dead).len(), 1, "a dry run removes nothing");

    let out = run(&rd, &["clean"]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{text}");
    assert!(
        text.contains(&format!("removed instance aisle{dead}x")),
        "{text}"
    );
    assert!(root_of(&rd, dead).is_empty() && shm_leftovers(dead).is_empty());
    assert_eq!(root_of(&rd, live).len(), 1, "the live instance is kept");
    let runs_on = live_group.nodes.iter().all(|(_, p)| alive(*p));

    let Group {
        mut child,
        stderr,
        nodes,
        ..
    } = live_group;
    // SAFETY: a signal to our own child; it stops its group and removes its instance.
    unsafe { libc::kill(live as i32, libc::SIGINT) };
    wait_exit(&mut child, Duration::from_secs(30)).expect("the live run stops");
    let log = stderr.join().unwrap_or_default();
    assert!(runs_on, "the live group runs on; its log:\n{log}");
    assert_group_gone(live, &nodes, &rd);
}
