//! The monotonic wall clock used to stamp messages and measure latency.
//!
//! CLOCK_MONOTONIC is shared by all processes of a machine, so a stamp taken in the
//! simulator can be subtracted from one taken in the controller. Only node adapters and
//! the supervisor read it; algorithm code is given times, it never reads a clock.

/// Nanoseconds of CLOCK_MONOTONIC.
pub fn monotonic_ns() -> u64 {
    read(libc::CLOCK_MONOTONIC)
}

/// CPU time the calling thread has consumed, in nanoseconds (CLOCK_THREAD_CPUTIME_ID):
/// what a stage's work cost the CPU, as opposed to the wall time it took.
pub fn thread_cpu_ns() -> u64 {
    read(libc::CLOCK_THREAD_CPUTIME_ID)
}

fn read(clock: libc::clockid_t) -> u64 {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `ts` is a valid timespec; both clocks used here are always available on
    // Linux (a failure would leave zeros, never undefined memory).
    unsafe { libc::clock_gettime(clock, &mut ts) };
    ts.tv_sec as u64 * 1_000_000_000 + ts.tv_nsec as u64
}
