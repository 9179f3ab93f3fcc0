//! Who shares the machine among the group runs of one test binary (cargo runs a
//! binary's tests on parallel threads). A realtime run asserts on time (the robot at
//! rest within 0.3 s of a fault, heartbeats within their 0.2 s timeout), which lockstep
//! neighbours keeping both cores of a 2-core CI machine busy would blur. So a realtime
//! run takes the machine [`alone`], and every other group run of that binary takes it
//! [`beside`] the others, still side by side with them.
//!
//! Take the guard once, at the start of a test: the lock prefers writers, so a second
//! read lock taken while a realtime test waits would wait for it forever.

use std::sync::{PoisonError, RwLock, RwLockReadGuard, RwLockWriteGuard};

static MACHINE: RwLock<()> = RwLock::new(());

/// For a realtime run: no other group of this test binary runs meanwhile.
pub fn alone() -> RwLockWriteGuard<'static, ()> {
    MACHINE.write().unwrap_or_else(PoisonError::into_inner)
}

/// For a lockstep run (or anything else that keeps cores busy): beside other such
/// runs, never beside a realtime one.
pub fn beside() -> RwLockReadGuard<'static, ()> {
    MACHINE.read().unwrap_or_else(PoisonError::into_inner)
}
