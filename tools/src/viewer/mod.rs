//! Turns recorded aisle messages into Foxglove's well-known protobuf messages and into
//! plottable JSON, so a run opens in Foxglove or Lichtblick with the scene in 3D and its
//! signals in plots.
//!
//! Grids (`/viz/map/global`, `/viz/map/local`, `foxglove.Grid`, one `int8` field
//! `occupancy`, row-major from the origin cell) hold the ROS `nav_msgs/OccupancyGrid`
//! values: 0 free, 100 a static obstacle, 99 an obstacle the lidar detected, -1 unknown
//! (the bus's grids hold 0, 1, 2: `aisle_geometry::grid`). The global map is assembled
//! from its full maps and changes; a full map is sent at once, changes at most once a
//! second of sim time (a viewer's grid is the whole map).
//!
//! Frames: `map` (the map frame), `base_link` (the robot base) and `sensor` (the lidar).
//! Every viewer message is stamped with the simulated time of the message it came from.
//! The converter keeps a little state so it emits only what changed (scene, logs) and
//! grows the driven path. It knows nothing about files or the bus.
//!
//! The robot (`/viz/robot`) is a scene entity made of its URDF's collision shapes in
//! `base_link` ([`robot`]). The plot channels (`/plot/odometry`, `/plot/cmd_vel`,
//! `/plot/teb`, `/plot/latency`) are JSON with a JSON Schema ([`plots`]).
//!
//! Modules: [`converter`] (the stateful conversion, message by message), [`build`]
//! (Foxglove messages from plain values, and their encoding), [`robot`], [`plots`].

mod build;
mod converter;
mod plots;
mod robot;

pub use build::timestamp;
pub use converter::ViewerConverter;

/// What the viewer channels show besides the record's messages: the robot model
/// (`/viz/robot`) and the scene, whose static bodies ground truth does not list.
#[derive(Debug, Default)]
pub struct ViewerModels {
    pub robot: Option<aisle_robot::RobotModel>,
    pub scene: Option<aisle_config::scene::Scene>,
}

use foxglove::Encode;
use foxglove::messages as fg;

/// The viewer channels, one per Foxglove message stream. Each carries its own message
/// encoding and schema ([`ViewerTopic::encoding`], [`ViewerTopic::schema`]): the
/// writer and the live view declare every channel from these alone.
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
    /// The robot model (`foxglove.SceneUpdate` in `base_link`), sent once.
    Robot,
    /// Plot channels (JSON): odometry, first velocity command, TEB step, stage latency.
    Odometry,
    Command,
    Teb,
    Latency,
}

impl ViewerTopic {
    pub const ALL: [ViewerTopic; 14] = [
        ViewerTopic::Scene,
        ViewerTopic::Points,
        ViewerTopic::GlobalMap,
        ViewerTopic::LocalMap,
        ViewerTopic::ReferencePath,
        ViewerTopic::Band,
        ViewerTopic::DrivenPath,
        ViewerTopic::Transforms,
        ViewerTopic::Log,
        ViewerTopic::Robot,
        ViewerTopic::Odometry,
        ViewerTopic::Command,
        ViewerTopic::Teb,
        ViewerTopic::Latency,
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
            ViewerTopic::Robot => "/viz/robot",
            ViewerTopic::Odometry => "/plot/odometry",
            ViewerTopic::Command => "/plot/cmd_vel",
            ViewerTopic::Teb => "/plot/teb",
            ViewerTopic::Latency => "/plot/latency",
        }
    }

    /// The channel's schema: a Foxglove protobuf message (`foxglove.X`,
    /// `FileDescriptorSet`) or, for the plot channels, a JSON Schema (`aisle.plot.X`).
    pub fn schema(self) -> Option<foxglove::Schema> {
        let json = |name: &str, text: &'static str| {
            Some(foxglove::Schema::new(name, "jsonschema", text.as_bytes()))
        };
        match self {
            ViewerTopic::Scene | ViewerTopic::Robot => fg::SceneUpdate::get_schema(),
            ViewerTopic::Points => fg::PointCloud::get_schema(),
            ViewerTopic::GlobalMap | ViewerTopic::LocalMap => fg::Grid::get_schema(),
            ViewerTopic::ReferencePath | ViewerTopic::Band | ViewerTopic::DrivenPath => {
                fg::PosesInFrame::get_schema()
            }
            ViewerTopic::Transforms => fg::FrameTransforms::get_schema(),
            ViewerTopic::Log => fg::Log::get_schema(),
            ViewerTopic::Odometry => json("aisle.plot.Odometry", plots::ODOMETRY_SCHEMA),
            ViewerTopic::Command => json("aisle.plot.Command", plots::COMMAND_SCHEMA),
            ViewerTopic::Teb => json("aisle.plot.TebStep", plots::TEB_SCHEMA),
            ViewerTopic::Latency => json("aisle.plot.StageLatency", plots::LATENCY_SCHEMA),
        }
    }

    /// The message encoding of the channel: `protobuf` or `json`.
    pub fn encoding(self) -> &'static str {
        match self {
            ViewerTopic::Odometry
            | ViewerTopic::Command
            | ViewerTopic::Teb
            | ViewerTopic::Latency => "json",
            _ => "protobuf",
        }
    }

    /// True for the channels whose newest message a late live subscriber gets at once
    /// (they change rarely or never).
    pub fn latched(self) -> bool {
        matches!(
            self,
            ViewerTopic::Scene
                | ViewerTopic::GlobalMap
                | ViewerTopic::ReferencePath
                | ViewerTopic::Robot
        )
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::aligned::{AlignedBuf, message_bytes, zeroed_box};
    use aisle_messages::topics::names as s;
    use aisle_messages::write_name;
    use aisle_messages::{GlobalGrid, MissionStatus, PointCloud, RobotState, WorldTruth};
    use foxglove::Decode;

    fn buf<M: aisle_messages::Message>(m: &M) -> AlignedBuf {
        AlignedBuf::from_bytes(message_bytes(m))
    }

    #[test]
    fn grid_keeps_cells_row_major_from_the_origin() {
        let mut g = zeroed_box::<GlobalGrid>();
        g.width = 3;
        g.height = 2;
        g.resolution = 0.1;
        g.origin_x = -5.0;
        g.origin_y = -10.0;
        g.cells[..6].copy_from_slice(&[0, 1, 2, 0, 7, 1]);
        g.header.stamp_ns = 1_500_000_000;
        let mut out = Vec::new();
        ViewerConverter::default().convert(s::GLOBAL_MAP, &buf(&*g), &mut out);
        assert_eq!(out.len(), 1);
        let d = fg::Grid::decode(out[0].data.as_slice()).unwrap();
        assert_eq!(d.column_count, 3);
        // ROS values: free 0, static 100, detected 99, unknown -1.
        assert_eq!(&d.data[..], &[0, 100, 99, 0, 0xff, 100]);
        assert_eq!(d.timestamp, Some(fg::Timestamp::new(1, 500_000_000)));
        let pos = d.pose.unwrap().position.unwrap();
        assert_eq!((pos.x, pos.y), (-5.0, -10.0));
        // An impossible size yields nothing rather than a panic.
        g.width = 5000;
        g.height = 5000;
        const { assert!(5000 * 5000 > aisle_messages::MAX_GLOBAL_GRID_CELLS) };
        out.clear();
        ViewerConverter::default().convert(s::GLOBAL_MAP, &buf(&*g), &mut out);
        assert!(out.is_empty());
    }

    #[test]
    fn the_global_map_is_sent_whole_at_once_and_its_changes_at_most_once_a_second() {
        let mut g = zeroed_box::<GlobalGrid>();
        (g.width, g.height, g.resolution, g.version) = (3, 2, 0.1, 4);
        let mut c = zeroed_box::<aisle_messages::MapChanges>();
        (c.base_version, c.width, c.height, c.len) = (4, 3, 2, 1);
        c.changes[0].index = 5;
        c.changes[0].value = 2;
        let mut conv = ViewerConverter::default();
        let grids = |out: &[ViewerMessage]| -> Vec<(u64, Vec<u8>)> {
            out.iter()
                .filter(|m| m.topic == ViewerTopic::GlobalMap)
                .map(|m| {
                    let d = fg::Grid::decode(m.data.as_slice()).unwrap();
                    (m.stamp_ns, d.data.to_vec())
                })
                .collect()
        };
        let mut out = Vec::new();
        conv.convert(s::GLOBAL_MAP, &buf(&*g), &mut out);
        assert_eq!(grids(&out), [(0, vec![0; 6])]);
        // Changes at 0.1 s and 0.5 s wait for the second to pass; the next message
        // after it brings the map with both.
        for (stamp, version, len) in [(100, 5, 1), (500, 6, 2)] {
            c.header.stamp_ns = stamp * 1_000_000;
            (c.version, c.len) = (version, len);
            c.changes[1].index = 1;
            c.changes[1].value = 2;
            out.clear();
            conv.convert(s::GLOBAL_MAP_CHANGES, &buf(&*c), &mut out);
            assert!(grids(&out).is_empty());
        }
        let mut later = zeroed_box::<RobotState>();
        later.header.stamp_ns = 1_000_000_000;
        out.clear();
        conv.convert(s::ROBOT_STATE, &buf(&*later), &mut out);
        assert_eq!(grids(&out), [(1_000_000_000, vec![0, 99, 0, 0, 0, 99])]);
        // Nothing pending: nothing sent; a last change goes out with `finish`.
        out.clear();
        later.header.stamp_ns = 2_500_000_000;
        conv.convert(s::ROBOT_STATE, &buf(&*later), &mut out);
        assert!(grids(&out).is_empty());
        c.version = 7;
        c.changes[1].value = 0;
        conv.convert(s::GLOBAL_MAP_CHANGES, &buf(&*c), &mut out);
        conv.finish(&mut out);
        assert_eq!(grids(&out), [(2_500_000_000, vec![0, 0, 0, 0, 0, 99])]);
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
        let scene = aisle_config::scene::Scene::parse(
            std::path::Path::new("warehouse.toml"),
            "[[body]]\nname = \"wall\"\nkind = \"wall\"\nstatic = true\n\
             pose = [0.0, 0.0, 0.0]\nsize = [1.0, 2.0, 3.0]\n",
        )
        .unwrap();
        // Ground truth lists the bodies that can move; the wall comes from the scene.
        let mut w = zeroed_box::<WorldTruth>();
        w.len = 1;
        w.bodies[0].pose.x = 2.0;
        w.bodies[0].size = [0.88, 0.8, 1.0];
        let mut conv = ViewerConverter::default().with_static_bodies(&scene);
        let mut out = Vec::new();
        conv.convert(s::WORLD_TRUTH, &buf(&*w), &mut out);
        conv.convert(s::WORLD_TRUTH, &buf(&*w), &mut out);
        assert_eq!(out.len(), 1);
        let su = fg::SceneUpdate::decode(out[0].data.as_slice()).unwrap();
        let ids: Vec<_> = su.entities.iter().map(|e| e.id.as_str()).collect();
        assert_eq!(ids, ["movable", "static"]);
        assert_eq!(su.entities[0].cubes.len(), 1);
        let wall = su.entities[1].cubes[0].size.unwrap();
        assert_eq!((wall.x, wall.y, wall.z), (1.0, 2.0, 3.0));
        // A move 0.1 s later: the movable bodies only; 5 s later the static ones again.
        w.bodies[0].pose.x = 2.5;
        w.header.stamp_ns = 100_000_000;
        conv.convert(s::WORLD_TRUTH, &buf(&*w), &mut out);
        assert_eq!(out.len(), 2);
        let su = fg::SceneUpdate::decode(out[1].data.as_slice()).unwrap();
        assert_eq!(su.entities.len(), 1);
        w.bodies[0].pose.x = 3.0;
        w.header.stamp_ns = 5_000_000_000;
        conv.convert(s::WORLD_TRUTH, &buf(&*w), &mut out);
        let su = fg::SceneUpdate::decode(out[2].data.as_slice()).unwrap();
        assert_eq!(su.entities.len(), 2);

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
    fn every_topic_has_a_schema_in_its_encoding() {
        for t in ViewerTopic::ALL {
            let s = t.schema().unwrap();
            assert!(!s.data.is_empty());
            match t.encoding() {
                "protobuf" => {
                    assert!(s.name.starts_with("foxglove."), "{}", s.name);
                    assert_eq!(s.encoding, "protobuf");
                }
                "json" => {
                    assert_eq!(s.encoding, "jsonschema");
                    let v: serde_json::Value = serde_json::from_slice(&s.data).unwrap();
                    assert_eq!(v["title"], s.name.as_str());
                }
                other => panic!("{}: encoding {other}", t.topic()),
            }
        }
    }

    /// Every field of `value` is declared in `schema`, recursively, with its type.
    fn check_fields(path: &str, value: &serde_json::Value, schema: &serde_json::Value) {
        use serde_json::Value as V;
        let ty = schema["type"]
            .as_str()
            .unwrap_or_else(|| panic!("{path}: no type"));
        match value {
            V::Object(fields) => {
                assert_eq!(ty, "object", "{path}");
                for (k, v) in fields {
                    let sub = &schema["properties"][k];
                    assert!(!sub.is_null(), "{path}.{k} is not in the schema");
                    check_fields(&format!("{path}.{k}"), v, sub);
                }
            }
            V::Number(n) if ty == "integer" => assert!(n.is_u64() || n.is_i64(), "{path}"),
            V::Number(_) => assert_eq!(ty, "number", "{path}"),
            V::Bool(_) => assert_eq!(ty, "boolean", "{path}"),
            other => panic!("{path}: unexpected {other}"),
        }
    }

    #[test]
    fn plot_payloads_hold_only_what_their_schema_declares() {
        use aisle_messages::{NodeKind, TickDone, Trajectory};
        let mut conv = ViewerConverter::default();
        let mut out = Vec::new();
        let mut r = zeroed_box::<RobotState>();
        r.header.tick = 3;
        r.header.stamp_ns = 300_000_000;
        r.pose.x = 1.5;
        r.twist = [0.4, -0.1];
        conv.convert(s::ROBOT_STATE, &buf(&*r), &mut out);
        let mut t = zeroed_box::<Trajectory>();
        t.header.tick = 3;
        t.header.tick_wall_ns = 1_000_000;
        t.header.publish_wall_ns = 3_500_000;
        t.len = 1;
        t.commands[0].v = 0.25;
        t.exit_flag = 2;
        t.iterations = 7;
        t.cost = 1.25;
        conv.convert(s::TRAJECTORY, &buf(&*t), &mut out);
        let mut d = zeroed_box::<TickDone>();
        d.node = NodeKind::Lidar.code();
        d.header.tick = 3;
        d.compute_ns = 2_000_000;
        conv.convert(s::TICK_DONE, &buf(&*d), &mut out);
        // Tick 3's latency goes out once tick 4 begins.
        d.header.tick = 4;
        conv.convert(s::TICK_DONE, &buf(&*d), &mut out);
        let mut seen = std::collections::BTreeMap::new();
        for m in out.iter().filter(|m| m.topic.encoding() == "json") {
            let v: serde_json::Value = serde_json::from_slice(&m.data).unwrap();
            let schema: serde_json::Value =
                serde_json::from_slice(&m.topic.schema().unwrap().data).unwrap();
            check_fields(m.topic.topic(), &v, &schema);
            assert!(seen.insert(m.topic, v).is_none(), "{:?} twice", m.topic);
        }
        assert_eq!(seen.len(), 4, "{seen:?}");
        let odom = &seen[&ViewerTopic::Odometry];
        assert_eq!(
            (odom["x"].as_f64(), odom["v"].as_f64()),
            (Some(1.5), Some(0.4))
        );
        assert_eq!(odom["header"]["stamp"]["nsec"], 300_000_000);
        assert_eq!(seen[&ViewerTopic::Command]["v"].as_f64(), Some(0.25));
        assert_eq!(seen[&ViewerTopic::Teb]["exit_flag"], 2);
        let lat = &seen[&ViewerTopic::Latency];
        assert_eq!(lat["header"]["tick"], 3);
        assert_eq!(lat["lidar_ms"].as_f64(), Some(2.0));
        assert_eq!(lat["end_to_end_ms"].as_f64(), Some(2.5));
        assert!(lat.get("mapper_ms").is_none(), "{lat}");
        conv.recycle(&mut out);
        assert!(out.is_empty());
        // At the end of the run the last tick goes out too.
        conv.finish(&mut out);
        assert_eq!(out.len(), 1);
        let last: serde_json::Value = serde_json::from_slice(&out[0].data).unwrap();
        assert_eq!(last["header"]["tick"], 4, "{last}");
    }

    #[test]
    fn the_robot_model_is_sent_once_in_base_link() {
        let urdf = aisle_config::testing::shipped("jackal.urdf");
        let model =
            aisle_robot::RobotModel::load(&urdf, &aisle_robot::RobotConfig::default()).unwrap();
        let mut conv = ViewerConverter::default().with_robot(&model);
        let mut out = Vec::new();
        let mut st = zeroed_box::<MissionStatus>();
        st.header.stamp_ns = 5;
        conv.convert(s::MISSION_STATUS, &buf(&*st), &mut out);
        conv.convert(s::MISSION_STATUS, &buf(&*st), &mut out);
        let robots: Vec<_> = out
            .iter()
            .filter(|m| m.topic == ViewerTopic::Robot)
            .collect();
        assert_eq!(robots.len(), 1);
        let su = fg::SceneUpdate::decode(robots[0].data.as_slice()).unwrap();
        let e = &su.entities[0];
        assert_eq!((e.frame_id.as_str(), e.frame_locked), ("base_link", true));
        assert_eq!((e.cubes.len(), e.cylinders.len()), (1, 4));
        // The viewer's base_link is on the floor: the chassis centre is 0.092 above the
        // URDF's base_link, which is base_height above the floor.
        let z = e.cubes[0].pose.as_ref().unwrap().position.unwrap().z;
        assert!((z - (0.092 + model.base_height())).abs() < 1e-12, "{z}");
        assert!(ViewerTopic::Robot.latched());
    }
}
