//! One writer per output file: an exclusive advisory lock (`flock`) held for as long as a
//! command writes a file, so a second command naming the same file (two `aisle run
//! --record same.mcap` at once) is refused before it starts instead of interleaving its
//! bytes with the first one's and both "succeeding".
//!
//! The lock is on the file itself (its inode), taken without truncating it: a writer
//! that truncates it in place (`File::create`, in this process or in a child such as the
//! recorder node) keeps it locked, and a file left by an earlier, finished command is
//! overwritten as before. The kernel drops the lock when its holder exits, however it
//! ends, so a killed command leaves no stale lock. A file the lock created and nobody
//! wrote (the command failed before it got there) is removed with the lock. Knows files
//! and `/proc/locks`, not what is written.

use std::fs::File;
use std::os::fd::AsRawFd;
use std::os::unix::fs::{MetadataExt, OpenOptionsExt};
use std::path::{Path, PathBuf};

#[derive(Debug, thiserror::Error)]
pub enum LockError {
    #[error(
        "{flag} {}: another command{} is writing this file now; choose another file, or wait until it ends",
        .path.display(),
        .holder.map(|p| format!(" (pid {p})")).unwrap_or_default()
    )]
    Busy {
        flag: String,
        path: PathBuf,
        holder: Option<u32>,
    },
    #[error("{flag} {}: cannot write it: {source}", .path.display())]
    Open {
        flag: String,
        path: PathBuf,
        source: std::io::Error,
    },
}

/// The exclusive lock on one output file, released when dropped.
#[derive(Debug)]
pub struct OutputLock {
    file: File,
    path: PathBuf,
    /// The lock created the file (it did not exist).
    created: bool,
}

impl OutputLock {
    /// Opens for writing (creating if need be, never truncating) and locks `path`, the
    /// output of `flag`: [`LockError::Open`] when it cannot be written (the same open
    /// the write does, so it is also the check that it can be), [`LockError::Busy`]
    /// naming the holder's pid when another open file holds it.
    pub fn acquire(flag: &str, path: &Path) -> Result<OutputLock, LockError> {
        let open_error = |source| LockError::Open {
            flag: flag.to_string(),
            path: path.to_path_buf(),
            source,
        };
        let existed = path.exists();
        // Non-blocking: a FIFO with no reader fails at once instead of hanging here.
        let file = std::fs::OpenOptions::new()
            .write(true)
            .create(true)
            .truncate(false)
            .custom_flags(libc::O_NONBLOCK)
            .open(path)
            .map_err(open_error)?;
        // SAFETY: flock(2) on a descriptor this function owns; no memory is involved.
        if unsafe { libc::flock(file.as_raw_fd(), libc::LOCK_EX | libc::LOCK_NB) } != 0 {
            let e = std::io::Error::last_os_error();
            if e.raw_os_error() != Some(libc::EWOULDBLOCK) {
                return Err(open_error(e));
            }
            let holder = file.metadata().ok().and_then(|m| holder(&m));
            return Err(LockError::Busy {
                flag: flag.to_string(),
                path: path.to_path_buf(),
                holder,
            });
        }
        tracing::debug!("locked {} for {flag}", path.display());
        Ok(OutputLock {
            file,
            path: path.to_path_buf(),
            created: !existed,
        })
    }

    pub fn path(&self) -> &Path {
        &self.path
    }
}

impl Drop for OutputLock {
    fn drop(&mut self) {
        let Ok(ours) = self.file.metadata() else {
            return;
        };
        // Only the very file the lock created, still empty and still at its path.
        let same = std::fs::metadata(&self.path)
            .is_ok_and(|m| m.ino() == ours.ino() && m.dev() == ours.dev());
        if self.created && same && ours.len() == 0 {
            let _ = std::fs::remove_file(&self.path);
        }
    }
}

/// The pid holding a `flock` on the file of `meta`, from `/proc/locks` (lines such as
/// `1: FLOCK  ADVISORY  WRITE 4242 08:01:1234 0 EOF`; waiters are marked `->`).
fn holder(meta: &std::fs::Metadata) -> Option<u32> {
    let dev = meta.dev();
    let major = ((dev >> 8) & 0xfff) | ((dev >> 32) & !0xfff);
    let minor = (dev & 0xff) | ((dev >> 12) & !0xff);
    let id = format!("{major:02x}:{minor:02x}:{}", meta.ino());
    let locks = std::fs::read_to_string("/proc/locks").ok()?;
    locks.lines().find_map(|line| {
        let fields: Vec<&str> = line.split_whitespace().collect();
        // A waiter's line has `->` where the holder's has the lock's kind.
        if fields.get(1) != Some(&"FLOCK") || fields.get(5) != Some(&id.as_str()) {
            return None;
        }
        fields.get(4)?.parse().ok()
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dir(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("aisle-lock-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    #[test]
    fn a_second_writer_is_refused_naming_the_file_and_the_holder() {
        let d = dir("busy");
        let p = d.join("same.mcap");
        let first = OutputLock::acquire("--record", &p).unwrap();
        let e = OutputLock::acquire("--record", &p).unwrap_err();
        let text = e.to_string();
        assert!(matches!(e, LockError::Busy { .. }), "{text}");
        assert!(text.contains("same.mcap"), "{text}");
        assert!(
            text.contains(&format!("pid {}", std::process::id())),
            "{text}"
        );
        // Written in place by another handle (the recorder's File::create): kept, and
        // free again once the first lock is dropped.
        std::fs::write(&p, b"data").unwrap();
        drop(first);
        assert_eq!(std::fs::read(&p).unwrap(), b"data");
        let again = OutputLock::acquire("--record", &p).unwrap();
        drop(again);
        assert!(
            p.exists(),
            "a file the lock did not create is never removed"
        );
        std::fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn a_file_the_lock_created_and_nobody_wrote_is_removed() {
        let d = dir("empty");
        let p = d.join("report.json");
        drop(OutputLock::acquire("--report", &p).unwrap());
        assert!(!p.exists());
        let e = OutputLock::acquire("--report", &d.join("no/such/dir.json")).unwrap_err();
        assert!(matches!(e, LockError::Open { .. }), "{e}");
        assert!(e.to_string().contains("no/such/dir.json"), "{e}");
        std::fs::remove_dir_all(&d).unwrap();
    }
}
