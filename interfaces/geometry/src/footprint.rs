//! Rectangular footprints centred on the robot's reference point.

use crate::Pose2;
use serde::{Deserialize, Serialize};

/// A rectangle centred on the pose it is placed at: `length` along the heading,
/// `width` across it. The robot alone and the robot carrying a rack (the rack sits
/// on `mid_mount`, above the base origin) are both of this shape.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Footprint {
    pub length: f64,
    pub width: f64,
}

impl Footprint {
    pub const fn new(length: f64, width: f64) -> Self {
        Self { length, width }
    }

    /// The same rectangle grown by `margin` on every side.
    pub fn inflated(&self, margin: f64) -> Footprint {
        Footprint::new(self.length + 2.0 * margin, self.width + 2.0 * margin)
    }

    /// Radius of the smallest circle around the centre containing the rectangle.
    pub fn circumscribed_radius(&self) -> f64 {
        0.5 * self.length.hypot(self.width)
    }

    pub fn inscribed_radius(&self) -> f64 {
        0.5 * self.length.min(self.width)
    }

    /// The four corners in the parent frame, counter-clockwise from front-left.
    pub fn corners(&self, at: &Pose2) -> [(f64, f64); 4] {
        let hl = 0.5 * self.length;
        let hw = 0.5 * self.width;
        [
            at.transform_point(hl, hw),
            at.transform_point(-hl, hw),
            at.transform_point(-hl, -hw),
            at.transform_point(hl, -hw),
        ]
    }

    /// Whether a parent-frame point lies inside the rectangle placed at `at`.
    pub fn contains(&self, at: &Pose2, px: f64, py: f64) -> bool {
        let (lx, ly) = at.inverse_transform_point(px, py);
        lx.abs() <= 0.5 * self.length && ly.abs() <= 0.5 * self.width
    }

    /// Signed distance from a parent-frame point to the rectangle placed at `at`:
    /// positive outside, negative inside.
    pub fn signed_distance(&self, at: &Pose2, px: f64, py: f64) -> f64 {
        let (lx, ly) = at.inverse_transform_point(px, py);
        let dx = lx.abs() - 0.5 * self.length;
        let dy = ly.abs() - 0.5 * self.width;
        let outside = dx.max(0.0).hypot(dy.max(0.0));
        outside + dx.max(dy).min(0.0)
    }

    /// Whether this rectangle placed at `at` and `other` placed at `other_at` overlap
    /// or touch (separating-axis test on the four edge normals).
    pub fn overlaps(&self, at: &Pose2, other: &Footprint, other_at: &Pose2) -> bool {
        let (dx, dy) = (other_at.x - at.x, other_at.y - at.y);
        let own = (
            at.theta.cos(),
            at.theta.sin(),
            0.5 * self.length,
            0.5 * self.width,
        );
        let oth = (
            other_at.theta.cos(),
            other_at.theta.sin(),
            0.5 * other.length,
            0.5 * other.width,
        );
        // Projected half size of rectangle (c, s, hl, hw) on the unit axis (ux, uy).
        let half = |r: (f64, f64, f64, f64), ux: f64, uy: f64| {
            r.2 * (r.0 * ux + r.1 * uy).abs() + r.3 * (-r.1 * ux + r.0 * uy).abs()
        };
        [own, oth].iter().all(|r| {
            [(r.0, r.1), (-r.1, r.0)]
                .iter()
                .all(|&(ux, uy)| (dx * ux + dy * uy).abs() <= half(own, ux, uy) + half(oth, ux, uy))
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn signed_distance_of_a_rotated_rectangle() {
        let f = Footprint::new(2.0, 1.0);
        let at = Pose2::new(1.0, 1.0, std::f64::consts::FRAC_PI_2);
        // Length now runs along +y: the point (1, 3) is 1 m beyond the front edge.
        assert!((f.signed_distance(&at, 1.0, 3.0) - 1.0).abs() < 1e-12);
        assert!((f.signed_distance(&at, 1.0, 1.0) + 0.5).abs() < 1e-12);
        assert!(f.contains(&at, 1.4, 1.9));
        assert!(!f.contains(&at, 1.6, 1.0));
        let corner = f.corners(&at)[0];
        assert!((corner.0 - 0.5).abs() < 1e-12 && (corner.1 - 2.0).abs() < 1e-12);
    }

    #[test]
    fn overlap_of_placed_rectangles() {
        let leg = Footprint::new(0.05, 0.05);
        let robot = Footprint::new(0.5, 0.4);
        let at = Pose2::new(0.0, 0.0, 0.0);
        // Beside the robot's long side, 0.01 m off, then touching through a corner
        // once the robot turns.
        assert!(!robot.overlaps(&at, &leg, &Pose2::new(0.0, 0.235, 0.0)));
        assert!(robot.overlaps(&at, &leg, &Pose2::new(0.0, 0.22, 0.0)));
        let turned = Pose2::new(0.0, 0.0, 0.3);
        assert!(robot.overlaps(&turned, &leg, &Pose2::new(0.2, 0.235, 0.0)));
        // A leg rotated by 45 degrees reaching in with its corner.
        let diamond = Pose2::new(0.0, 0.2 + 0.035 - 0.01, std::f64::consts::FRAC_PI_4);
        assert!(robot.overlaps(&at, &leg, &diamond));
    }
}
