//! Who created an instance: the owner record in its root (pid and the process's start
//! time from `/proc/<pid>/stat`, so a reused pid is not mistaken for the owner), and
//! whether that process still runs. Linux only (`/proc`).

use std::io::Write;
use std::os::unix::fs::OpenOptionsExt;
use std::path::Path;

/// The owner record's file name inside an instance root (iceoryx2's own files there all
/// start with the instance prefix).
pub const OWNER_FILE: &str = "aisle-owner";

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Owner {
    pub pid: u32,
    /// Start time in clock ticks after boot (field 22 of `/proc/<pid>/stat`).
    pub start: u64,
}

impl Owner {
    /// This process.
    pub fn current() -> Option<Owner> {
        let pid = std::process::id();
        Some(Owner {
            pid,
            start: start_time(pid)?,
        })
    }

    /// True while the very process that wrote the record runs (not a zombie).
    pub fn is_alive(&self) -> bool {
        start_time(self.pid) == Some(self.start)
    }

    /// Writes the record into `root`, private, once (it never replaces one).
    pub fn write(&self, root: &Path) -> std::io::Result<()> {
        let mut f = std::fs::OpenOptions::new()
            .write(true)
            .create_new(true)
            .mode(0o600)
            .open(root.join(OWNER_FILE))?;
        writeln!(f, "pid={} start={}", self.pid, self.start)
    }

    /// The record in `root`, if there is a readable one.
    pub fn read(root: &Path) -> Option<Owner> {
        Self::parse(&std::fs::read_to_string(root.join(OWNER_FILE)).ok()?)
    }

    fn parse(text: &str) -> Option<Owner> {
        let mut pid = None;
        let mut start = None;
        for field in text.split_whitespace() {
            match field.split_once('=') {
                Some(("pid", v)) => pid = v.parse().ok(),
                Some(("start", v)) => start = v.parse().ok(),
                _ => {}
            }
        }
        Some(Owner {
            pid: pid?,
            start: start?,
        })
    }
}

/// The start time of a live (not zombie) process, from `/proc/<pid>/stat`.
pub fn start_time(pid: u32) -> Option<u64> {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).ok()?;
    // The command name (field 2) may hold spaces and parentheses: split after the last.
    let rest = stat.rsplit_once(')')?.1;
    let fields: Vec<&str> = rest.split_whitespace().collect();
    if fields.first() == Some(&"Z") || fields.first() == Some(&"X") {
        return None;
    }
    fields.get(19)?.parse().ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn this_process_is_alive_and_a_reused_pid_is_not_its_owner() {
        let me = Owner::current().unwrap();
        assert!(me.is_alive());
        let reused = Owner {
            start: me.start + 1,
            ..me
        };
        assert!(!reused.is_alive());
        assert_eq!(
            Owner::parse(&format!("pid={} start={}\n", me.pid, me.start)),
            Some(me)
        );
        assert_eq!(Owner::parse("pid=12"), None);
    }

    #[test]
    fn the_record_is_written_once_and_read_back() {
        let d = std::path::PathBuf::from(format!("/tmp/aisle-owner-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir(&d).unwrap();
        let me = Owner::current().unwrap();
        me.write(&d).unwrap();
        assert!(me.write(&d).is_err(), "never replaced");
        assert_eq!(Owner::read(&d), Some(me));
        std::fs::remove_dir_all(&d).unwrap();
    }
}
