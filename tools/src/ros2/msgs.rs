//! The ROS 2 messages the export writes, as plain serde structs whose field order is the
//! `.msg` field order (CDR is positional), and their encoding: the 4-byte encapsulation
//! header (`CDR_LE`) followed by the body serialised by `cdr-encoding`.
//!
//! Knows the ROS 2 wire layouts only; nothing of aisle's messages (see `convert`) or of
//! the `.msg` texts (see `schemas`).

use serde::{Serialize, Serializer};
use serde_big_array::BigArray;

/// `builtin_interfaces/msg/Time`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
pub struct Time {
    pub sec: i32,
    pub nanosec: u32,
}

impl Time {
    /// Nanoseconds (simulated time since the run started) as a ROS time; saturates at
    /// `i32::MAX` seconds (68 years of simulation).
    pub fn from_ns(ns: u64) -> Time {
        Time {
            sec: i32::try_from(ns / 1_000_000_000).unwrap_or(i32::MAX),
            nanosec: (ns % 1_000_000_000) as u32,
        }
    }
}

/// `std_msgs/msg/Header`.
#[derive(Debug, Clone, PartialEq, Default, Serialize)]
pub struct Header {
    pub stamp: Time,
    pub frame_id: String,
}

/// `geometry_msgs/msg/Point` and `geometry_msgs/msg/Vector3` (the same layout).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
pub struct Vector3 {
    pub x: f64,
    pub y: f64,
    pub z: f64,
}

/// `geometry_msgs/msg/Quaternion`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Quaternion {
    pub x: f64,
    pub y: f64,
    pub z: f64,
    pub w: f64,
}

impl Default for Quaternion {
    fn default() -> Self {
        Quaternion::from_rpy(0.0, 0.0, 0.0)
    }
}

impl Quaternion {
    /// From roll, pitch, yaw (yaw applied first, then pitch, then roll: aisle's
    /// `Pose3Msg` convention, which is also ROS's fixed-axis RPY).
    pub fn from_rpy(roll: f64, pitch: f64, yaw: f64) -> Quaternion {
        let (sr, cr) = (roll / 2.0).sin_cos();
        let (sp, cp) = (pitch / 2.0).sin_cos();
        let (sy, cy) = (yaw / 2.0).sin_cos();
        Quaternion {
            x: sr * cp * cy - cr * sp * sy,
            y: cr * sp * cy + sr * cp * sy,
            z: cr * cp * sy - sr * sp * cy,
            w: cr * cp * cy + sr * sp * sy,
        }
    }
}

/// `geometry_msgs/msg/Pose`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
pub struct Pose {
    pub position: Vector3,
    pub orientation: Quaternion,
}

impl Pose {
    /// A planar pose (x, y, heading) at height 0.
    pub fn planar(x: f64, y: f64, yaw: f64) -> Pose {
        Pose {
            position: Vector3 { x, y, z: 0.0 },
            orientation: Quaternion::from_rpy(0.0, 0.0, yaw),
        }
    }
}

/// `geometry_msgs/msg/PoseStamped`.
#[derive(Debug, Clone, PartialEq, Default, Serialize)]
pub struct PoseStamped {
    pub header: Header,
    pub pose: Pose,
}

/// `geometry_msgs/msg/Twist`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
pub struct Twist {
    pub linear: Vector3,
    pub angular: Vector3,
}

impl Twist {
    /// A planar twist: forward speed `v` (m/s) and yaw rate `w` (rad/s).
    pub fn planar(v: f64, w: f64) -> Twist {
        Twist {
            linear: Vector3 {
                x: v,
                y: 0.0,
                z: 0.0,
            },
            angular: Vector3 {
                x: 0.0,
                y: 0.0,
                z: w,
            },
        }
    }
}

/// `geometry_msgs/msg/PoseWithCovariance`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PoseWithCovariance {
    pub pose: Pose,
    #[serde(with = "BigArray")]
    pub covariance: [f64; 36],
}

/// `geometry_msgs/msg/TwistWithCovariance`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TwistWithCovariance {
    pub twist: Twist,
    #[serde(with = "BigArray")]
    pub covariance: [f64; 36],
}

/// `geometry_msgs/msg/Transform`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
pub struct Transform {
    pub translation: Vector3,
    pub rotation: Quaternion,
}

/// `geometry_msgs/msg/TransformStamped`.
#[derive(Debug, Clone, PartialEq, Default, Serialize)]
pub struct TransformStamped {
    pub header: Header,
    pub child_frame_id: String,
    pub transform: Transform,
}

/// `tf2_msgs/msg/TFMessage`.
#[derive(Debug, Clone, PartialEq, Default, Serialize)]
pub struct TfMessage {
    pub transforms: Vec<TransformStamped>,
}

/// `nav_msgs/msg/Odometry`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Odometry {
    pub header: Header,
    pub child_frame_id: String,
    pub pose: PoseWithCovariance,
    pub twist: TwistWithCovariance,
}

/// `nav_msgs/msg/Path`.
#[derive(Debug, Clone, PartialEq, Default, Serialize)]
pub struct Path {
    pub header: Header,
    pub poses: Vec<PoseStamped>,
}

/// `nav_msgs/msg/MapMetaData`.
#[derive(Debug, Clone, PartialEq, Default, Serialize)]
pub struct MapMetaData {
    pub map_load_time: Time,
    pub resolution: f32,
    pub width: u32,
    pub height: u32,
    pub origin: Pose,
}

/// `nav_msgs/msg/OccupancyGrid`; `data` holds the `int8` cells as their bytes.
#[derive(Debug, Clone, PartialEq, Default, Serialize)]
pub struct OccupancyGrid {
    pub header: Header,
    pub info: MapMetaData,
    pub data: Bytes,
}

/// `sensor_msgs/msg/PointField`.
#[derive(Debug, Clone, PartialEq, Default, Serialize)]
pub struct PointField {
    pub name: String,
    pub offset: u32,
    pub datatype: u8,
    pub count: u32,
}

/// `PointField.FLOAT32`.
pub const FLOAT32: u8 = 7;

/// `sensor_msgs/msg/PointCloud2`.
#[derive(Debug, Clone, PartialEq, Default, Serialize)]
pub struct PointCloud2 {
    pub header: Header,
    pub height: u32,
    pub width: u32,
    pub fields: Vec<PointField>,
    pub is_bigendian: bool,
    pub point_step: u32,
    pub row_step: u32,
    pub data: Bytes,
    pub is_dense: bool,
}

/// A `uint8[]` / `int8[]` sequence serialised in one piece (length, then the bytes),
/// not byte by byte as serde does for a `Vec<u8>`.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Bytes(pub Vec<u8>);

impl Serialize for Bytes {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_bytes(&self.0)
    }
}

/// The CDR encapsulation header of plain little-endian CDR (`CDR_LE`), which ROS 2
/// writes before every serialised message.
pub const CDR_LE: [u8; 4] = [0x00, 0x01, 0x00, 0x00];

/// `msg` as a ROS 2 serialised message: the encapsulation header, then the little-endian
/// CDR body (aligned from the end of the header, as ROS 2 does).
pub fn encode<T: Serialize>(msg: &T) -> Result<Vec<u8>, cdr_encoding::Error> {
    let mut out = Vec::with_capacity(256);
    out.extend_from_slice(&CDR_LE);
    cdr_encoding::to_writer::<T, byteorder::LittleEndian, _>(&mut out, msg)?;
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn time_and_string_follow_ros2_cdr() {
        let h = Header {
            stamp: Time::from_ns(1_500_000_000),
            frame_id: "map".into(),
        };
        let bytes = encode(&h).unwrap();
        // header | sec 1 | nanosec 5e8 | len 4 | "map\0"
        let mut want = CDR_LE.to_vec();
        want.extend_from_slice(&1i32.to_le_bytes());
        want.extend_from_slice(&500_000_000u32.to_le_bytes());
        want.extend_from_slice(&4u32.to_le_bytes());
        want.extend_from_slice(b"map\0");
        assert_eq!(bytes, want);
    }

    #[test]
    fn doubles_are_aligned_to_eight_from_the_body_start() {
        // A string of 2 bytes ("a\0") after its length ends at body offset 6; the
        // following f64 starts at 8.
        #[derive(Serialize)]
        struct S {
            s: String,
            x: f64,
        }
        let bytes = encode(&S {
            s: "a".into(),
            x: 1.0,
        })
        .unwrap();
        assert_eq!(bytes.len(), 4 + 8 + 8);
        assert_eq!(&bytes[12..], &1.0f64.to_le_bytes());
    }

    #[test]
    fn byte_sequences_are_length_prefixed_and_fixed_arrays_are_not() {
        let bytes = encode(&Bytes(vec![1, 2, 3])).unwrap();
        assert_eq!(&bytes[4..], &[3, 0, 0, 0, 1, 2, 3]);
        let twist = TwistWithCovariance {
            twist: Twist::planar(1.0, 2.0),
            covariance: [0.5; 36],
        };
        assert_eq!(encode(&twist).unwrap().len(), 4 + 6 * 8 + 36 * 8);
    }

    #[test]
    fn quaternion_of_a_yaw() {
        let q = Quaternion::from_rpy(0.0, 0.0, std::f64::consts::PI);
        assert!(q.w.abs() < 1e-12 && (q.z - 1.0).abs() < 1e-12);
    }
}
