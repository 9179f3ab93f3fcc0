//! A recorded run as a ROS 2 bag: `aisle export --ros2 RUN.mcap OUT.mcap` writes an MCAP
//! file with the `ros2` profile (schemas encoded `ros2msg` with the full concatenated
//! `.msg` definitions, as rosbag2 writes them; messages encoded `cdr`, little endian
//! with the 4-byte encapsulation header), which `ros2 bag play`, `rosbags` and Foxglove
//! open as they open a bag recorded on a robot. No `metadata.yaml` is written: readers
//! open the `.mcap` file itself.
//!
//! | topic | type | from | when |
//! |---|---|---|---|
//! | `/aisle/points` | `sensor_msgs/msg/PointCloud2` | `aisle/lidar/points` | every scan; organised (`height` rows x `width` columns), x y z float32 in frame `sensor`, NaN for no return (`is_dense` false then) |
//! | `/map` | `nav_msgs/msg/OccupancyGrid` | `aisle/map/global`, `aisle/map/global_changes` | every version of the global map: each full map, and each change applied to it (QoS transient local) |
//! | `/aisle/local_map` | `nav_msgs/msg/OccupancyGrid` | `aisle/map/local` | every local map (frame `map`) |
//! | `/plan` | `nav_msgs/msg/Path` | `aisle/controller/goal` | once per goal: the reference path the controller follows |
//! | `/aisle/band` | `nav_msgs/msg/Path` | `aisle/controller/band` | every controller step: the TEB band, each pose stamped with its time along the band |
//! | `/aisle/driven_path` | `nav_msgs/msg/Path` | `aisle/robot_state` | every 10th robot state: the poses driven so far |
//! | `/odom` | `nav_msgs/msg/Odometry` | `aisle/robot_state` | every tick: pose (frame `odom`) and twist (frame `base_link`); ground truth, so covariances are 0 |
//! | `/cmd_vel` | `geometry_msgs/msg/Twist` | `aisle/controller/trajectory` | every controller step: the trajectory's first command (0 for an empty one) |
//! | `/tf` | `tf2_msgs/msg/TFMessage` | `aisle/robot_state` | every tick: `map` -> `odom` (identity: the simulator's pose is exact) -> `base_link` |
//! | `/tf_static` | `tf2_msgs/msg/TFMessage` | `aisle/lidar/points` | the sensor mount `base_link` -> `sensor`, at the first scan and whenever it changes (QoS transient local) |
//!
//! Grids: aisle's cells hold 0 free, 1 static, 2 detected; the ROS grids hold 0 free,
//! 100 occupied (static or detected) and -1 unknown (any other value).
//! Times: every message's `header.stamp` is the simulated time of its source message;
//! the bag's log time is the record's (simulated time in lockstep, Unix time in
//! realtime). Frames are those of the Foxglove channels (`map`, `base_link`, `sensor`)
//! plus `odom`.
//!
//! Modules: `msgs` (the ROS types and their CDR encoding, by `cdr-encoding`), `schemas`
//! (their `.msg` definitions), `convert` (aisle messages in, ROS messages out), `export`
//! (file in, file out, errors).

mod convert;
mod export;
mod msgs;
mod schemas;

pub use convert::{DRIVEN_EVERY, MAX_DRIVEN, RosConverter, RosMessage, ros_occupancy};
pub use export::{ExportError, ExportSummary, export_ros2};

/// The frames of the exported transforms and messages.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Frame {
    Map,
    Odom,
    BaseLink,
    Sensor,
}

impl Frame {
    pub fn name(self) -> &'static str {
        match self {
            Frame::Map => "map",
            Frame::Odom => "odom",
            Frame::BaseLink => "base_link",
            Frame::Sensor => "sensor",
        }
    }
}

/// The topics of the exported bag.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum RosTopic {
    Points,
    Map,
    LocalMap,
    Plan,
    Band,
    DrivenPath,
    Odom,
    CmdVel,
    Tf,
    TfStatic,
}

impl RosTopic {
    pub const ALL: [RosTopic; 10] = [
        RosTopic::Points,
        RosTopic::Map,
        RosTopic::LocalMap,
        RosTopic::Plan,
        RosTopic::Band,
        RosTopic::DrivenPath,
        RosTopic::Odom,
        RosTopic::CmdVel,
        RosTopic::Tf,
        RosTopic::TfStatic,
    ];

    pub fn name(self) -> &'static str {
        match self {
            RosTopic::Points => "/aisle/points",
            RosTopic::Map => "/map",
            RosTopic::LocalMap => "/aisle/local_map",
            RosTopic::Plan => "/plan",
            RosTopic::Band => "/aisle/band",
            RosTopic::DrivenPath => "/aisle/driven_path",
            RosTopic::Odom => "/odom",
            RosTopic::CmdVel => "/cmd_vel",
            RosTopic::Tf => "/tf",
            RosTopic::TfStatic => "/tf_static",
        }
    }

    /// The ROS 2 type (`pkg/msg/Type`, the schema's name).
    pub fn type_name(self) -> &'static str {
        match self {
            RosTopic::Points => "sensor_msgs/msg/PointCloud2",
            RosTopic::Map | RosTopic::LocalMap => "nav_msgs/msg/OccupancyGrid",
            RosTopic::Plan | RosTopic::Band | RosTopic::DrivenPath => "nav_msgs/msg/Path",
            RosTopic::Odom => "nav_msgs/msg/Odometry",
            RosTopic::CmdVel => "geometry_msgs/msg/Twist",
            RosTopic::Tf | RosTopic::TfStatic => "tf2_msgs/msg/TFMessage",
        }
    }

    /// True for a topic a late subscriber must still get (QoS durability
    /// transient local, as ROS's `/tf_static` and map servers offer).
    pub fn latched(self) -> bool {
        matches!(self, RosTopic::TfStatic | RosTopic::Map)
    }

    pub fn index(self) -> usize {
        self as usize
    }
}

#[cfg(test)]
mod tests;
