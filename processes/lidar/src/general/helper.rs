//! A second thread for the column sweep of tilted scans: it waits for a column range of
//! the placement the scanning thread shares with it, sweeps it into a buffer of its own
//! and hands the buffer back. One job at a time, through one slot under a mutex and a
//! condition variable (futexes: waiting and waking allocate nothing, and buffers and the
//! shared placement move through the slot, so no scan allocates).
//!
//! Nothing waits on it without an answer: a helper whose thread could not start or has
//! ended reports so, and the caller sweeps the range itself. Knows nothing of boxes or
//! rays beyond the [`Lane`] it runs.

use super::place::Placement;
use super::sweep::Lane;
use std::ops::Range;
use std::sync::{Arc, Condvar, Mutex, MutexGuard};
use std::thread::JoinHandle;

/// Columns `cols` of `placement` into `out` (rows x `cols.len()`).
#[derive(Debug)]
struct Job {
    placement: Arc<Placement>,
    cols: Range<usize>,
    out: Vec<[f32; 3]>,
}

/// A job's buffer, filled, and its returns.
#[derive(Debug)]
pub(super) struct Done {
    pub out: Vec<[f32; 3]>,
    pub hits: usize,
}

/// What the two threads exchange.
#[derive(Debug, Default)]
struct Slot {
    job: Option<Job>,
    done: Option<Done>,
    /// Set by the owner to end the thread.
    closing: bool,
    /// Cleared when the thread ends (also by unwinding).
    alive: bool,
}

#[derive(Debug, Default)]
struct Shared {
    slot: Mutex<Slot>,
    changed: Condvar,
}

impl Shared {
    fn lock(&self) -> MutexGuard<'_, Slot> {
        // The slot holds no invariant a panic could break halfway.
        self.slot.lock().unwrap_or_else(|e| e.into_inner())
    }

    fn wait<'a>(&self, g: MutexGuard<'a, Slot>) -> MutexGuard<'a, Slot> {
        self.changed.wait(g).unwrap_or_else(|e| e.into_inner())
    }
}

/// The helper thread and the slot it serves.
#[derive(Debug)]
pub(super) struct Helper {
    shared: Arc<Shared>,
    thread: Option<JoinHandle<()>>,
}

impl Helper {
    /// Starts the thread with a lane for `rows` rows and up to `spans` spans; `None`
    /// when the OS refuses a thread.
    pub fn start(rows: usize, spans: usize) -> Option<Helper> {
        let shared = Arc::new(Shared::default());
        shared.lock().alive = true;
        let theirs = Arc::clone(&shared);
        let lane = Lane::new(rows, spans);
        let thread = std::thread::Builder::new()
            .name("lidar-sweep".into())
            .spawn(move || serve(&theirs, lane))
            .ok()?;
        Some(Helper {
            shared,
            thread: Some(thread),
        })
    }

    /// Hands over columns `cols` of `placement` with `out` to fill (resized to
    /// `rows x cols.len()`); false when the helper has gone.
    pub fn send(
        &self,
        placement: Arc<Placement>,
        cols: Range<usize>,
        mut out: Vec<[f32; 3]>,
    ) -> bool {
        out.resize(placement.pattern.rows() * cols.len(), [0.0; 3]);
        let mut slot = self.shared.lock();
        if !slot.alive {
            return false;
        }
        slot.job = Some(Job {
            placement,
            cols,
            out,
        });
        drop(slot);
        self.shared.changed.notify_all();
        true
    }

    /// Waits for the job sent last; `None` when the helper has gone.
    pub fn wait(&self) -> Option<Done> {
        let mut slot = self.shared.lock();
        loop {
            if let Some(done) = slot.done.take() {
                return Some(done);
            }
            if !slot.alive {
                return None;
            }
            slot = self.shared.wait(slot);
        }
    }
}

impl Drop for Helper {
    fn drop(&mut self) {
        self.shared.lock().closing = true;
        self.shared.changed.notify_all();
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// Marks the thread gone when it ends, however it ends.
struct Alive<'a>(&'a Shared);

impl Drop for Alive<'_> {
    fn drop(&mut self) {
        let mut slot = self.0.lock();
        slot.alive = false;
        // A job it held goes too: the placement returns to its owner.
        slot.job = None;
        drop(slot);
        self.0.changed.notify_all();
    }
}

/// The thread's loop: one job after another until the owner closes the slot.
fn serve(shared: &Shared, mut lane: Lane) {
    let _alive = Alive(shared);
    let mut slot = shared.lock();
    loop {
        if slot.closing {
            return;
        }
        let Some(Job {
            placement,
            cols,
            mut out,
        }) = slot.job.take()
        else {
            slot = shared.wait(slot);
            continue;
        };
        drop(slot);
        let stride = cols.len();
        let hits = lane.sweep(&placement, cols, &mut out, stride);
        // The placement goes back to the scanning thread's sole ownership before it
        // learns that the job is done.
        drop(placement);
        slot = shared.lock();
        slot.done = Some(Done { out, hits });
        shared.changed.notify_all();
    }
}
