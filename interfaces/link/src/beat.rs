//! Whether the hosts of a spread group can hear each other: every host (each daemon and
//! the supervisor's) puts a beat on `aisle/host/<name>/alive` every [`BEAT`], at
//! real-time priority and dropped rather than queued when the link cannot take it, and
//! notes when each other host's last beat arrived. The supervisor tells a link that is
//! down from a node that hangs by it; a daemon stops its nodes when the supervisor's
//! host stays silent too long.
//!
//! Knows the key and the period; not what a silence means to whom.

use crate::LinkError;
use std::collections::BTreeMap;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::Duration;
use zenoh::Wait;
use zenoh::qos::{CongestionControl, Priority};
use zenoh::sample::Sample;

/// How often a host beats.
pub const BEAT: Duration = Duration::from_millis(20);

fn alive_key(host: &str) -> String {
    format!("aisle/host/{host}/alive")
}

/// Beats for `host` from a thread of its own (a long request does not silence it),
/// until dropped.
pub struct Beating {
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
}

impl Beating {
    pub fn start(session: &zenoh::Session, host: &str) -> Result<Beating, LinkError> {
        let stop = Arc::new(AtomicBool::new(false));
        let (flag, session, key) = (stop.clone(), session.clone(), alive_key(host));
        let thread = std::thread::Builder::new()
            .name("beat".into())
            .spawn(move || {
                while !flag.load(Ordering::Relaxed) {
                    let put = session
                        .put(&key, Vec::<u8>::new())
                        .congestion_control(CongestionControl::Drop)
                        .priority(Priority::RealTime);
                    if let Err(e) = put.wait() {
                        tracing::debug!("beat {key}: {e}");
                    }
                    std::thread::sleep(BEAT);
                }
            })
            .map_err(|e| LinkError::Start {
                host: host.into(),
                what: format!("cannot start the beat thread: {e}"),
            })?;
        Ok(Beating {
            stop,
            thread: Some(thread),
        })
    }
}

impl Drop for Beating {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// When each host's last beat arrived (`aisle_bus::clock::monotonic_ns`).
pub struct Beats {
    book: Arc<Mutex<BTreeMap<String, u64>>>,
    _subscriber: zenoh::pubsub::Subscriber<()>,
}

impl Beats {
    pub fn declare(session: &zenoh::Session) -> Result<Beats, LinkError> {
        let book: Arc<Mutex<BTreeMap<String, u64>>> = Arc::default();
        let noted = book.clone();
        let _subscriber = session
            .declare_subscriber(alive_key("*"))
            .callback(move |s: Sample| {
                let now = aisle_bus::clock::monotonic_ns();
                let host = s
                    .key_expr()
                    .as_str()
                    .strip_prefix("aisle/host/")
                    .and_then(|k| k.strip_suffix("/alive"));
                if let (Some(host), Ok(mut m)) = (host, noted.lock()) {
                    m.insert(host.to_string(), now);
                }
            })
            .wait()
            .map_err(|e| LinkError::Start {
                host: "*".into(),
                what: format!("cannot subscribe to the hosts' beats: {e}"),
            })?;
        Ok(Beats { book, _subscriber })
    }

    /// Host -> arrival of its last beat; a host not heard yet is absent.
    pub fn last(&self) -> BTreeMap<String, u64> {
        self.book.lock().map(|m| m.clone()).unwrap_or_default()
    }
}
