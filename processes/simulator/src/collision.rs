//! Boxes that stand upright and turn only about z ("prisms"): overlap and planar
//! distance between them, the only shapes the warehouse has.
//!
//! Two prisms collide when their height ranges overlap AND their floor rectangles
//! overlap (separating-axis test on the four edge normals). Their clearance is the
//! distance between the floor rectangles, counted only when the height ranges overlap
//! (a deck above the robot is no obstacle, its legs are). Touching counts as contact.
//!
//! Knows nothing of bodies, the robot or time.

use aisle_config::scene::BoxPart;
use aisle_geometry::Pose2;

/// An upright box: rectangle centred at (x, y), turned by the angle whose cosine and
/// sine are (c, s), half sizes (hx, hy), spanning heights [z_min, z_max].
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Prism {
    pub x: f64,
    pub y: f64,
    pub c: f64,
    pub s: f64,
    pub hx: f64,
    pub hy: f64,
    pub z_min: f64,
    pub z_max: f64,
}

/// A circle around a group of prisms, for cheap rejection.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Bound {
    pub x: f64,
    pub y: f64,
    pub r: f64,
}

impl Bound {
    /// A lower bound of the planar distance between anything inside the two circles.
    #[inline]
    pub fn gap(&self, o: &Bound) -> f64 {
        let (dx, dy) = (self.x - o.x, self.y - o.y);
        // sqrt of the sum of squares, not `hypot`: libm's hypot guards against overflow
        // that warehouse distances never reach and costs several times more.
        (dx * dx + dy * dy).sqrt() - self.r - o.r
    }
}

impl Prism {
    /// A rectangle of full size (length, width) centred on `at`, from the floor up.
    pub fn at_pose(at: &Pose2, length: f64, width: f64, z_min: f64, z_max: f64) -> Prism {
        let (s, c) = at.theta.sin_cos();
        Prism {
            x: at.x,
            y: at.y,
            c,
            s,
            hx: 0.5 * length,
            hy: 0.5 * width,
            z_min,
            z_max,
        }
    }

    /// A body part (given in the body's frame) placed with the body at `body`.
    pub fn from_part(body: &Pose2, part: &BoxPart) -> Prism {
        let (x, y) = body.transform_point(part.center[0], part.center[1]);
        Prism::at_pose(
            &Pose2::new(x, y, body.theta),
            part.size[0],
            part.size[1],
            part.z_min(),
            part.z_max(),
        )
    }

    pub fn bound(&self) -> Bound {
        Bound {
            x: self.x,
            y: self.y,
            r: (self.hx * self.hx + self.hy * self.hy).sqrt(),
        }
    }

    #[inline]
    pub fn heights_overlap(&self, o: &Prism) -> bool {
        self.z_min < o.z_max && o.z_min < self.z_max
    }

    fn corners(&self) -> [(f64, f64); 4] {
        let (ax, ay) = (self.c * self.hx, self.s * self.hx);
        let (bx, by) = (-self.s * self.hy, self.c * self.hy);
        [
            (self.x + ax + bx, self.y + ay + by),
            (self.x - ax + bx, self.y - ay + by),
            (self.x - ax - bx, self.y - ay - by),
            (self.x + ax - bx, self.y + ay - by),
        ]
    }

    /// Squared planar distance from a point to the rectangle, 0 inside.
    #[inline]
    fn point_distance_sq(&self, px: f64, py: f64) -> f64 {
        let (dx, dy) = (px - self.x, py - self.y);
        let lx = ((self.c * dx + self.s * dy).abs() - self.hx).max(0.0);
        let ly = ((-self.s * dx + self.c * dy).abs() - self.hy).max(0.0);
        lx * lx + ly * ly
    }

    /// Whether the floor rectangles overlap or touch (separating-axis test).
    pub fn rects_overlap(&self, o: &Prism) -> bool {
        let (dx, dy) = (o.x - self.x, o.y - self.y);
        // Axes of self, then of o; each axis projects both half sizes.
        let axes = [(self.c, self.s), (-self.s, self.c), (o.c, o.s), (-o.s, o.c)];
        for (i, &(ux, uy)) in axes.iter().enumerate() {
            let (own, other) = if i < 2 { (self, o) } else { (o, self) };
            let h_own = if i % 2 == 0 { own.hx } else { own.hy };
            let h_other = other.hx * (other.c * ux + other.s * uy).abs()
                + other.hy * (-other.s * ux + other.c * uy).abs();
            if (dx * ux + dy * uy).abs() > h_own + h_other {
                return false;
            }
        }
        true
    }

    /// Planar distance between the floor rectangles, 0 when they overlap.
    pub fn rect_distance(&self, o: &Prism) -> f64 {
        if self.rects_overlap(o) {
            return 0.0;
        }
        // Disjoint convex polygons: the closest pair always involves a vertex. One
        // square root at the end instead of one per vertex.
        let mut d2 = f64::INFINITY;
        for (x, y) in self.corners() {
            d2 = d2.min(o.point_distance_sq(x, y));
        }
        for (x, y) in o.corners() {
            d2 = d2.min(self.point_distance_sq(x, y));
        }
        d2.sqrt()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::FRAC_PI_4;

    fn unit(x: f64, y: f64, th: f64) -> Prism {
        Prism::at_pose(&Pose2::new(x, y, th), 1.0, 1.0, 0.0, 1.0)
    }

    #[test]
    fn axis_aligned_distance_and_overlap() {
        let a = unit(0.0, 0.0, 0.0);
        assert!((a.rect_distance(&unit(3.0, 0.0, 0.0)) - 2.0).abs() < 1e-12);
        assert!((a.rect_distance(&unit(2.0, 2.0, 0.0)) - 2f64.sqrt()).abs() < 1e-12);
        assert_eq!(a.rect_distance(&unit(0.9, 0.2, 0.0)), 0.0);
        assert!(a.rects_overlap(&unit(1.0, 0.0, 0.0)), "touching counts");
    }

    #[test]
    fn rotated_rectangles() {
        let a = unit(0.0, 0.0, 0.0);
        // A diamond whose corner points at a's right edge from 0.3 m away.
        let h = 0.5 * 2f64.sqrt();
        let b = unit(0.5 + 0.3 + h, 0.0, FRAC_PI_4);
        assert!((a.rect_distance(&b) - 0.3).abs() < 1e-12);
        // A cross: no corner of either inside the other, yet they overlap.
        let long = Prism::at_pose(&Pose2::new(0.0, 0.0, 0.0), 4.0, 0.2, 0.0, 1.0);
        let across = Prism::at_pose(&Pose2::new(0.0, 0.0, 1.0), 4.0, 0.2, 0.0, 1.0);
        assert!(long.rects_overlap(&across));
        // Diamond near a's corner but separated along a diagonal axis.
        let c = unit(1.3, 1.3, FRAC_PI_4);
        assert!(!a.rects_overlap(&c));
        assert!(a.rect_distance(&c) > 0.0);
    }

    #[test]
    fn heights_gate_contact() {
        let robot = Prism::at_pose(&Pose2::default(), 0.5, 0.4, 0.0, 0.25);
        let deck = Prism::at_pose(&Pose2::default(), 0.9, 0.8, 0.30, 0.35);
        assert!(robot.rects_overlap(&deck) && !robot.heights_overlap(&deck));
        let part = BoxPart {
            center: [1.0, 0.0, 0.15],
            size: [0.1, 0.1, 0.3],
        };
        let leg = Prism::from_part(&Pose2::new(2.0, 0.0, std::f64::consts::FRAC_PI_2), &part);
        assert!((leg.x - 2.0).abs() < 1e-12 && (leg.y - 1.0).abs() < 1e-12);
        assert!(robot.heights_overlap(&leg));
        assert!((leg.bound().r - 0.05 * 2f64.sqrt()).abs() < 1e-12);
    }
}
