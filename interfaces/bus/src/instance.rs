//! One isolated iceoryx2 instance: a unique file prefix (for /dev/shm) and a root
//! directory (for service and node metadata), so parallel runs never see each other.
//! Its creator claims it (root, owner record, private management segment, see
//! `mgmt_segment.rs`) before any iceoryx2 node exists; a joiner only joins one that
//! exists. Nothing of it is ever accessible to another user.

use crate::owner::Owner;
use crate::{BusError, mgmt_segment};
use iceoryx2::config::Config;
use iceoryx2::prelude::*;
use std::path::{Path as StdPath, PathBuf};
use std::sync::atomic::{AtomicU32, Ordering};

static COUNTER: AtomicU32 = AtomicU32::new(0);

/// Longest root path plus prefix with which iceoryx2 0.10 can still create its event
/// sockets (measured: a unix socket path holds at most 107 bytes).
pub const MAX_ROOT_AND_PREFIX: usize = 68;

/// Where an instance lives. Passed to every child on its command line.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Instance {
    /// File-name prefix of every shared-memory object, e.g. `aisle_1234_0_`.
    pub prefix: String,
    /// Directory holding the instance's service and node metadata.
    pub root: PathBuf,
}

impl Instance {
    /// A fresh instance under `base` (e.g. `/tmp/aisle-0`, see `run_dir`): the prefix combines the pid,
    /// a per-process counter and the monotonic clock, so concurrent launches differ.
    pub fn unique(base: &StdPath) -> Instance {
        let n = COUNTER.fetch_add(1, Ordering::Relaxed);
        // Short: iceoryx2 builds socket paths from the root and the prefix (see
        // `MAX_ROOT_AND_PREFIX`). The clock part tells apart a reused pid.
        let t = (crate::clock::monotonic_ns() / 1000) % 0x10_0000;
        let prefix = format!("aisle{}x{}x{:x}_", std::process::id(), n, t);
        Instance {
            root: base.join(&prefix),
            prefix,
        }
    }

    pub fn new(prefix: impl Into<String>, root: impl Into<PathBuf>) -> Result<Instance, BusError> {
        let prefix = prefix.into();
        let root = root.into();
        if !valid_prefix(&prefix) {
            return Err(BusError::Instance {
                prefix,
                what: "the prefix must be 1-48 characters of [A-Za-z0-9_]".into(),
            });
        }
        if !root.is_absolute() {
            return Err(BusError::Instance {
                prefix,
                what: format!("the root {} must be an absolute path", root.display()),
            });
        }
        Ok(Instance { prefix, root })
    }

    /// The iceoryx2 configuration of this instance.
    pub fn iceoryx_config(&self) -> Result<Config, BusError> {
        let err = |what: String| BusError::Instance {
            prefix: self.prefix.clone(),
            what,
        };
        let used = self.root.as_os_str().len() + self.prefix.len();
        if used > MAX_ROOT_AND_PREFIX {
            return Err(err(format!(
                "the instance root {} is too long: iceoryx2 keeps unix-domain sockets under it, \
                 whose paths are limited, so root and prefix together may have {MAX_ROOT_AND_PREFIX} \
                 bytes (they have {used}); choose a shorter AISLE_RUN_DIR",
                self.root.display()
            )));
        }
        let mut cfg = Config::default();
        cfg.global.prefix = FileName::new(self.prefix.as_bytes())
            .map_err(|e| err(format!("invalid prefix: {e:?}")))?;
        let mut root = self.root.to_string_lossy().into_owned();
        if !root.ends_with('/') {
            root.push('/');
        }
        let path = iceoryx2::prelude::Path::new(root.as_bytes())
            .map_err(|e| err(format!("invalid root {root}: {e:?}")))?;
        cfg.global.set_root_path(&path);
        Ok(cfg)
    }

    /// Creates the root directory, readable and writable by the owner only, and checks
    /// what is there (an existing root must be a directory of this user, 0700).
    pub fn create_root(&self) -> Result<(), BusError> {
        crate::run_dir::create_private_dir(&self.root)
            .map_err(|e| self.error(format!("cannot create {}: {e}", self.root.display())))?;
        self.check_root()
    }

    /// The creator's side: the root, the owner record (this process, for the sweep of a
    /// later run) and iceoryx2's management segment, all private, before any iceoryx2
    /// node exists.
    pub fn claim(&self) -> Result<(), BusError> {
        self.create_root()?;
        let me =
            Owner::current().ok_or_else(|| self.error("cannot read /proc/self/stat".into()))?;
        match me.write(&self.root) {
            Ok(()) => {}
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {
                if Owner::read(&self.root) != Some(me) {
                    return Err(self.error(format!(
                        "{} is claimed by another process (see its {})",
                        self.root.display(),
                        crate::owner::OWNER_FILE
                    )));
                }
            }
            Err(e) => return Err(self.error(format!("cannot write the owner record: {e}"))),
        }
        mgmt_segment::create_private(&self.prefix)
    }

    /// A joiner's side: the instance must exist (root and management segment, both
    /// private to this user), so a join never creates one that nobody serves.
    pub fn check_joinable(&self) -> Result<(), BusError> {
        let missing = |what: String| BusError::NoInstance {
            prefix: self.prefix.clone(),
            root: self.root.clone(),
            what,
        };
        match std::fs::symlink_metadata(&self.root) {
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                return Err(missing("the root directory does not exist".into()));
            }
            _ => self.check_root()?,
        }
        if !mgmt_segment::path(&self.prefix).exists() {
            return Err(missing(format!(
                "{} does not exist",
                mgmt_segment::path(&self.prefix).display()
            )));
        }
        mgmt_segment::check_private(&self.prefix)
    }

    /// Every shared-memory file of the instance is this user's and closed to everyone
    /// else. Checked after iceoryx2 opened a node: had it made a management segment of
    /// its own (another iceoryx2 version, another name), it would be 0666 and show here.
    pub fn check_private(&self) -> Result<(), BusError> {
        use std::os::unix::fs::{MetadataExt, PermissionsExt};
        mgmt_segment::check_private(&self.prefix)?;
        for f in self.shm_files() {
            let Ok(meta) = std::fs::symlink_metadata(&f) else {
                continue; // removed meanwhile (a node of the instance ended)
            };
            let mode = meta.permissions().mode() & 0o7777;
            if meta.uid() != crate::run_dir::euid() || mode & 0o077 != 0 {
                return Err(self.error(format!(
                    "{} (owner uid {}, mode {mode:04o}) is not private to this user: refused",
                    f.display(),
                    meta.uid()
                )));
            }
        }
        Ok(())
    }

    fn check_root(&self) -> Result<(), BusError> {
        let meta = std::fs::symlink_metadata(&self.root)
            .map_err(|e| self.error(format!("{}: {e}", self.root.display())))?;
        crate::run_dir::check_dir(&self.root, &meta, crate::run_dir::euid(), 0o077)
            .map_err(|e| self.error(e.to_string()))
    }

    fn error(&self, what: String) -> BusError {
        BusError::Instance {
            prefix: self.prefix.clone(),
            what,
        }
    }

    /// Shared-memory files of this instance currently in /dev/shm.
    pub fn shm_files(&self) -> Vec<PathBuf> {
        let Ok(dir) = std::fs::read_dir("/dev/shm") else {
            return Vec::new();
        };
        let mut files: Vec<PathBuf> = dir
            .filter_map(Result::ok)
            .filter(|e| e.file_name().to_string_lossy().starts_with(&self.prefix))
            .map(|e| e.path())
            .collect();
        files.sort();
        files
    }

    /// Removes everything the instance left: its root directory and its /dev/shm files.
    /// Call only when no process of the instance is running.
    pub fn remove(&self) -> std::io::Result<()> {
        for f in self.shm_files() {
            match std::fs::remove_file(&f) {
                Err(e) if e.kind() != std::io::ErrorKind::NotFound => return Err(e),
                _ => {}
            }
        }
        match std::fs::remove_dir_all(&self.root) {
            Err(e) if e.kind() != std::io::ErrorKind::NotFound => Err(e),
            _ => Ok(()),
        }
    }

    /// The pids of the processes that still have a live node in the instance, other
    /// than this one: observers that joined it (an external `aisle record`, `aisle
    /// echo`, a Python client). Empty when the instance cannot be listed (it is gone).
    pub fn attached_pids(&self) -> Vec<u32> {
        let mut pids: Vec<u32> = Vec::new();
        for (_, pid) in self.live_nodes() {
            if !pids.contains(&pid) {
                pids.push(pid);
            }
        }
        pids
    }

    /// The live nodes of the instance other than this process's, each with its name
    /// (a process's `NodeKind` name: `simulator`, `supervisor`, `replay`, ...) and pid.
    /// Empty when the instance cannot be listed (it is gone).
    pub fn live_nodes(&self) -> Vec<(String, u32)> {
        use iceoryx2::node::NodeView;
        let Ok(config) = self.iceoryx_config() else {
            return Vec::new();
        };
        let own = std::process::id();
        let mut nodes = Vec::new();
        let _ = Node::<ipc::Service>::list(&config, |state| {
            if let iceoryx2::node::NodeState::Alive(view) = state
                && let Some(details) = view.details()
                && let Ok(pid) = u32::try_from(details.process_id().value())
                && pid != own
            {
                nodes.push((details.name().as_str().to_string(), pid));
            }
            CallbackProgression::Continue
        });
        nodes
    }

    /// True when nothing of the instance remains on disk or in /dev/shm.
    pub fn is_gone(&self) -> bool {
        self.shm_files().is_empty() && !self.root.exists()
    }
}

/// 1-48 characters of `[A-Za-z0-9_]` (iceoryx2 file names, no path separators).
pub fn valid_prefix(prefix: &str) -> bool {
    !prefix.is_empty()
        && prefix.len() <= 48
        && prefix
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_')
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unique_instances_differ_and_validate() {
        let a = Instance::unique(StdPath::new("/tmp/aisle-test"));
        let b = Instance::unique(StdPath::new("/tmp/aisle-test"));
        assert_ne!(a.prefix, b.prefix);
        assert!(Instance::new(a.prefix.clone(), a.root.clone()).is_ok());
        assert!(Instance::new("bad/prefix", "/tmp").is_err());
        assert!(Instance::new("ok", "relative/root").is_err());
        assert!(a.iceoryx_config().is_ok());
    }
}
