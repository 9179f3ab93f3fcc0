//! The plottable channels (Foxglove's Plot panel): odometry, velocity commands, the TEB
//! solver's outcome per step and each stage's latency per tick, as JSON messages with a
//! JSON Schema (message encoding `json`, schema encoding `jsonschema`), so a plot path
//! such as `/plot/odometry.v` works with no extension.
//!
//! Each payload is a `serde` struct written straight into a reused buffer (no
//! intermediate values); its schema is a static text beside it. Every message has
//! `header.stamp` (sim time, `{sec, nsec}`: Foxglove reads it as a time) and
//! `header.tick`. Knows the aisle messages these come from and nothing of files.

use super::{ViewerMessage, ViewerTopic};
use aisle_messages::{Header, RobotState, TickDone, Trajectory};
use serde::Serialize;

/// The schema of `header`, shared by every plot channel.
macro_rules! header_schema {
    () => {
        r#""header":{"type":"object","properties":{
"stamp":{"type":"object","description":"sim time","properties":{"sec":{"type":"integer","minimum":0},"nsec":{"type":"integer","minimum":0}}},
"tick":{"type":"integer","minimum":0,"description":"the tick the values belong to"}}}"#
    };
}

pub(super) const ODOMETRY_SCHEMA: &str = concat!(
    r#"{"title":"aisle.plot.Odometry","type":"object","properties":{"#,
    header_schema!(),
    r#","x":{"type":"number","description":"m, map frame"},
"y":{"type":"number","description":"m, map frame"},
"theta":{"type":"number","description":"heading, rad"},
"v":{"type":"number","description":"linear velocity applied, m/s"},
"w":{"type":"number","description":"angular velocity applied, rad/s"}}}"#
);

pub(super) const COMMAND_SCHEMA: &str = concat!(
    r#"{"title":"aisle.plot.Command","type":"object","properties":{"#,
    header_schema!(),
    r#","v":{"type":"number","description":"first command of the trajectory, m/s"},
"w":{"type":"number","description":"first command of the trajectory, rad/s"},
"goal_id":{"type":"integer","minimum":0}}}"#
);

pub(super) const TEB_SCHEMA: &str = concat!(
    r#"{"title":"aisle.plot.TebStep","type":"object","properties":{"#,
    header_schema!(),
    r#","exit_flag":{"type":"integer","minimum":0,"description":"0 valid, 1 collision, 2 margin, 3 turning radius, 4 time not increasing, 5 off path, 6 acceleration over its limit, 7 stale input"},
"iterations":{"type":"integer","minimum":0},
"cost":{"type":"number"},
"max_violation":{"type":"number"},
"solve_ms":{"type":"number","description":"wall time of the solve, ms"},
"reached_goal":{"type":"boolean"}}}"#
);

pub(super) const LATENCY_SCHEMA: &str = concat!(
    r#"{"title":"aisle.plot.StageLatency","type":"object","properties":{"#,
    header_schema!(),
    r#","lidar_ms":{"type":"number","description":"compute time of the stage for this tick (TickDone.compute_ns), ms; absent when it did not act"},
"mapper_ms":{"type":"number"},
"teb_controller_ms":{"type":"number"},
"supervisor_ms":{"type":"number"},
"end_to_end_ms":{"type":"number","description":"tick start to the trajectory's publication, wall time, ms"}}}"#
);

#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
struct Stamp {
    sec: u32,
    nsec: u32,
}

#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
struct PlotHeader {
    stamp: Stamp,
    tick: u64,
}

impl PlotHeader {
    fn of(h: &Header) -> Self {
        let t = super::build::timestamp(h.stamp_ns);
        PlotHeader {
            stamp: Stamp {
                sec: t.sec(),
                nsec: t.nsec(),
            },
            tick: h.tick,
        }
    }
}

#[derive(Serialize)]
struct Odometry {
    header: PlotHeader,
    x: f64,
    y: f64,
    theta: f64,
    v: f64,
    w: f64,
}

#[derive(Serialize)]
struct Command {
    header: PlotHeader,
    v: f64,
    w: f64,
    goal_id: u64,
}

#[derive(Serialize)]
struct TebStep {
    header: PlotHeader,
    exit_flag: u32,
    iterations: u32,
    cost: f64,
    max_violation: f64,
    solve_ms: f64,
    reached_goal: bool,
}

/// One tick's latencies; a stage that did not act on it has no field.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub(super) struct StageLatency {
    header: PlotHeader,
    #[serde(skip_serializing_if = "Option::is_none")]
    lidar_ms: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    mapper_ms: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    teb_controller_ms: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    supervisor_ms: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    end_to_end_ms: Option<f64>,
}

fn ms(ns: u64) -> f64 {
    ns as f64 / 1e6
}

/// Writes `value` as JSON into `buf` (cleared first) as a message of `topic`.
fn json(
    topic: ViewerTopic,
    stamp_ns: u64,
    value: &impl Serialize,
    mut buf: Vec<u8>,
) -> ViewerMessage {
    buf.clear();
    // Writing these plain structs into a Vec cannot fail (serde_json writes a
    // non-finite float as null).
    let _ = serde_json::to_writer(&mut buf, value);
    ViewerMessage {
        topic,
        stamp_ns,
        data: buf,
    }
}

pub(super) fn odometry(m: &RobotState, buf: Vec<u8>) -> ViewerMessage {
    let value = Odometry {
        header: PlotHeader::of(&m.header),
        x: m.pose.x,
        y: m.pose.y,
        theta: m.pose.theta,
        v: m.twist[0],
        w: m.twist[1],
    };
    json(ViewerTopic::Odometry, m.header.stamp_ns, &value, buf)
}

/// The command and the solver's outcome of one controller step.
pub(super) fn trajectory(
    m: &Trajectory,
    out: &mut Vec<ViewerMessage>,
    mut buffer: impl FnMut() -> Vec<u8>,
) {
    let header = PlotHeader::of(&m.header);
    let stamp = m.header.stamp_ns;
    // The command applied first: what a velocity controller would be sent now.
    let (v, w) = m.commands[..(m.len as usize).min(m.commands.len())]
        .first()
        .map_or((0.0, 0.0), |c| (c.v, c.w));
    let command = Command {
        header,
        v,
        w,
        goal_id: m.goal_id,
    };
    out.push(json(ViewerTopic::Command, stamp, &command, buffer()));
    let step = TebStep {
        header,
        exit_flag: m.exit_flag,
        iterations: m.iterations,
        cost: m.cost,
        max_violation: m.max_violation,
        solve_ms: ms(m.solve_ns),
        reached_goal: m.reached_goal != 0,
    };
    out.push(json(ViewerTopic::Teb, stamp, &step, buffer()));
}

/// Gathers the latencies of one tick from the stages' acknowledgements and the
/// trajectory, and hands the tick over once a newer one starts (so its message lags
/// one tick; the last tick at the end of the run). A sample of a tick already handed over (a straggler, realtime only) is
/// left out; the latency table (`aisle run`, `aisle profile`) still counts it.
#[derive(Debug, Default)]
pub(super) struct LatencyTicks {
    pending: Option<(u64, StageLatency)>,
}

impl LatencyTicks {
    /// The entry of the tick `h` belongs to, and the finished tick it displaced.
    fn entry(&mut self, h: &Header) -> (Option<&mut StageLatency>, Option<(u64, StageLatency)>) {
        let newer = self
            .pending
            .as_ref()
            .is_none_or(|(_, p)| h.tick > p.header.tick);
        let done = if newer {
            let fresh = StageLatency {
                header: PlotHeader::of(h),
                ..StageLatency::default()
            };
            self.pending.replace((h.stamp_ns, fresh))
        } else {
            None
        };
        let entry = self
            .pending
            .as_mut()
            .filter(|(_, p)| p.header.tick == h.tick)
            .map(|(_, p)| p);
        (entry, done)
    }

    /// A stage's acknowledgement.
    pub(super) fn done(&mut self, d: &TickDone) -> Option<(u64, StageLatency)> {
        let stage = crate::latency::SampleBook::compute_stage(d)?;
        let (entry, done) = self.entry(&d.header);
        if let Some(e) = entry {
            let slot = match stage {
                "lidar" => &mut e.lidar_ms,
                "mapper" => &mut e.mapper_ms,
                "teb_controller" => &mut e.teb_controller_ms,
                "supervisor" => &mut e.supervisor_ms,
                _ => return done,
            };
            *slot = Some(ms(d.compute_ns));
        }
        done
    }

    /// The tick still gathering, at the end of the run.
    pub(super) fn finish(&mut self) -> Option<(u64, StageLatency)> {
        self.pending.take()
    }

    /// A trajectory: end to end, when both wall times are known.
    pub(super) fn trajectory(&mut self, h: &Header) -> Option<(u64, StageLatency)> {
        if h.tick_wall_ns == 0 || h.publish_wall_ns < h.tick_wall_ns {
            return None;
        }
        let (entry, done) = self.entry(h);
        if let Some(e) = entry {
            e.end_to_end_ms = Some(ms(h.publish_wall_ns - h.tick_wall_ns));
        }
        done
    }
}

pub(super) fn latency(stamp_ns: u64, l: &StageLatency, buf: Vec<u8>) -> ViewerMessage {
    json(ViewerTopic::Latency, stamp_ns, l, buf)
}
