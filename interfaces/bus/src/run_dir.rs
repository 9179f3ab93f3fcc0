//! The run directory: where instance roots live (`AISLE_RUN_DIR`, else a per-user
//! `<tmp>/aisle-<euid>`), and the rule that decides whether it can be trusted.
//!
//! A run directory is trusted when nobody but this user (or root) can rename, replace
//! or write into it or any of its ancestors: otherwise another user could swap an
//! instance root mid-run. It is created 0700 when missing (race-free: `mkdir` with the
//! mode, then `lstat` to check what is really there). Knows paths and permissions, not
//! iceoryx2.

use std::ffi::OsString;
use std::os::unix::fs::{DirBuilderExt, MetadataExt, PermissionsExt};
use std::path::{Path, PathBuf};

/// The variable naming the run directory.
pub const RUN_DIR_VAR: &str = "AISLE_RUN_DIR";

/// Longest default run directory; longer temporary directories fall back to `/tmp`
/// (root and prefix must fit `MAX_ROOT_AND_PREFIX`, see `instance.rs`).
const MAX_DEFAULT_LEN: usize = 24;

#[derive(Debug, thiserror::Error)]
pub enum RunDirError {
    #[error(
        "{RUN_DIR_VAR} is set but empty; set it to an absolute directory or unset it (default {default})"
    )]
    Empty { default: String },
    #[error(
        "{RUN_DIR_VAR}={value:?} is not an absolute path; set it to an absolute directory or unset it (default {default})"
    )]
    Relative { value: String, default: String },
    #[error("the run directory {path} (owner uid {uid}, mode {mode:04o}) is refused: {why}")]
    Untrusted {
        path: PathBuf,
        uid: u32,
        mode: u32,
        why: String,
    },
    #[error("the run directory {path}: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
}

/// The effective user id of this process.
pub fn euid() -> u32 {
    // SAFETY: geteuid has no preconditions and cannot fail.
    unsafe { libc::geteuid() }
}

/// The run directory of this process, created if missing and checked; `Err` names the
/// variable or the path and why it is refused.
pub fn run_dir() -> Result<PathBuf, RunDirError> {
    let dir = resolve(std::env::var_os(RUN_DIR_VAR))?;
    prepare(&dir)?;
    Ok(dir)
}

/// The run directory `AISLE_RUN_DIR` names (`value`), else the per-user default.
pub fn resolve(value: Option<OsString>) -> Result<PathBuf, RunDirError> {
    let Some(value) = value else {
        return Ok(default_dir());
    };
    let default = default_dir().display().to_string();
    if value.is_empty() {
        return Err(RunDirError::Empty { default });
    }
    let path = PathBuf::from(&value);
    if !path.is_absolute() {
        return Err(RunDirError::Relative {
            value: value.to_string_lossy().into_owned(),
            default,
        });
    }
    Ok(path)
}

/// `<tmp>/aisle-<euid>`, or `/tmp/aisle-<euid>` when the temporary directory's path is
/// too long for iceoryx2's socket paths.
pub fn default_dir() -> PathBuf {
    let name = format!("aisle-{}", euid());
    let t = std::env::temp_dir().join(&name);
    if t.is_absolute() && t.as_os_str().len() <= MAX_DEFAULT_LEN {
        t
    } else {
        Path::new("/tmp").join(name)
    }
}

/// Creates `dir` (0700) unless it exists, then checks it and its ancestors.
pub fn prepare(dir: &Path) -> Result<(), RunDirError> {
    let io = |source| RunDirError::Io {
        path: dir.to_path_buf(),
        source,
    };
    if let Some(parent) = dir.parent() {
        check_ancestors(parent)?;
    }
    create_private_dir(dir).map_err(io)?;
    // What is there now, whoever made it: never follow a link.
    let meta = std::fs::symlink_metadata(dir).map_err(io)?;
    check_dir(dir, &meta, euid(), 0o022)
}

/// Creates `dir` and any missing ancestors with mode 0700, whatever the umask is at
/// that instant; an existing `dir` is left as it is. iceoryx2 narrows the process-wide
/// umask to 0177 while it binds a socket (`unix_datagram_socket.rs`), so a directory
/// another thread made meanwhile would be 0600, which even its owner cannot enter
/// unless privileged: each directory made here gets its mode set again once it exists.
pub fn create_private_dir(dir: &Path) -> std::io::Result<()> {
    if let Some(parent) = dir.parent()
        && !parent.as_os_str().is_empty()
        && std::fs::symlink_metadata(parent).is_err()
    {
        create_private_dir(parent)?;
    }
    match std::fs::DirBuilder::new().mode(0o700).create(dir) {
        Ok(()) => std::fs::set_permissions(dir, std::fs::Permissions::from_mode(0o700)),
        Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => Ok(()),
        Err(e) => Err(e),
    }
}

/// A directory this user may keep instances in: a real directory (not a link), owned by
/// `euid`, with none of the `forbidden` mode bits (group/other write for a run
/// directory, all group/other bits for an instance root).
pub fn check_dir(
    path: &Path,
    meta: &std::fs::Metadata,
    euid: u32,
    forbidden: u32,
) -> Result<(), RunDirError> {
    let mode = meta.permissions().mode() & 0o7777;
    let refuse = |why: &str| {
        Err(RunDirError::Untrusted {
            path: path.to_path_buf(),
            uid: meta.uid(),
            mode,
            why: why.to_string(),
        })
    };
    if meta.file_type().is_symlink() {
        return refuse("it is a symbolic link");
    }
    if !meta.is_dir() {
        return refuse("it is not a directory");
    }
    if meta.uid() != euid {
        return refuse(&format!(
            "it belongs to another user (this process runs as uid {euid}); remove it or choose another {RUN_DIR_VAR}"
        ));
    }
    if mode & forbidden != 0 {
        return refuse(&format!(
            "other users may write into it; `chmod go-w` it (mode {:04o} at most) or choose another {RUN_DIR_VAR}",
            0o7777 & !forbidden & 0o777
        ));
    }
    Ok(())
}

/// Every ancestor of `dir`, as written and as resolved: owned by root or this user, and
/// not writable by group or others unless sticky (`/tmp`), so nobody else can rename
/// the run directory away.
fn check_ancestors(dir: &Path) -> Result<(), RunDirError> {
    let me = euid();
    for a in dir.ancestors() {
        let meta = std::fs::symlink_metadata(a).map_err(|source| RunDirError::Io {
            path: a.to_path_buf(),
            source,
        })?;
        check_ancestor(a, &meta, me)?;
    }
    let real = std::fs::canonicalize(dir).map_err(|source| RunDirError::Io {
        path: dir.to_path_buf(),
        source,
    })?;
    for a in real.ancestors() {
        let meta = std::fs::metadata(a).map_err(|source| RunDirError::Io {
            path: a.to_path_buf(),
            source,
        })?;
        check_ancestor(a, &meta, me)?;
    }
    Ok(())
}

/// One ancestor: owned by root or `euid`; a directory writable by group or others must
/// be sticky (a link's own mode means nothing).
pub fn check_ancestor(path: &Path, meta: &std::fs::Metadata, euid: u32) -> Result<(), RunDirError> {
    let mode = meta.permissions().mode() & 0o7777;
    let refuse = |why: String| {
        Err(RunDirError::Untrusted {
            path: path.to_path_buf(),
            uid: meta.uid(),
            mode,
            why,
        })
    };
    if meta.uid() != 0 && meta.uid() != euid {
        return refuse(format!(
            "this ancestor of the run directory belongs to another user, who could rename it (this process runs as uid {euid})"
        ));
    }
    let sticky = mode & 0o1000 != 0;
    if meta.is_dir() && mode & 0o022 != 0 && !sticky {
        return refuse(
            "this ancestor of the run directory is writable by other users and not sticky, so they could rename it".into(),
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::os::unix::fs::PermissionsExt;

    fn scratch(name: &str) -> PathBuf {
        let d = PathBuf::from(format!("/tmp/aisle-rd-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        let _ = std::fs::remove_file(&d);
        d
    }

    #[test]
    fn empty_and_relative_values_are_refused_naming_the_variable() {
        let e = resolve(Some(OsString::new())).unwrap_err().to_string();
        assert!(e.contains("AISLE_RUN_DIR is set but empty"), "{e}");
        let e = resolve(Some("runs/x".into())).unwrap_err().to_string();
        assert!(
            e.contains("AISLE_RUN_DIR=\"runs/x\" is not an absolute path"),
            "{e}"
        );
        assert_eq!(
            resolve(Some("/tmp/x".into())).unwrap(),
            PathBuf::from("/tmp/x")
        );
        let d = resolve(None).unwrap();
        assert!(d.ends_with(format!("aisle-{}", euid())) && d.is_absolute());
    }

    #[test]
    fn a_missing_run_dir_is_created_private_and_an_existing_0755_one_is_kept() {
        let d = scratch("new");
        prepare(&d).unwrap();
        let mode = std::fs::metadata(&d).unwrap().permissions().mode() & 0o777;
        assert_eq!(mode, 0o700);
        std::fs::set_permissions(&d, std::fs::Permissions::from_mode(0o755)).unwrap();
        prepare(&d).unwrap();
        std::fs::remove_dir(&d).unwrap();
    }

    #[test]
    fn a_group_or_other_writable_run_dir_is_refused_naming_path_uid_and_mode() {
        for m in [0o775, 0o757, 0o1777] {
            let d = scratch("open");
            std::fs::create_dir(&d).unwrap();
            std::fs::set_permissions(&d, std::fs::Permissions::from_mode(m)).unwrap();
            let e = prepare(&d).unwrap_err().to_string();
            std::fs::remove_dir(&d).unwrap();
            assert!(e.contains(&d.display().to_string()), "{e}");
            assert!(e.contains(&format!("mode {m:04o}")), "{e}");
            assert!(e.contains(&format!("uid {}", euid())), "{e}");
            assert!(e.contains("other users may write"), "{e}");
        }
    }

    #[test]
    fn a_symlink_or_a_file_is_refused() {
        let target = scratch("target");
        std::fs::create_dir(&target).unwrap();
        let link = scratch("link");
        std::os::unix::fs::symlink(&target, &link).unwrap();
        let e = prepare(&link).unwrap_err().to_string();
        assert!(e.contains("symbolic link"), "{e}");
        std::fs::remove_file(&link).unwrap();
        std::fs::remove_dir(&target).unwrap();
        let f = scratch("file");
        std::fs::write(&f, b"").unwrap();
        let e = prepare(&f).unwrap_err().to_string();
        assert!(e.contains("not a directory"), "{e}");
        std::fs::remove_file(&f).unwrap();
    }

    #[test]
    fn a_run_dir_of_another_user_is_refused() {
        // The metadata of a directory owned by this user, judged as if we were another.
        let d = scratch("owner");
        std::fs::create_dir(&d).unwrap();
        let meta = std::fs::symlink_metadata(&d).unwrap();
        let other = euid().wrapping_add(4242);
        let e = check_dir(&d, &meta, other, 0o022).unwrap_err().to_string();
        assert!(e.contains("belongs to another user"), "{e}");
        assert!(e.contains(&format!("owner uid {}", euid())), "{e}");
        assert!(check_dir(&d, &meta, euid(), 0o022).is_ok());
        std::fs::remove_dir(&d).unwrap();
    }

    #[test]
    fn ancestors_must_be_trusted_unless_sticky() {
        let tmp = std::fs::metadata("/tmp").unwrap();
        assert!(
            check_ancestor(Path::new("/tmp"), &tmp, euid()).is_ok(),
            "/tmp is sticky"
        );
        let d = scratch("parent");
        std::fs::create_dir(&d).unwrap();
        std::fs::set_permissions(&d, std::fs::Permissions::from_mode(0o777)).unwrap();
        let e = prepare(&d.join("runs")).unwrap_err().to_string();
        assert!(e.contains("ancestor") && e.contains("not sticky"), "{e}");
        std::fs::set_permissions(&d, std::fs::Permissions::from_mode(0o1777)).unwrap();
        prepare(&d.join("runs")).unwrap();
        std::fs::remove_dir_all(&d).unwrap();
    }
}
