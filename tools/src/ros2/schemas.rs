//! The `.msg` definitions of the exported types, and each type's full definition as
//! rosbag2 stores it in an MCAP schema record (encoding `ros2msg`): the type's own text,
//! then every type it uses, each after a line of 80 `=` and a `MSG: package/Type` line.
//!
//! The texts give the fields (and `PointField`'s constants) without the comments of the
//! upstream files: readers need the fields, in order, and nothing else. Knows nothing of
//! aisle.

/// One ROS 2 message type: its name (`pkg/Type`, as a `MSG:` line names it), its fields,
/// and the types those fields use (directly).
struct MsgType {
    name: &'static str,
    text: &'static str,
    uses: &'static [&'static str],
}

const TYPES: &[MsgType] = &[
    MsgType {
        name: "builtin_interfaces/Time",
        text: "int32 sec\nuint32 nanosec\n",
        uses: &[],
    },
    MsgType {
        name: "std_msgs/Header",
        text: "builtin_interfaces/Time stamp\nstring frame_id\n",
        uses: &["builtin_interfaces/Time"],
    },
    MsgType {
        name: "geometry_msgs/Point",
        text: "float64 x\nfloat64 y\nfloat64 z\n",
        uses: &[],
    },
    MsgType {
        name: "geometry_msgs/Vector3",
        text: "float64 x\nfloat64 y\nfloat64 z\n",
        uses: &[],
    },
    MsgType {
        name: "geometry_msgs/Quaternion",
        text: "float64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1\n",
        uses: &[],
    },
    MsgType {
        name: "geometry_msgs/Pose",
        text: "geometry_msgs/Point position\ngeometry_msgs/Quaternion orientation\n",
        uses: &["geometry_msgs/Point", "geometry_msgs/Quaternion"],
    },
    MsgType {
        name: "geometry_msgs/PoseStamped",
        text: "std_msgs/Header header\ngeometry_msgs/Pose pose\n",
        uses: &["std_msgs/Header", "geometry_msgs/Pose"],
    },
    MsgType {
        name: "geometry_msgs/PoseWithCovariance",
        text: "geometry_msgs/Pose pose\nfloat64[36] covariance\n",
        uses: &["geometry_msgs/Pose"],
    },
    MsgType {
        name: "geometry_msgs/Twist",
        text: "geometry_msgs/Vector3 linear\ngeometry_msgs/Vector3 angular\n",
        uses: &["geometry_msgs/Vector3"],
    },
    MsgType {
        name: "geometry_msgs/TwistWithCovariance",
        text: "geometry_msgs/Twist twist\nfloat64[36] covariance\n",
        uses: &["geometry_msgs/Twist"],
    },
    MsgType {
        name: "geometry_msgs/Transform",
        text: "geometry_msgs/Vector3 translation\ngeometry_msgs/Quaternion rotation\n",
        uses: &["geometry_msgs/Vector3", "geometry_msgs/Quaternion"],
    },
    MsgType {
        name: "geometry_msgs/TransformStamped",
        text: "std_msgs/Header header\nstring child_frame_id\ngeometry_msgs/Transform transform\n",
        uses: &["std_msgs/Header", "geometry_msgs/Transform"],
    },
    MsgType {
        name: "tf2_msgs/TFMessage",
        text: "geometry_msgs/TransformStamped[] transforms\n",
        uses: &["geometry_msgs/TransformStamped"],
    },
    MsgType {
        name: "nav_msgs/Odometry",
        text: "std_msgs/Header header\nstring child_frame_id\n\
               geometry_msgs/PoseWithCovariance pose\ngeometry_msgs/TwistWithCovariance twist\n",
        uses: &[
            "std_msgs/Header",
            "geometry_msgs/PoseWithCovariance",
            "geometry_msgs/TwistWithCovariance",
        ],
    },
    MsgType {
        name: "nav_msgs/Path",
        text: "std_msgs/Header header\ngeometry_msgs/PoseStamped[] poses\n",
        uses: &["std_msgs/Header", "geometry_msgs/PoseStamped"],
    },
    MsgType {
        name: "nav_msgs/MapMetaData",
        text: "builtin_interfaces/Time map_load_time\nfloat32 resolution\nuint32 width\n\
               uint32 height\ngeometry_msgs/Pose origin\n",
        uses: &["builtin_interfaces/Time", "geometry_msgs/Pose"],
    },
    MsgType {
        name: "nav_msgs/OccupancyGrid",
        text: "std_msgs/Header header\nnav_msgs/MapMetaData info\nint8[] data\n",
        uses: &["std_msgs/Header", "nav_msgs/MapMetaData"],
    },
    MsgType {
        name: "sensor_msgs/PointField",
        text: "uint8 INT8=1\nuint8 UINT8=2\nuint8 INT16=3\nuint8 UINT16=4\nuint8 INT32=5\n\
               uint8 UINT32=6\nuint8 FLOAT32=7\nuint8 FLOAT64=8\n\
               string name\nuint32 offset\nuint8 datatype\nuint32 count\n",
        uses: &[],
    },
    MsgType {
        name: "sensor_msgs/PointCloud2",
        text: "std_msgs/Header header\nuint32 height\nuint32 width\n\
               sensor_msgs/PointField[] fields\nbool is_bigendian\nuint32 point_step\n\
               uint32 row_step\nuint8[] data\nbool is_dense\n",
        uses: &["std_msgs/Header", "sensor_msgs/PointField"],
    },
];

/// The line between two definitions, as rosbag2 writes it.
const SEPARATOR: &str =
    "================================================================================\n";

/// `pkg/msg/Type` (a schema's name) as `pkg/Type` (a `MSG:` line's).
fn short(full: &str) -> Option<String> {
    let (pkg, rest) = full.split_once("/msg/")?;
    Some(format!("{pkg}/{rest}"))
}

fn find(name: &str) -> Option<&'static MsgType> {
    TYPES.iter().find(|t| t.name == name)
}

/// The full definition of `pkg/msg/Type` (the schema record's data), or `None` for a
/// type this module does not know. Every used type appears once, depth first in the
/// order of use.
pub fn definition(full_name: &str) -> Option<String> {
    let root = find(&short(full_name)?)?;
    let mut order: Vec<&MsgType> = Vec::new();
    let mut stack: Vec<&str> = root.uses.iter().rev().copied().collect();
    while let Some(name) = stack.pop() {
        let t = find(name)?;
        if order.iter().any(|o| o.name == t.name) {
            continue;
        }
        order.push(t);
        stack.extend(t.uses.iter().rev().copied());
    }
    let mut text = root.text.to_string();
    for t in order {
        text.push('\n');
        text.push_str(SEPARATOR);
        text.push_str(&format!("MSG: {}\n", t.name));
        text.push_str(t.text);
    }
    Some(text)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_used_type_is_defined_once() {
        for t in TYPES {
            for u in t.uses {
                assert!(find(u).is_some(), "{} uses undefined {u}", t.name);
            }
        }
        let odom = definition("nav_msgs/msg/Odometry").unwrap();
        assert!(odom.starts_with("std_msgs/Header header\n"));
        for dep in [
            "std_msgs/Header",
            "builtin_interfaces/Time",
            "geometry_msgs/Pose",
        ] {
            assert_eq!(odom.matches(&format!("MSG: {dep}\n")).count(), 1, "{dep}");
        }
        assert!(odom.contains(&format!("\n{SEPARATOR}MSG: geometry_msgs/Vector3\n")));
        assert_eq!(definition("nav_msgs/msg/Unknown"), None);
        assert_eq!(definition("Odometry"), None);
    }
}
