//! The recorder's writer thread: takes the payloads the drain copied out, writes them
//! with their viewer conversions, the run's metadata and attachments, and flushes a
//! chunk every flush period.
//!
//! With a live view (`--foxglove`) the converted viewer messages also go to the
//! [`LiveServer`] (which never blocks); without a file (a live view alone) nothing is
//! written but the conversion still runs.
//!
//! Knows the file layout (through [`RecordWriter`]) and the viewer; not the bus. Buffers
//! go back to the drain once written, so the node thread rarely allocates.

use super::RecorderOptions;
use super::log_clock::LogClock;
use crate::aligned::AlignedBuf;
use crate::live::{LiveError, LiveServer, LiveSummary};
use crate::viewer::{ViewerConverter, ViewerMessage, ViewerModels, ViewerOptions};
use crate::writer::{RecordWriter, WriteCounts, WriteError};
use aisle_bus::{NodeError, clock};
use std::collections::BTreeMap;
use std::fs::File;
use std::io::BufWriter;
use std::net::SocketAddr;
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
    thread: JoinHandle<Result<Written, WriteError>>,
}

/// What the writer thread wrote and served.
pub(super) struct Written {
    pub counts: WriteCounts,
    pub live: Option<LiveSummary>,
}

impl WriterThread {
    /// Creates `out` (when given) and starts writing into it, and serves the live view
    /// when the options ask for one; `names[i]` is the service of source i.
    pub(super) fn start(
        out: Option<&Path>,
        options: &RecorderOptions,
        names: &[&'static str],
        clock: LogClock,
        models: ViewerModels,
    ) -> Result<WriterThread, NodeError> {
        let writer = out.map(|out| create(out, options)).transpose()?;
        let (ready_tx, ready) = mpsc::sync_channel(1);
        let (jobs, job_rx) = mpsc::channel::<Job>();
        let (free_tx, free_rx) = mpsc::channel::<(usize, AlignedBuf)>();
        let queued = Arc::new(AtomicUsize::new(0));
        let write = WriteLoop {
            writer,
            live: options.live,
            ready: ready_tx,
            jobs: job_rx,
            free: free_tx,
            queued: queued.clone(),
            names: names.to_vec(),
            viewer: options.viewer,
            models,
            clock,
            flush_period_ns: options.flush_period.as_nanos() as u64,
        };
        let thread = std::thread::Builder::new()
            .name("recorder-writer".into())
            .spawn(move || write.run())
            .map_err(|e| NodeError::setup("the writer thread", e))?;
        // The live view starts in the writer thread (so the server's threads inherit its
        // idle priority); a bad address is a setup error before the node is ready.
        match ready.recv() {
            Ok(Ok(())) => {}
            Ok(Err(e)) => return Err(NodeError::setup("the live view", e)),
            Err(_) => {
                return Err(NodeError::Protocol(
                    "the writer thread ended at its start".into(),
                ));
            }
        }
        Ok(WriterThread {
            jobs,
            free: free_rx,
            queued,
            thread,
        })
    }

    /// Closes the queue and waits until the file is finalised and the live view closed.
    pub(super) fn finish(self, out: &Path) -> Result<Written, NodeError> {
        let WriterThread { jobs, thread, .. } = self;
        drop(jobs);
        thread
            .join()
            .map_err(|_| NodeError::Protocol("the writer thread panicked".into()))?
            .map_err(|e| NodeError::Protocol(format!("writing {}: {e}", out.display())))
    }
}

/// Creates the record file and its writer.
fn create(out: &Path, options: &RecorderOptions) -> Result<RecordWriter<Output>, NodeError> {
    let file =
        File::create(out).map_err(|e| NodeError::setup(format!("output {}", out.display()), e))?;
    RecordWriter::new(BufWriter::with_capacity(1 << 20, file), options.writer)
        .map_err(|e| NodeError::setup(format!("output {}", out.display()), e))
}

type Output = BufWriter<File>;

/// The writer thread's state.
struct WriteLoop<W: std::io::Write + std::io::Seek> {
    /// The record file; `None` for a live view alone.
    writer: Option<RecordWriter<W>>,
    /// Where to serve the live view, if anywhere.
    live: Option<SocketAddr>,
    /// Told once the live view serves (or could not start).
    ready: mpsc::SyncSender<Result<(), LiveError>>,
    jobs: mpsc::Receiver<Job>,
    free: mpsc::Sender<(usize, AlignedBuf)>,
    queued: Arc<AtomicUsize>,
    names: Vec<&'static str>,
    viewer: ViewerOptions,
    /// The robot model and the scene's static bodies the viewer channels show.
    models: ViewerModels,
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
    fn run(self) -> Result<Written, WriteError> {
        run_only_when_idle();
        let WriteLoop {
            mut writer,
            live,
            ready,
            jobs,
            free,
            queued,
            names,
            viewer,
            models,
            mut clock,
            flush_period_ns,
        } = self;
        let mut live = match live.map(LiveServer::start).transpose() {
            Ok(live) => live,
            Err(e) => {
                let _ = ready.send(Err(e));
                return Ok(Written {
                    counts: WriteCounts::default(),
                    live: None,
                });
            }
        };
        if let Some(l) = &live {
            tracing::info!("recorder: serving the live view on ws://{}", l.addr());
        }
        let _ = ready.send(Ok(()));
        let mut viewer = ViewerConverter::new(viewer);
        if let Some(model) = &models.robot {
            viewer = viewer.with_robot(model);
        }
        if let Some(scene) = &models.scene {
            viewer = viewer.with_static_bodies(scene);
        }
        let mut converted = Vec::new();
        let mut full = AlignedBuf::new();
        let mut last_flush = clock::monotonic_ns();
        let mut last_log_time = 0;
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
                    last_log_time = log_time;
                    if let Some(w) = &mut writer {
                        w.write_raw_at(index, log_time, full.bytes())?;
                    }
                    viewer.recycle(&mut converted);
                    viewer.convert(names[index], &full, &mut converted);
                    emit(&converted, live.as_mut(), writer.as_mut(), log_time)?;
                    let _ = free.send((index, buf));
                }
                Job::Metadata(name, entries) => {
                    if let Some(w) = &mut writer {
                        w.write_metadata(&name, entries)?
                    }
                }
                Job::Attach {
                    name,
                    media_type,
                    data,
                    time,
                } => {
                    if let Some(w) = &mut writer {
                        w.attach(&name, media_type, &data, clock.of_event(time))?
                    }
                }
            }
            let now = clock::monotonic_ns();
            if now.saturating_sub(last_flush) >= flush_period_ns {
                if let Some(w) = &mut writer {
                    w.flush()?;
                }
                last_flush = now;
            }
        }
        // The last tick's plot messages, held back until the next tick that never came.
        viewer.recycle(&mut converted);
        viewer.finish(&mut converted);
        emit(&converted, live.as_mut(), writer.as_mut(), last_log_time)?;
        let live = live.map(LiveServer::finish);
        let counts = match writer {
            Some(w) => w.finish()?.1,
            None => WriteCounts::default(),
        };
        Ok(Written { counts, live })
    }
}

/// Hands converted viewer messages to the live view (which never blocks) and the file.
fn emit<W: std::io::Write + std::io::Seek>(
    messages: &[ViewerMessage],
    mut live: Option<&mut LiveServer>,
    mut writer: Option<&mut RecordWriter<W>>,
    log_time: u64,
) -> Result<(), WriteError> {
    for m in messages {
        if let Some(l) = live.as_deref_mut() {
            l.offer(m, log_time);
        }
        if let Some(w) = writer.as_deref_mut() {
            w.write_viewer(m, log_time)?;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_output_error_names_the_file_and_leaves_the_recorder_to_its_caller() {
        let out = Path::new("/nonexistent/dir/x.mcap");
        let Err(e) = create(out, &RecorderOptions::default()) else {
            panic!("created a file under /nonexistent");
        };
        // The node's caller prints `error: recorder: <e>`: the source named once.
        let line = format!("error: recorder: {e}");
        assert_eq!(line.matches("recorder").count(), 1, "{line}");
        assert!(line.contains("output /nonexistent/dir/x.mcap"), "{line}");
    }
}
