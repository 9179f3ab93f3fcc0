//! The conversion message by message, and the export of a synthetic record read back
//! with the `mcap` crate (the Python `rosbags` reader checks a real run:
//! tests/ros2_export.rs).

use super::*;
use crate::aligned::{AlignedBuf, message_bytes, zeroed_box};
use aisle_messages::topics::names as s;
use aisle_messages::{ControllerGoal, GlobalGrid, OccupancyGrid, PointCloud, RobotState};

fn buf<M: aisle_messages::Message>(m: &M) -> AlignedBuf {
    AlignedBuf::from_bytes(message_bytes(m))
}

fn convert(conv: &mut RosConverter, service: &str, b: &AlignedBuf) -> Vec<RosMessage> {
    let mut out = Vec::new();
    conv.convert(service, b, &mut out).unwrap();
    out
}

fn u32_at(d: &[u8], at: usize) -> u32 {
    u32::from_le_bytes(d[at..at + 4].try_into().unwrap())
}

#[test]
fn grid_cells_follow_the_ros_convention() {
    assert_eq!([0, 1, 2, 3, 255].map(ros_occupancy), [0, 100, 100, -1, -1]);
    let mut g = zeroed_box::<OccupancyGrid>();
    g.width = 3;
    g.height = 2;
    g.resolution = 0.25;
    g.cells[..6].copy_from_slice(&[0, 1, 2, 0, 7, 1]);
    let out = convert(&mut RosConverter::default(), s::LOCAL_MAP, &buf(&*g));
    assert_eq!(out.len(), 1);
    assert_eq!(out[0].topic, RosTopic::LocalMap);
    let d = &out[0].data;
    // The cells are the last 6 bytes, after their length.
    assert_eq!(u32_at(d, d.len() - 10), 6);
    assert_eq!(&d[d.len() - 6..], &[0, 100, 100, 0, 0xff, 100]);
    // An impossible size or resolution yields nothing and is counted.
    let mut conv = RosConverter::default();
    let mut g = zeroed_box::<GlobalGrid>();
    (g.width, g.height, g.resolution) = (5000, 5000, 0.25);
    assert!(convert(&mut conv, s::GLOBAL_MAP, &buf(&*g)).is_empty());
    g.width = 3;
    g.resolution = f64::NAN;
    assert!(convert(&mut conv, s::GLOBAL_MAP, &buf(&*g)).is_empty());
    assert_eq!(conv.skipped(), 2);
}

#[test]
fn the_map_is_the_full_map_with_its_newest_changes() {
    let mut g = zeroed_box::<GlobalGrid>();
    (g.width, g.height, g.resolution, g.version) = (3, 2, 0.25, 2);
    let mut conv = RosConverter::default();
    let cells = |out: &[RosMessage]| out[0].data[out[0].data.len() - 6..].to_vec();
    let out = convert(&mut conv, s::GLOBAL_MAP, &buf(&*g));
    assert_eq!((out[0].topic, cells(&out)), (RosTopic::Map, vec![0; 6]));
    let mut c = zeroed_box::<aisle_messages::MapChanges>();
    (c.base_version, c.version, c.width, c.height, c.len) = (2, 3, 3, 2, 1);
    c.changes[0].index = 4;
    c.changes[0].value = 2;
    let out = convert(&mut conv, s::GLOBAL_MAP_CHANGES, &buf(&*c));
    assert_eq!(cells(&out), [0, 0, 0, 0, 100, 0]);
    // Changes of another full map wait for it; a broken list is skipped and counted.
    c.base_version = 9;
    assert!(convert(&mut conv, s::GLOBAL_MAP_CHANGES, &buf(&*c)).is_empty());
    (c.base_version, c.version) = (2, 4);
    c.changes[0].index = 6;
    assert!(convert(&mut conv, s::GLOBAL_MAP_CHANGES, &buf(&*c)).is_empty());
    assert_eq!(conv.skipped(), 1);
}

#[test]
fn cloud_stays_organised_and_the_mount_goes_out_once() {
    let mut c = zeroed_box::<PointCloud>();
    c.rows = 1;
    c.cols = 3;
    c.points[0] = [1.0, 2.0, 3.0];
    c.points[1] = [f32::NAN; 3];
    c.points[2] = [4.0, 5.0, 6.0];
    c.sensor_pose.position = [0.3, 0.0, 0.2];
    let mut conv = RosConverter::default();
    let out = convert(&mut conv, s::POINT_CLOUD, &buf(&*c));
    let topics: Vec<_> = out.iter().map(|m| m.topic).collect();
    assert_eq!(topics, [RosTopic::TfStatic, RosTopic::Points]);
    let d = &out[1].data;
    // 36 bytes of points, then is_dense = false (a NaN).
    assert_eq!(u32_at(d, d.len() - 41), 36);
    assert_eq!(&d[d.len() - 37..d.len() - 33], &1.0f32.to_le_bytes());
    assert_eq!(d[d.len() - 1], 0);
    // The same mount is not sent again, even from another robot pose (rounding moves
    // it in the last bits); a moved one is.
    c.header.stamp_ns = 100_000_000;
    c.robot_pose.x = 12.345;
    c.robot_pose.theta = 0.7;
    let (sn, cs) = 0.7f64.sin_cos();
    c.sensor_pose.position = [12.345 + 0.3 * cs, 0.3 * sn, 0.2];
    c.sensor_pose.rpy[2] = 0.7;
    let again = convert(&mut conv, s::POINT_CLOUD, &buf(&*c));
    assert_eq!(again.len(), 1);
    c.sensor_pose.position[2] = 0.4;
    assert_eq!(convert(&mut conv, s::POINT_CLOUD, &buf(&*c)).len(), 2);
}

#[test]
fn robot_state_gives_odometry_transforms_and_a_growing_path() {
    let mut conv = RosConverter::default();
    let mut r = zeroed_box::<RobotState>();
    let mut paths = Vec::new();
    for i in 0..(2 * DRIVEN_EVERY) {
        // Stands still for the first three states.
        r.pose.x = (i.saturating_sub(2)) as f64 * 0.1;
        r.header.stamp_ns = i * 100_000_000;
        let out = convert(&mut conv, s::ROBOT_STATE, &buf(&*r));
        assert_eq!(out[0].topic, RosTopic::Odom);
        assert_eq!(out[1].topic, RosTopic::Tf);
        paths.extend(out.into_iter().filter(|m| m.topic == RosTopic::DrivenPath));
    }
    assert_eq!(paths.len(), 2);
    // Path: header (4 + 8 stamp + 4 + "map\0") then the pose count.
    assert_eq!(u32_at(&paths[0].data, 4 + 16), DRIVEN_EVERY as u32 - 2);
    assert_eq!(u32_at(&paths[1].data, 4 + 16), 2 * DRIVEN_EVERY as u32 - 2);
    r.pose.theta = f64::INFINITY;
    assert!(convert(&mut conv, s::ROBOT_STATE, &buf(&*r)).is_empty());
    assert_eq!(conv.skipped(), 1);
}

#[test]
fn reference_path_once_per_goal() {
    let mut conv = RosConverter::default();
    let mut g = zeroed_box::<ControllerGoal>();
    g.goal_id = 1;
    g.len = 2;
    assert_eq!(convert(&mut conv, s::CONTROLLER_GOAL, &buf(&*g)).len(), 1);
    assert!(convert(&mut conv, s::CONTROLLER_GOAL, &buf(&*g)).is_empty());
    g.goal_id = 2;
    assert_eq!(convert(&mut conv, s::CONTROLLER_GOAL, &buf(&*g)).len(), 1);
    assert_eq!(conv.skipped(), 0);
}

fn temp(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("aisle-ros2-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

#[test]
fn a_synthetic_record_becomes_a_ros2_bag() {
    let dir = temp("bag");
    let (rec, bag) = (dir.join("run.mcap"), dir.join("run.ros2.mcap"));
    let f = std::fs::File::create(&rec).unwrap();
    crate::synthetic::write_synthetic(f, 40, crate::WriterOptions::default()).unwrap();
    let summary = export_ros2(&rec, &bag).unwrap();
    assert_eq!(summary.skipped, 0);
    assert_eq!(summary.damaged, None);
    for t in RosTopic::ALL {
        assert!(summary.written[t.name()] > 0, "{}: {summary:?}", t.name());
    }
    assert_eq!(summary.written["/odom"], 40);
    let bytes = std::fs::read(&bag).unwrap();
    let s = mcap::Summary::read(&bytes).unwrap().unwrap();
    for schema in s.schemas.values() {
        assert_eq!(schema.encoding, "ros2msg");
        assert!(schema.name.contains("/msg/"), "{}", schema.name);
    }
    for c in s.channels.values() {
        assert_eq!(c.message_encoding, "cdr");
        assert!(c.metadata.contains_key("offered_qos_profiles"));
    }
    let total: u64 = summary.written.values().sum();
    let mut n = 0;
    for m in mcap::MessageStream::new(&bytes).unwrap() {
        let m = m.unwrap();
        assert_eq!(&m.data[..4], &msgs::CDR_LE);
        n += 1;
    }
    assert_eq!(n, total);
    // The profile is in the header, right after the magic and the opcode + length.
    assert_eq!(&bytes[8 + 9..8 + 9 + 4], &4u32.to_le_bytes());
    assert_eq!(&bytes[8 + 13..8 + 17], b"ros2");

    // A bag is not a record; the record is never its own output; no partial is left.
    let again = dir.join("again.mcap");
    let e = export_ros2(&bag, &again).unwrap_err();
    assert!(matches!(e, ExportError::NotARecord { .. }), "{e}");
    let e = export_ros2(&rec, &rec).unwrap_err();
    assert!(matches!(e, ExportError::SameFile { .. }), "{e}");
    let e = export_ros2(&rec, &dir.join("missing/out.mcap")).unwrap_err();
    assert!(e.to_string().contains("missing/out.mcap"), "{e}");
    let e = export_ros2(&rec, &dir).unwrap_err();
    assert!(e.to_string().contains("is a directory"), "{e}");
    let e = export_ros2(&dir.join("nope.mcap"), &again).unwrap_err();
    assert!(e.to_string().contains("nope.mcap"), "{e}");
    let left: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .flatten()
        .map(|e| e.file_name())
        .collect();
    assert_eq!(left.len(), 2, "{left:?}");
    std::fs::remove_dir_all(&dir).unwrap();
}
