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
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
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
    /// Set at the end of the run: the writer thread hands its work back.
    handover: Arc<AtomicBool>,
    thread: JoinHandle<Result<Option<Pump<Output>>, WriteError>>,
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
        let handover = Arc::new(AtomicBool::new(false));
        let write = WriteLoop {
            writer,
            live: options.live,
            ready: ready_tx,
            viewer: options.viewer,
            models,
            intake: Intake {
                jobs: job_rx,
                free: free_tx,
                queued: queued.clone(),
                names: names.to_vec(),
                clock,
                flush_period_ns: options.flush_period.as_nanos() as u64,
            },
        };
        let handed_over = handover.clone();
        let thread = std::thread::Builder::new()
            .name("recorder-writer".into())
            .spawn(move || {
                run_only_when_idle();
                let Some(mut pump) = write.start() else {
                    return Ok(None);
                };
                pump.run(Some(&handed_over))?;
                Ok(Some(pump))
            })
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
            handover,
            thread,
        })
    }

    /// Closes the queue, takes the writing back from the writer thread, writes what is
    /// still queued on the calling thread and finalises the file and the live view.
    ///
    /// Why on the calling thread: the run is over, so nothing is left to protect from
    /// the writer, but an idle-priority thread gets next to no CPU while the machine is
    /// busy (a test suite, a CPU hog), and cannot raise its own priority back without
    /// privilege; the supervisor's grace would run out with the queue unwritten and the
    /// file unfinalised. The writer thread returns after the job it is on.
    pub(super) fn finish(self, out: &Path) -> Result<Written, NodeError> {
        let WriterThread {
            jobs,
            handover,
            thread,
            ..
        } = self;
        drop(jobs);
        handover.store(true, Ordering::Release);
        let failed = |e: WriteError| NodeError::Protocol(format!("writing {}: {e}", out.display()));
        let pump = thread
            .join()
            .map_err(|_| NodeError::Protocol("the writer thread panicked".into()))?
            .map_err(failed)?;
        let Some(mut pump) = pump else {
            return Ok(Written {
                counts: WriteCounts::default(),
                live: None,
            });
        };
        pump.run(None).map_err(failed)?;
        pump.finish().map_err(failed)
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

/// What the writer thread starts from.
struct WriteLoop<W: std::io::Write + std::io::Seek> {
    /// The record file; `None` for a live view alone.
    writer: Option<RecordWriter<W>>,
    /// Where to serve the live view, if anywhere.
    live: Option<SocketAddr>,
    /// Told once the live view serves (or could not start).
    ready: mpsc::SyncSender<Result<(), LiveError>>,
    viewer: ViewerOptions,
    /// The robot model and the scene's static bodies the viewer channels show.
    models: ViewerModels,
    intake: Intake,
}

/// Where the jobs come from and where their buffers go back, and how they are stamped
/// and flushed: what the writing keeps across the handover.
struct Intake {
    jobs: mpsc::Receiver<Job>,
    free: mpsc::Sender<(usize, AlignedBuf)>,
    queued: Arc<AtomicUsize>,
    names: Vec<&'static str>,
    /// Maps receive times to `log_time`.
    clock: LogClock,
    flush_period_ns: u64,
}

/// Puts the calling thread in `SCHED_IDLE`: it runs only on a core no stage wants, so
/// encoding and compressing the record (in this thread: the writer starts no compression
/// worker) never delays a stage. The drain thread, which copies out of shared memory
/// and acknowledges lockstep ticks, keeps its normal priority; the queue between them
/// (`queue_bytes`) absorbs the backlog, and what is left when the run ends is written by
/// the drain thread ([`WriterThread::finish`]). Lowering its own priority needs no
/// privilege; if the OS still refuses, the recorder says so once and writes at normal
/// priority.
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
    /// Starts the live view (when asked) and the viewer conversion; `None` when the
    /// live view could not start (the node thread is told through `ready`).
    fn start(self) -> Option<Pump<W>> {
        let live = match self.live.map(LiveServer::start).transpose() {
            Ok(live) => live,
            Err(e) => {
                let _ = self.ready.send(Err(e));
                return None;
            }
        };
        if let Some(l) = &live {
            tracing::info!("recorder: serving the live view on ws://{}", l.addr());
        }
        let _ = self.ready.send(Ok(()));
        let mut viewer = ViewerConverter::new(self.viewer);
        if let Some(model) = &self.models.robot {
            viewer = viewer.with_robot(model);
        }
        if let Some(scene) = &self.models.scene {
            viewer = viewer.with_static_bodies(scene);
        }
        Some(Pump {
            writer: self.writer,
            live,
            viewer,
            converted: Vec::new(),
            full: AlignedBuf::new(),
            intake: self.intake,
            last_flush: clock::monotonic_ns(),
            last_log_time: 0,
        })
    }
}

/// The writing under way: the file, the live view and the viewer conversion, and the
/// queue they take jobs from. Made in the writer thread and handed back to the node
/// thread at the end ([`WriterThread::finish`]).
struct Pump<W: std::io::Write + std::io::Seek> {
    writer: Option<RecordWriter<W>>,
    live: Option<LiveServer>,
    viewer: ViewerConverter,
    /// Viewer messages of the payload being written, reused.
    converted: Vec<ViewerMessage>,
    /// The payload being written, padded back to its full length, reused.
    full: AlignedBuf,
    intake: Intake,
    last_flush: u64,
    last_log_time: u64,
}

impl<W: std::io::Write + std::io::Seek> Pump<W> {
    /// Writes jobs until the queue is closed and empty, or, when `handover` is given,
    /// until it is set.
    fn run(&mut self, handover: Option<&AtomicBool>) -> Result<(), WriteError> {
        while let Ok(job) = self.intake.jobs.recv() {
            self.write(job)?;
            let now = clock::monotonic_ns();
            if now.saturating_sub(self.last_flush) >= self.intake.flush_period_ns {
                if let Some(w) = &mut self.writer {
                    w.flush()?;
                }
                self.last_flush = now;
            }
            if handover.is_some_and(|h| h.load(Ordering::Acquire)) {
                break;
            }
        }
        Ok(())
    }

    fn write(&mut self, job: Job) -> Result<(), WriteError> {
        match job {
            Job::Raw {
                index,
                log_time,
                buf,
                full_len,
            } => {
                self.intake.queued.fetch_sub(buf.len(), Ordering::Relaxed);
                self.full.set_padded(buf.bytes(), full_len);
                let log_time = self.intake.clock.of_payload(log_time, self.full.bytes());
                self.last_log_time = log_time;
                if let Some(w) = &mut self.writer {
                    w.write_raw_at(index, log_time, self.full.bytes())?;
                }
                self.viewer.recycle(&mut self.converted);
                self.viewer
                    .convert(self.intake.names[index], &self.full, &mut self.converted);
                emit(
                    &self.converted,
                    self.live.as_mut(),
                    self.writer.as_mut(),
                    log_time,
                )?;
                let _ = self.intake.free.send((index, buf));
            }
            Job::Metadata(name, entries) => {
                if let Some(w) = &mut self.writer {
                    w.write_metadata(&name, entries)?
                }
            }
            Job::Attach {
                name,
                media_type,
                data,
                time,
            } => {
                if let Some(w) = &mut self.writer {
                    w.attach(&name, media_type, &data, self.intake.clock.of_event(time))?
                }
            }
        }
        Ok(())
    }

    /// Writes the last tick's plot messages (held back until a next tick that never
    /// came), then finalises the file and closes the live view.
    fn finish(mut self) -> Result<Written, WriteError> {
        self.viewer.recycle(&mut self.converted);
        self.viewer.finish(&mut self.converted);
        emit(
            &self.converted,
            self.live.as_mut(),
            self.writer.as_mut(),
            self.last_log_time,
        )?;
        let live = self.live.map(LiveServer::finish);
        let counts = match self.writer {
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
    use crate::writer::WriterOptions;
    use std::io::Cursor;

    /// At the end of a run the writer thread stops after the job it is on, and the
    /// caller writes the rest: nothing queued is lost in the handover.
    #[test]
    fn the_jobs_queued_at_the_handover_are_written_by_the_caller() {
        let (ready, _ready_rx) = mpsc::sync_channel(1);
        let (jobs, job_rx) = mpsc::channel();
        let (free, _free_rx) = mpsc::channel();
        let file = RecordWriter::new(Cursor::new(Vec::new()), WriterOptions::default()).unwrap();
        let start = WriteLoop {
            writer: Some(file),
            live: None,
            ready,
            viewer: ViewerOptions::default(),
            models: ViewerModels::default(),
            intake: Intake {
                jobs: job_rx,
                free,
                queued: Arc::default(),
                names: Vec::new(),
                clock: LogClock::of_mode(aisle_messages::TickMode::Lockstep),
                flush_period_ns: 0,
            },
        };
        let mut pump = start.start().unwrap();
        for i in 0..5u8 {
            let job = Job::Attach {
                name: format!("file{i}.toml"),
                media_type: "application/toml",
                data: vec![i; 100],
                time: u64::from(i),
            };
            jobs.send(job).unwrap();
        }
        drop(jobs);
        pump.run(Some(&AtomicBool::new(true))).unwrap();
        let attached = |p: &Pump<_>| p.writer.as_ref().unwrap().counts().attachments;
        assert_eq!(attached(&pump), 1, "handed over after one job");
        pump.run(None).unwrap();
        assert_eq!(attached(&pump), 5);
        let written = pump.finish().unwrap();
        assert_eq!(written.counts.attachments, 5);
    }

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
