//! The stateful conversion from recorded aisle messages to ROS 2 messages: one raw
//! payload in, the encoded ROS messages it yields out. Keeps what it needs to emit a
//! reference path once per goal, to grow the driven path and to publish the sensor mount
//! only when it changes.
//!
//! Knows aisle's message layouts and the export's choices (frames, topics, the grid value
//! convention, how often the driven path goes out); the ROS types are in `msgs`, the file
//! in `export`.

use super::msgs::{self as ros, Bytes, Header, Pose, Quaternion, Time, Twist, Vector3};
use super::{Frame, RosTopic};
use crate::aligned::AlignedBuf;
use aisle_messages::topics::names as s;
use aisle_messages::{
    ControllerBand, ControllerGoal, GlobalGrid, GlobalMapCopy, GridMessage, MAX_CLOUD_POINTS,
    MAX_COMMANDS, MAX_PATH_POSES, MapChanges, OccupancyGrid, PointCloud, RobotState, Trajectory,
};

/// One encoded ROS 2 message.
#[derive(Debug, Clone, PartialEq)]
pub struct RosMessage {
    pub topic: RosTopic,
    /// Simulated time of the source message (its `header.stamp`).
    pub stamp_ns: u64,
    pub data: Vec<u8>,
}

/// The driven path goes out with every n-th robot state.
pub const DRIVEN_EVERY: u64 = 10;
/// Longest driven path published; beyond it every other pose is dropped (the start and
/// the newest pose are always kept).
pub const MAX_DRIVEN: usize = 4096;

/// ROS occupancy of an aisle cell: 0 free -> 0, 1 static and 2 detected -> 100
/// (occupied), anything else -> -1 (unknown).
pub fn ros_occupancy(cell: u8) -> i8 {
    match cell {
        0 => 0,
        1 | 2 => 100,
        _ => -1,
    }
}

/// Stateful converter from aisle messages to ROS 2 messages.
#[derive(Debug, Default)]
pub struct RosConverter {
    last_goal_id: Option<u64>,
    driven: Vec<(f64, f64, f64)>,
    states: u64,
    mount: Option<ros::Transform>,
    skipped: u64,
    /// The global map as its full maps and changes make it (`/map` is the whole map).
    global: GlobalMapCopy,
}

impl RosConverter {
    /// Messages of a converted type that yielded nothing (bytes of the wrong size,
    /// counts out of range, non-finite poses).
    pub fn skipped(&self) -> u64 {
        self.skipped
    }

    /// Converts one recorded message of `service`; appends what it yields to `out`.
    /// Services the export does not convert yield nothing.
    pub fn convert(
        &mut self,
        service: &str,
        msg: &AlignedBuf,
        out: &mut Vec<RosMessage>,
    ) -> Result<(), cdr_encoding::Error> {
        let converted = match service {
            s::POINT_CLOUD => msg.view::<PointCloud>().map(|m| self.cloud(m, out)),
            s::GLOBAL_MAP => msg
                .view::<GlobalGrid>()
                .map(|m| self.global(m.header.stamp_ns, Some(m), None, out)),
            s::GLOBAL_MAP_CHANGES => msg
                .view::<MapChanges>()
                .map(|m| self.global(m.header.stamp_ns, None, Some(m), out)),
            s::LOCAL_MAP => msg
                .view::<OccupancyGrid>()
                .map(|m| grid(RosTopic::LocalMap, m, out)),
            s::CONTROLLER_GOAL => msg.view::<ControllerGoal>().map(|m| self.goal(m, out)),
            s::CONTROLLER_BAND => msg.view::<ControllerBand>().map(|m| band(m, out)),
            s::ROBOT_STATE => msg.view::<RobotState>().map(|m| self.robot(m, out)),
            s::TRAJECTORY => msg.view::<Trajectory>().map(|m| command(m, out)),
            _ => return Ok(()),
        };
        match converted {
            Some(Err(e)) => return Err(e),
            None | Some(Ok(false)) => self.skipped += 1,
            Some(Ok(true)) => {}
        }
        Ok(())
    }

    fn cloud(&mut self, m: &PointCloud, out: &mut Vec<RosMessage>) -> Result<bool, Error> {
        let (rows, cols) = (m.rows as usize, m.cols as usize);
        let n = rows * cols;
        if n > MAX_CLOUD_POINTS {
            return Ok(false);
        }
        let stamp = m.header.stamp_ns;
        // The mount is derived from two map-frame poses, so it wobbles in the last bits
        // from scan to scan: only a real change (over `MOUNT_CHANGE`) is sent again.
        if let Some(mount) = sensor_mount(m)
            && self.mount.is_none_or(|old| moved(&old, &mount))
        {
            self.mount = Some(mount);
            let tf = ros::TfMessage {
                transforms: vec![transform(stamp, Frame::BaseLink, Frame::Sensor, mount)],
            };
            push(out, RosTopic::TfStatic, stamp, &tf)?;
        }
        let mut data = Vec::with_capacity(n * 12);
        let mut dense = true;
        for p in &m.points[..n] {
            dense &= p.iter().all(|v| v.is_finite());
            for v in p {
                data.extend_from_slice(&v.to_le_bytes());
            }
        }
        let field = |name: &str, offset: u32| ros::PointField {
            name: name.into(),
            offset,
            datatype: ros::FLOAT32,
            count: 1,
        };
        let cloud = ros::PointCloud2 {
            header: header(stamp, Frame::Sensor),
            height: m.rows,
            width: m.cols,
            fields: vec![field("x", 0), field("y", 4), field("z", 8)],
            is_bigendian: false,
            point_step: 12,
            row_step: 12 * m.cols,
            data: Bytes(data),
            is_dense: dense,
        };
        push(out, RosTopic::Points, stamp, &cloud)?;
        Ok(true)
    }

    /// `/map` whenever the held global map changes: a new full map, or changes.
    fn global(
        &mut self,
        stamp: u64,
        full: Option<&GlobalGrid>,
        changes: Option<&MapChanges>,
        out: &mut Vec<RosMessage>,
    ) -> Result<bool, Error> {
        match (self.global.update(full, changes), self.global.view()) {
            (Ok(u), _) if u.refused.is_some() => Ok(false),
            (Ok(u), Ok(view)) if u.changed() => grid_of(RosTopic::Map, stamp, &view, out),
            (Ok(_), _) => Ok(true),
            (Err(_), _) => Ok(false),
        }
    }

    fn goal(&mut self, m: &ControllerGoal, out: &mut Vec<RosMessage>) -> Result<bool, Error> {
        let n = m.len as usize;
        if n > MAX_PATH_POSES {
            return Ok(false);
        }
        if self.last_goal_id == Some(m.goal_id) {
            return Ok(true);
        }
        self.last_goal_id = Some(m.goal_id);
        let stamp = m.header.stamp_ns;
        let poses = m.reference[..n].iter().map(|p| (stamp, p.x, p.y, p.theta));
        push(out, RosTopic::Plan, stamp, &path(stamp, poses))?;
        Ok(true)
    }

    fn robot(&mut self, m: &RobotState, out: &mut Vec<RosMessage>) -> Result<bool, Error> {
        let p = &m.pose;
        let twist = m.twist;
        if !([p.x, p.y, p.theta, twist[0], twist[1]]
            .iter()
            .all(|v| v.is_finite()))
        {
            return Ok(false);
        }
        let stamp = m.header.stamp_ns;
        let pose = Pose::planar(p.x, p.y, p.theta);
        let odom = ros::Odometry {
            header: header(stamp, Frame::Odom),
            child_frame_id: Frame::BaseLink.name().into(),
            pose: ros::PoseWithCovariance {
                pose,
                covariance: [0.0; 36],
            },
            twist: ros::TwistWithCovariance {
                twist: Twist::planar(twist[0], twist[1]),
                covariance: [0.0; 36],
            },
        };
        push(out, RosTopic::Odom, stamp, &odom)?;
        let base = ros::Transform {
            translation: pose.position,
            rotation: pose.orientation,
        };
        let tf = ros::TfMessage {
            transforms: vec![
                transform(stamp, Frame::Map, Frame::Odom, ros::Transform::default()),
                transform(stamp, Frame::Odom, Frame::BaseLink, base),
            ],
        };
        push(out, RosTopic::Tf, stamp, &tf)?;
        if self.driven.last() != Some(&(p.x, p.y, p.theta)) {
            if self.driven.len() >= MAX_DRIVEN {
                let newest = self.driven.len() - 1;
                let kept = (0..newest).step_by(2).chain([newest]);
                self.driven = kept.map(|i| self.driven[i]).collect();
            }
            self.driven.push((p.x, p.y, p.theta));
        }
        self.states += 1;
        if self.states.is_multiple_of(DRIVEN_EVERY) {
            let poses = self.driven.iter().map(|&(x, y, th)| (stamp, x, y, th));
            push(out, RosTopic::DrivenPath, stamp, &path(stamp, poses))?;
        }
        Ok(true)
    }
}

type Error = cdr_encoding::Error;

/// A grid that is not valid (see [`GridMessage::view`]) is skipped.
fn grid(topic: RosTopic, m: &OccupancyGrid, out: &mut Vec<RosMessage>) -> Result<bool, Error> {
    match m.view() {
        Ok(view) => grid_of(topic, m.header.stamp_ns, &view, out),
        Err(_) => Ok(false),
    }
}

fn grid_of(
    topic: RosTopic,
    stamp: u64,
    g: &aisle_geometry::GridView<'_>,
    out: &mut Vec<RosMessage>,
) -> Result<bool, Error> {
    if !g.resolution.is_finite() || g.resolution <= 0.0 {
        return Ok(false);
    }
    let cells = g.cells[..g.width * g.height]
        .iter()
        .map(|&c| ros_occupancy(c) as u8)
        .collect();
    let msg = ros::OccupancyGrid {
        header: header(stamp, Frame::Map),
        info: ros::MapMetaData {
            map_load_time: Time::from_ns(stamp),
            resolution: g.resolution as f32,
            width: g.width as u32,
            height: g.height as u32,
            origin: Pose::planar(g.origin_x, g.origin_y, 0.0),
        },
        data: Bytes(cells),
    };
    push(out, topic, stamp, &msg)?;
    Ok(true)
}

/// The band's poses, each stamped with the band's stamp plus its time along the band.
fn band(m: &ControllerBand, out: &mut Vec<RosMessage>) -> Result<bool, Error> {
    let n = m.len as usize;
    if n > MAX_COMMANDS {
        return Ok(false);
    }
    let stamp = m.header.stamp_ns;
    let poses = m.poses[..n].iter().map(|p| {
        let dt = if p.t.is_finite() && p.t > 0.0 {
            (p.t * 1e9) as u64
        } else {
            0
        };
        (stamp.saturating_add(dt), p.x, p.y, p.theta)
    });
    push(out, RosTopic::Band, stamp, &path(stamp, poses))?;
    Ok(true)
}

/// The controller's first command of a trajectory (what the robot is told to do now);
/// zero for an empty one (a stop).
fn command(m: &Trajectory, out: &mut Vec<RosMessage>) -> Result<bool, Error> {
    let n = m.len as usize;
    if n > MAX_COMMANDS {
        return Ok(false);
    }
    let (v, w) = m.commands[..n].first().map_or((0.0, 0.0), |c| (c.v, c.w));
    push(
        out,
        RosTopic::CmdVel,
        m.header.stamp_ns,
        &Twist::planar(v, w),
    )?;
    Ok(true)
}

/// The sensor's pose relative to the robot base, from the two map-frame poses a cloud
/// carries; `None` when they are not finite.
fn sensor_mount(m: &PointCloud) -> Option<ros::Transform> {
    let (rp, sp) = (&m.robot_pose, &m.sensor_pose);
    let all = [rp.x, rp.y, rp.theta]
        .into_iter()
        .chain(sp.position)
        .chain(sp.rpy);
    if !all.into_iter().all(f64::is_finite) {
        return None;
    }
    let (sn, c) = rp.theta.sin_cos();
    let (dx, dy) = (sp.position[0] - rp.x, sp.position[1] - rp.y);
    Some(ros::Transform {
        translation: Vector3 {
            x: c * dx + sn * dy,
            y: -sn * dx + c * dy,
            z: sp.position[2],
        },
        rotation: Quaternion::from_rpy(sp.rpy[0], sp.rpy[1], sp.rpy[2] - rp.theta),
    })
}

/// Smallest change of the sensor mount (metres, or quaternion components) that is
/// published again on `/tf_static`.
pub const MOUNT_CHANGE: f64 = 1e-6;

fn moved(a: &ros::Transform, b: &ros::Transform) -> bool {
    let (ta, tb, ra, rb) = (&a.translation, &b.translation, &a.rotation, &b.rotation);
    [
        ta.x - tb.x,
        ta.y - tb.y,
        ta.z - tb.z,
        ra.x - rb.x,
        ra.y - rb.y,
        ra.z - rb.z,
        ra.w - rb.w,
    ]
    .iter()
    .any(|d| d.abs() > MOUNT_CHANGE)
}

fn header(stamp_ns: u64, frame: Frame) -> Header {
    Header {
        stamp: Time::from_ns(stamp_ns),
        frame_id: frame.name().into(),
    }
}

fn transform(
    stamp_ns: u64,
    parent: Frame,
    child: Frame,
    t: ros::Transform,
) -> ros::TransformStamped {
    ros::TransformStamped {
        header: header(stamp_ns, parent),
        child_frame_id: child.name().into(),
        transform: t,
    }
}

/// A path in the map frame from (stamp, x, y, heading) poses.
fn path(stamp_ns: u64, poses: impl Iterator<Item = (u64, f64, f64, f64)>) -> ros::Path {
    ros::Path {
        header: header(stamp_ns, Frame::Map),
        poses: poses
            .map(|(t, x, y, th)| ros::PoseStamped {
                header: header(t, Frame::Map),
                pose: Pose::planar(x, y, th),
            })
            .collect(),
    }
}

fn push<T: serde::Serialize>(
    out: &mut Vec<RosMessage>,
    topic: RosTopic,
    stamp_ns: u64,
    msg: &T,
) -> Result<(), Error> {
    out.push(RosMessage {
        topic,
        stamp_ns,
        data: ros::encode(msg)?,
    });
    Ok(())
}
