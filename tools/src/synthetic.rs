//! A synthetic recorded run for tests and benchmarks: a robot driving two segments past
//! a rack, with ticks, acknowledgements, clouds, maps, goals, bands and trajectories
//! whose timings are known exactly.
//!
//! Deterministic: the same number of ticks gives the same bytes. Knows nothing about the
//! real processes; only the message layouts.

use crate::aligned::{AlignedBuf, message_bytes, zeroed_box};
use crate::viewer::{ViewerConverter, ViewerOptions};
use crate::writer::{RecordWriter, WriteError, WriterOptions};
use aisle_messages::topics::names as s;
use aisle_messages::{
    ControllerBand, ControllerGoal, GlobalGrid, GridMessage, Message, MissionStatus, NodeKind,
    OccupancyGrid, PointCloud, RobotState, StageStatus, Tick, TickDone, Trajectory, WorldTruth,
    write_name,
};
use std::io::{Seek, Write};

/// Simulated tick length.
pub const DT_NS: u64 = 100_000_000;
/// Wall time between tick starts in the synthetic run.
pub const WALL_PERIOD_NS: u64 = 10_000_000;
/// Monotonic time of tick 0.
pub const WALL_START_NS: u64 = 1_000_000_000_000;

/// Compute time the synthetic lidar reports for tick `k`.
pub fn lidar_compute_ns(k: u64) -> u64 {
    1_000_000 + (k % 10) * 100_000
}

/// Compute time the synthetic mapper reports for tick `k`.
pub fn mapper_compute_ns(k: u64) -> u64 {
    2_000_000 + (k % 5) * 200_000
}

/// End-to-end latency of the trajectory of tick `k` (controller acts every 5th tick).
pub fn trajectory_latency_ns(k: u64) -> u64 {
    5_000_000 + (k % 7) * 1_000_000
}

/// The process that publishes `service` in a real run.
fn writer_of<M: Message>(service: &str, m: &M) -> NodeKind {
    crate::catalog::producer(service).unwrap_or_else(|| {
        let done = crate::aligned::AlignedBuf::from_bytes(message_bytes(m));
        done.view::<TickDone>()
            .and_then(|d| NodeKind::from_u32(d.node))
            .unwrap_or(NodeKind::Supervisor)
    })
}

/// One recorded sample.
pub struct Sample {
    pub service: &'static str,
    pub log_time: u64,
    pub bytes: AlignedBuf,
}

/// The run being built: its samples so far and each publisher slot's sequence number.
struct Run {
    out: Vec<Sample>,
    seqs: [u64; 32],
    ticks: u64,
    /// The last tick of segment 0.
    half: u64,
}

impl Run {
    // Messages arrive boxed because the large ones would overflow the stack.
    #[allow(clippy::boxed_local)]
    fn push<M: Message>(
        &mut self,
        slot: usize,
        service: &'static str,
        mut m: Box<M>,
        k: u64,
        latency_ns: u64,
    ) {
        self.seqs[slot] += 1;
        let tick_wall = WALL_START_NS + k * WALL_PERIOD_NS;
        let source = writer_of(service, &*m);
        let h = m.header_mut();
        h.source = source.code();
        h.seq = self.seqs[slot];
        h.stamp_ns = k * DT_NS;
        h.tick = k;
        h.tick_wall_ns = tick_wall;
        h.publish_wall_ns = tick_wall + latency_ns;
        let log_time = h.publish_wall_ns + 50_000;
        self.out.push(Sample {
            service,
            log_time,
            bytes: AlignedBuf::from_bytes(message_bytes(&*m)),
        });
    }

    fn done(&mut self, node: NodeKind, status: StageStatus, compute_ns: u64, k: u64) {
        let mut d = zeroed_box::<TickDone>();
        d.node = node.code();
        d.status = status as u32;
        d.compute_ns = compute_ns;
        self.push(
            10 + node.code() as usize,
            s::TICK_DONE,
            d,
            k,
            compute_ns + 10_000,
        );
    }

    /// Along x in segment 0, then along y.
    fn pose_at(&self, k: u64) -> (f64, f64, f64) {
        let half = self.half;
        if k <= half {
            (k as f64 * 0.1, 0.0, 0.0)
        } else {
            (
                half as f64 * 0.1,
                (k - half) as f64 * 0.1,
                std::f64::consts::FRAC_PI_2,
            )
        }
    }

    fn segment(&self, k: u64) -> u32 {
        u32::from(k > self.half)
    }

    /// The simulator's tick k: robot state, ground truth, the `Tick`.
    fn simulator(&mut self, k: u64) {
        let (x, y, th) = self.pose_at(k);
        let mut r = zeroed_box::<RobotState>();
        r.pose.x = x;
        r.pose.y = y;
        r.pose.theta = th;
        self.push(0, s::ROBOT_STATE, r, k, 100_000);

        let mut w = zeroed_box::<WorldTruth>();
        w.len = 2;
        write_name(&mut w.bodies[0].name, "wall");
        w.bodies[0].pose.x = 5.0;
        w.bodies[0].pose.y = -4.0;
        w.bodies[0].size = [10.0, 0.2, 3.0];
        w.bodies[0].is_static = 1;
        write_name(&mut w.bodies[1].name, "rack");
        w.bodies[1].pose.x = 3.0;
        w.bodies[1].pose.y = 2.0;
        w.bodies[1].size = [0.88, 0.8, 1.0];
        self.push(1, s::WORLD_TRUTH, w, k, 120_000);

        let mut t = zeroed_box::<Tick>();
        t.dt_ns = DT_NS;
        t.stages = u32::from(k.is_multiple_of(5));
        self.push(2, s::TICK, t, k, 150_000);
    }

    /// The lidar's cloud of tick k (one missing return) and its acknowledgement.
    fn lidar(&mut self, k: u64) {
        let (x, y, th) = self.pose_at(k);
        let mut c = zeroed_box::<PointCloud>();
        c.rows = 2;
        c.cols = 4;
        for (i, p) in c.points[..8].iter_mut().enumerate() {
            *p = if i == 3 {
                [f32::NAN; 3]
            } else {
                [1.0 + i as f32, 0.5, 0.1]
            };
        }
        c.robot_pose.x = x;
        c.robot_pose.y = y;
        c.robot_pose.theta = th;
        c.sensor_pose.position = [x + 0.25, y + 0.1, 0.2];
        c.sensor_pose.rpy = [0.0, 0.0, th];
        self.push(3, s::POINT_CLOUD, c, k, lidar_compute_ns(k));
        self.done(NodeKind::Lidar, StageStatus::Done, lidar_compute_ns(k), k);
    }

    /// The mapper's maps of tick k (the global one every 10th) and its acknowledgement.
    fn mapper(&mut self, k: u64) {
        if k.is_multiple_of(10) {
            self.push(4, s::GLOBAL_MAP, grid::<GlobalGrid>(0, k), k, 3_000_000);
        }
        self.push(5, s::LOCAL_MAP, grid::<OccupancyGrid>(1, k), k, 3_000_000);
        self.done(NodeKind::Mapper, StageStatus::Done, mapper_compute_ns(k), k);
    }

    /// A goal at the start of each segment; every 5th tick a trajectory and a band,
    /// else an idle acknowledgement.
    fn controller(&mut self, k: u64) {
        let (x, y, th) = self.pose_at(k);
        let segment = self.segment(k);
        if k == 0 || k == self.half + 1 {
            let mut g = zeroed_box::<ControllerGoal>();
            g.goal_id = u64::from(segment) + 1;
            g.len = 20;
            for (i, p) in g.reference[..20].iter_mut().enumerate() {
                let (px, py, pth) = self.pose_at(k + i as u64 * self.ticks / 40);
                p.x = px;
                p.y = py;
                p.theta = pth;
                p.direction = 1;
            }
            self.push(6, s::CONTROLLER_GOAL, g, k, 200_000);
        }
        if k.is_multiple_of(5) {
            let mut tr = zeroed_box::<Trajectory>();
            tr.len = 3;
            tr.goal_id = u64::from(segment) + 1;
            self.push(7, s::TRAJECTORY, tr, k, trajectory_latency_ns(k));
            let mut b = zeroed_box::<ControllerBand>();
            b.len = 5;
            for (i, p) in b.poses[..5].iter_mut().enumerate() {
                p.t = i as f64 * 0.3;
                p.x = x + if th == 0.0 { i as f64 * 0.3 } else { 0.0 };
                p.y = y + if th == 0.0 { 0.0 } else { i as f64 * 0.3 };
                p.theta = th;
            }
            self.push(8, s::CONTROLLER_BAND, b, k, trajectory_latency_ns(k));
            self.done(
                NodeKind::TebController,
                StageStatus::Done,
                trajectory_latency_ns(k) - 500_000,
                k,
            );
        }
        if !k.is_multiple_of(5) {
            // The controller acknowledges the ticks it does not act on as idle.
            self.done(NodeKind::TebController, StageStatus::Idle, 0, k);
        }
    }

    /// The mission status at the start of each segment and at the end.
    fn mission(&mut self, k: u64) {
        if k == 0 || k == self.half + 1 || k + 1 == self.ticks {
            let segment = self.segment(k);
            let mut st = zeroed_box::<MissionStatus>();
            st.segment = segment;
            st.segments = 2;
            st.state = 2;
            write_name(&mut st.text, &format!("driving segment {segment}"));
            self.push(9, s::MISSION_STATUS, st, k, 300_000);
        }
    }
}

/// The samples of a synthetic run of `ticks` ticks, in receive order. The robot drives
/// along x from (0, 0) in segment 0 for the first half, then along y in segment 1.
pub fn synthetic_run(ticks: u64) -> Vec<Sample> {
    let mut run = Run {
        out: Vec::new(),
        seqs: [0; 32],
        ticks,
        half: ticks / 2,
    };
    for k in 0..ticks {
        run.simulator(k);
        run.lidar(k);
        run.mapper(k);
        run.controller(k);
        run.mission(k);
    }
    let mut out = run.out;
    out.sort_by_key(|s| s.log_time);
    out
}

/// A 40 x 60 map (20 x 30 m at 0.5 m) with a static wall and, from tick 20 on, a detected
/// blob where the rack stands, as a global (`GlobalGrid`) or local (`OccupancyGrid`) map.
fn grid<G: GridMessage>(kind: u32, k: u64) -> Box<G> {
    let mut cells = [0u8; 40 * 60];
    cells[12 * 40..13 * 40].fill(1);
    if k >= 20 {
        cells[24 * 40 + 16] = 2;
        cells[24 * 40 + 17] = 2;
    }
    let view =
        aisle_geometry::GridView::new(-5.0, -10.0, 0.5, 40, 60, &cells).expect("a valid grid");
    let mut g = zeroed_box::<G>();
    g.write(kind, k / 20, &view)
        .expect("a 40 x 60 grid fits either message");
    g
}

/// Writes the synthetic run (raw and viewer channels) into `w`.
pub fn write_synthetic<W: Write + Seek>(
    w: W,
    ticks: u64,
    options: WriterOptions,
) -> Result<W, WriteError> {
    let mut writer = RecordWriter::new(w, options)?;
    let mut conv = ViewerConverter::new(ViewerOptions::default());
    let mut viewer = Vec::new();
    writer.attach(
        "mission.toml",
        "application/toml",
        b"[mission]\nname = \"synthetic\"\n",
        WALL_START_NS,
    )?;
    for sample in synthetic_run(ticks) {
        writer.write_raw(sample.service, sample.log_time, sample.bytes.bytes())?;
        viewer.clear();
        conv.convert(sample.service, &sample.bytes, &mut viewer);
        for v in &viewer {
            writer.write_viewer(v, sample.log_time)?;
        }
    }
    Ok(writer.finish()?.0)
}
