//! The stateful part of the viewer conversion: one recorded message in, the viewer
//! messages it yields out. Keeps what it needs to emit only what changed (scene, reference
//! path, logs) and to grow the driven path.
//!
//! Knows the aisle message layouts and the viewer's choices (colours, frames, what to
//! skip); the Foxglove messages themselves are made in [`super::build`].

use super::build::{encode, grid, grid_of_view, log, path, pose3, rgba, timestamp, transform};
use super::plots::{self, LatencyTicks};
use super::{ViewerMessage, ViewerOptions, ViewerTopic, robot};
use crate::aligned::AlignedBuf;
use crate::payload_fields::{STAMP_AT, u64_at};
use aisle_messages::topics::names as s;
use aisle_messages::{
    ControllerBand, ControllerGoal, GlobalGrid, GlobalMapCopy, Header, Heartbeat, MAX_BODIES,
    MAX_CLOUD_POINTS, MAX_COMMANDS, MAX_PATH_POSES, MapChanges, MissionState, MissionStatus,
    NodeKind, NodeState, OccupancyGrid, PointCloud, RobotState, TickDone, Trajectory, WorldTruth,
    read_name,
};
use foxglove::messages as fg;

/// Stateful converter from aisle messages to viewer messages.
#[derive(Debug, Default)]
pub struct ViewerConverter {
    options: ViewerOptions,
    last_bodies: Vec<u8>,
    last_goal_id: Option<u64>,
    driven: Vec<fg::Pose>,
    last_driven: Option<(f64, f64, f64)>,
    states: u64,
    clouds: u64,
    last_status: Option<(u32, u32, String)>,
    last_failures: Vec<(u32, String)>,
    /// The robot's entity until it is sent (with the first message converted).
    robot: Option<fg::SceneEntity>,
    /// The scene's static bodies (ground truth lists only the bodies that can move),
    /// sent with the first ground truth and again every `STATIC_RESEND_NS`, so a viewer
    /// that joins late gets them too.
    statics: Vec<fg::CubePrimitive>,
    statics_sent_ns: Option<u64>,
    latency: LatencyTicks,
    /// The global map as its full maps and changes make it.
    global: GlobalMapCopy,
    /// The global map changed since it was last sent, and when that was (sim time).
    global_pending: bool,
    global_sent_ns: Option<u64>,
    /// The stamp of the newest message converted.
    last_stamp_ns: u64,
    /// Buffers of messages already written, for the JSON plot messages (so writing
    /// them allocates nothing once the pool is warm).
    spare: Vec<Vec<u8>>,
}

/// Buffers kept for reuse, and the largest one kept (the JSON messages are small).
const SPARE_BUFFERS: usize = 16;
const SPARE_CAPACITY: usize = 4096;

/// How often the static bodies are sent again, sim time.
const STATIC_RESEND_NS: u64 = 5_000_000_000;

/// Sim time between two global maps sent for their changes: the map crosses the bus as
/// the few cells that change, but a viewer's grid is the whole map (2 MB at 100 x 200 m),
/// so changes are gathered and sent at most this often (a full map goes at once).
const GLOBAL_MAP_PERIOD_NS: u64 = 1_000_000_000;

/// Longest driven path kept; beyond it every other pose is dropped.
const MAX_DRIVEN: usize = 20_000;

impl ViewerConverter {
    pub fn new(options: ViewerOptions) -> Self {
        Self {
            options,
            ..Self::default()
        }
    }

    /// Also shows the scene's static bodies in `/viz/scene`.
    pub fn with_static_bodies(mut self, scene: &aisle_config::scene::Scene) -> Self {
        let grey = rgba(0.55, 0.57, 0.6, 0.8);
        self.statics = scene
            .static_bodies()
            .map(|b| {
                let fp = b.footprint();
                cube(
                    b.pose.x,
                    b.pose.y,
                    b.pose.theta,
                    [fp.length, fp.width, b.height()],
                    grey,
                )
            })
            .collect();
        self
    }

    /// Also sends the robot model (`/viz/robot`), with the first message converted.
    pub fn with_robot(mut self, model: &aisle_robot::RobotModel) -> Self {
        self.robot = Some(robot::entity(model));
        self
    }

    /// Empties `out`, keeping the buffers of its messages for the next plot messages
    /// (call it instead of `clear` once they are written).
    pub fn recycle(&mut self, out: &mut Vec<ViewerMessage>) {
        for m in out.drain(..) {
            if self.spare.len() < SPARE_BUFFERS && m.data.capacity() <= SPARE_CAPACITY {
                self.spare.push(m.data);
            }
        }
    }

    /// What is still held back at the end of the run (the last tick's latencies, the
    /// global map's last changes).
    pub fn finish(&mut self, out: &mut Vec<ViewerMessage>) {
        let done = self.latency.finish();
        self.send_latency(done, out);
        if self.global_pending {
            self.send_global(self.last_stamp_ns, out);
        }
    }

    /// The held global map as a viewer grid.
    fn send_global(&mut self, stamp_ns: u64, out: &mut Vec<ViewerMessage>) {
        self.global_pending = false;
        self.global_sent_ns = Some(stamp_ns);
        if let Ok(view) = self.global.view()
            && let Some(g) = grid_of_view(stamp_ns, &view)
        {
            out.push(encode(ViewerTopic::GlobalMap, stamp_ns, &g));
        }
    }

    fn buffer(&mut self) -> Vec<u8> {
        self.spare.pop().unwrap_or_default()
    }

    /// Converts one recorded message of `service`; appends what it yields to `out`.
    /// Messages whose bytes do not fit their type, or whose counts are out of range,
    /// yield nothing (the raw channel still has them).
    pub fn convert(&mut self, service: &str, msg: &AlignedBuf, out: &mut Vec<ViewerMessage>) {
        if msg.len() >= size_of::<Header>() {
            let stamp = u64_at(msg.bytes(), STAMP_AT);
            self.last_stamp_ns = self.last_stamp_ns.max(stamp);
            if let Some(entity) = self.robot.take() {
                out.push(robot::message(&entity, stamp));
            }
            if self.global_pending
                && self
                    .global_sent_ns
                    .is_none_or(|t| stamp >= t.saturating_add(GLOBAL_MAP_PERIOD_NS))
            {
                self.send_global(stamp, out);
            }
        }
        match service {
            s::WORLD_TRUTH => {
                if let Some(m) = msg.view::<WorldTruth>() {
                    self.world(m, out)
                }
            }
            s::POINT_CLOUD => {
                if let Some(m) = msg.view::<PointCloud>() {
                    self.cloud(m, out)
                }
            }
            s::LOCAL_MAP => {
                if let Some(m) = msg.view::<OccupancyGrid>()
                    && let Some(g) = grid(m)
                {
                    out.push(encode(ViewerTopic::LocalMap, m.header.stamp_ns, &g));
                }
            }
            s::GLOBAL_MAP => {
                if let Some(m) = msg.view::<GlobalGrid>()
                    && self.global.update(Some(m), None).is_ok_and(|u| u.full)
                {
                    self.send_global(m.header.stamp_ns, out);
                }
            }
            s::GLOBAL_MAP_CHANGES => {
                if let Some(m) = msg.view::<MapChanges>()
                    && self.global.update(None, Some(m)).is_ok_and(|u| u.changed())
                {
                    self.global_pending = true;
                }
            }
            s::CONTROLLER_GOAL => {
                if let Some(m) = msg.view::<ControllerGoal>() {
                    self.goal(m, out)
                }
            }
            s::CONTROLLER_BAND => {
                if let Some(m) = msg.view::<ControllerBand>() {
                    band(m, out)
                }
            }
            s::ROBOT_STATE => {
                if let Some(m) = msg.view::<RobotState>() {
                    self.robot(m, out)
                }
            }
            s::MISSION_STATUS => {
                if let Some(m) = msg.view::<MissionStatus>() {
                    self.status(m, out)
                }
            }
            s::TRAJECTORY => {
                if let Some(m) = msg.view::<Trajectory>() {
                    self.trajectory(m, out)
                }
            }
            s::TICK_DONE => {
                if let Some(m) = msg.view::<TickDone>() {
                    let done = self.latency.done(m);
                    self.send_latency(done, out);
                }
            }
            s::HEARTBEAT => {
                if let Some(m) = msg.view::<Heartbeat>() {
                    self.heartbeat(m, out)
                }
            }
            _ => {}
        }
    }

    fn world(&mut self, m: &WorldTruth, out: &mut Vec<ViewerMessage>) {
        let n = m.len as usize;
        if n > MAX_BODIES {
            return;
        }
        let bytes = crate::aligned::message_bytes(m);
        // Bodies start after header, len, collisions and min_clearance (64 bytes).
        let bodies = &bytes[64..];
        if self.last_bodies == bodies {
            return;
        }
        self.last_bodies = bodies.to_vec();
        let t = timestamp(m.header.stamp_ns);
        // The bodies that can move, and the static ones in contact (red).
        let movable = m.bodies[..n]
            .iter()
            .map(|b| {
                let color = if b.carried != 0 {
                    rgba(0.95, 0.55, 0.1, 0.9)
                } else if b.is_static != 0 {
                    rgba(0.9, 0.1, 0.1, 0.9)
                } else {
                    rgba(0.6, 0.35, 0.15, 0.9)
                };
                cube(b.pose.x, b.pose.y, b.pose.theta, b.size, color)
            })
            .collect();
        let entity = |id: &str, cubes| fg::SceneEntity {
            timestamp: Some(t),
            frame_id: "map".into(),
            id: id.into(),
            cubes,
            ..Default::default()
        };
        let mut entities = vec![entity("movable", movable)];
        let stamp = m.header.stamp_ns;
        let due = self
            .statics_sent_ns
            .is_none_or(|sent| stamp.saturating_sub(sent) >= STATIC_RESEND_NS || stamp < sent);
        if due && !self.statics.is_empty() {
            self.statics_sent_ns = Some(stamp);
            entities.push(entity("static", self.statics.clone()));
        }
        let update = fg::SceneUpdate {
            deletions: vec![],
            entities,
        };
        out.push(encode(ViewerTopic::Scene, m.header.stamp_ns, &update));
    }

    fn cloud(&mut self, m: &PointCloud, out: &mut Vec<ViewerMessage>) {
        let n = m.rows as usize * m.cols as usize;
        if n > MAX_CLOUD_POINTS {
            return;
        }
        // The transforms go out with every cloud, converted or not, so the sensor frame
        // is always known.
        let t = timestamp(m.header.stamp_ns);
        let rp = &m.robot_pose;
        let sp = &m.sensor_pose;
        let (c, sn) = (rp.theta.cos(), rp.theta.sin());
        let (dx, dy) = (sp.position[0] - rp.x, sp.position[1] - rp.y);
        let rel = pose3(
            c * dx + sn * dy,
            -sn * dx + c * dy,
            sp.position[2],
            sp.rpy[0],
            sp.rpy[1],
            sp.rpy[2] - rp.theta,
        );
        let tfs = fg::FrameTransforms {
            transforms: vec![
                transform(
                    t,
                    "map",
                    "base_link",
                    pose3(rp.x, rp.y, 0.0, 0.0, 0.0, rp.theta),
                ),
                transform(t, "base_link", "sensor", rel),
            ],
        };
        out.push(encode(ViewerTopic::Transforms, m.header.stamp_ns, &tfs));
        let every = u64::from(self.options.cloud_every);
        self.clouds += 1;
        if every == 0 || !(self.clouds - 1).is_multiple_of(every) {
            return;
        }
        let mut data = Vec::with_capacity(n * 12);
        for p in &m.points[..n] {
            if p.iter().all(|v| v.is_finite()) {
                for v in p {
                    data.extend_from_slice(&v.to_le_bytes());
                }
            }
        }
        let field = |name: &str, offset: u32| fg::PackedElementField {
            name: name.into(),
            offset,
            r#type: fg::packed_element_field::NumericType::Float32 as i32,
        };
        let pc = fg::PointCloud {
            timestamp: Some(t),
            frame_id: "sensor".into(),
            pose: Some(pose3(0.0, 0.0, 0.0, 0.0, 0.0, 0.0)),
            point_stride: 12,
            fields: vec![field("x", 0), field("y", 4), field("z", 8)],
            data: data.into(),
        };
        out.push(encode(ViewerTopic::Points, m.header.stamp_ns, &pc));
    }

    fn trajectory(&mut self, m: &Trajectory, out: &mut Vec<ViewerMessage>) {
        let spare = &mut self.spare;
        plots::trajectory(m, out, || spare.pop().unwrap_or_default());
        let done = self.latency.trajectory(&m.header);
        self.send_latency(done, out);
    }

    fn send_latency(
        &mut self,
        done: Option<(u64, plots::StageLatency)>,
        out: &mut Vec<ViewerMessage>,
    ) {
        if let Some((stamp, l)) = done {
            let buf = self.buffer();
            out.push(plots::latency(stamp, &l, buf));
        }
    }

    fn goal(&mut self, m: &ControllerGoal, out: &mut Vec<ViewerMessage>) {
        let n = m.len as usize;
        if n > MAX_PATH_POSES || self.last_goal_id == Some(m.goal_id) {
            return;
        }
        self.last_goal_id = Some(m.goal_id);
        let poses = m.reference[..n].iter().map(|p| (p.x, p.y, p.theta));
        out.push(path(ViewerTopic::ReferencePath, m.header.stamp_ns, poses));
    }

    fn robot(&mut self, m: &RobotState, out: &mut Vec<ViewerMessage>) {
        let t = timestamp(m.header.stamp_ns);
        let p = &m.pose;
        if !(p.x.is_finite() && p.y.is_finite() && p.theta.is_finite()) {
            return;
        }
        let tfs = fg::FrameTransforms {
            transforms: vec![transform(
                t,
                "map",
                "base_link",
                pose3(p.x, p.y, 0.0, 0.0, 0.0, p.theta),
            )],
        };
        out.push(encode(ViewerTopic::Transforms, m.header.stamp_ns, &tfs));
        let buf = self.buffer();
        out.push(plots::odometry(m, buf));
        let moved = self.last_driven.is_none_or(|(x, y, th)| {
            (p.x - x).hypot(p.y - y) > 0.02 || aisle_geometry::wrap_angle(p.theta - th).abs() > 0.05
        });
        if moved {
            self.last_driven = Some((p.x, p.y, p.theta));
            if self.driven.len() >= MAX_DRIVEN {
                let kept: Vec<fg::Pose> = self.driven.iter().step_by(2).cloned().collect();
                self.driven = kept;
            }
            self.driven.push(pose3(p.x, p.y, 0.0, 0.0, 0.0, p.theta));
        }
        self.states += 1;
        let every = u64::from(self.options.driven_every.max(1));
        if self.states.is_multiple_of(every) {
            let msg = fg::PosesInFrame {
                timestamp: Some(t),
                frame_id: "map".into(),
                poses: self.driven.clone(),
            };
            out.push(encode(ViewerTopic::DrivenPath, m.header.stamp_ns, &msg));
        }
    }

    fn status(&mut self, m: &MissionStatus, out: &mut Vec<ViewerMessage>) {
        let text = read_name(&m.text).to_string();
        let key = (m.state, m.segment, text.clone());
        if self.last_status.as_ref() == Some(&key) {
            return;
        }
        self.last_status = Some(key);
        let state = MissionState::from_u32(m.state);
        let level = match state {
            Some(MissionState::Failed) => fg::log::Level::Error,
            _ => fg::log::Level::Info,
        };
        let message = format!(
            "{:?} segment {}/{} replans {} distance {:.2} m: {}",
            state.map_or_else(|| format!("state {}", m.state), |s| format!("{s:?}")),
            m.segment,
            m.segments,
            m.replans,
            m.distance,
            text
        );
        out.push(log(m.header.stamp_ns, level, "mission", message));
    }

    fn heartbeat(&mut self, m: &Heartbeat, out: &mut Vec<ViewerMessage>) {
        if NodeState::from_u32(m.state) != Some(NodeState::Failed) {
            return;
        }
        let text = read_name(&m.text).to_string();
        let key = (m.node, text.clone());
        if self.last_failures.contains(&key) {
            return;
        }
        self.last_failures.push(key);
        let name = NodeKind::from_u32(m.node).map_or("unknown", NodeKind::name);
        out.push(log(
            m.header.stamp_ns,
            fg::log::Level::Error,
            name,
            format!("{name} failed: {text}"),
        ));
    }
}

fn band(m: &ControllerBand, out: &mut Vec<ViewerMessage>) {
    let n = m.len as usize;
    if n > MAX_COMMANDS {
        return;
    }
    let poses = m.poses[..n].iter().map(|p| (p.x, p.y, p.theta));
    out.push(path(ViewerTopic::Band, m.header.stamp_ns, poses));
}

/// A box standing on the floor at `(x, y)`, turned by `theta`; `size` is length, width,
/// height.
fn cube(x: f64, y: f64, theta: f64, size: [f64; 3], color: fg::Color) -> fg::CubePrimitive {
    fg::CubePrimitive {
        pose: Some(pose3(x, y, size[2] / 2.0, 0.0, 0.0, theta)),
        size: Some(fg::Vector3 {
            x: size[0],
            y: size[1],
            z: size[2],
        }),
        color: Some(color),
    }
}
