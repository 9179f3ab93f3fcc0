//! Applying one node's [`Options`] to the calling process, at startup, before its first
//! cycle: affinity and priority to every thread it has (later threads inherit them),
//! memory locked, stack and heap pre-faulted, the CPUs' wake-up latency requested. What the OS refuses (no CAP_SYS_NICE, an
//! RLIMIT_RTPRIO or RLIMIT_MEMLOCK too low, a CPU outside the cpuset, a PM QoS device
//! only root may write) is collected, with
//! the reason, and the run goes on without it: [`apply_or_warn`] logs it in one warning.
//!
//! Knows Linux system calls; not which node it runs in, nor the file.

use super::Options;
use std::io::Error as OsError;
use std::sync::OnceLock;

/// Whether processes forked later inherit a real-time priority.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Forks {
    /// A node: its later threads inherit the priority (`SCHED_RESET_ON_FORK` would
    /// reset them, since threads are forks to the scheduler).
    Inherit,
    /// The supervisor: the nodes it starts begin with the normal policy and apply
    /// their own options.
    Reset,
}

/// An option the OS refused, and why.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Refusal {
    /// The option as written in `realtime.toml`, e.g. `priority = 80`.
    pub option: String,
    /// The OS error and what would allow it.
    pub why: String,
}

/// What [`apply`] did.
#[derive(Debug, Default)]
pub struct Outcome {
    /// The options in effect now, as written in `realtime.toml`.
    pub applied: Vec<String>,
    pub refused: Vec<Refusal>,
}

/// The CPU mask the process had before [`apply`] changed it, for the supervisor's
/// children (the launcher gives it back to them: a node's affinity is its own).
static INHERITED: OnceLock<libc::cpu_set_t> = OnceLock::new();

/// The affinity the process started with, when [`apply`] changed it.
pub fn inherited_affinity() -> Option<libc::cpu_set_t> {
    INHERITED.get().copied()
}

/// The CPUs the calling thread may run on.
pub fn available_cpus() -> Result<Vec<usize>, OsError> {
    let set = current_affinity()?;
    // SAFETY: CPU_ISSET reads one bit of a mask we own; every index is < CPU_SETSIZE.
    Ok((0..libc::CPU_SETSIZE as usize)
        .filter(|&c| unsafe { libc::CPU_ISSET(c, &set) })
        .collect())
}

fn current_affinity() -> Result<libc::cpu_set_t, OsError> {
    // SAFETY: an all-zero cpu_set_t is a valid empty mask; the kernel writes at most
    // size_of::<cpu_set_t>() bytes into it.
    unsafe {
        let mut set: libc::cpu_set_t = std::mem::zeroed();
        if libc::sched_getaffinity(0, std::mem::size_of::<libc::cpu_set_t>(), &mut set) != 0 {
            return Err(OsError::last_os_error());
        }
        Ok(set)
    }
}

/// Applies `o` to this process; never fails, reports what it could not do.
pub fn apply(o: &Options, forks: Forks) -> Outcome {
    let mut out = Outcome::default();
    let mut record = |option: String, r: Result<(), String>| match r {
        Ok(()) => out.applied.push(option),
        Err(why) => out.refused.push(Refusal { option, why }),
    };
    if !o.cpus.is_empty() {
        record(format!("cpus = {:?}", o.cpus), set_affinity(&o.cpus));
    }
    if o.prefault_heap_kb > 0 {
        let kb = o.prefault_heap_kb;
        record(format!("prefault_heap_kb = {kb}"), prefault_heap(kb));
    }
    if o.prefault_stack_kb > 0 {
        let kb = o.prefault_stack_kb;
        record(format!("prefault_stack_kb = {kb}"), prefault_stack(kb));
    }
    // After the prefaults: under a finite limit only what is mapped now is locked, and
    // the grown heap and stack are what the hot path uses.
    if o.lock_memory {
        record("lock_memory = true".into(), super::lock::lock_memory());
    }
    if let Some(us) = o.max_wakeup_latency_us {
        let device = std::path::Path::new(super::wakeup::DEVICE);
        record(
            format!("max_wakeup_latency_us = {us}"),
            super::wakeup::request(device, us),
        );
    }
    if o.priority > 0 {
        let p = o.priority;
        record(format!("priority = {p}"), set_fifo(p, forks));
    }
    out
}

/// [`apply`], then one warning naming every refused option and why (none when all
/// applied), and one debug line with what applied.
pub fn apply_or_warn(node: &str, o: &Options, forks: Forks) -> Outcome {
    let out = apply(o, forks);
    if !out.refused.is_empty() {
        let list: Vec<String> = out
            .refused
            .iter()
            .map(|r| format!("{}: {}", r.option, r.why))
            .collect();
        tracing::warn!(
            "{node}: real-time options refused by the OS, running without them: {}",
            list.join("; ")
        );
    }
    if !out.applied.is_empty() {
        tracing::debug!(
            "{node}: real-time options applied: {}",
            out.applied.join(", ")
        );
    }
    out
}

/// The ids of this process's threads.
fn threads() -> Vec<libc::pid_t> {
    let Ok(dir) = std::fs::read_dir("/proc/self/task") else {
        return vec![0];
    };
    dir.flatten()
        .filter_map(|e| e.file_name().to_str().and_then(|s| s.parse().ok()))
        .collect()
}

/// Runs `call` for every thread; the first failure other than a thread that ended
/// meanwhile (ESRCH).
fn each_thread(call: impl Fn(libc::pid_t) -> libc::c_int) -> Result<(), OsError> {
    for tid in threads() {
        if call(tid) != 0 {
            let e = OsError::last_os_error();
            if e.raw_os_error() != Some(libc::ESRCH) {
                return Err(e);
            }
        }
    }
    Ok(())
}

fn set_affinity(cpus: &[usize]) -> Result<(), String> {
    let before = current_affinity().map_err(|e| format!("sched_getaffinity: {e}"))?;
    // SAFETY: an all-zero mask is valid; CPU_SET writes one bit, and every index was
    // checked below CPU_SETSIZE when the file was loaded (and is again here).
    let mut set: libc::cpu_set_t = unsafe { std::mem::zeroed() };
    for &c in cpus {
        if c >= libc::CPU_SETSIZE as usize {
            return Err(format!("CPU {c} is beyond CPU_SETSIZE"));
        }
        unsafe { libc::CPU_SET(c, &mut set) };
    }
    let size = std::mem::size_of::<libc::cpu_set_t>();
    // SAFETY: `set` outlives the call; the kernel reads `size` bytes of it.
    each_thread(|tid| unsafe { libc::sched_setaffinity(tid, size, &set) }).map_err(|e| {
        let why = if e.raw_os_error() == Some(libc::EINVAL) {
            "none of these CPUs is in this process's cpuset"
        } else {
            "needs CAP_SYS_NICE to change another user's threads"
        };
        format!("sched_setaffinity: {e}; {why}")
    })?;
    let _ = INHERITED.set(before);
    Ok(())
}

fn set_fifo(priority: u32, forks: Forks) -> Result<(), String> {
    let policy = match forks {
        Forks::Inherit => libc::SCHED_FIFO,
        Forks::Reset => libc::SCHED_FIFO | libc::SCHED_RESET_ON_FORK,
    };
    let param = libc::sched_param {
        sched_priority: priority as libc::c_int,
    };
    // SAFETY: `param` outlives the call.
    each_thread(|tid| unsafe { libc::sched_setscheduler(tid, policy, &param) }).map_err(|e| {
        let limit = rlimit_text(libc::RLIMIT_RTPRIO, |v| v.to_string());
        format!(
            "sched_setscheduler(SCHED_FIFO): {e}; needs CAP_SYS_NICE or RLIMIT_RTPRIO >= {priority} (it is {limit})"
        )
    })
}

/// An rlimit's soft value (`RLIM_INFINITY` when unlimited); `None` when unreadable.
pub(super) fn soft_rlimit(resource: libc::__rlimit_resource_t) -> Option<u64> {
    let mut r = libc::rlimit {
        rlim_cur: 0,
        rlim_max: 0,
    };
    // SAFETY: the kernel writes one rlimit into `r`.
    (unsafe { libc::getrlimit(resource, &mut r) } == 0).then_some(r.rlim_cur)
}

/// An rlimit's soft value for a message.
fn rlimit_text(resource: libc::__rlimit_resource_t, show: fn(u64) -> String) -> String {
    match soft_rlimit(resource) {
        None => "unknown".into(),
        Some(libc::RLIM_INFINITY) => "unlimited".into(),
        Some(v) => show(v),
    }
}

/// Touches `kb` KiB below the current stack frame, 16 KiB a frame, so the pages are
/// mapped before the hot path needs them. Refused above [`super::MAX_PREFAULT_STACK_KB`]
/// or half the stack's rlimit, so it can never overflow the main thread's stack.
fn prefault_stack(kb: u32) -> Result<(), String> {
    let limit = soft_rlimit(libc::RLIMIT_STACK).unwrap_or(0);
    if kb > super::MAX_PREFAULT_STACK_KB {
        return Err(format!("more than {} KiB", super::MAX_PREFAULT_STACK_KB));
    }
    if limit != libc::RLIM_INFINITY && u64::from(kb) * 1024 > limit / 2 {
        return Err(format!(
            "more than half the stack limit (RLIMIT_STACK {} KiB)",
            limit / 1024
        ));
    }
    touch_stack(kb.div_ceil(STACK_CHUNK_KB));
    Ok(())
}

const STACK_CHUNK_KB: u32 = 16;

#[inline(never)]
fn touch_stack(chunks: u32) {
    // Written (zeroed) and kept alive across the call below, so neither the write nor
    // the frame can be optimised away or reused by a tail call.
    let chunk = [0u8; STACK_CHUNK_KB as usize * 1024];
    if chunks > 1 {
        touch_stack(chunks - 1);
    }
    std::hint::black_box(&chunk);
}

/// Grows the allocator's main arena by `kb` KiB, touched, and keeps it: large blocks
/// no longer get their own mmap (which faults on every use) and freed memory is never
/// trimmed, so the hot path's allocations reuse resident pages. With `lock_memory`
/// the pages also stay resident.
#[cfg(target_env = "gnu")]
fn prefault_heap(kb: u32) -> Result<(), String> {
    // SAFETY: mallopt only sets allocator parameters.
    let ok = unsafe {
        libc::mallopt(libc::M_MMAP_MAX, 0) == 1 && libc::mallopt(libc::M_TRIM_THRESHOLD, -1) == 1
    };
    if !ok {
        return Err("mallopt refused M_MMAP_MAX / M_TRIM_THRESHOLD".into());
    }
    let bytes = kb as usize * 1024;
    let mut block: Vec<u8> = Vec::new();
    block
        .try_reserve_exact(bytes)
        .map_err(|e| format!("cannot allocate {kb} KiB: {e}"))?;
    let p = block.as_mut_ptr();
    for i in (0..bytes).step_by(4096) {
        // SAFETY: `i < bytes`, the capacity just reserved; a volatile write so that the
        // page is touched even though the block is freed unread.
        unsafe { std::ptr::write_volatile(p.add(i), 1) };
    }
    drop(block);
    Ok(())
}

#[cfg(not(target_env = "gnu"))]
fn prefault_heap(_kb: u32) -> Result<(), String> {
    Err("needs glibc's mallopt".into())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn what_needs_no_privilege_applies_without_a_refusal() {
        let cpus = available_cpus().unwrap();
        assert!(!cpus.is_empty());
        let o = Options {
            cpus: cpus.clone(),
            prefault_stack_kb: 256,
            prefault_heap_kb: 1024,
            ..Options::default()
        };
        let out = apply(&o, Forks::Inherit);
        assert!(out.refused.is_empty(), "{:?}", out.refused);
        assert_eq!(out.applied.len(), 3, "{:?}", out.applied);
        assert_eq!(available_cpus().unwrap(), cpus);
        assert!(inherited_affinity().is_some());
    }

    #[test]
    fn nothing_asked_nothing_done() {
        let out = apply(&Options::default(), Forks::Inherit);
        assert!(out.applied.is_empty() && out.refused.is_empty());
    }

    #[test]
    fn a_stack_prefault_near_the_limit_is_refused_not_attempted() {
        let err = prefault_stack(super::super::MAX_PREFAULT_STACK_KB + 1).unwrap_err();
        assert!(err.contains("more than"), "{err}");
    }
}
