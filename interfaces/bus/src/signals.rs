//! SIGINT, SIGTERM and SIGHUP (the terminal closed) as a stop request.
//!
//! The handler only sets a flag; every wait in the bus uses short timeouts and checks
//! [`stop_requested`], so a process stops within one wait slice (<= 100 ms) of the
//! signal. iceoryx2's own lazy handler is never installed because no process calls
//! `Node::wait` or a WaitSet.

use std::sync::atomic::{AtomicBool, AtomicI32, Ordering};

static STOP: AtomicBool = AtomicBool::new(false);
static SIGNAL: AtomicI32 = AtomicI32::new(0);

extern "C" fn on_signal(sig: libc::c_int) {
    SIGNAL.store(sig, Ordering::SeqCst);
    STOP.store(true, Ordering::SeqCst);
}

/// Installs the handler for SIGINT, SIGTERM and SIGHUP. Idempotent.
pub fn install() {
    for sig in [libc::SIGINT, libc::SIGTERM, libc::SIGHUP] {
        // SAFETY: the handler is async-signal-safe (two atomic stores); the sigaction
        // struct is fully initialised by zeroing and setting the handler.
        unsafe {
            // A SIGHUP ignored by whoever started us (`nohup`) stays ignored.
            let mut old: libc::sigaction = std::mem::zeroed();
            libc::sigaction(sig, std::ptr::null(), &mut old);
            if sig == libc::SIGHUP && old.sa_sigaction == libc::SIG_IGN {
                continue;
            }
            let mut action: libc::sigaction = std::mem::zeroed();
            action.sa_sigaction = on_signal as *const () as usize;
            libc::sigemptyset(&mut action.sa_mask);
            action.sa_flags = 0;
            libc::sigaction(sig, &action, std::ptr::null_mut());
        }
    }
}

/// True once SIGINT, SIGTERM or SIGHUP arrived (or [`request_stop`] was called).
pub fn stop_requested() -> bool {
    STOP.load(Ordering::SeqCst)
}

/// The signal that requested the stop, if any.
pub fn last_signal() -> Option<i32> {
    match SIGNAL.load(Ordering::SeqCst) {
        0 => None,
        s => Some(s),
    }
}

/// Asks every wait loop of this process to stop.
pub fn request_stop() {
    STOP.store(true, Ordering::SeqCst);
}
