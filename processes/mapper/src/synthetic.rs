//! Deterministic synthetic organised clouds for tests and benchmarks: rays cast
//! analytically against boxes (each turned about z only) in the map frame.
//!
//! Not a lidar simulator (no noise, no floor, no beam divergence; the `aisle-lidar` crate
//! is the real one). Knows nothing of grids.

use crate::cloud::{BeamGeometry, SensorPose};
use aisle_config::scene::Scene;
use aisle_geometry::Pose2;

/// A box in the map frame: planar pose of its centre, z range, half extents in its frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WorldBox {
    pub pose: Pose2,
    pub z_min: f64,
    pub z_max: f64,
    pub half_x: f64,
    pub half_y: f64,
}

impl WorldBox {
    /// A box standing on the floor.
    pub fn standing(x: f64, y: f64, yaw: f64, size: [f64; 3]) -> Self {
        Self {
            pose: Pose2::new(x, y, yaw),
            z_min: 0.0,
            z_max: size[2],
            half_x: 0.5 * size[0],
            half_y: 0.5 * size[1],
        }
    }

    /// Distance along the unit ray `o + t d` to its first entry into the box, if any.
    fn hit(&self, o: [f64; 3], d: [f64; 3]) -> Option<f64> {
        let (lx, ly) = self.pose.inverse_transform_point(o[0], o[1]);
        let (s, c) = self.pose.theta.sin_cos();
        let ld = [c * d[0] + s * d[1], -s * d[0] + c * d[1], d[2]];
        let lo = [lx, ly, o[2] - 0.5 * (self.z_min + self.z_max)];
        let half = [self.half_x, self.half_y, 0.5 * (self.z_max - self.z_min)];
        let mut t0 = 0.0f64;
        let mut t1 = f64::INFINITY;
        for k in 0..3 {
            if ld[k].abs() < 1e-12 {
                if lo[k].abs() > half[k] {
                    return None;
                }
            } else {
                let a = (-half[k] - lo[k]) / ld[k];
                let b = (half[k] - lo[k]) / ld[k];
                t0 = t0.max(a.min(b));
                t1 = t1.min(a.max(b));
            }
        }
        (t0 <= t1 && t0 > 0.0).then_some(t0)
    }
}

/// Boxes of a scene; `movable` chooses whether movable bodies are included.
pub fn boxes_of_scene(scene: &Scene, movable: bool) -> Vec<WorldBox> {
    let mut out = Vec::new();
    for b in scene.bodies.iter().filter(|b| b.is_static || movable) {
        for p in &b.parts {
            let (x, y) = b.pose.transform_point(p.center[0], p.center[1]);
            out.push(WorldBox {
                pose: Pose2::new(x, y, b.pose.theta),
                z_min: p.z_min(),
                z_max: p.z_max(),
                half_x: 0.5 * p.size[0],
                half_y: 0.5 * p.size[1],
            });
        }
    }
    out
}

/// Casts every beam of `beams` from `sensor` against `boxes` and writes the organised
/// cloud (sensor frame, NaN beyond `max_range`) into `out`, resized to rows x cols.
pub fn cast_cloud(
    boxes: &[WorldBox],
    sensor: &SensorPose,
    beams: &BeamGeometry,
    max_range: f64,
    out: &mut Vec<[f32; 3]>,
) {
    out.clear();
    let r = &sensor.rotation;
    for row in 0..beams.rows {
        let (se, ce) = beams.elevation(row).sin_cos();
        for col in 0..beams.cols {
            let (sa, ca) = beams.azimuth(col).sin_cos();
            let ds = [ce * ca, ce * sa, se];
            let dw = [
                r[0][0] * ds[0] + r[0][1] * ds[1] + r[0][2] * ds[2],
                r[1][0] * ds[0] + r[1][1] * ds[1] + r[1][2] * ds[2],
                r[2][0] * ds[0] + r[2][1] * ds[1] + r[2][2] * ds[2],
            ];
            let t = boxes
                .iter()
                .filter_map(|b| b.hit(sensor.position, dw))
                .fold(f64::INFINITY, f64::min);
            out.push(if t <= max_range {
                [(t * ds[0]) as f32, (t * ds[1]) as f32, (t * ds[2]) as f32]
            } else {
                [f32::NAN; 3]
            });
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_wall_ahead_is_hit_at_its_face() {
        let wall = WorldBox::standing(5.0, 0.0, 0.0, [1.0, 10.0, 2.0]);
        let beams = BeamGeometry {
            rows: 1,
            cols: 1,
            elevation_first_deg: 0.0,
            elevation_last_deg: 0.0,
            azimuth_first_deg: 0.0,
            azimuth_last_deg: 0.0,
        };
        let mut out = Vec::new();
        cast_cloud(
            &[wall],
            &SensorPose::level(0.0, 0.0, 0.3, 0.0),
            &beams,
            12.0,
            &mut out,
        );
        assert_eq!(out.len(), 1);
        assert!((out[0][0] - 4.5).abs() < 1e-5, "{:?}", out[0]);
        cast_cloud(
            &[wall],
            &SensorPose::level(0.0, 0.0, 0.3, 3.0),
            &beams,
            12.0,
            &mut out,
        );
        assert!(out[0][0].is_nan());
    }
}
