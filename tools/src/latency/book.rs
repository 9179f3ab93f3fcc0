//! The samples of one run, by series, and the rules by which a message becomes a
//! sample; summarised into the latency table and exported sample by sample.

use super::budgets::{Budgets, STAGE_ORDER};
use super::release::{LATENESS, TickRelease, lateness};
use super::stats::Summary;
use aisle_messages::{Header, NodeKind, PlanResponse, StageStatus, Tick, TickDone, TickMode};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::io::Write;

/// The latency table: one row per series, and the tick-release row.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct LatencyTable {
    /// The budgeted series in [`STAGE_ORDER`], then any other, by name.
    pub stages: Vec<Summary>,
    pub tick_release: Option<TickRelease>,
}

/// One sample: its tick, its value and (a stage's compute time) the CPU time of the
/// computing thread, 0 when not measured.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Sample {
    tick: u64,
    ns: u64,
    cpu_ns: u64,
}

/// Every sample of a run, per series in arrival order, and the start of every tick.
#[derive(Debug, Default, Clone)]
pub struct SampleBook {
    series: BTreeMap<String, Vec<Sample>>,
    /// `(tick, tick_wall_ns)` of every tick seen.
    releases: Vec<(u64, u64)>,
    dt_ns: u64,
    realtime: bool,
    /// Only ticks before this one count (see the window in the module docs).
    end: Option<u64>,
}

impl SampleBook {
    /// One sample of `stage` for `tick`.
    pub fn record(&mut self, stage: &str, tick: u64, ns: u64) {
        self.record_cpu(stage, tick, ns, 0);
    }

    /// One compute sample of `stage` for `tick` with the CPU time it cost (0: unknown).
    pub fn record_cpu(&mut self, stage: &str, tick: u64, ns: u64, cpu_ns: u64) {
        let s = Sample { tick, ns, cpu_ns };
        match self.series.get_mut(stage) {
            Some(v) => v.push(s),
            None => {
                self.series.insert(stage.to_string(), vec![s]);
            }
        }
    }

    /// The stage a `TickDone` is a compute sample of: its node's, unless it is idle
    /// (nothing to do on that tick) or the recorder's (which computes nothing).
    pub fn compute_stage(d: &TickDone) -> Option<&'static str> {
        let kind = NodeKind::from_u32(d.node)?;
        (d.status != StageStatus::Idle as u32 && kind != NodeKind::Recorder).then(|| kind.name())
    }

    /// A stage's acknowledgement: its compute time (see [`Self::compute_stage`]).
    pub fn record_done(&mut self, d: &TickDone) {
        if let Some(stage) = Self::compute_stage(d) {
            self.record_cpu(stage, d.header.tick, d.compute_ns, d.cpu_ns);
        }
    }

    /// A trajectory: end to end, from the start of its tick to its publication (when
    /// both are known).
    pub fn record_trajectory(&mut self, h: &Header) {
        if h.tick_wall_ns != 0 && h.publish_wall_ns >= h.tick_wall_ns {
            self.record("end_to_end", h.tick, h.publish_wall_ns - h.tick_wall_ns);
        }
    }

    /// A plan: the planner's solve time.
    pub fn record_plan(&mut self, r: &PlanResponse) {
        self.record("global_planner", r.header.tick, r.solve_ns);
    }

    /// A tick: its start, the period and the clock mode.
    pub fn record_tick(&mut self, t: &Tick) {
        self.releases.push((t.header.tick, t.header.tick_wall_ns));
        self.dt_ns = t.dt_ns;
        self.realtime = t.mode == TickMode::Realtime as u32;
    }

    /// Closes the window: only ticks before `last` count (`last` is the last tick the
    /// supervisor acted on).
    pub fn end_at(&mut self, last: u64) {
        self.end = Some(last);
    }

    fn in_window(&self, tick: u64) -> bool {
        self.end.is_none_or(|end| tick < end)
    }

    /// The series in table order, with their samples `(tick, ns)` in the window.
    pub fn series(&self) -> Vec<(&str, Vec<(u64, u64)>)> {
        self.windowed()
            .into_iter()
            .map(|(name, v)| (name, v.iter().map(|s| (s.tick, s.ns)).collect()))
            .collect()
    }

    /// The series in table order, with their samples in the window.
    fn windowed(&self) -> Vec<(&str, Vec<Sample>)> {
        let ordered = STAGE_ORDER
            .iter()
            .filter_map(|s| self.series.get_key_value(*s))
            .chain(
                self.series
                    .iter()
                    .filter(|(k, _)| !STAGE_ORDER.contains(&k.as_str())),
            );
        ordered
            .map(|(name, v)| {
                let kept = v
                    .iter()
                    .copied()
                    .filter(|s| self.in_window(s.tick))
                    .collect();
                (name.as_str(), kept)
            })
            .filter(|(_, v): &(&str, Vec<_>)| !v.is_empty())
            .collect()
    }

    fn releases(&self) -> Vec<(u64, u64)> {
        let r = self.releases.iter().copied();
        r.filter(|s| self.in_window(s.0)).collect()
    }

    /// The table: every series scored against `budgets` (a series without a budget,
    /// or every series when there are none, is not scored).
    pub fn summarise(&self, budgets: Option<&Budgets>) -> LatencyTable {
        let stages = self
            .windowed()
            .into_iter()
            .filter_map(|(name, v)| {
                let values: Vec<u64> = v.iter().map(|s| s.ns).collect();
                let cpu: Vec<u64> = v.iter().map(|s| s.cpu_ns).filter(|&c| c > 0).collect();
                let summary = Summary::of(name, &values, budgets.and_then(|b| b.of(name)))?;
                Some(summary.with_cpu(&cpu))
            })
            .collect();
        let releases = self.releases();
        LatencyTable {
            stages,
            tick_release: (!releases.is_empty())
                .then(|| TickRelease::of(&releases, self.dt_ns, self.realtime)),
        }
    }

    /// Every sample as CSV (`stage,tick,ms,cpu_ms`, the CPU time empty where it is
    /// not measured): the series in table order, then (in realtime) each tick's
    /// release lateness.
    pub fn write_csv(&self, mut out: impl Write) -> std::io::Result<()> {
        writeln!(out, "stage,tick,ms,cpu_ms")?;
        for (name, v) in self.windowed() {
            for s in v {
                write!(out, "{name},{},{:.6},", s.tick, s.ns as f64 / 1e6)?;
                if s.cpu_ns > 0 {
                    write!(out, "{:.6}", s.cpu_ns as f64 / 1e6)?;
                }
                writeln!(out)?;
            }
        }
        for (tick, ns) in self.release_lateness() {
            writeln!(out, "{LATENESS},{tick},{:.6},", ns as f64 / 1e6)?;
        }
        out.flush()
    }

    /// Realtime: `(tick, lateness ns)` of every release in the window; empty in
    /// lockstep.
    pub fn release_lateness(&self) -> Vec<(u64, u64)> {
        if self.realtime {
            lateness(&self.releases(), self.dt_ns)
        } else {
            Vec::new()
        }
    }

    /// The tick period in nanoseconds (0 before any tick).
    pub fn dt_ns(&self) -> u64 {
        self.dt_ns
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use aisle_messages::zeroed_box;

    fn done(node: NodeKind, tick: u64, status: StageStatus, ns: u64) -> TickDone {
        let mut d = *zeroed_box::<TickDone>();
        d.header.tick = tick;
        d.node = node.code();
        d.status = status as u32;
        d.compute_ns = ns;
        d
    }

    fn budgets() -> Budgets {
        let text = "[stage]\nsimulator = 1.0\nlidar = 2.0\nmapper = 1.0\nteb_controller = 5.0\n\
                    global_planner = 50.0\nsupervisor = 1.0\n[end_to_end]\ntick_to_command = 10.0\n";
        aisle_config::parse(std::path::Path::new("b.toml"), text).unwrap()
    }

    #[test]
    fn messages_become_samples_by_one_rule() {
        let mut book = SampleBook::default();
        let mut lidar = done(NodeKind::Lidar, 0, StageStatus::Done, 3_000_000);
        lidar.cpu_ns = 2_500_000;
        book.record_done(&lidar);
        book.record_done(&done(NodeKind::TebController, 0, StageStatus::Idle, 1));
        book.record_done(&done(NodeKind::Recorder, 0, StageStatus::Done, 0));
        let mut h = *zeroed_box::<Header>();
        (h.tick, h.tick_wall_ns, h.publish_wall_ns) = (1, 100, 4_000_100);
        book.record_trajectory(&h);
        h.tick_wall_ns = 0;
        book.record_trajectory(&h);
        book.record("zeta", 0, 1);
        let t = book.summarise(Some(&budgets()));
        let names: Vec<&str> = t.stages.iter().map(|s| s.stage.as_str()).collect();
        assert_eq!(names, ["lidar", "end_to_end", "zeta"]);
        assert_eq!((t.stages[0].misses, t.stages[0].budget_ms), (1, Some(2.0)));
        assert_eq!(t.stages[0].cpu_p99_ms, Some(2.5));
        assert_eq!(t.stages[1].cpu_p99_ms, None, "not a compute sample");
        assert_eq!(t.stages[1].samples, 1);
        assert_eq!(t.stages[2].budget_ms, None);
        assert!(t.tick_release.is_none());
    }

    #[test]
    fn the_window_ends_before_the_last_tick_and_the_csv_has_every_sample() {
        let mut book = SampleBook::default();
        for k in 0..5u64 {
            let mut t = *zeroed_box::<Tick>();
            t.header.tick = k;
            t.header.tick_wall_ns = 1_000 + k * 100_000_000 + k;
            t.dt_ns = 100_000_000;
            t.mode = TickMode::Realtime as u32;
            book.record_tick(&t);
            book.record("lidar", k, 1_000_000 * (k + 1));
        }
        book.end_at(4);
        let t = book.summarise(None);
        assert_eq!(t.stages[0].samples, 4);
        assert_eq!(t.stages[0].max_ms, 4.0);
        let r = t.tick_release.unwrap();
        assert_eq!((r.ticks, r.overruns, r.skipped), (4, 0, 0));
        assert_eq!(r.lateness.unwrap().max_ms, 3e-6);
        let mut csv = Vec::new();
        book.write_csv(&mut csv).unwrap();
        let csv = String::from_utf8(csv).unwrap();
        let lines: Vec<&str> = csv.lines().collect();
        assert_eq!(lines[0], "stage,tick,ms,cpu_ms");
        assert_eq!(lines[1], "lidar,0,1.000000,");
        assert_eq!(lines.len(), 1 + 4 + 4);
        assert_eq!(lines[8], "tick release lateness,3,0.000003,");
    }
}
