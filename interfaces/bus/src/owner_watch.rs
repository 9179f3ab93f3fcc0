//! Whether the process that created an instance (its owner: `aisle run`'s supervisor, a
//! replay of its own) still runs it, for observers that joined it from outside (`aisle
//! echo`, `aisle hz`). Such an observer must leave when the group ends: its owner waits
//! for attached observers before it removes the instance, and removing the files of an
//! observer's ports from under it is what iceoryx2 reports as a corrupted system.
//!
//! The instance has ended when its owner record is gone (the instance was removed), the
//! owner no longer runs, or the owner's node, seen in the instance before, has left it
//! (the owner stopped its group and now waits for observers). Knows the owner record and
//! the instance's live nodes; not what the owner is or does.

use crate::Instance;
use crate::clock;
use crate::owner::Owner;

/// How often the owner is looked at (each look reads `/proc` and lists the nodes).
const EVERY_NS: u64 = 200_000_000;

/// Watches one instance's owner.
#[derive(Debug)]
pub struct OwnerWatch {
    instance: Instance,
    owner: Option<Owner>,
    /// The owner had a live node in the instance at some look.
    seen_node: bool,
    looked_ns: u64,
    ended: Option<String>,
}

impl OwnerWatch {
    /// Starts watching `instance` (its owner is read now).
    pub fn new(instance: &Instance) -> OwnerWatch {
        let mut w = OwnerWatch {
            instance: instance.clone(),
            owner: Owner::read(&instance.root),
            seen_node: false,
            looked_ns: 0,
            ended: None,
        };
        w.look();
        w
    }

    /// Why the instance has ended (naming its owner), or `None` while its owner runs
    /// it. Looks again at most every 200 ms; once ended, stays ended.
    pub fn ended(&mut self) -> Option<&str> {
        if self.ended.is_none() && clock::monotonic_ns().saturating_sub(self.looked_ns) >= EVERY_NS
        {
            self.look();
        }
        self.ended.as_deref()
    }

    fn look(&mut self) {
        self.looked_ns = clock::monotonic_ns();
        let prefix = &self.instance.prefix;
        let Some(owner) = self.owner else {
            self.ended = Some(format!(
                "instance {prefix} has no owner record in {}: it was removed",
                self.instance.root.display()
            ));
            return;
        };
        let pid = owner.pid;
        if Owner::read(&self.instance.root) != Some(owner) {
            self.ended = Some(format!(
                "instance {prefix} was removed by its owner (pid {pid})"
            ));
        } else if !owner.is_alive() {
            self.ended = Some(format!(
                "the owner of instance {prefix} (pid {pid}) has exited"
            ));
        } else if self.instance.live_nodes().iter().any(|(_, p)| *p == pid) {
            self.seen_node = true;
        } else if self.seen_node {
            self.ended = Some(format!(
                "the owner of instance {prefix} (pid {pid}) has stopped its group and left it"
            ));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_instance_without_an_owner_record_has_ended() {
        let i = Instance::unique(std::path::Path::new("/tmp/aisle-watch-test"));
        let mut w = OwnerWatch::new(&i);
        let why = w.ended().expect("no owner record").to_string();
        assert!(why.contains(&i.prefix) && why.contains("removed"), "{why}");
    }

    #[test]
    fn a_live_owner_without_a_node_yet_has_not_ended_and_a_dead_one_has() {
        let i = Instance::unique(std::path::Path::new("/tmp/aisle-watch-test"));
        std::fs::create_dir_all(&i.root).unwrap();
        let me = Owner::current().unwrap();
        me.write(&i.root).unwrap();
        let mut w = OwnerWatch::new(&i);
        assert_eq!(w.ended(), None, "this process owns it and runs");
        // The same pid with another start time: a reused pid, not the owner.
        w.owner = Some(Owner {
            start: me.start + 1,
            ..me
        });
        w.look();
        let why = w.ended().expect("the recorded owner is not this process");
        assert!(why.contains(&format!("pid {}", me.pid)), "{why}");
        std::fs::remove_dir_all(&i.root).unwrap();
    }
}
