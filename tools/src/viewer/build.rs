//! Foxglove messages made from plain values (grids, paths, logs, poses, transforms) and
//! encoded into viewer messages.
//!
//! Knows the Foxglove protobuf messages and the `map` frame; keeps no state and does not
//! decide what is worth emitting (the converter does).

use super::{ViewerMessage, ViewerTopic};
use aisle_geometry::GridView;
use aisle_messages::{GridMessage, OccupancyGrid};
use foxglove::Encode;
use foxglove::messages as fg;

/// A path of planar poses (x, y, yaw) in the map frame.
pub(super) fn path(
    topic: ViewerTopic,
    stamp_ns: u64,
    poses: impl Iterator<Item = (f64, f64, f64)>,
) -> ViewerMessage {
    let msg = fg::PosesInFrame {
        timestamp: Some(timestamp(stamp_ns)),
        frame_id: "map".into(),
        poses: poses
            .map(|(x, y, yaw)| pose3(x, y, 0.0, 0.0, 0.0, yaw))
            .collect(),
    };
    encode(topic, stamp_ns, &msg)
}

/// `m` as a Foxglove grid; `None` when it is not a valid grid ([`GridMessage::view`]).
pub(super) fn grid(m: &OccupancyGrid) -> Option<fg::Grid> {
    grid_of_view(m.header.stamp_ns, &m.view().ok()?)
}

/// The grid `g` (a map held outside a message) stamped `stamp_ns`; `None` for an empty
/// or impossible grid.
pub(super) fn grid_of_view(stamp_ns: u64, g: &GridView<'_>) -> Option<fg::Grid> {
    let (w, h) = (g.width, g.height);
    if w == 0
        || h == 0
        || w.checked_mul(h)? != g.cells.len()
        || g.resolution.is_nan()
        || g.resolution <= 0.0
    {
        return None;
    }
    Some(fg::Grid {
        timestamp: Some(timestamp(stamp_ns)),
        frame_id: "map".into(),
        pose: Some(pose3(g.origin_x, g.origin_y, 0.0, 0.0, 0.0, 0.0)),
        column_count: w as u32,
        cell_size: Some(fg::Vector2 {
            x: g.resolution,
            y: g.resolution,
        }),
        row_stride: w as u32,
        cell_stride: 1,
        fields: vec![fg::PackedElementField {
            name: "occupancy".into(),
            offset: 0,
            r#type: fg::packed_element_field::NumericType::Int8 as i32,
        }],
        data: g.cells[..w * h]
            .iter()
            .map(|&c| ros_occupancy(c) as u8)
            .collect::<Vec<u8>>()
            .into(),
    })
}

/// A cell of an aisle grid in the ROS `nav_msgs/OccupancyGrid` convention, which
/// Foxglove's grid colour modes and ROS users read: free 0, a static obstacle 100
/// (lethal), an obstacle the lidar detected 99 (so the two stay apart), any other
/// value -1 (unknown).
pub(super) fn ros_occupancy(cell: u8) -> i8 {
    use aisle_geometry::{FREE, OCCUPIED_DETECTED, OCCUPIED_STATIC};
    match cell {
        FREE => 0,
        OCCUPIED_STATIC => 100,
        OCCUPIED_DETECTED => 99,
        _ => -1,
    }
}

pub(super) fn log(
    stamp_ns: u64,
    level: fg::log::Level,
    name: &str,
    message: String,
) -> ViewerMessage {
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

pub(super) fn encode<T: Encode>(topic: ViewerTopic, stamp_ns: u64, msg: &T) -> ViewerMessage {
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

pub(super) fn rgba(r: f64, g: f64, b: f64, a: f64) -> fg::Color {
    fg::Color { r, g, b, a }
}

/// A pose from a position and roll, pitch, yaw (yaw applied first, then pitch, then roll).
pub(super) fn pose3(x: f64, y: f64, z: f64, roll: f64, pitch: f64, yaw: f64) -> fg::Pose {
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

pub(super) fn transform(
    t: fg::Timestamp,
    parent: &str,
    child: &str,
    p: fg::Pose,
) -> fg::FrameTransform {
    fg::FrameTransform {
        timestamp: Some(t),
        parent_frame_id: parent.into(),
        child_frame_id: child.into(),
        translation: p.position,
        rotation: p.orientation,
    }
}
