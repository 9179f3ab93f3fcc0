//! What the obstacle layer reads: an organised point cloud, the sensor's 3D pose and the
//! lidar's beam pattern (defined by `aisle-robot`, checked here).
//!
//! Sensor frame: x forward, y left, z up. Beam (row r, column c) points along
//! `(cos e cos a, cos e sin a, sin e)` with elevation `e` of row r and azimuth `a` of
//! column c (counter-clockwise from x). Rows are elevation channels, columns azimuth
//! channels; NaN in any coordinate means no return. Knows nothing of the map.

use crate::error::MapError;
use aisle_geometry::Pose2;
/// The lidar's beam pattern is the robot's description (`aisle-robot`); re-exported so
/// the mapper's API stays in one place.
pub use aisle_robot::BeamGeometry;

/// Most points one cloud may have (64 rows x 2048 columns), the capacity of the point
/// cloud message; kept here so the algorithm does not depend on the message crate.
pub const MAX_CLOUD_POINTS: usize = 64 * 2048;

/// A borrowed organised cloud: `rows x cols` points, row-major, sensor frame.
#[derive(Debug, Clone, Copy)]
pub struct OrganizedCloud<'a> {
    pub rows: usize,
    pub cols: usize,
    pub points: &'a [[f32; 3]],
}

impl<'a> OrganizedCloud<'a> {
    pub fn new(rows: usize, cols: usize, points: &'a [[f32; 3]]) -> Result<Self, MapError> {
        if rows.checked_mul(cols) != Some(points.len()) {
            return Err(MapError::CloudShape {
                rows,
                cols,
                len: points.len(),
                exp_rows: rows,
                exp_cols: cols,
            });
        }
        Ok(Self { rows, cols, points })
    }
}

/// The checks the obstacle layer needs of a beam pattern: finite angles, and at least
/// one and at most [`MAX_CLOUD_POINTS`] beams.
pub(crate) fn check_beams(g: &BeamGeometry) -> Result<(), MapError> {
    let angles = [
        g.elevation_first_deg,
        g.elevation_last_deg,
        g.azimuth_first_deg,
        g.azimuth_last_deg,
    ];
    if !angles.iter().all(|a| a.is_finite()) {
        return Err(MapError::NotFinite {
            what: "beam geometry angle",
        });
    }
    let max = MAX_CLOUD_POINTS;
    match g.rows.checked_mul(g.cols) {
        Some(n) if n > 0 && n <= max => Ok(()),
        _ => Err(MapError::TooMany {
            what: "beam channels (rows x cols, at least 1)",
            got: g.rows.saturating_mul(g.cols),
            max,
        }),
    }
}

/// The sensor's pose in the world: `p_world = rotation * p_sensor + position`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SensorPose {
    pub position: [f64; 3],
    /// Row-major rotation matrix, world from sensor.
    pub rotation: [[f64; 3]; 3],
}

impl SensorPose {
    /// From roll, pitch, yaw applied as in URDF and `Pose3Msg`:
    /// `R = Rz(yaw) * Ry(pitch) * Rx(roll)`.
    pub fn from_rpy(position: [f64; 3], roll: f64, pitch: f64, yaw: f64) -> Self {
        let (sr, cr) = roll.sin_cos();
        let (sp, cp) = pitch.sin_cos();
        let (sy, cy) = yaw.sin_cos();
        Self {
            position,
            rotation: [
                [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
                [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
                [-sp, cp * sr, cp * cr],
            ],
        }
    }

    /// A level sensor at height `z` with heading `yaw`.
    pub fn level(x: f64, y: f64, z: f64, yaw: f64) -> Self {
        Self::from_rpy([x, y, z], 0.0, 0.0, yaw)
    }

    /// A level sensor whose planar pose in the map frame is `pose`, at height `z`
    /// (for callers that only track the sensor in 2D).
    pub fn planar(pose: &Pose2, z: f64) -> Self {
        Self::level(pose.x, pose.y, z, pose.theta)
    }

    pub fn is_finite(&self) -> bool {
        self.position.iter().all(|v| v.is_finite())
            && self.rotation.iter().flatten().all(|v| v.is_finite())
    }

    pub fn transform(&self, p: [f64; 3]) -> [f64; 3] {
        let r = &self.rotation;
        let t = &self.position;
        [
            r[0][0] * p[0] + r[0][1] * p[1] + r[0][2] * p[2] + t[0],
            r[1][0] * p[0] + r[1][1] * p[1] + r[1][2] * p[2] + t[1],
            r[2][0] * p[0] + r[2][1] * p[1] + r[2][2] * p[2] + t[2],
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn seed_geometry_channels() {
        let g = BeamGeometry::default();
        check_beams(&g).unwrap();
        assert!((g.azimuth(0) + 120f64.to_radians()).abs() < 1e-12);
        assert!((g.azimuth(600)).abs() < 1e-12);
        assert!((g.azimuth(1200) - 120f64.to_radians()).abs() < 1e-12);
        assert!((g.elevation(30) - 30f64.to_radians()).abs() < 1e-12);
    }

    #[test]
    fn rpy_matches_yaw_then_pitch_then_roll() {
        let p = SensorPose::from_rpy([1.0, 2.0, 0.3], 0.0, 0.0, std::f64::consts::FRAC_PI_2);
        let w = p.transform([1.0, 0.0, 0.0]);
        assert!((w[0] - 1.0).abs() < 1e-12 && (w[1] - 3.0).abs() < 1e-12);
        // Pitching down (positive pitch about y) sends the forward axis below the horizon.
        let q = SensorPose::from_rpy([0.0; 3], 0.0, 0.1, 0.0);
        assert!(q.transform([1.0, 0.0, 0.0])[2] < 0.0);
        // Roll turns +y up towards +z.
        let r = SensorPose::from_rpy([0.0; 3], 0.1, 0.0, 0.0);
        assert!(r.transform([0.0, 1.0, 0.0])[2] > 0.0);
    }

    #[test]
    fn planar_pose_is_a_level_sensor() {
        let p = SensorPose::planar(&Pose2::new(1.0, 2.0, 0.5), 0.4);
        assert_eq!(p, SensorPose::level(1.0, 2.0, 0.4, 0.5));
        let w = p.transform([1.0, 0.0, 0.0]);
        assert!((w[0] - (1.0 + 0.5f64.cos())).abs() < 1e-12);
        assert!((w[1] - (2.0 + 0.5f64.sin())).abs() < 1e-12);
        assert!((w[2] - 0.4).abs() < 1e-12);
    }

    #[test]
    fn cloud_shape_is_checked() {
        let pts = vec![[0.0f32; 3]; 6];
        assert!(OrganizedCloud::new(2, 3, &pts).is_ok());
        assert!(OrganizedCloud::new(2, 4, &pts).is_err());
        assert!(OrganizedCloud::new(usize::MAX, 2, &pts).is_err());
    }
}
