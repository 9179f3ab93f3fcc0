//! The recorder's node thread: drains every subscriber, copies each new payload into a
//! reused buffer for the writer thread, counts what is lost, and acknowledges lockstep
//! ticks once everything before the acknowledgements it waits for is drained.
//!
//! Knows the bus ports and the header fields; not the file layout (the writer thread
//! writes) nor the run's metadata. Ends on a stop request (as `StopRequested`), when the
//! parent process goes away, when the writer stopped, and after `idle_stop` without
//! traffic from other processes.

use super::answer::AnswerRule;
use super::seq::{SeqTracker, SeqVerdict};
use super::write::Job;
use super::{RecordSummary, RecorderOptions};
use crate::aligned::AlignedBuf;
use crate::payload_fields::{DONE_NODE_AT, SOURCE_AT, TICK_AT, u32_at, u64_at};
use crate::raw_ports::RawSource;
use crate::writer::trimmed_len;
use aisle_bus::{BusError, HeartbeatSender, NodeError, Publisher, Stamp, clock, signals};
use aisle_messages::{NodeKind, NodeState, StageStatus, TickDone, topics};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::mpsc;
use std::time::{Duration, Instant};

/// The ports and queues the drain works with (owned by the caller, which still needs
/// them after the drain ended).
pub(super) struct DrainPorts<'a> {
    /// Every subscriber, with its index in `names` (and in the writer's raw channels).
    pub sources: &'a [(usize, Box<dyn RawSource>)],
    pub acks: &'a mut Publisher<TickDone>,
    pub heartbeat: &'a mut HeartbeatSender,
    pub jobs: &'a mpsc::Sender<Job>,
    pub free: &'a mpsc::Receiver<(usize, AlignedBuf)>,
    pub queued: &'a AtomicUsize,
    pub names: &'a [&'static str],
    pub options: &'a RecorderOptions,
    /// The parent process when the recorder started.
    pub parent: u32,
}

/// What the drain remembers from one sample to the next.
struct Taker<'a> {
    names: &'a [&'static str],
    options: &'a RecorderOptions,
    queued: &'a AtomicUsize,
    /// Reusable buffers per source.
    pool: Vec<Vec<AlignedBuf>>,
    seqs: SeqTracker,
    /// Whether a loss on a source has been logged already.
    warned: Vec<bool>,
    tick_done: Option<usize>,
    answer: AnswerRule,
    /// The newest tick completed by the acknowledgements the recorder waits for and not
    /// acknowledged by it yet.
    unanswered: Option<u64>,
    last_traffic: Instant,
}

/// Drains until the recording ends (see the module docs).
pub(super) fn drain(
    ports: DrainPorts<'_>,
    answer: AnswerRule,
    summary: &mut RecordSummary,
) -> Result<(), NodeError> {
    let DrainPorts {
        sources,
        acks,
        heartbeat,
        jobs,
        free,
        queued,
        names,
        options,
        parent,
    } = ports;
    let mut taker = Taker {
        names,
        options,
        queued,
        pool: vec![Vec::new(); sources.len()],
        seqs: SeqTracker::default(),
        warned: vec![false; sources.len()],
        tick_done: names.iter().position(|n| *n == topics::TICK_DONE.name),
        // The acknowledgements of the recorder's `after` nodes (the supervisor's) are
        // the last messages of tick k; once everything before them is drained, the
        // recorder acknowledges k too, and a lockstep simulator that waits for it loses
        // nothing. A repeated one is answered too: a restarted simulator repeats the
        // tick it died in and waits for everyone again.
        answer,
        unanswered: None,
        last_traffic: Instant::now(),
    };
    // The acknowledgements' source, whose event the idle waits sleep on.
    let acks_source = taker
        .tick_done
        .and_then(|t| sources.iter().find(|(i, _)| *i == t));
    let mut idle_passes = 0u32;
    loop {
        if signals::stop_requested() {
            // What was published before the stop request is still in the subscribers'
            // queues (iceoryx2 keeps a departed publisher's undelivered samples): taken
            // now, a stop that lands mid-pass cannot cut the last tick in half.
            drain_remaining(sources, jobs, &mut taker, summary)?;
            return Err(BusError::StopRequested.into());
        }
        if std::os::unix::process::parent_id() != parent {
            tracing::warn!("recorder: the parent process exited; finalising");
            drain_remaining(sources, jobs, &mut taker, summary)?;
            return Ok(());
        }
        while let Ok((i, buf)) = free.try_recv() {
            taker.pool[i].push(buf);
        }
        let received = drain_sources(sources, jobs, &mut taker, summary)?;
        heartbeat.tick(NodeState::Running)?;
        idle_passes = if received == 0 { idle_passes + 1 } else { 0 };
        if received == 0 {
            if let Some(t) = taker.unanswered.take() {
                acknowledge(acks, t)?;
            }
            if let Some(idle) = options.idle_stop
                && taker.last_traffic.elapsed() >= idle
            {
                tracing::info!(
                    "recorder: nothing published for {:.1} s; the group has ended, finalising",
                    idle.as_secs_f64()
                );
                return Ok(());
            }
            wait_for_traffic(
                acks_source,
                jobs,
                &mut taker,
                summary,
                idle_wait(idle_passes, options),
            )?;
        }
    }
}

/// How long the recorder sleeps after `idle_passes` passes in a row found nothing: 1 ms
/// after the first, doubling up to `poll_period`. Traffic that keeps coming (a topic of
/// a node of the user's own at hundreds of hertz, with no acknowledgement after it)
/// keeps the sleeps short; between a realtime group's ticks they grow.
fn idle_wait(idle_passes: u32, options: &RecorderOptions) -> Duration {
    let ms = 1u64 << idle_passes.saturating_sub(1).min(16);
    Duration::from_millis(ms).min(options.poll_period)
}

/// Sleeps until the next acknowledgement of a tick arrives (taking it) or `period`
/// passes. Every node acknowledges a tick after publishing its outputs, and the
/// supervisor's is the last message of a tick, so a pass after each finds what came
/// before it, and a lockstep tick is answered at once. (A sleep of 1 ms between passes
/// woke the recorder 1,000 times a second: 6 % of a core in a realtime run.)
fn wait_for_traffic(
    acks_source: Option<&(usize, Box<dyn RawSource>)>,
    jobs: &mpsc::Sender<Job>,
    taker: &mut Taker<'_>,
    summary: &mut RecordSummary,
    period: Duration,
) -> Result<(), NodeError> {
    let Some((i, src)) = acks_source else {
        std::thread::sleep(period);
        return Ok(());
    };
    let (i, size) = (*i, src.message_size());
    let mut job = None;
    let waited = src.wait_raw(period, &mut |bytes| {
        job = taker.take(i, clock::monotonic_ns(), (bytes, size), summary);
    });
    match waited {
        // The loop drains what is left before it stops.
        Err(BusError::StopRequested) => {}
        other => {
            other?;
        }
    }
    if !queue(jobs, job) {
        return Err(NodeError::Protocol("the writer stopped".into()));
    }
    Ok(())
}

/// Hands a taken sample's copy to the writer; false when the writer has stopped.
fn queue(jobs: &mpsc::Sender<Job>, job: Option<Job>) -> bool {
    job.is_none_or(|job| jobs.send(job).is_ok())
}

/// Passes over every source until one finds nothing (bounded: a publisher that never
/// stops cannot hold the recorder open).
fn drain_remaining(
    sources: &[(usize, Box<dyn RawSource>)],
    jobs: &mpsc::Sender<Job>,
    taker: &mut Taker<'_>,
    summary: &mut RecordSummary,
) -> Result<(), NodeError> {
    for _ in 0..16 {
        if drain_sources(sources, jobs, taker, summary)? == 0 {
            break;
        }
    }
    Ok(())
}

/// Takes every waiting sample of every source; returns how many there were.
fn drain_sources(
    sources: &[(usize, Box<dyn RawSource>)],
    jobs: &mpsc::Sender<Job>,
    taker: &mut Taker<'_>,
    summary: &mut RecordSummary,
) -> Result<usize, NodeError> {
    let mut received = 0usize;
    let mut writer_gone = false;
    for (i, src) in sources {
        let i = *i;
        let size = src.message_size();
        loop {
            let log_time = clock::monotonic_ns();
            let mut job = None;
            let got = src
                .receive_raw(&mut |bytes| job = taker.take(i, log_time, (bytes, size), summary))?;
            if !got {
                break;
            }
            received += 1;
            writer_gone |= !queue(jobs, job);
        }
    }
    if writer_gone {
        // The writer stopped on an error; it is reported when the thread is joined.
        return Err(NodeError::Protocol("the writer stopped".into()));
    }
    Ok(received)
}

/// The recorder's own acknowledgement of tick `t`.
fn acknowledge(acks: &mut Publisher<TickDone>, t: u64) -> Result<(), BusError> {
    acks.publish(
        Stamp {
            tick: t,
            ..Stamp::default()
        },
        |m| {
            m.node = NodeKind::Recorder.code();
            m.status = StageStatus::Done as u32;
        },
    )?;
    Ok(())
}

impl Taker<'_> {
    /// Notes a sample of source `i` and copies it out; `None` when it is a repeat or
    /// the writer queue is full.
    fn take(
        &mut self,
        i: usize,
        log_time: u64,
        (bytes, full_len): (&[u8], usize),
        summary: &mut RecordSummary,
    ) -> Option<Job> {
        if u32_at(bytes, SOURCE_AT) != NodeKind::Recorder.code() {
            self.last_traffic = Instant::now();
        }
        if Some(i) == self.tick_done {
            let t = u64_at(bytes, TICK_AT);
            if self.answer.note(t, u32_at(bytes, DONE_NODE_AT)) {
                self.unanswered = Some(self.unanswered.map_or(t, |s: u64| s.max(t)));
            }
        }
        match self.seqs.check(i, bytes) {
            SeqVerdict::Repeat => return None,
            SeqVerdict::New { lost } if lost > 0 => {
                *summary.lost_in_bus.entry(self.names[i]).or_default() += lost;
                if !self.warned[i] {
                    self.warned[i] = true;
                    tracing::warn!(
                        "recorder: {} lost {lost} samples on {} (counting on)",
                        "fell behind:",
                        self.names[i]
                    );
                }
            }
            SeqVerdict::New { .. } => {}
        }
        // Only the used part is copied out of shared memory (the port hands out the used
        // part of clouds and grids, and trailing zeros are cut): less time in this thread.
        let used = &bytes[..trimmed_len(bytes)];
        if self.queued.load(Ordering::Relaxed) + used.len() > self.options.queue_bytes {
            *summary.lost_in_queue.entry(self.names[i]).or_default() += 1;
            return None;
        }
        let mut buf = self.pool[i].pop().unwrap_or_default();
        buf.set(used);
        self.queued.fetch_add(used.len(), Ordering::Relaxed);
        Some(Job::Raw {
            index: i,
            log_time,
            buf,
            full_len,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn idle_sleeps_double_from_one_millisecond_to_the_poll_period() {
        let options = RecorderOptions::default();
        let ms: Vec<u128> = (1..=7)
            .map(|n| idle_wait(n, &options).as_millis())
            .collect();
        assert_eq!(ms, [1, 2, 4, 8, 16, 20, 20]);
        assert_eq!(idle_wait(u32::MAX, &options), options.poll_period);
    }
}
