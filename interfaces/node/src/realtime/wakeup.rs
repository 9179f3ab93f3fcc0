//! The CPUs' wake-up latency: a PM QoS request (`/dev/cpu_dma_latency`) that keeps every
//! CPU out of idle states slower to leave than the asked number of microseconds, for as
//! long as this process holds the file open. 0 keeps idle CPUs polling: a node woken
//! by its trigger finds its CPU running, its caches and, in a virtual machine, its host
//! core still its own, instead of a halted CPU the host may have given away.
//!
//! The kernel takes the least of all open requests and drops a request when its file is
//! closed, so a process that ends, crashed or killed included, leaves nothing behind.
//! Knows Linux's PM QoS interface; not which node asks.

use std::fs::File;
use std::io::Write;
use std::path::Path;
use std::sync::Mutex;

/// The kernel's PM QoS interface for the CPUs' wake-up latency.
pub(super) const DEVICE: &str = "/dev/cpu_dma_latency";

/// The request this process holds (replaced by a later one): open until it ends.
static HELD: Mutex<Option<File>> = Mutex::new(None);

/// Asks for a wake-up latency of at most `us` microseconds through `device` and holds
/// the request for the rest of the process's life.
pub(super) fn request(device: &Path, us: u32) -> Result<(), String> {
    let mut file = std::fs::OpenOptions::new()
        .write(true)
        .open(device)
        .map_err(|e| {
            let why = match e.kind() {
                std::io::ErrorKind::PermissionDenied => {
                    "it is normally root's (mode 0600): run as root, or let aisle's user \
                     write it (a udev rule)"
                }
                std::io::ErrorKind::NotFound => "this kernel has no PM QoS device",
                _ => "the kernel's PM QoS device",
            };
            format!("open {}: {e}; {why}", device.display())
        })?;
    // The device takes the value as a native 32-bit integer (or as hex text); every
    // value `realtime.toml` accepts fits.
    let value = i32::try_from(us).map_err(|_| format!("{us} µs is beyond an i32"))?;
    file.write_all(&value.to_ne_bytes())
        .map_err(|e| format!("write {}: {e}", device.display()))?;
    // A poisoned lock only means another thread panicked while swapping the file; the
    // slot is still a plain Option.
    let mut held = HELD.lock().unwrap_or_else(|p| p.into_inner());
    *held = Some(file);
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn temp(name: &str) -> std::path::PathBuf {
        std::env::temp_dir().join(format!("aisle-wakeup-{name}-{}", std::process::id()))
    }

    #[test]
    fn the_request_is_written_as_a_native_i32_and_held() {
        let path = temp("file");
        std::fs::write(&path, b"").unwrap();
        request(&path, 25).unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), 25i32.to_ne_bytes());
        assert!(HELD.lock().unwrap().is_some());
        let _ = std::fs::remove_file(&path);
    }

    #[test]
    fn a_missing_device_is_refused_with_the_reason() {
        let err = request(&temp("none"), 0).unwrap_err();
        assert!(err.contains("no PM QoS device"), "{err}");
        assert!(err.contains("aisle-wakeup-none"), "{err}");
    }

    #[test]
    fn a_value_beyond_an_i32_is_refused_before_writing() {
        let path = temp("big");
        std::fs::write(&path, b"").unwrap();
        let err = request(&path, u32::MAX).unwrap_err();
        assert!(err.contains("beyond an i32"), "{err}");
        assert!(std::fs::read(&path).unwrap().is_empty());
        let _ = std::fs::remove_file(&path);
    }
}
