//! Finding and removing what dead instances left behind: instance roots in a run
//! directory whose owner (see `owner.rs`) is gone, with their `/dev/shm/<prefix>*` files,
//! and `/dev/shm` files of `aisle<pid>x...` instances whose creator pid is dead.
//!
//! Only files and directories of this user are touched, never a live owner's instance.
//! Knows the file layout of an instance, not iceoryx2's contents.

use crate::owner::{Owner, start_time};
use crate::run_dir::euid;
use std::collections::BTreeMap;
use std::os::unix::fs::MetadataExt;
use std::path::{Path, PathBuf};

/// A dead instance: what was (or, in a dry run, would be) removed.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct StaleInstance {
    pub prefix: String,
    /// Its root, when it was in the swept run directory.
    pub root: Option<PathBuf>,
    pub shm_files: Vec<PathBuf>,
    /// Why it counts as dead, e.g. "owner pid 1234 is gone".
    pub why: String,
}

/// What a sweep found.
#[derive(Debug, Default)]
pub struct SweepReport {
    pub removed: Vec<StaleInstance>,
    /// Instances left alone, with the reason (a live owner, no owner record).
    pub kept: Vec<(String, String)>,
    /// Removals that failed, in words.
    pub errors: Vec<String>,
}

/// Sweeps `run_dir` and `/dev/shm`; with `dry_run` nothing is removed.
pub fn sweep(run_dir: &Path, dry_run: bool) -> SweepReport {
    sweep_in(run_dir, Path::new("/dev/shm"), dry_run)
}

fn sweep_in(run_dir: &Path, shm: &Path, dry_run: bool) -> SweepReport {
    let mut report = SweepReport::default();
    let mut live: Vec<String> = Vec::new();
    let mut stale: Vec<StaleInstance> = Vec::new();
    for (prefix, root) in instance_roots(run_dir) {
        match verdict(&prefix, Owner::read(&root)) {
            Ok(why) => stale.push(StaleInstance {
                prefix,
                root: Some(root),
                shm_files: Vec::new(),
                why,
            }),
            Err(why) => {
                report.kept.push((prefix.clone(), why));
                live.push(prefix);
            }
        }
    }
    let known: Vec<String> = stale.iter().map(|s| s.prefix.clone()).collect();
    let files = own_files(shm);
    for s in &mut stale {
        s.shm_files = files
            .iter()
            .filter(|(n, _)| belongs(n, &s.prefix, &live))
            .map(|(_, p)| p.clone())
            .collect();
    }
    // Instances whose root is elsewhere or gone: only the `aisle<pid>x` pattern says
    // whose they were.
    let mut orphans: BTreeMap<String, Vec<PathBuf>> = BTreeMap::new();
    for (name, path) in &files {
        let Some(prefix) = pattern_prefix(name) else {
            continue;
        };
        if known
            .iter()
            .chain(&live)
            .any(|k| name.starts_with(k.as_str()))
        {
            continue;
        }
        if let Some(pid) = pattern_pid(prefix)
            && start_time(pid).is_none()
        {
            orphans
                .entry(prefix.to_string())
                .or_default()
                .push(path.clone());
        }
    }
    for (prefix, shm_files) in orphans {
        let pid = pattern_pid(&prefix).unwrap_or(0);
        stale.push(StaleInstance {
            prefix,
            root: None,
            shm_files,
            why: format!("creator pid {pid} is gone"),
        });
    }
    for s in stale {
        if !dry_run {
            remove(&s, &mut report.errors);
        }
        report.removed.push(s);
    }
    report
}

/// `Ok(why it is dead)` or `Err(why it is kept)`.
fn verdict(prefix: &str, owner: Option<Owner>) -> Result<String, String> {
    match owner {
        Some(o) if o.is_alive() => Err(format!("owner pid {} is running", o.pid)),
        Some(o) => Ok(format!("owner pid {} is gone", o.pid)),
        // Being created right now, or made by something older: only a creator pid
        // in the name can tell.
        None => match pattern_pid(prefix) {
            Some(pid) if start_time(pid).is_none() => {
                Ok(format!("creator pid {pid} is gone (no owner record)"))
            }
            Some(pid) => Err(format!("creator pid {pid} runs (no owner record)")),
            None => Err("no owner record".to_string()),
        },
    }
}

/// Directories of this user in `run_dir` named like an instance prefix.
fn instance_roots(run_dir: &Path) -> Vec<(String, PathBuf)> {
    own_entries(run_dir, |name, meta| {
        meta.is_dir() && crate::instance::valid_prefix(name)
    })
}

/// Regular files of this user in `shm`, by name.
fn own_files(shm: &Path) -> Vec<(String, PathBuf)> {
    own_entries(shm, |_, meta| meta.is_file())
}

/// The entries of `dir` that this user owns and `keep` accepts (links not followed),
/// sorted by name.
fn own_entries(
    dir: &Path,
    keep: impl Fn(&str, &std::fs::Metadata) -> bool,
) -> Vec<(String, PathBuf)> {
    let me = euid();
    let Ok(entries) = std::fs::read_dir(dir) else {
        return Vec::new();
    };
    let mut v: Vec<(String, PathBuf)> = entries
        .flatten()
        .filter_map(|e| {
            let name = e.file_name().into_string().ok()?;
            let meta = std::fs::symlink_metadata(e.path()).ok()?;
            (meta.uid() == me && keep(&name, &meta)).then(|| (name, e.path()))
        })
        .collect();
    v.sort();
    v
}

/// `name` is a file of `prefix`, and not of a live instance whose prefix extends it.
fn belongs(name: &str, prefix: &str, live: &[String]) -> bool {
    name.starts_with(prefix)
        && !live
            .iter()
            .any(|l| l.len() > prefix.len() && name.starts_with(l.as_str()))
}

/// The prefix of a file named by `Instance::unique`: `aisle<pid>x<n>x<hex>_`.
fn pattern_prefix(name: &str) -> Option<&str> {
    let end = name.find('_')? + 1;
    let prefix = &name[..end];
    let mut parts = prefix
        .strip_prefix("aisle")?
        .trim_end_matches('_')
        .split('x');
    let ok = parts.next().is_some_and(is_digits)
        && parts.next().is_some_and(is_digits)
        && parts
            .next()
            .is_some_and(|h| !h.is_empty() && h.bytes().all(|b| b.is_ascii_hexdigit()))
        && parts.next().is_none();
    ok.then_some(prefix)
}

fn is_digits(s: &str) -> bool {
    !s.is_empty() && s.bytes().all(|b| b.is_ascii_digit())
}

/// The creator pid in an `aisle<pid>x...` prefix.
fn pattern_pid(prefix: &str) -> Option<u32> {
    pattern_prefix(prefix)?
        .strip_prefix("aisle")?
        .split('x')
        .next()?
        .parse()
        .ok()
}

fn remove(s: &StaleInstance, errors: &mut Vec<String>) {
    for f in &s.shm_files {
        if let Err(e) = std::fs::remove_file(f)
            && e.kind() != std::io::ErrorKind::NotFound
        {
            errors.push(format!("{}: {e}", f.display()));
        }
    }
    if let Some(root) = &s.root
        && let Err(e) = std::fs::remove_dir_all(root)
        && e.kind() != std::io::ErrorKind::NotFound
    {
        errors.push(format!("{}: {e}", root.display()));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A pid that is not running: past the kernel's limit.
    const DEAD: u32 = 4_194_304 + 7;

    fn scratch(name: &str) -> (PathBuf, PathBuf) {
        let base = PathBuf::from(format!("/tmp/aisle-sw-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&base);
        let (run, shm) = (base.join("run"), base.join("shm"));
        std::fs::create_dir_all(&run).unwrap();
        std::fs::create_dir_all(&shm).unwrap();
        (run, shm)
    }

    fn instance(run: &Path, shm: &Path, prefix: &str, owner: Option<Owner>) {
        std::fs::create_dir(run.join(prefix)).unwrap();
        if let Some(o) = owner {
            o.write(&run.join(prefix)).unwrap();
        }
        std::fs::write(shm.join(format!("{prefix}abc.data")), b"x").unwrap();
    }

    #[test]
    fn prefixes_of_unique_instances_are_recognised() {
        assert_eq!(
            pattern_prefix("aisle12x0x1f_abc.data"),
            Some("aisle12x0x1f_")
        );
        assert_eq!(pattern_pid("aisle12x0x1f_"), Some(12));
        assert_eq!(pattern_prefix("aisle12x0_abc"), None);
        assert_eq!(pattern_prefix("aisleAx0x1f_"), None);
        assert_eq!(pattern_prefix("zz_node"), None);
    }

    #[test]
    fn dead_owners_instances_go_and_live_ones_stay() {
        let (run, shm) = scratch("owners");
        let me = Owner::current().unwrap();
        let dead = Owner {
            pid: DEAD,
            start: 1,
        };
        let reused = Owner {
            start: me.start + 1,
            ..me
        };
        instance(&run, &shm, "live_", Some(me));
        instance(&run, &shm, "dead_", Some(dead));
        instance(&run, &shm, "reused_", Some(reused));
        instance(&run, &shm, &format!("aisle{DEAD}x0x1_"), None);
        instance(&run, &shm, "unknown_", None);
        std::fs::write(shm.join(format!("aisle{DEAD}x3x2_q.data")), b"x").unwrap();
        std::fs::write(shm.join(format!("aisle{}x3x2_q.data", me.pid)), b"x").unwrap();

        let dry = sweep_in(&run, &shm, true);
        assert_eq!(dry.removed.len(), 4, "{dry:?}");
        assert!(run.join("dead_").exists(), "a dry run removes nothing");

        let r = sweep_in(&run, &shm, false);
        let mut gone: Vec<&str> = r.removed.iter().map(|s| s.prefix.as_str()).collect();
        gone.sort();
        let orphan = format!("aisle{DEAD}x3x2_");
        let unnamed = format!("aisle{DEAD}x0x1_");
        assert_eq!(
            gone,
            vec![unnamed.as_str(), orphan.as_str(), "dead_", "reused_"]
        );
        assert!(r.errors.is_empty(), "{:?}", r.errors);
        let left: Vec<String> = std::fs::read_dir(&shm)
            .unwrap()
            .flatten()
            .map(|e| e.file_name().into_string().unwrap())
            .collect();
        let mut left = left;
        left.sort();
        let mine = format!("aisle{}x3x2_q.data", me.pid);
        assert_eq!(
            left,
            vec![mine.as_str(), "live_abc.data", "unknown_abc.data"]
        );
        assert!(run.join("live_").exists() && run.join("unknown_").exists());
        assert!(!run.join("dead_").exists() && !run.join("reused_").exists());
        std::fs::remove_dir_all(run.parent().unwrap()).unwrap();
    }

    #[test]
    fn a_stale_prefix_spares_the_files_of_a_live_longer_prefix() {
        let (run, shm) = scratch("nested");
        instance(
            &run,
            &shm,
            "zz_",
            Some(Owner {
                pid: DEAD,
                start: 1,
            }),
        );
        instance(&run, &shm, "zz_b_", Some(Owner::current().unwrap()));
        let r = sweep_in(&run, &shm, false);
        assert_eq!(r.removed.len(), 1);
        assert_eq!(r.removed[0].shm_files, vec![shm.join("zz_abc.data")]);
        assert!(shm.join("zz_b_abc.data").exists());
        std::fs::remove_dir_all(run.parent().unwrap()).unwrap();
    }
}
