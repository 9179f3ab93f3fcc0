//! `SensorPose`: a sensor frame as a rigid transform (position and full 3D rotation),
//! in the robot's floor frame (a mount, see [`crate::RobotModel::mount_in_base`]) or in
//! the world (the mount on a robot pose, [`SensorPose::on_robot`]).
//!
//! Plain row-major arithmetic, so the lidar's raycaster can use it directly. Knows
//! nothing of the scene or the URDF.

use aisle_geometry::Pose2;

/// Rigid transform from the sensor frame (x forward, y left, z up) to the world frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SensorPose {
    /// Sensor origin in the world, metres.
    pub position: [f64; 3],
    /// Row-major rotation matrix; column j is sensor axis j in world coordinates.
    pub rotation: [[f64; 3]; 3],
}

/// A rotation whose z column is this close to world z counts as level (yaw only).
const LEVEL_TOLERANCE: f64 = 1e-12;

impl SensorPose {
    pub const IDENTITY: SensorPose = SensorPose {
        position: [0.0; 3],
        rotation: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
    };

    /// A level sensor at height `z` above the floor, heading `yaw`.
    pub fn planar(x: f64, y: f64, z: f64, yaw: f64) -> SensorPose {
        SensorPose::from_xyz_rpy([x, y, z], [0.0, 0.0, yaw])
    }

    /// Translation plus fixed-axis roll, pitch, yaw (the URDF `<origin>` convention:
    /// R = Rz(yaw) Ry(pitch) Rx(roll)).
    pub fn from_xyz_rpy(xyz: [f64; 3], rpy: [f64; 3]) -> SensorPose {
        let (sr, cr) = rpy[0].sin_cos();
        let (sp, cp) = rpy[1].sin_cos();
        let (sy, cy) = rpy[2].sin_cos();
        SensorPose {
            position: xyz,
            rotation: [
                [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
                [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
                [-sp, cp * sr, cp * cr],
            ],
        }
    }

    /// The pose of a planar robot on the floor (z = 0), as a 3D transform.
    pub fn from_pose2(p: &Pose2) -> SensorPose {
        SensorPose::planar(p.x, p.y, 0.0, p.theta)
    }

    /// `self * other`: `other` is given in the frame of `self`.
    pub fn compose(&self, other: &SensorPose) -> SensorPose {
        let a = &self.rotation;
        let b = &other.rotation;
        let mut rotation = [[0.0; 3]; 3];
        let mut position = self.position;
        for i in 0..3 {
            for j in 0..3 {
                rotation[i][j] = (0..3).map(|k| a[i][k] * b[k][j]).sum();
            }
            position[i] += (0..3).map(|k| a[i][k] * other.position[k]).sum::<f64>();
        }
        SensorPose { position, rotation }
    }

    /// World pose of a sensor mounted at `mount` (in the robot base frame) on a robot
    /// at planar pose `robot`.
    pub fn on_robot(robot: &Pose2, mount: &SensorPose) -> SensorPose {
        SensorPose::from_pose2(robot).compose(mount)
    }

    /// Finite, and the rotation is orthonormal with determinant +1 (to 1e-6).
    pub fn is_valid(&self) -> bool {
        let r = &self.rotation;
        if !self
            .position
            .iter()
            .chain(r.iter().flatten())
            .all(|v| v.is_finite())
        {
            return false;
        }
        for i in 0..3 {
            for j in 0..3 {
                let dot: f64 = (0..3).map(|k| r[k][i] * r[k][j]).sum();
                let want = if i == j { 1.0 } else { 0.0 };
                if (dot - want).abs() > 1e-6 {
                    return false;
                }
            }
        }
        let det = r[0][0] * (r[1][1] * r[2][2] - r[1][2] * r[2][1])
            - r[0][1] * (r[1][0] * r[2][2] - r[1][2] * r[2][0])
            + r[0][2] * (r[1][0] * r[2][1] - r[1][1] * r[2][0]);
        (det - 1.0).abs() < 1e-6
    }

    /// The heading when the sensor is level (its z axis is world z), else `None`.
    pub fn level_yaw(&self) -> Option<f64> {
        let r = &self.rotation;
        let level = r[2][0].abs() < LEVEL_TOLERANCE
            && r[2][1].abs() < LEVEL_TOLERANCE
            && r[0][2].abs() < LEVEL_TOLERANCE
            && r[1][2].abs() < LEVEL_TOLERANCE
            && r[2][2] > 0.0;
        level.then(|| r[1][0].atan2(r[0][0]))
    }

    /// A world vector expressed in the sensor frame (R^T v).
    #[inline]
    pub fn vector_to_sensor(&self, v: [f64; 3]) -> [f64; 3] {
        let r = &self.rotation;
        [
            r[0][0] * v[0] + r[1][0] * v[1] + r[2][0] * v[2],
            r[0][1] * v[0] + r[1][1] * v[1] + r[2][1] * v[2],
            r[0][2] * v[0] + r[1][2] * v[1] + r[2][2] * v[2],
        ]
    }

    /// A sensor-frame vector expressed in the world (R v).
    #[inline]
    pub fn vector_to_world(&self, v: [f64; 3]) -> [f64; 3] {
        let r = &self.rotation;
        [
            r[0][0] * v[0] + r[0][1] * v[1] + r[0][2] * v[2],
            r[1][0] * v[0] + r[1][1] * v[1] + r[1][2] * v[2],
            r[2][0] * v[0] + r[2][1] * v[1] + r[2][2] * v[2],
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mount_on_robot_puts_the_sensor_where_expected() {
        let mount = SensorPose::from_xyz_rpy([0.25, 0.1, 0.2], [0.0, 0.0, 0.0]);
        let robot = Pose2::new(2.0, 13.0, std::f64::consts::FRAC_PI_2);
        let s = SensorPose::on_robot(&robot, &mount);
        assert!((s.position[0] - 1.9).abs() < 1e-12);
        assert!((s.position[1] - 13.25).abs() < 1e-12);
        assert!((s.position[2] - 0.2).abs() < 1e-12);
        assert!((s.level_yaw().unwrap() - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        assert!(s.is_valid());
    }

    #[test]
    fn tilted_pose_is_not_level_and_rpy_matches_urdf_convention() {
        let s = SensorPose::from_xyz_rpy([0.0; 3], [0.0, 0.3, 0.0]);
        assert!(s.level_yaw().is_none());
        // Positive pitch about y turns the x axis down.
        assert!(s.vector_to_world([1.0, 0.0, 0.0])[2] < 0.0);
        let back = s.vector_to_sensor(s.vector_to_world([0.3, -0.2, 0.9]));
        assert!((back[0] - 0.3).abs() < 1e-12 && (back[2] - 0.9).abs() < 1e-12);
    }

    #[test]
    fn invalid_poses_are_detected() {
        let mut s = SensorPose::IDENTITY;
        assert!(s.is_valid());
        s.position[1] = f64::NAN;
        assert!(!s.is_valid());
        let mut m = SensorPose::IDENTITY;
        m.rotation[0][0] = 2.0;
        assert!(!m.is_valid());
        let mut flip = SensorPose::IDENTITY;
        flip.rotation[2][2] = -1.0;
        assert!(!flip.is_valid());
    }
}
