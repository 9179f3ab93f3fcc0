//! Turns recorded aisle messages into Foxglove's well-known protobuf messages, so a run
//! opens in Foxglove or Lichtblick with the scene in 3D.
//!
//! Frames: `map` (the map frame), `base_link` (the robot base) and `sensor` (the lidar).
//! Every viewer message is stamped with the simulated time of the message it came from.
//! The converter keeps a little state so it emits only what changed (scene, logs) and
//! grows the driven path. It knows nothing about files or the bus.

use crate::aligned::AlignedBuf;
use aisle_messages::topics::names as s;
use aisle_messages::{
    ControllerBand, ControllerGoal, Heartbeat, MAX_BODIES, MAX_CLOUD_POINTS, MAX_COMMANDS,
    MAX_GRID_CELLS, MAX_PATH_POSES, MissionState, MissionStatus, NodeKind, NodeState,
    OccupancyGrid, PointCloud, RobotState, WorldTruth, read_name,
};
use foxglove::Encode;
use foxglove::messages as fg;

/// The viewer channels, one per Foxglove message stream.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum ViewerTopic {
    Scene,
    Points,
    GlobalMap,
    LocalMap,
    ReferencePath,
    Band,
    DrivenPath,
    Transforms,
    Log,
}

impl ViewerTopic {
    pub const ALL: [ViewerTopic; 9] = [
        ViewerTopic::Scene,
        ViewerTopic::Points,
        ViewerTopic::GlobalMap,
        ViewerTopic::LocalMap,
        ViewerTopic::ReferencePath,
        ViewerTopic::Band,
        ViewerTopic::DrivenPath,
        ViewerTopic::Transforms,
        ViewerTopic::Log,
    ];

    pub fn topic(self) -> &'static str {
        match self {
            ViewerTopic::Scene => "/viz/scene",
            ViewerTopic::Points => "/viz/lidar/points",
            ViewerTopic::GlobalMap => "/viz/map/global",
            ViewerTopic::LocalMap => "/viz/map/local",
            ViewerTopic::ReferencePath => "/viz/path/reference",
            ViewerTopic::Band => "/viz/path/band",
            ViewerTopic::DrivenPath => "/viz/path/driven",
            ViewerTopic::Transforms => "/tf",
            ViewerTopic::Log => "/viz/log",
        }
    }

    /// The Foxglove schema (`foxglove.X`, protobuf `FileDescriptorSet`).
    pub fn schema(self) -> Option<foxglove::Schema> {
        match self {
            ViewerTopic::Scene => fg::SceneUpdate::get_schema(),
            ViewerTopic::Points => fg::PointCloud::get_schema(),
            ViewerTopic::GlobalMap | ViewerTopic::LocalMap => fg::Grid::get_schema(),
            ViewerTopic::ReferencePath | ViewerTopic::Band | ViewerTopic::DrivenPath => {
                fg::PosesInFrame::get_schema()
            }
            ViewerTopic::Transforms => fg::FrameTransforms::get_schema(),
            ViewerTopic::Log => fg::Log::get_schema(),
        }
    }

    pub fn index(self) -> usize {
        self as usize
    }
}

/// One encoded viewer message.
#[derive(Debug, Clone, PartialEq)]
pub struct ViewerMessage {
    pub topic: ViewerTopic,
    /// Simulated time the message is stamped with.
    pub stamp_ns: u64,
    pub data: Vec<u8>,
}

/// What the converter does with point clouds (the largest viewer stream).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ViewerOptions {
    /// Convert every n-th point cloud (1 = all, 0 = none).
    pub cloud_every: u32,
    /// Publish the driven path every n-th robot state.
    pub driven_every: u32,
}

impl Default for ViewerOptions {
    fn default() -> Self {
        Self {
            cloud_every: 1,
            driven_every: 10,
        }
    }
}

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
}

/// Longest driven path kept; beyond it every other pose is dropped.
const MAX_DRIVEN: usize = 20_000;

impl ViewerConverter {
    pub fn new(options: ViewerOptions) -> Self {
        Self {
            options,
            ..Self::default()
        }
    }

    /// Converts one recorded message of `service`; appends what it yields to `out`.
    /// Messages whose bytes do not fit their type, or whose counts are out of range,
    /// yield nothing (the raw channel still has them).
    pub fn convert(&mut self, service: &str, msg: &AlignedBuf, out: &mut Vec<ViewerMessage>) {
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
            s::GLOBAL_MAP | s::LOCAL_MAP => {
                if let Some(m) = msg.view::<OccupancyGrid>() {
                    let topic = if service == s::GLOBAL_MAP {
                        ViewerTopic::GlobalMap
                    } else {
                        ViewerTopic::LocalMap
                    };
                    if let Some(g) = grid(m) {
                        out.push(encode(topic, m.header.stamp_ns, &g));
                    }
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
        let mut fixed = Vec::new();
        let mut movable = Vec::new();
        for b in &m.bodies[..n] {
            let color = if b.carried != 0 {
                rgba(0.95, 0.55, 0.1, 0.9)
            } else if b.is_static != 0 {
                rgba(0.55, 0.57, 0.6, 0.8)
            } else {
                rgba(0.6, 0.35, 0.15, 0.9)
            };
            let cube = fg::CubePrimitive {
                pose: Some(pose3(
                    b.pose.x,
                    b.pose.y,
                    b.size[2] / 2.0,
                    0.0,
                    0.0,
                    b.pose.theta,
                )),
                size: Some(fg::Vector3 {
                    x: b.size[0],
                    y: b.size[1],
                    z: b.size[2],
                }),
                color: Some(color),
            };
            if b.is_static != 0 {
                fixed.push(cube);
            } else {
                movable.push(cube);
            }
        }
        let entity = |id: &str, cubes| fg::SceneEntity {
            timestamp: Some(t),
            frame_id: "map".into(),
            id: id.into(),
            cubes,
            ..Default::default()
        };
        let update = fg::SceneUpdate {
            deletions: vec![],
            entities: vec![entity("static", fixed), entity("movable", movable)],
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

    fn goal(&mut self, m: &ControllerGoal, out: &mut Vec<ViewerMessage>) {
        let n = m.len as usize;
        if n > MAX_PATH_POSES || self.last_goal_id == Some(m.goal_id) {
            return;
        }
        self.last_goal_id = Some(m.goal_id);
        let poses = m.reference[..n]
            .iter()
            .map(|p| pose3(p.x, p.y, 0.0, 0.0, 0.0, p.theta))
            .collect();
        let msg = fg::PosesInFrame {
            timestamp: Some(timestamp(m.header.stamp_ns)),
            frame_id: "map".into(),
            poses,
        };
        out.push(encode(ViewerTopic::ReferencePath, m.header.stamp_ns, &msg));
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
    let poses = m.poses[..n]
        .iter()
        .map(|p| pose3(p.x, p.y, 0.0, 0.0, 0.0, p.theta))
        .collect();
    let msg = fg::PosesInFrame {
        timestamp: Some(timestamp(m.header.stamp_ns)),
        frame_id: "map".into(),
        poses,
    };
    out.push(encode(ViewerTopic::Band, m.header.stamp_ns, &msg));
}

fn grid(m: &OccupancyGrid) -> Option<fg::Grid> {
    let (w, h) = (m.width as usize, m.height as usize);
    if w == 0
        || h == 0
        || w.checked_mul(h)? > MAX_GRID_CELLS
        || m.resolution.is_nan()
        || m.resolution <= 0.0
    {
        return None;
    }
    Some(fg::Grid {
        timestamp: Some(timestamp(m.header.stamp_ns)),
        frame_id: "map".into(),
        pose: Some(pose3(m.origin_x, m.origin_y, 0.0, 0.0, 0.0, 0.0)),
        column_count: m.width,
        cell_size: Some(fg::Vector2 {
            x: m.resolution,
            y: m.resolution,
        }),
        row_stride: m.width,
        cell_stride: 1,
        fields: vec![fg::PackedElementField {
            name: "occupancy".into(),
            offset: 0,
            r#type: fg::packed_element_field::NumericType::Uint8 as i32,
        }],
        data: m.cells[..w * h].to_vec().into(),
    })
}

fn log(stamp_ns: u64, level: fg::log::Level, name: &str, message: String) -> ViewerMessage {
    let msg = fg::Log {
        timestamp: Some(timestamp(stamp_ns)),
        level: level as i32,
        message,
        name: name.into(),
        file: String::new(),
        line: 0,
    };
    encode(ViewerTopic::Log, stamp_ns, &msg)
}

fn encode<T: Encode>(topic: ViewerTopic, stamp_ns: u64, msg: &T) -> ViewerMessage {
    let mut data = Vec::with_capacity(msg.encoded_len().unwrap_or(64));
    // Encoding into a growable Vec cannot run out of space, the only encode error.
    let _ = msg.encode(&mut data);
    ViewerMessage {
        topic,
        stamp_ns,
        data,
    }
}

/// Simulated nanoseconds as a protobuf timestamp.
pub fn timestamp(ns: u64) -> fg::Timestamp {
    let sec = (ns / 1_000_000_000).min(u64::from(u32::MAX)) as u32;
    fg::Timestamp::new(sec, (ns % 1_000_000_000) as u32)
}

fn rgba(r: f64, g: f64, b: f64, a: f64) -> fg::Color {
    fg::Color { r, g, b, a }
}

/// A pose from a position and roll, pitch, yaw (yaw applied first, then pitch, then roll).
fn pose3(x: f64, y: f64, z: f64, roll: f64, pitch: f64, yaw: f64) -> fg::Pose {
    let (sr, cr) = (roll / 2.0).sin_cos();
    let (sp, cp) = (pitch / 2.0).sin_cos();
    let (sy, cy) = (yaw / 2.0).sin_cos();
    fg::Pose {
        position: Some(fg::Vector3 { x, y, z }),
        orientation: Some(fg::Quaternion {
            x: sr * cp * cy - cr * sp * sy,
            y: cr * sp * cy + sr * cp * sy,
            z: cr * cp * sy - sr * sp * cy,
            w: cr * cp * cy + sr * sp * sy,
        }),
    }
}

fn transform(t: fg::Timestamp, parent: &str, child: &str, p: fg::Pose) -> fg::FrameTransform {
    fg::FrameTransform {
        timestamp: Some(t),
        parent_frame_id: parent.into(),
        child_frame_id: child.into(),
        translation: p.position,
        rotation: p.orientation,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::aligned::{message_bytes, zeroed_box};
    use aisle_messages::write_name;
    use foxglove::Decode;

    fn buf<M: aisle_messages::Message>(m: &M) -> AlignedBuf {
        AlignedBuf::from_bytes(message_bytes(m))
    }

    #[test]
    fn grid_keeps_cells_row_major_from_the_origin() {
        let mut g = zeroed_box::<OccupancyGrid>();
        g.width = 3;
        g.height = 2;
        g.resolution = 0.1;
        g.origin_x = -5.0;
        g.origin_y = -10.0;
        g.cells[..6].copy_from_slice(&[0, 1, 2, 0, 0, 1]);
        g.header.stamp_ns = 1_500_000_000;
        let mut out = Vec::new();
        ViewerConverter::default().convert(s::GLOBAL_MAP, &buf(&*g), &mut out);
        assert_eq!(out.len(), 1);
        let d = fg::Grid::decode(out[0].data.as_slice()).unwrap();
        assert_eq!(d.column_count, 3);
        assert_eq!(&d.data[..], &[0, 1, 2, 0, 0, 1]);
        assert_eq!(d.timestamp, Some(fg::Timestamp::new(1, 500_000_000)));
        let pos = d.pose.unwrap().position.unwrap();
        assert_eq!((pos.x, pos.y), (-5.0, -10.0));
        // An impossible size yields nothing rather than a panic.
        g.width = 5000;
        g.height = 5000;
        out.clear();
        ViewerConverter::default().convert(s::GLOBAL_MAP, &buf(&*g), &mut out);
        assert!(out.is_empty());
    }

    #[test]
    fn cloud_drops_missing_returns_and_places_the_sensor() {
        let mut c = zeroed_box::<PointCloud>();
        c.rows = 1;
        c.cols = 3;
        c.points[0] = [1.0, 2.0, 3.0];
        c.points[1] = [f32::NAN; 3];
        c.points[2] = [4.0, 5.0, 6.0];
        c.robot_pose.x = 1.0;
        c.robot_pose.theta = std::f64::consts::FRAC_PI_2;
        c.sensor_pose.position = [1.0, 0.25, 0.2];
        c.sensor_pose.rpy = [0.0, 0.0, std::f64::consts::FRAC_PI_2];
        let mut out = Vec::new();
        ViewerConverter::default().convert(s::POINT_CLOUD, &buf(&*c), &mut out);
        assert_eq!(out.len(), 2);
        let tf = fg::FrameTransforms::decode(out[0].data.as_slice()).unwrap();
        let rel = tf.transforms[1].translation.unwrap();
        assert!(
            (rel.x - 0.25).abs() < 1e-12 && rel.y.abs() < 1e-12,
            "{rel:?}"
        );
        let q = tf.transforms[1].rotation.unwrap();
        assert!((q.w - 1.0).abs() < 1e-12);
        let pc = fg::PointCloud::decode(out[1].data.as_slice()).unwrap();
        assert_eq!(pc.data.len(), 24);
        assert_eq!(pc.frame_id, "sensor");
    }

    #[test]
    fn scene_and_logs_are_emitted_on_change_only() {
        let mut w = zeroed_box::<WorldTruth>();
        w.len = 2;
        w.bodies[0].is_static = 1;
        w.bodies[0].size = [1.0, 2.0, 3.0];
        w.bodies[1].pose.x = 2.0;
        w.bodies[1].size = [0.88, 0.8, 1.0];
        let mut conv = ViewerConverter::default();
        let mut out = Vec::new();
        conv.convert(s::WORLD_TRUTH, &buf(&*w), &mut out);
        conv.convert(s::WORLD_TRUTH, &buf(&*w), &mut out);
        assert_eq!(out.len(), 1);
        let su = fg::SceneUpdate::decode(out[0].data.as_slice()).unwrap();
        assert_eq!(su.entities[0].cubes.len(), 1);
        assert_eq!(su.entities[1].cubes.len(), 1);
        w.bodies[1].pose.x = 2.5;
        conv.convert(s::WORLD_TRUTH, &buf(&*w), &mut out);
        assert_eq!(out.len(), 2);

        let mut st = zeroed_box::<MissionStatus>();
        write_name(&mut st.text, "planning segment 1");
        out.clear();
        conv.convert(s::MISSION_STATUS, &buf(&*st), &mut out);
        conv.convert(s::MISSION_STATUS, &buf(&*st), &mut out);
        assert_eq!(out.len(), 1);
        let l = fg::Log::decode(out[0].data.as_slice()).unwrap();
        assert!(l.message.contains("planning segment 1"), "{}", l.message);
    }

    #[test]
    fn driven_path_grows_and_is_published_periodically() {
        let mut conv = ViewerConverter::new(ViewerOptions {
            cloud_every: 1,
            driven_every: 2,
        });
        let mut r = zeroed_box::<RobotState>();
        let mut out = Vec::new();
        for i in 0..4 {
            r.pose.x = f64::from(i) * 0.1;
            conv.convert(s::ROBOT_STATE, &buf(&*r), &mut out);
        }
        let paths: Vec<_> = out
            .iter()
            .filter(|m| m.topic == ViewerTopic::DrivenPath)
            .collect();
        assert_eq!(paths.len(), 2);
        let last = fg::PosesInFrame::decode(paths[1].data.as_slice()).unwrap();
        assert_eq!(last.poses.len(), 4);
    }

    #[test]
    fn every_topic_has_a_foxglove_protobuf_schema() {
        for t in ViewerTopic::ALL {
            let s = t.schema().unwrap();
            assert!(s.name.starts_with("foxglove."), "{}", s.name);
            assert_eq!(s.encoding, "protobuf");
            assert!(!s.data.is_empty());
        }
    }
}
