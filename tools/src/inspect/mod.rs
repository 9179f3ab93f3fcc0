//! Looking at a running instance from outside its group, topic by topic, whatever the
//! message type: [`topics`] (the live services with type, rate and port counts),
//! [`echo`] (each sample as text, see [`text`]) and [`hz`] (rate and period statistics
//! over a window, see [`rate`]). Ports are the bus's type-erased ones, opened by name.
//!
//! Rates are measured on this process's monotonic clock at arrival (a replay publishes
//! recorded headers, whose wall times belong to the recording). A subscriber first
//! receives the history of state topics; [`topics`] and [`hz`] let it arrive and drop it
//! before they measure. [`echo`] and [`hz`] end with [`InspectError::Ended`] when the
//! instance's owner ends it (`aisle_bus::OwnerWatch`), rather than watching a group that
//! is gone. Knows the topic table and the catalogue, not the processes.

pub mod rate;
pub mod text;

use crate::raw_ports::{RawSource, open_source};
use aisle_bus::{Bus, BusError, OwnerWatch, clock, signals};
use aisle_messages::topics;
use rate::{RateStats, rate_stats};
use std::time::Duration;
use text::{TextOptions, payload_text};

/// How long history samples are given to arrive (and are dropped) before a measurement.
pub const SETTLE: Duration = Duration::from_millis(150);
/// Longest sleep between polls of several subscribers.
const POLL: Duration = Duration::from_millis(2);

#[derive(Debug, thiserror::Error)]
pub enum InspectError {
    #[error("no topic `{topic}`; topics: {known}")]
    UnknownTopic { topic: String, known: String },
    #[error("`{topic}`: cannot subscribe: {source}")]
    Subscribe { topic: String, source: BusError },
    #[error(transparent)]
    Bus(#[from] BusError),
    /// The instance's owner ended it (`aisle_bus::OwnerWatch`): nothing more comes.
    #[error("{0}: nothing more will be published on `{1}`")]
    Ended(String, String),
}

/// [`InspectError::Ended`] once the watched instance has ended.
fn check_ended(watch: &mut OwnerWatch, topic: &str) -> Result<(), InspectError> {
    match watch.ended() {
        Some(why) => Err(InspectError::Ended(why.to_string(), topic.to_string())),
        None => Ok(()),
    }
}

/// One row of `aisle topics`.
#[derive(Debug, Clone, PartialEq)]
pub struct TopicRow {
    pub name: String,
    pub type_name: String,
    /// Connected publishers and subscribers (before this process subscribed); `None`
    /// for a service this build does not know.
    pub ports: Option<(usize, usize)>,
    /// Samples per second over the window; `None` when it could not be measured (an
    /// unknown type, or no free subscriber slot).
    pub rate_hz: Option<f64>,
}

/// The publish/subscribe services of the instance, with each one's rate over `window`.
pub fn topics(bus: &Bus, window: Duration) -> Result<Vec<TopicRow>, InspectError> {
    let services = bus.services()?;
    let sources: Vec<Option<Box<dyn RawSource>>> = services
        .iter()
        .map(|s| {
            let known = topics::info(&s.name).is_some_and(|t| t.type_name == s.type_name);
            if known {
                open_source(bus, &s.name).ok().flatten()
            } else {
                None
            }
        })
        .collect();
    let mut counts = vec![0u64; sources.len()];
    poll_all(&sources, SETTLE, &mut |_| {})?;
    poll_all(&sources, window, &mut |i| counts[i] += 1)?;
    let secs = window.as_secs_f64().max(1e-9);
    Ok(services
        .into_iter()
        .zip(sources.iter().zip(counts))
        .map(|(s, (src, n))| TopicRow {
            name: s.name,
            type_name: s.type_name,
            ports: s.ports,
            rate_hz: src.as_ref().map(|_| n as f64 / secs),
        })
        .collect())
}

/// Receives from every source for `span`, calling `got(index)` for each sample.
fn poll_all(
    sources: &[Option<Box<dyn RawSource>>],
    span: Duration,
    got: &mut dyn FnMut(usize),
) -> Result<(), InspectError> {
    let end = clock::monotonic_ns() + span.as_nanos() as u64;
    while clock::monotonic_ns() < end {
        if signals::stop_requested() {
            return Err(BusError::StopRequested.into());
        }
        for (i, s) in sources.iter().enumerate() {
            if let Some(s) = s {
                while s.receive_raw(&mut |_| got(i))? {}
            }
        }
        std::thread::sleep(POLL);
    }
    Ok(())
}

/// A subscriber of `topic`, or an error listing the topics there are.
fn subscribe(bus: &Bus, topic: &str) -> Result<Box<dyn RawSource>, InspectError> {
    let unknown = || InspectError::UnknownTopic {
        topic: topic.to_string(),
        known: topics::ALL
            .iter()
            .map(|t| t.name)
            .collect::<Vec<_>>()
            .join(", "),
    };
    topics::info(topic).ok_or_else(unknown)?;
    open_source(bus, topic)
        .map_err(|source| InspectError::Subscribe {
            topic: topic.to_string(),
            source,
        })?
        .ok_or_else(unknown)
}

/// What [`echo`] does.
#[derive(Debug, Clone, Default)]
pub struct EchoOptions {
    /// Stop after this many samples (`None`: until a stop request or the timeout).
    pub count: Option<u64>,
    /// Give up waiting after this long in total.
    pub timeout: Option<Duration>,
    pub text: TextOptions,
}

/// Hands each sample of `topic` to `print` as text (history first), until `count`
/// samples, the timeout or a stop request. Returns the samples printed;
/// [`InspectError::Ended`] when the instance ends first.
pub fn echo(
    bus: &Bus,
    topic: &str,
    opts: &EchoOptions,
    print: &mut dyn FnMut(&str),
) -> Result<u64, InspectError> {
    let source = subscribe(bus, topic)?;
    let type_name = topics::info(topic).map(|t| t.type_name).unwrap_or_default();
    let deadline = opts
        .timeout
        .map(|t| clock::monotonic_ns() + t.as_nanos() as u64);
    let mut watch = OwnerWatch::new(bus.instance());
    let mut printed = 0;
    while opts.count.is_none_or(|c| printed < c) {
        check_ended(&mut watch, topic)?;
        let slice = match deadline {
            Some(d) => {
                let now = clock::monotonic_ns();
                if now >= d {
                    break;
                }
                Duration::from_nanos(d - now).min(Duration::from_millis(100))
            }
            None => Duration::from_millis(100),
        };
        let got = match source.wait_raw(slice, &mut |b| {
            let text = payload_text(type_name, b, &opts.text).unwrap_or_default();
            print(&text);
        }) {
            Err(BusError::StopRequested) => break,
            r => r?,
        };
        if got {
            printed += 1;
        }
    }
    Ok(printed)
}

/// Measures `topic` window after window (its history dropped first) and hands each
/// window's statistics to `report` (`None` for a window with fewer than two samples),
/// `reports` times or until a stop request. Returns the windows measured;
/// [`InspectError::Ended`] when the instance ends first.
pub fn hz(
    bus: &Bus,
    topic: &str,
    window: Duration,
    reports: Option<u64>,
    report: &mut dyn FnMut(Option<RateStats>),
) -> Result<u64, InspectError> {
    let source = subscribe(bus, topic)?;
    let sources = [Some(source)];
    if poll_all(&sources, SETTLE, &mut |_| {}).is_err() {
        return Ok(0);
    }
    let Some(source) = &sources[0] else {
        return Ok(0);
    };
    let mut watch = OwnerWatch::new(bus.instance());
    let mut done = 0;
    let mut arrivals: Vec<u64> = Vec::with_capacity(1024);
    while reports.is_none_or(|r| done < r) {
        arrivals.clear();
        let end = clock::monotonic_ns() + window.as_nanos() as u64;
        loop {
            check_ended(&mut watch, topic)?;
            let now = clock::monotonic_ns();
            if now >= end {
                break;
            }
            let slice = Duration::from_nanos(end - now).min(Duration::from_millis(100));
            match source.wait_raw(slice, &mut |_| {}) {
                Ok(true) => arrivals.push(clock::monotonic_ns()),
                Ok(false) => {}
                Err(BusError::StopRequested) => return Ok(done),
                Err(e) => return Err(e.into()),
            }
        }
        report(rate_stats(&arrivals));
        done += 1;
    }
    Ok(done)
}
