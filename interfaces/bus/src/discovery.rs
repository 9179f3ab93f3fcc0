//! Instance discovery: how a process that was not launched by a supervisor (a Python
//! script, `aisle echo`, `aisle topics`) finds a running instance.
//!
//! Whoever creates an instance writes `<root>/aisle-instance.toml` (private, written
//! under a temporary name and linked into place, so a reader never sees half a file;
//! never replaced). An instance is live when its owner record's process runs and that
//! file exists. `AISLE_PREFIX` and `AISLE_ROOT` in the environment name one instance
//! explicitly and win over the run directory; otherwise the newest live instance (by its
//! owner's start time) of the run directory is taken, unless a prefix is asked for.
//!
//! Knows file layouts, the environment and `/proc`, not iceoryx2. The Python SDK reads
//! the same file by the same rules (keep them in step).

use crate::owner::Owner;
use crate::run_dir::RunDirError;
use crate::{BusError, Instance};
use aisle_messages::TickMode;
use serde::{Deserialize, Serialize};
use std::io::Write;
use std::os::unix::fs::OpenOptionsExt;
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::time::Duration;

/// The discovery file's name inside an instance root.
pub const INSTANCE_FILE: &str = "aisle-instance.toml";
/// Names the instance prefix explicitly (with [`ROOT_VAR`]).
pub const PREFIX_VAR: &str = "AISLE_PREFIX";
/// Names the instance root explicitly (with [`PREFIX_VAR`]).
pub const ROOT_VAR: &str = "AISLE_ROOT";

/// The clock mode as the file spells it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Mode {
    Lockstep,
    Realtime,
}

impl From<TickMode> for Mode {
    fn from(m: TickMode) -> Mode {
        match m {
            TickMode::Lockstep => Mode::Lockstep,
            TickMode::Realtime => Mode::Realtime,
        }
    }
}

impl Mode {
    pub fn name(self) -> &'static str {
        match self {
            Mode::Lockstep => "lockstep",
            Mode::Realtime => "realtime",
        }
    }
}

/// The contents of `aisle-instance.toml`.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InstanceRecord {
    pub prefix: String,
    pub root: PathBuf,
    /// The owner's pid (the process that created the instance).
    pub pid: u32,
    pub mode: Mode,
    pub seed: u64,
    /// The creator's message schema hash, 16 hex digits.
    pub schema_hash: String,
    /// The config directory of the group, when the creator knows it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub config_dir: Option<PathBuf>,
    /// What created it: `run`, `replay`, `record`, ...
    pub by: String,
}

impl InstanceRecord {
    pub fn instance(&self) -> Result<Instance, BusError> {
        Instance::new(self.prefix.clone(), self.root.clone())
    }
}

/// How the creating process describes itself in the file it writes.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Creator {
    /// Default: the first argument when it is a plain word (`aisle run` -> `run`), else
    /// the executable's name.
    pub by: Option<String>,
    pub config_dir: Option<PathBuf>,
}

static CREATOR: Mutex<Option<Creator>> = Mutex::new(None);

/// Sets what the instances this process creates say of their creator (a binary calls
/// this once, before it creates one).
pub fn set_creator(by: &str, config_dir: Option<&Path>) {
    *CREATOR.lock().unwrap_or_else(|p| p.into_inner()) = Some(Creator {
        by: Some(by.to_string()),
        config_dir: config_dir.map(Path::to_path_buf),
    });
}

fn creator() -> Creator {
    CREATOR
        .lock()
        .unwrap_or_else(|p| p.into_inner())
        .clone()
        .unwrap_or_default()
}

fn default_by() -> String {
    let mut args = std::env::args();
    let exe = args.next().unwrap_or_default();
    if let Some(a) = args.next()
        && !a.is_empty()
        && a.chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
        && !a.starts_with('-')
    {
        return a;
    }
    Path::new(&exe)
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "unknown".into())
}

/// Absolute, without resolving links when the path does not exist (yet).
fn absolute(p: &Path) -> PathBuf {
    std::fs::canonicalize(p).unwrap_or_else(|_| std::path::absolute(p).unwrap_or(p.into()))
}

/// The creator's side, right after it announced the instance: writes the discovery file
/// into the (claimed) root. Never replaces one.
pub fn write(
    instance: &Instance,
    schema_hash: u64,
    seed: u64,
    mode: TickMode,
) -> Result<(), BusError> {
    let c = creator();
    let record = InstanceRecord {
        prefix: instance.prefix.clone(),
        root: instance.root.clone(),
        pid: std::process::id(),
        mode: mode.into(),
        seed,
        schema_hash: format!("{schema_hash:016x}"),
        config_dir: c.config_dir.as_deref().map(absolute),
        by: c.by.unwrap_or_else(default_by),
    };
    write_record(&record).map_err(|e| BusError::Instance {
        prefix: instance.prefix.clone(),
        what: format!(
            "cannot write {}: {e}",
            instance.root.join(INSTANCE_FILE).display()
        ),
    })
}

fn write_record(record: &InstanceRecord) -> std::io::Result<()> {
    let text = toml::to_string(record).map_err(std::io::Error::other)?;
    let tmp = record.root.join(format!(".{INSTANCE_FILE}.tmp"));
    let _ = std::fs::remove_file(&tmp);
    let mut f = std::fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .mode(0o600)
        .open(&tmp)?;
    f.write_all(text.as_bytes())?;
    f.sync_all()?;
    drop(f);
    // A link is atomic and refuses an existing name: the file appears whole, once.
    let linked = std::fs::hard_link(&tmp, record.root.join(INSTANCE_FILE));
    let _ = std::fs::remove_file(&tmp);
    linked
}

/// The discovery file of the instance rooted at `root`.
pub fn read(root: &Path) -> Result<InstanceRecord, String> {
    let path = root.join(INSTANCE_FILE);
    let text = std::fs::read_to_string(&path).map_err(|e| format!("{}: {e}", path.display()))?;
    let record: InstanceRecord =
        toml::from_str(&text).map_err(|e| format!("{}: {e}", path.display()))?;
    let name = root.file_name().map(|n| n.to_string_lossy().into_owned());
    if record.root != root || name.as_deref() != Some(record.prefix.as_str()) {
        return Err(format!(
            "{}: describes prefix `{}` at {}, not its own directory",
            path.display(),
            record.prefix,
            record.root.display()
        ));
    }
    Ok(record)
}

/// A live instance of the run directory.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LiveInstance {
    pub record: InstanceRecord,
    pub owner: Owner,
    /// How long its owner has been running (zero when `/proc/uptime` cannot be read).
    pub age: Duration,
}

/// What a look into the run directory found.
#[derive(Debug, Default)]
pub struct Listing {
    /// Newest first.
    pub live: Vec<LiveInstance>,
    /// Live owners whose discovery file cannot be read, in words.
    pub unreadable: Vec<String>,
}

/// The live instances among the direct subdirectories of `run_dir` (see the module docs).
pub fn list(run_dir: &Path) -> Listing {
    let mut listing = Listing::default();
    let Ok(entries) = std::fs::read_dir(run_dir) else {
        return listing;
    };
    let uptime = uptime_ticks();
    for e in entries.flatten() {
        let root = e.path();
        let Ok(meta) = std::fs::symlink_metadata(&root) else {
            continue;
        };
        if !meta.is_dir() {
            continue;
        }
        let Some(owner) = Owner::read(&root).filter(Owner::is_alive) else {
            continue;
        };
        if !root.join(INSTANCE_FILE).exists() {
            continue; // being created, or by a build without discovery
        }
        match read(&root) {
            Ok(record) => listing.live.push(LiveInstance {
                age: uptime
                    .map(|(now, hz)| {
                        Duration::from_secs_f64(now.saturating_sub(owner.start) as f64 / hz)
                    })
                    .unwrap_or_default(),
                record,
                owner,
            }),
            Err(e) => listing.unreadable.push(e),
        }
    }
    listing.live.sort_by(|a, b| {
        b.owner
            .start
            .cmp(&a.owner.start)
            .then(a.record.prefix.cmp(&b.record.prefix))
    });
    listing.unreadable.sort();
    listing
}

/// Seconds since boot in clock ticks, and the ticks per second.
fn uptime_ticks() -> Option<(u64, f64)> {
    let text = std::fs::read_to_string("/proc/uptime").ok()?;
    let secs: f64 = text.split_whitespace().next()?.parse().ok()?;
    // SAFETY: sysconf has no preconditions.
    let hz = unsafe { libc::sysconf(libc::_SC_CLK_TCK) };
    (hz > 0).then_some(((secs * hz as f64) as u64, hz as f64))
}

/// Why no instance was found.
#[derive(Debug, thiserror::Error)]
pub enum DiscoveryError {
    #[error(
        "no live aisle instance in {run_dir}: start a group (`aisle run`) or a replay (`aisle replay FILE`), or name one with {PREFIX_VAR} and {ROOT_VAR}{unreadable}"
    )]
    NoneLive {
        run_dir: PathBuf,
        unreadable: String,
    },
    #[error("no live instance `{prefix}` in {run_dir}; live: {live}")]
    NoSuchPrefix {
        prefix: String,
        run_dir: PathBuf,
        live: String,
    },
    #[error("{set} is set but {unset} is not: set both to name an instance, or neither")]
    HalfNamed {
        set: &'static str,
        unset: &'static str,
    },
    #[error("{PREFIX_VAR}/{ROOT_VAR}: {0}")]
    Named(BusError),
    #[error(transparent)]
    RunDir(#[from] RunDirError),
}

/// An instance found: where it is, and its discovery file when it has one.
#[derive(Debug, Clone)]
pub struct Found {
    pub instance: Instance,
    pub record: Option<InstanceRecord>,
}

/// The instance to talk to: `AISLE_PREFIX`/`AISLE_ROOT` when set, else the newest live
/// instance of the run directory (or the live one called `prefix`).
pub fn find(prefix: Option<&str>) -> Result<Found, DiscoveryError> {
    let p = std::env::var_os(PREFIX_VAR).filter(|v| !v.is_empty());
    let r = std::env::var_os(ROOT_VAR).filter(|v| !v.is_empty());
    match (p, r) {
        (Some(p), Some(r)) => {
            let instance = Instance::new(p.to_string_lossy(), PathBuf::from(r))
                .map_err(DiscoveryError::Named)?;
            let record = read(&instance.root).ok();
            Ok(Found { instance, record })
        }
        (Some(_), None) => Err(DiscoveryError::HalfNamed {
            set: PREFIX_VAR,
            unset: ROOT_VAR,
        }),
        (None, Some(_)) => Err(DiscoveryError::HalfNamed {
            set: ROOT_VAR,
            unset: PREFIX_VAR,
        }),
        (None, None) => find_in(&crate::run_dir::run_dir()?, prefix),
    }
}

/// [`find`] in `run_dir`, without looking at the environment.
pub fn find_in(run_dir: &Path, prefix: Option<&str>) -> Result<Found, DiscoveryError> {
    let listing = list(run_dir);
    let chosen = match prefix {
        None => listing.live.first(),
        Some(p) => listing.live.iter().find(|l| l.record.prefix == p),
    };
    match (chosen, prefix) {
        (Some(l), _) => Ok(Found {
            instance: l.record.instance().map_err(DiscoveryError::Named)?,
            record: Some(l.record.clone()),
        }),
        (None, Some(p)) if !listing.live.is_empty() => Err(DiscoveryError::NoSuchPrefix {
            prefix: p.to_string(),
            run_dir: run_dir.to_path_buf(),
            live: listing
                .live
                .iter()
                .map(|l| l.record.prefix.as_str())
                .collect::<Vec<_>>()
                .join(", "),
        }),
        _ => Err(DiscoveryError::NoneLive {
            run_dir: run_dir.to_path_buf(),
            unreadable: if listing.unreadable.is_empty() {
                String::new()
            } else {
                format!(" (unreadable: {})", listing.unreadable.join("; "))
            },
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::os::unix::fs::PermissionsExt;

    fn scratch(name: &str) -> PathBuf {
        let d = PathBuf::from(format!("/tmp/aisle-disc-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    fn claim(run_dir: &Path, prefix: &str, owner: Owner) -> Instance {
        let inst = Instance::new(prefix, run_dir.join(prefix)).unwrap();
        inst.create_root().unwrap();
        owner.write(&inst.root).unwrap();
        inst
    }

    #[test]
    fn the_file_is_private_complete_never_replaced_and_read_back() {
        let d = scratch("write");
        let inst = claim(&d, "p1", Owner::current().unwrap());
        set_creator("replay", Some(&d));
        write(&inst, 0xabc, 7, TickMode::Realtime).unwrap();
        let path = inst.root.join(INSTANCE_FILE);
        let mode = std::fs::metadata(&path).unwrap().permissions().mode() & 0o777;
        assert_eq!(mode, 0o600);
        let text = std::fs::read_to_string(&path).unwrap();
        assert!(text.contains("mode = \"realtime\""), "{text}");
        assert!(
            text.contains("schema_hash = \"0000000000000abc\""),
            "{text}"
        );
        let r = read(&inst.root).unwrap();
        assert_eq!(
            (r.seed, r.by.as_str(), r.pid),
            (7, "replay", std::process::id())
        );
        assert_eq!(r.config_dir.as_deref(), Some(d.as_path()));
        assert!(
            write(&inst, 1, 1, TickMode::Lockstep).is_err(),
            "never replaced"
        );
        assert_eq!(read(&inst.root).unwrap().seed, 7);
        let names: Vec<_> = std::fs::read_dir(&inst.root)
            .unwrap()
            .map(|e| e.unwrap().file_name().into_string().unwrap())
            .collect();
        assert_eq!(names.len(), 2, "no temporary file left: {names:?}");
        std::fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn unknown_keys_and_foreign_roots_are_refused_naming_the_file() {
        let d = scratch("bad");
        let inst = claim(&d, "p2", Owner::current().unwrap());
        let path = inst.root.join(INSTANCE_FILE);
        let good = format!(
            "prefix = \"p2\"\nroot = \"{}\"\npid = 1\nmode = \"lockstep\"\nseed = 1\nschema_hash = \"00\"\nby = \"run\"\n",
            inst.root.display()
        );
        std::fs::write(&path, format!("{good}colour = 1\n")).unwrap();
        let e = read(&inst.root).unwrap_err();
        assert!(e.contains(INSTANCE_FILE) && e.contains("colour"), "{e}");
        std::fs::write(&path, good.replace("\"p2\"", "\"p3\"")).unwrap();
        let e = read(&inst.root).unwrap_err();
        assert!(e.contains("not its own directory"), "{e}");
        std::fs::write(&path, &good).unwrap();
        assert!(read(&inst.root).is_ok());
        let l = list(&d);
        assert_eq!(l.live.len(), 1);
        std::fs::write(&path, good.replace("lockstep", "sometimes")).unwrap();
        let l = list(&d);
        assert!(l.live.is_empty() && l.unreadable.len() == 1, "{l:?}");
        let e = find_in(&d, None).unwrap_err().to_string();
        assert!(
            e.contains("no live aisle instance") && e.contains("sometimes"),
            "{e}"
        );
        std::fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn only_live_owners_count_and_the_newest_comes_first() {
        let d = scratch("list");
        let me = Owner::current().unwrap();
        let mut child = std::process::Command::new("sleep")
            .arg("30")
            .spawn()
            .unwrap();
        let pid = child.id();
        let younger = Owner {
            pid,
            start: crate::owner::start_time(pid).unwrap(),
        };
        let old = claim(&d, "old", me);
        let new = claim(&d, "new", younger);
        let dead = claim(
            &d,
            "dead",
            Owner {
                pid: me.pid,
                start: me.start + 1,
            },
        );
        let _no_file = claim(&d, "nofile", me);
        for i in [&old, &new, &dead] {
            write_record(&InstanceRecord {
                prefix: i.prefix.clone(),
                root: i.root.clone(),
                pid: me.pid,
                mode: Mode::Lockstep,
                seed: 1,
                schema_hash: "00".into(),
                config_dir: None,
                by: "run".into(),
            })
            .unwrap();
        }
        let l = list(&d);
        let live: Vec<_> = l.live.iter().map(|l| l.record.prefix.as_str()).collect();
        assert_eq!(live, ["new", "old"], "the child started after this process");
        assert_eq!(find_in(&d, None).unwrap().instance, new);
        assert_eq!(find_in(&d, Some("old")).unwrap().instance, old);
        let e = find_in(&d, Some("dead")).unwrap_err().to_string();
        assert!(
            e.contains("no live instance `dead`") && e.contains("live: new, old"),
            "{e}"
        );
        child.kill().unwrap();
        child.wait().unwrap();
        assert_eq!(
            list(&d).live.len(),
            1,
            "a dead owner's instance is not live"
        );
        std::fs::remove_dir_all(&d).unwrap();
        let e = find_in(&d, None).unwrap_err().to_string();
        assert!(e.contains("no live aisle instance"), "{e}");
    }
}
