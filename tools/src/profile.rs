//! Latency and jitter of a recorded run, per stage and end to end.
//!
//! Figures come from the message headers, not from the recorder's receive times, so the
//! recorder's own delays do not distort them: stage compute time is `TickDone.compute_ns`
//! per node; a stage's output latency is `publish_wall_ns - tick_wall_ns` of its output
//! (both CLOCK_MONOTONIC, comparable across processes); end to end is that latency for
//! the controller's `Trajectory` (tick start -> command); the tick period is the
//! interval between successive `Tick` publications. For each: p50, p99, max, mean,
//! jitter (standard deviation) and the number of samples over the deadline.
//! Knows the recorded file and the headers; not how the stages compute.

use crate::aligned::AlignedBuf;
use crate::payload_fields::{PUBLISH_WALL_AT, TICK_AT, TICK_WALL_AT, u64_at};
use crate::reader::{ReadError, RecordFile};
use aisle_messages::topics::names as s;
use aisle_messages::{NodeKind, PlanResponse, StageStatus, TickDone};
use std::fmt::Write as _;
use std::path::Path;

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ProfileOptions {
    /// Deadline of every stage and of end to end (a tick at 10 Hz: 100 ms).
    pub deadline_ns: u64,
}

impl Default for ProfileOptions {
    fn default() -> Self {
        Self {
            deadline_ns: 100_000_000,
        }
    }
}

#[derive(Debug, thiserror::Error)]
pub enum ProfileError {
    #[error(transparent)]
    Read(#[from] ReadError),
    #[error("{path}: no latency data (no TickDone, Trajectory or Tick messages were recorded)")]
    Empty { path: String },
    #[error("cannot write {path}: {source}")]
    Write {
        path: String,
        source: std::io::Error,
    },
}

/// Summary figures of one series, in nanoseconds.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Stats {
    pub count: usize,
    pub p50: u64,
    pub p99: u64,
    pub max: u64,
    pub mean: f64,
    /// Standard deviation.
    pub jitter: f64,
    pub deadline_misses: usize,
}

/// The one quantile definition of aisle (`aisle run`'s table and `aisle profile`
/// alike): nearest rank, the smallest sample with at least `p`·n samples at or below
/// it (p99 of 100 samples is the 99th smallest). `sorted` must be sorted and not empty.
pub fn nearest_rank(sorted: &[u64], p: f64) -> u64 {
    let n = sorted.len();
    sorted[((p * n as f64).ceil() as usize).clamp(1, n) - 1]
}

impl Stats {
    /// Nearest-rank percentiles ([`nearest_rank`]); `None` for an empty series.
    pub fn of(values: &[u64], deadline_ns: u64) -> Option<Stats> {
        if values.is_empty() {
            return None;
        }
        let mut v = values.to_vec();
        v.sort_unstable();
        let n = v.len();
        let rank = |p: f64| nearest_rank(&v, p);
        let mean = v.iter().map(|&x| x as f64).sum::<f64>() / n as f64;
        let var = v.iter().map(|&x| (x as f64 - mean).powi(2)).sum::<f64>() / n as f64;
        Some(Stats {
            count: n,
            p50: rank(0.5),
            p99: rank(0.99),
            max: v[n - 1],
            mean,
            jitter: var.sqrt(),
            deadline_misses: v.iter().filter(|&&x| x > deadline_ns).count(),
        })
    }
}

/// One measured series: (tick, nanoseconds) in recorded order.
#[derive(Debug, Clone, PartialEq)]
pub struct Series {
    pub name: String,
    pub samples: Vec<(u64, u64)>,
    pub stats: Stats,
}

#[derive(Debug, Clone, PartialEq)]
pub struct ProfileReport {
    /// Compute time per stage (`compute <node>`), output latency per service
    /// (`latency <service>`), planner solve time, in that order.
    pub stages: Vec<Series>,
    /// Tick start -> trajectory published.
    pub end_to_end: Option<Series>,
    /// Interval between tick starts.
    pub tick_period: Option<Series>,
    pub deadline_ns: u64,
    /// Where a damaged file stopped being readable.
    pub truncated: Option<String>,
}

/// Profiles a recorded file with the default deadline.
pub fn profile(path: &Path) -> Result<ProfileReport, ProfileError> {
    profile_with(path, &ProfileOptions::default())
}

pub fn profile_with(path: &Path, opts: &ProfileOptions) -> Result<ProfileReport, ProfileError> {
    let file = RecordFile::open(path)?;
    profile_file(&file, opts)
}

/// Services whose output latency is measured, in report order.
const LATENCY_SERVICES: [&str; 4] = [
    s::POINT_CLOUD,
    s::LOCAL_MAP,
    s::GLOBAL_MAP,
    s::CONTROLLER_BAND,
];

/// The raw series, gathered in one pass over the file.
#[derive(Default)]
struct Collected {
    compute: Vec<(NodeKind, Vec<(u64, u64)>)>,
    latency: [Vec<(u64, u64)>; LATENCY_SERVICES.len()],
    e2e: Vec<(u64, u64)>,
    solve: Vec<(u64, u64)>,
    period: Vec<(u64, u64)>,
    last_tick_wall: Option<u64>,
    buf: AlignedBuf,
}

impl Collected {
    /// Adds what one recorded payload of `topic` says.
    fn add(&mut self, topic: &str, data: &[u8]) {
        if data.len() < 48 {
            return;
        }
        let tick = u64_at(data, TICK_AT);
        let tick_wall = u64_at(data, TICK_WALL_AT);
        let published = u64_at(data, PUBLISH_WALL_AT);
        let since_tick = (tick_wall != 0 && published >= tick_wall).then(|| published - tick_wall);
        match topic {
            s::TICK_DONE => {
                self.buf.set(data);
                // Idle acknowledgements (a stage with nothing to do on this tick) are
                // not compute samples.
                if let Some(d) = self.buf.view::<TickDone>()
                    && d.status != StageStatus::Idle as u32
                    && let Some(kind) = NodeKind::from_u32(d.node)
                {
                    match self.compute.iter_mut().find(|(k, _)| *k == kind) {
                        Some((_, v)) => v.push((tick, d.compute_ns)),
                        None => self.compute.push((kind, vec![(tick, d.compute_ns)])),
                    }
                }
            }
            s::TRAJECTORY => {
                if let Some(l) = since_tick {
                    self.e2e.push((tick, l));
                }
            }
            s::PLAN_RESPONSE => {
                self.buf.set(data);
                if let Some(r) = self.buf.view::<PlanResponse>() {
                    self.solve.push((tick, r.solve_ns));
                }
            }
            s::TICK => {
                if let Some(prev) = self.last_tick_wall
                    && published > prev
                {
                    self.period.push((tick, published - prev));
                }
                self.last_tick_wall = Some(published);
            }
            _ => {}
        }
        if let Some(i) = LATENCY_SERVICES.iter().position(|x| *x == topic)
            && let Some(l) = since_tick
        {
            self.latency[i].push((tick, l));
        }
    }

    /// The series with their figures; `None` when there is nothing to report.
    fn report(self, deadline_ns: u64, truncated: Option<String>) -> Option<ProfileReport> {
        let Collected {
            mut compute,
            latency,
            e2e,
            solve,
            period,
            ..
        } = self;
        compute.sort_by_key(|(k, _)| *k as u32);
        let d = deadline_ns;
        let series = |name: String, samples: Vec<(u64, u64)>| {
            let values: Vec<u64> = samples.iter().map(|x| x.1).collect();
            Stats::of(&values, d).map(|stats| Series {
                name,
                samples,
                stats,
            })
        };
        let mut stages = Vec::new();
        for (kind, v) in compute {
            stages.extend(series(format!("compute {}", kind.name()), v));
        }
        for (svc, v) in LATENCY_SERVICES.iter().zip(latency) {
            stages.extend(series(format!("latency {svc}"), v));
        }
        stages.extend(series("solve global_planner".into(), solve));
        let end_to_end = series("end to end (tick -> trajectory)".into(), e2e);
        let tick_period = series("tick period".into(), period);
        if stages.is_empty() && end_to_end.is_none() && tick_period.is_none() {
            return None;
        }
        Some(ProfileReport {
            stages,
            end_to_end,
            tick_period,
            deadline_ns: d,
            truncated,
        })
    }
}

pub fn profile_file(
    file: &RecordFile,
    opts: &ProfileOptions,
) -> Result<ProfileReport, ProfileError> {
    let mut collected = Collected::default();
    let mut truncated = None;
    for m in file.raw_messages() {
        match m {
            Ok(m) => collected.add(m.channel.topic.as_str(), &m.data),
            Err(e) => {
                truncated = Some(e.to_string());
                break;
            }
        }
    }
    collected
        .report(opts.deadline_ns, truncated)
        .ok_or_else(|| ProfileError::Empty {
            path: file.path().display().to_string(),
        })
}

fn ms(ns: f64) -> String {
    format!("{:.3}", ns / 1e6)
}

impl ProfileReport {
    /// Every series: the stages, then end to end, then the tick period.
    pub fn all(&self) -> impl Iterator<Item = &Series> {
        self.stages
            .iter()
            .chain(self.end_to_end.iter())
            .chain(self.tick_period.iter())
    }

    /// The figures as a text table (milliseconds).
    pub fn table(&self) -> String {
        let mut t = String::new();
        let width = self.all().map(|s| s.name.len()).max().unwrap_or(5).max(5);
        let _ = writeln!(
            t,
            "{:<width$} {:>7} {:>9} {:>9} {:>9} {:>9} {:>9} {:>7}",
            "stage", "count", "p50 ms", "p99 ms", "max ms", "mean ms", "jitter", "misses"
        );
        for s in self.all() {
            let st = &s.stats;
            let _ = writeln!(
                t,
                "{:<width$} {:>7} {:>9} {:>9} {:>9} {:>9} {:>9} {:>7}",
                s.name,
                st.count,
                ms(st.p50 as f64),
                ms(st.p99 as f64),
                ms(st.max as f64),
                ms(st.mean),
                ms(st.jitter),
                st.deadline_misses
            );
        }
        let _ = writeln!(
            t,
            "deadline {} ms; jitter = standard deviation",
            ms(self.deadline_ns as f64)
        );
        if let Some(tr) = &self.truncated {
            let _ = writeln!(t, "note: {tr}");
        }
        t
    }

    /// Log-scale histograms (power-of-two buckets from 1 us), one per series.
    pub fn histograms(&self) -> String {
        let mut t = String::new();
        for s in self.all() {
            let _ = writeln!(t, "{}", s.name);
            let mut buckets = [0usize; 40];
            for &(_, v) in &s.samples {
                let b = (64 - (v / 1000).leading_zeros()) as usize;
                buckets[b.min(39)] += 1;
            }
            let most = *buckets.iter().max().unwrap_or(&1);
            let first = buckets.iter().position(|&c| c > 0).unwrap_or(0);
            let last = buckets.iter().rposition(|&c| c > 0).unwrap_or(0);
            for (b, &count) in buckets.iter().enumerate().take(last + 1).skip(first) {
                let upper_us = if b == 0 { 1u64 } else { 1u64 << b };
                let bar = (count * 40).div_ceil(most.max(1));
                let _ = writeln!(
                    t,
                    "  < {:>9} ms | {:<40} {}",
                    format!("{:.3}", upper_us as f64 / 1000.0),
                    "#".repeat(bar),
                    count
                );
            }
        }
        t
    }

    /// A plot of every series against the tick, in milliseconds, with the deadline.
    pub fn svg(&self) -> String {
        let series: Vec<&Series> = self.all().filter(|s| s.name != "tick period").collect();
        let (w, h, left, right, top, bottom) = (960.0, 480.0, 70.0, 260.0, 20.0, 40.0);
        let plot_w = w - left - right;
        let plot_h = h - top - bottom;
        let max_tick = series
            .iter()
            .flat_map(|s| s.samples.iter().map(|x| x.0))
            .max()
            .unwrap_or(1)
            .max(1) as f64;
        let max_ms = series
            .iter()
            .map(|s| s.stats.max as f64 / 1e6)
            .fold(self.deadline_ns as f64 / 1e6, f64::max)
            * 1.05;
        let x = |tick: u64| left + tick as f64 / max_tick * plot_w;
        let y = |v_ms: f64| top + plot_h - v_ms / max_ms * plot_h;
        let colors = [
            "#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f",
            "#bcbd22", "#17becf",
        ];
        let mut o = String::new();
        let _ = writeln!(
            o,
            r#"<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" font-family="sans-serif" font-size="12">"#
        );
        let _ = writeln!(o, r#"<rect width="{w}" height="{h}" fill="white"/>"#);
        let _ = writeln!(
            o,
            r#"<rect x="{left}" y="{top}" width="{plot_w}" height="{plot_h}" fill="none" stroke="black"/>"#
        );
        for i in 0..=5 {
            let v = max_ms * i as f64 / 5.0;
            let _ = writeln!(
                o,
                r#"<text x="{}" y="{}" text-anchor="end">{:.1}</text>"#,
                left - 6.0,
                y(v) + 4.0,
                v
            );
        }
        let _ = writeln!(
            o,
            r#"<text x="{}" y="{}" text-anchor="middle">tick (max {})</text>"#,
            left + plot_w / 2.0,
            h - 8.0,
            max_tick
        );
        let _ = writeln!(
            o,
            r#"<text x="14" y="{}" transform="rotate(-90 14 {})" text-anchor="middle">latency [ms]</text>"#,
            top + plot_h / 2.0,
            top + plot_h / 2.0
        );
        let dy = y(self.deadline_ns as f64 / 1e6);
        let _ = writeln!(
            o,
            r#"<line x1="{left}" y1="{dy}" x2="{}" y2="{dy}" stroke="red" stroke-dasharray="6 4"/>"#,
            left + plot_w
        );
        for (i, s) in series.iter().enumerate() {
            let c = colors[i % colors.len()];
            let mut pts = String::new();
            for &(t, v) in &s.samples {
                let _ = write!(pts, "{:.1},{:.1} ", x(t), y(v as f64 / 1e6));
            }
            let _ = writeln!(
                o,
                r#"<polyline points="{pts}" fill="none" stroke="{c}" stroke-width="1"/>"#
            );
            let ly = top + 16.0 * i as f64 + 10.0;
            let _ = writeln!(
                o,
                r#"<rect x="{}" y="{}" width="12" height="4" fill="{c}"/><text x="{}" y="{}">{} (p99 {} ms)</text>"#,
                w - right + 10.0,
                ly - 4.0,
                w - right + 28.0,
                ly,
                xml_escape(&s.name),
                ms(s.stats.p99 as f64)
            );
        }
        let _ = writeln!(o, "</svg>");
        o
    }

    pub fn write_svg(&self, path: &Path) -> Result<(), ProfileError> {
        std::fs::write(path, self.svg()).map_err(|source| ProfileError::Write {
            path: path.display().to_string(),
            source,
        })
    }
}

fn xml_escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synthetic::{
        lidar_compute_ns, mapper_compute_ns, trajectory_latency_ns, write_synthetic,
    };
    use crate::writer::WriterOptions;
    use std::io::Cursor;

    fn report(ticks: u64, deadline_ns: u64) -> ProfileReport {
        let bytes = write_synthetic(Cursor::new(Vec::new()), ticks, WriterOptions::default())
            .unwrap()
            .into_inner();
        let file = RecordFile::from_bytes(Path::new("p.mcap"), bytes).unwrap();
        profile_file(&file, &ProfileOptions { deadline_ns }).unwrap()
    }

    #[test]
    fn stats_use_nearest_rank_and_count_misses() {
        let v: Vec<u64> = (1..=100).collect();
        let s = Stats::of(&v, 95).unwrap();
        assert_eq!((s.p50, s.p99, s.max, s.count), (50, 99, 100, 100));
        assert_eq!(s.deadline_misses, 5);
        assert!((s.mean - 50.5).abs() < 1e-12);
        assert!((s.jitter - 28.866).abs() < 1e-3, "{}", s.jitter);
        assert!(Stats::of(&[], 1).is_none());
    }

    #[test]
    fn synthetic_run_figures_match_what_was_generated() {
        let r = report(100, 9_000_000);
        let find = |n: &str| r.stages.iter().find(|s| s.name == n).unwrap();
        let lidar = find("compute lidar");
        let values: Vec<u64> = (0..100).map(lidar_compute_ns).collect();
        assert_eq!(lidar.stats, Stats::of(&values, 9_000_000).unwrap());
        assert_eq!(lidar.stats.max, 1_900_000);
        // Idle acknowledgements are not compute samples.
        assert_eq!(find("compute teb_controller").stats.count, 20);
        let mapper = find("compute mapper");
        assert_eq!(mapper.stats.max, mapper_compute_ns(4));
        let e2e = r.end_to_end.as_ref().unwrap();
        assert_eq!(e2e.stats.count, 20);
        let expected: Vec<u64> = (0..100).step_by(5).map(trajectory_latency_ns).collect();
        assert_eq!(e2e.stats.max, *expected.iter().max().unwrap());
        // Latencies of 10 and 11 ms exceed the 9 ms deadline.
        assert_eq!(
            e2e.stats.deadline_misses,
            expected.iter().filter(|&&v| v > 9_000_000).count()
        );
        let period = r.tick_period.as_ref().unwrap();
        assert_eq!(period.stats.p50, crate::synthetic::WALL_PERIOD_NS);
        assert_eq!(period.stats.jitter, 0.0);
        let table = r.table();
        assert!(table.contains("compute lidar"), "{table}");
        assert!(table.contains("end to end"), "{table}");
        let hist = r.histograms();
        assert!(hist.contains('#'), "{hist}");
        let svg = r.svg();
        assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"));
        assert!(svg.matches("<polyline").count() >= 5);
    }

    #[test]
    fn a_file_without_latency_data_is_an_error() {
        let mut w =
            crate::writer::RecordWriter::new(Cursor::new(Vec::new()), WriterOptions::default())
                .unwrap();
        w.write_metadata("x", Default::default()).unwrap();
        let bytes = w.finish().unwrap().0.into_inner();
        let file = RecordFile::from_bytes(Path::new("empty.mcap"), bytes).unwrap();
        let e = profile_file(&file, &ProfileOptions::default()).unwrap_err();
        assert!(e.to_string().contains("empty.mcap"), "{e}");
    }
}
