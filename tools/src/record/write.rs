//! The recorder's writer thread: takes the payloads the drain copied out, writes them
//! with their viewer conversions, the run's metadata and attachments, and flushes a
//! chunk every flush period.
//!
//! Knows the file layout (through [`RecordWriter`]) and the viewer; not the bus. Buffers
//! go back to the drain once written, so the node thread rarely allocates.

use super::RecorderOptions;
use super::log_clock::LogClock;
use crate::aligned::AlignedBuf;
use crate::viewer::{ViewerConverter, ViewerOptions};
use crate::writer::{RecordWriter, WriteCounts, WriteError};
use aisle_bus::{NodeError, clock};
use std::collections::BTreeMap;
use std::fs::File;
use std::io::BufWriter;
use std::path::Path;
use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::mpsc;
use std::thread::JoinHandle;

/// What the node thread hands to the writer thread.
pub(super) enum Job {
    /// A payload without its trailing zeros, and its full length.
    Raw {
        index: usize,
        log_time: u64,
        buf: AlignedBuf,
        full_len: usize,
    },
    Metadata(String, BTreeMap<String, String>),
    Attach {
        name: String,
        media_type: &'static str,
        data: Vec<u8>,
        time: u64,
    },
}

/// The running writer thread and the node thread's ends of its queues.
pub(super) struct WriterThread {
    pub jobs: mpsc::Sender<Job>,
    /// Written buffers coming back, by source index.
    pub free: mpsc::Receiver<(usize, AlignedBuf)>,
    /// Payload bytes queued and not written yet.
    pub queued: Arc<AtomicUsize>,
    thread: JoinHandle<Result<WriteCounts, WriteError>>,
}

impl WriterThread {
    /// Creates `out` and starts writing into it; `names[i]` is the service of source i.
    pub(super) fn start(
        out: &Path,
        options: &RecorderOptions,
        names: &[&'static str],
        clock: LogClock,
    ) -> Result<WriterThread, NodeError> {
        let file = File::create(out)
            .map_err(|e| NodeError::setup(format!("recorder: output {}", out.display()), e))?;
        let writer = RecordWriter::new(BufWriter::with_capacity(1 << 20, file), options.writer)
            .map_err(|e| NodeError::setup(format!("recorder: output {}", out.display()), e))?;
        let (jobs, job_rx) = mpsc::channel::<Job>();
        let (free_tx, free_rx) = mpsc::channel::<(usize, AlignedBuf)>();
        let queued = Arc::new(AtomicUsize::new(0));
        let write = WriteLoop {
            writer,
            jobs: job_rx,
            free: free_tx,
            queued: queued.clone(),
            names: names.to_vec(),
            viewer: options.viewer,
            clock,
            flush_period_ns: options.flush_period.as_nanos() as u64,
        };
        let thread = std::thread::Builder::new()
            .name("recorder-writer".into())
            .spawn(move || write.run())
            .map_err(|e| NodeError::setup("recorder: writer thread", e))?;
        Ok(WriterThread {
            jobs,
            free: free_rx,
            queued,
            thread,
        })
    }

    /// Closes the queue and waits until the file is finalised.
    pub(super) fn finish(self, out: &Path) -> Result<WriteCounts, NodeError> {
        let WriterThread { jobs, thread, .. } = self;
        drop(jobs);
        thread
            .join()
            .map_err(|_| NodeError::Protocol("recorder: the writer thread panicked".into()))?
            .map_err(|e| NodeError::Protocol(format!("writing {}: {e}", out.display())))
    }
}

/// The writer thread's state.
struct WriteLoop<W: std::io::Write + std::io::Seek> {
    writer: RecordWriter<W>,
    jobs: mpsc::Receiver<Job>,
    free: mpsc::Sender<(usize, AlignedBuf)>,
    queued: Arc<AtomicUsize>,
    names: Vec<&'static str>,
    viewer: ViewerOptions,
    /// Maps receive times to `log_time`.
    clock: LogClock,
    flush_period_ns: u64,
}

/// Puts the calling thread (and the compression worker it starts) in `SCHED_IDLE`: it
/// runs only on a core no stage wants, so encoding and compressing the record never
/// delays a stage. The drain thread, which copies out of shared memory and acknowledges
/// lockstep ticks, keeps its normal priority; the queue between them (`queue_bytes`)
/// absorbs the backlog. Lowering its own priority needs no privilege; if the OS still
/// refuses, the recorder says so once and writes at normal priority.
fn run_only_when_idle() {
    let param = libc::sched_param { sched_priority: 0 };
    // SAFETY: plain system call on the calling thread (pid 0) with a valid parameter.
    let rc = unsafe { libc::sched_setscheduler(0, libc::SCHED_IDLE, &param) };
    if rc != 0 {
        tracing::warn!(
            "recorder: the writer thread stays at normal priority (SCHED_IDLE refused: {})",
            std::io::Error::last_os_error()
        );
    }
}

impl<W: std::io::Write + std::io::Seek> WriteLoop<W> {
    fn run(self) -> Result<WriteCounts, WriteError> {
        run_only_when_idle();
        let WriteLoop {
            mut writer,
            jobs,
            free,
            queued,
            names,
            viewer,
            mut clock,
            flush_period_ns,
        } = self;
        let mut viewer = ViewerConverter::new(viewer);
        let mut converted = Vec::new();
        let mut full = AlignedBuf::new();
        let mut last_flush = clock::monotonic_ns();
        for job in jobs {
            match job {
                Job::Raw {
                    index,
                    log_time,
                    buf,
                    full_len,
                } => {
                    queued.fetch_sub(buf.len(), Ordering::Relaxed);
                    full.set_padded(buf.bytes(), full_len);
                    let log_time = clock.of_payload(log_time, full.bytes());
                    writer.write_raw_at(index, log_time, full.bytes())?;
                    converted.clear();
                    viewer.convert(names[index], &full, &mut converted);
                    for m in &converted {
                        writer.write_viewer(m, log_time)?;
                    }
                    let _ = free.send((index, buf));
                }
                Job::Metadata(name, entries) => writer.write_metadata(&name, entries)?,
                Job::Attach {
                    name,
                    media_type,
                    data,
                    time,
                } => writer.attach(&name, media_type, &data, clock.of_event(time))?,
            }
            let now = clock::monotonic_ns();
            if now.saturating_sub(last_flush) >= flush_period_ns {
                writer.flush()?;
                last_flush = now;
            }
        }
        Ok(writer.finish()?.1)
    }
}
