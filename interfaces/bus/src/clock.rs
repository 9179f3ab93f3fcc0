//! The monotonic wall clock used to stamp messages and measure latency.
//!
//! CLOCK_MONOTONIC is shared by all processes of a machine, so a stamp taken in the
//! simulator can be subtracted from one taken in the controller. Only node adapters and
//! the supervisor read it; algorithm code is given times, it never reads a clock.

/// Nanoseconds of CLOCK_MONOTONIC.
pub fn monotonic_ns() -> u64 {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `ts` is a valid timespec; CLOCK_MONOTONIC is always available on Linux.
    unsafe { libc::clock_gettime(libc::CLOCK_MONOTONIC, &mut ts) };
    ts.tv_sec as u64 * 1_000_000_000 + ts.tv_nsec as u64
}
