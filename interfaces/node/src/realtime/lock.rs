//! `lock_memory`: which of the process's pages are kept resident, within what the OS
//! allows.
//!
//! The kernel charges a locked mapping at its whole size against RLIMIT_MEMLOCK, touched
//! or not, and with `MCL_FUTURE` it refuses any later mapping (an allocation, a thread's
//! stack, a port's segment) that would pass the limit: an allocation that fails that way
//! aborts the process mid-run. The shared-memory segments of a port are sized for their
//! capacity (a global map's publisher maps 26 samples of 16 MiB), so a node maps 0.1-1.8
//! GiB of which it touches a few MB. Hence two ways:
//! - **no limit** (CAP_IPC_LOCK, or RLIMIT_MEMLOCK unlimited): every page, now and later,
//!   locked as it is first touched (`mlockall`, `MCL_ONFAULT`);
//! - **a finite limit**: the mappings there are now, whole, in the order the hot path
//!   needs them (the stack, the heap, the other private writable memory, the program's
//!   code and data, then shared memory), smallest first within each, while they fit;
//!   nothing later, so that no mapping can ever fail on the limit. What was left out is
//!   reported.
//!
//! [`plan`] decides (pure, tested on its own); [`lock_memory`] reads `/proc/self/maps`
//! and asks the kernel. Knows Linux's mapping list and lock calls; not the nodes.

use std::io::Error as OsError;

/// What a mapping holds, in the order a finite allowance is spent on them.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub(crate) enum Class {
    /// The main thread's stack.
    Stack,
    /// The allocator's main arena.
    Heap,
    /// Other private writable memory: thread stacks, arenas, large blocks.
    Private,
    /// The program's and libraries' code and read-only data.
    Program,
    /// Shared memory (the bus's segments).
    Shared,
}

/// One line of `/proc/self/maps` that may be locked.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct Mapping {
    pub start: usize,
    pub len: usize,
    pub class: Class,
}

/// Parses one `/proc/<pid>/maps` line; `None` for what cannot or need not be locked:
/// inaccessible ranges (guard pages), the kernel's own (`[vvar]`, `[vdso]`,
/// `[vsyscall]`) and unreadable lines.
pub(crate) fn parse_line(line: &str) -> Option<Mapping> {
    let mut fields = line.split_whitespace();
    let (range, perms) = (fields.next()?, fields.next()?);
    let path = fields.nth(3).unwrap_or("");
    let (a, b) = range.split_once('-')?;
    let start = usize::from_str_radix(a, 16).ok()?;
    let end = usize::from_str_radix(b, 16).ok()?;
    let p = perms.as_bytes();
    if end <= start || p.len() < 4 || p[..3] == *b"---" {
        return None;
    }
    let class = match path {
        "[stack]" => Class::Stack,
        "[heap]" => Class::Heap,
        _ if path.starts_with("[anon") || path.starts_with("[stack:") => Class::Private,
        _ if path.starts_with('[') => return None,
        _ if p[3] == b's' => Class::Shared,
        // Anonymous or the program's own data and bss.
        _ if p[1] == b'w' => Class::Private,
        _ => Class::Program,
    };
    Some(Mapping {
        start,
        len: end - start,
        class,
    })
}

/// The mappings to lock within `allowance` bytes, of `maps`: by class, smallest first
/// within a class (more of the small hot ranges before one large buffer), each whole or
/// not at all.
pub(crate) fn plan(maps: &[Mapping], allowance: u64) -> Vec<Mapping> {
    let mut order: Vec<&Mapping> = maps.iter().collect();
    order.sort_by_key(|m| (m.class, m.len, m.start));
    let mut left = allowance;
    let mut chosen = Vec::new();
    for m in order {
        if m.len as u64 <= left {
            left -= m.len as u64;
            chosen.push(m.clone());
        }
    }
    chosen
}

/// RLIMIT_MEMLOCK's soft value in bytes; `None`: unlimited or unreadable (no check to
/// plan for).
fn memlock_limit() -> Option<u64> {
    super::apply::soft_rlimit(libc::RLIMIT_MEMLOCK).filter(|&v| v != libc::RLIM_INFINITY)
}

/// Whether the process holds CAP_IPC_LOCK (locking is then not charged to a limit).
fn may_lock_without_limit() -> bool {
    const CAP_IPC_LOCK: u32 = 14;
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            let hex = s.lines().find_map(|l| l.strip_prefix("CapEff:"))?.trim();
            u64::from_str_radix(hex, 16).ok()
        })
        .is_some_and(|mask| mask & (1 << CAP_IPC_LOCK) != 0)
}

/// Locks this process's memory as the module doc says; the error names what was left
/// unlocked and why.
pub(super) fn lock_memory() -> Result<(), String> {
    match memlock_limit() {
        Some(limit) if !may_lock_without_limit() => lock_within(limit),
        _ => lock_all(),
    }
}

/// Every page now and later, as it is first touched; with current and future pages
/// populated as they were mapped, the global map's pools made each process that maps
/// them 0.5-1.4 GiB resident. A kernel without `MCL_ONFAULT` (before 4.4) gets the
/// populating lock.
fn lock_all() -> Result<(), String> {
    let flags = libc::MCL_CURRENT | libc::MCL_FUTURE;
    // SAFETY: mlockall takes flags only.
    if unsafe { libc::mlockall(flags | libc::MCL_ONFAULT) } == 0 {
        return Ok(());
    }
    // SAFETY: as above.
    if OsError::last_os_error().raw_os_error() == Some(libc::EINVAL)
        && unsafe { libc::mlockall(flags) } == 0
    {
        return Ok(());
    }
    Err(format!("mlockall: {}", OsError::last_os_error()))
}

/// The current mappings that fit in `limit` bytes, whole; the error says what that
/// left out.
fn lock_within(limit: u64) -> Result<(), String> {
    let text = std::fs::read_to_string("/proc/self/maps")
        .map_err(|e| format!("reading /proc/self/maps: {e}"))?;
    let maps: Vec<Mapping> = text.lines().filter_map(parse_line).collect();
    let mut locked = Vec::new();
    for m in plan(&maps, limit) {
        if lock_range(&m).is_ok() {
            locked.push(m);
        }
    }
    let total = |ms: &[Mapping], c: Option<Class>| -> u64 {
        ms.iter()
            .filter(|m| c.is_none_or(|c| m.class == c))
            .map(|m| m.len as u64)
            .sum()
    };
    let kib = |b: u64| b / 1024;
    let (mapped, done) = (total(&maps, None), total(&locked, None));
    let shared = total(&maps, Some(Class::Shared));
    let own = mapped - shared;
    let own_done = done - total(&locked, Some(Class::Shared));
    Err(format!(
        "RLIMIT_MEMLOCK is {} KiB and the kernel charges a locked mapping whole: locked \
         {} of {} KiB of the process's own memory and {} of {} KiB of shared memory \
         (the bus's segments, sized for their capacity), smallest first after the stack \
         and heap; later mappings are not locked, so that none can fail on the limit. \
         CAP_IPC_LOCK or an unlimited memlock locks every page",
        kib(limit),
        kib(own_done),
        kib(own),
        kib(done - own_done),
        kib(shared)
    ))
}

/// Locks `m`'s pages as they are first touched (`MLOCK_ONFAULT`), or at once on a
/// kernel without it.
fn lock_range(m: &Mapping) -> Result<(), OsError> {
    let addr = m.start as *const libc::c_void;
    // SAFETY: mlock2 only changes the flags of the pages of a range this process maps
    // (read from its own maps file); a range unmapped since fails with ENOMEM.
    if unsafe { libc::mlock2(addr, m.len, libc::MLOCK_ONFAULT) } == 0 {
        return Ok(());
    }
    let e = OsError::last_os_error();
    // SAFETY: as above.
    if e.raw_os_error() == Some(libc::EINVAL) && unsafe { libc::mlock(addr, m.len) } == 0 {
        return Ok(());
    }
    Err(e)
}

#[cfg(test)]
mod tests {
    use super::*;

    const MAPS: &str = "\
55d0a0000000-55d0a2000000 r-xp 00000000 08:01 123 /usr/bin/aisle
55d0a2000000-55d0a2100000 rw-p 02000000 08:01 123 /usr/bin/aisle
55d0a3000000-55d0a3200000 rw-p 00000000 00:00 0 [heap]
7f0000000000-7f0001000000 rw-s 00000000 00:19 7 /dev/shm/iox2_abc.data
7f0001000000-7f0001001000 ---p 00000000 00:00 0
7f0001001000-7f0001801000 rw-p 00000000 00:00 0
7f0002000000-7f0002010000 rw-p 00000000 00:00 0
7ffc00000000-7ffc00021000 rw-p 00000000 00:00 0 [stack]
7ffc00100000-7ffc00102000 r--p 00000000 00:00 0 [vvar]
7ffc00102000-7ffc00104000 r-xp 00000000 00:00 0 [vdso]
";

    fn maps() -> Vec<Mapping> {
        MAPS.lines().filter_map(parse_line).collect()
    }

    #[test]
    fn the_maps_file_is_read_into_classes_without_guards_or_kernel_pages() {
        let m = maps();
        let classes: Vec<Class> = m.iter().map(|m| m.class).collect();
        assert_eq!(
            classes,
            [
                Class::Program,
                Class::Private,
                Class::Heap,
                Class::Shared,
                Class::Private,
                Class::Private,
                Class::Stack,
            ]
        );
        assert_eq!(m[2].start, 0x55d0a3000000);
        assert_eq!(m[2].len, 0x200000);
        assert_eq!(parse_line("not a mapping"), None);
        assert_eq!(parse_line("7000-6000 rw-p 0 00:00 0"), None);
    }

    #[test]
    fn a_small_allowance_goes_to_the_stack_and_heap_first_then_the_smallest() {
        // Stack 132 KiB, heap 2 MiB, then private: 64 KiB, 1 MiB (the program's data),
        // 8 MiB; then 32 MiB of code; then 16 MiB shared.
        let chosen = plan(&maps(), 4 * 1024 * 1024);
        let classes: Vec<(Class, usize)> = chosen.iter().map(|m| (m.class, m.len)).collect();
        assert_eq!(
            classes,
            [
                (Class::Stack, 0x21000),
                (Class::Heap, 0x200000),
                (Class::Private, 0x10000),
                (Class::Private, 0x100000),
            ]
        );
        let used: usize = chosen.iter().map(|m| m.len).sum();
        assert!(used as u64 <= 4 * 1024 * 1024);
    }

    #[test]
    fn nothing_is_locked_beyond_the_allowance_and_everything_fits_a_large_one() {
        assert!(plan(&maps(), 60 * 1024).is_empty());
        assert_eq!(
            plan(&maps(), 64 * 1024).len(),
            1,
            "the 64 KiB mapping alone"
        );
        let all = plan(&maps(), u64::MAX);
        assert_eq!(all.len(), maps().len());
        assert_eq!(all.last().unwrap().class, Class::Shared);
    }

    #[test]
    fn this_process_locks_within_a_limit_and_says_what_it_left() {
        // The test process's own maps (its stack among them), locked within 1 MiB: the
        // report names the limit and both kinds of memory.
        let text = std::fs::read_to_string("/proc/self/maps").unwrap();
        let maps: Vec<Mapping> = text.lines().filter_map(parse_line).collect();
        assert!(maps.iter().any(|m| m.class == Class::Stack));
        assert!(
            plan(&maps, 1 << 20)
                .iter()
                .map(|m| m.len as u64)
                .sum::<u64>()
                <= 1 << 20
        );
        let why = lock_within(1 << 20).unwrap_err();
        // SAFETY: munlockall takes no arguments; it undoes the locks made above.
        unsafe { libc::munlockall() };
        assert!(why.contains("RLIMIT_MEMLOCK is 1024 KiB"), "{why}");
        assert!(why.contains("of the process's own memory"), "{why}");
        assert!(why.contains("KiB of shared memory"), "{why}");
    }
}
