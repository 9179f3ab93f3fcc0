//! Rectangles on the floor: overlap (separating axes), containment in the map, and the
//! distance along a ray to the nearest one. The generator's whole notion of "free";
//! knows nothing of the scene file or the mission.

use crate::check::placement::Extent;
use aisle_geometry::{Footprint, Pose2};

/// A rectangle centred on `at`, `size.length` along its heading.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rect {
    pub at: Pose2,
    pub size: Footprint,
}

impl Rect {
    pub fn new(at: Pose2, size: Footprint) -> Rect {
        Rect { at, size }
    }

    /// The same rectangle grown by `margin` on every side.
    pub fn grown(&self, margin: f64) -> Rect {
        Rect::new(self.at, self.size.inflated(margin))
    }

    fn axes(&self) -> [(f64, f64); 2] {
        let (s, c) = self.at.theta.sin_cos();
        [(c, s), (-s, c)]
    }

    /// Whether the two rectangles share a point (touching counts): no separating axis
    /// among the four edge normals.
    pub fn overlaps(&self, other: &Rect) -> bool {
        let a = self.size.corners(&self.at);
        let b = other.size.corners(&other.at);
        let project = |pts: &[(f64, f64); 4], (ax, ay): (f64, f64)| {
            pts.iter()
                .map(|&(x, y)| x * ax + y * ay)
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
                    (lo.min(v), hi.max(v))
                })
        };
        self.axes().into_iter().chain(other.axes()).all(|axis| {
            let (a0, a1) = project(&a, axis);
            let (b0, b1) = project(&b, axis);
            a0 <= b1 && b0 <= a1
        })
    }

    /// Whether every corner lies within `(x0, y0, x1, y1)`.
    pub fn inside(&self, (x0, y0, x1, y1): Extent) -> bool {
        self.size
            .corners(&self.at)
            .iter()
            .all(|&(x, y)| x >= x0 && x <= x1 && y >= y0 && y <= y1)
    }

    /// Distance from `(px, py)` along the unit direction `(dx, dy)` to where the ray
    /// enters this rectangle, if it does (0 when it starts inside).
    pub fn ray_entry(&self, (px, py): (f64, f64), (dx, dy): (f64, f64)) -> Option<f64> {
        let (lx, ly) = self.at.inverse_transform_point(px, py);
        let (s, c) = self.at.theta.sin_cos();
        // The direction in the rectangle's frame.
        let (ux, uy) = (c * dx + s * dy, -s * dx + c * dy);
        let (mut t0, mut t1) = (0.0_f64, f64::INFINITY);
        for (p, u, h) in [
            (lx, ux, 0.5 * self.size.length),
            (ly, uy, 0.5 * self.size.width),
        ] {
            if u.abs() < 1e-12 {
                if p.abs() > h {
                    return None;
                }
                continue;
            }
            let (a, b) = ((-h - p) / u, (h - p) / u);
            t0 = t0.max(a.min(b));
            t1 = t1.min(a.max(b));
        }
        (t0 <= t1).then_some(t0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::FRAC_PI_4;

    fn square(x: f64, y: f64, theta: f64) -> Rect {
        Rect::new(Pose2::new(x, y, theta), Footprint::new(1.0, 1.0))
    }

    #[test]
    fn overlap_needs_a_shared_point() {
        assert!(square(0.0, 0.0, 0.0).overlaps(&square(0.9, 0.0, 0.0)));
        assert!(!square(0.0, 0.0, 0.0).overlaps(&square(1.1, 0.0, 0.0)));
        // A diamond reaches 0.707 m: it touches a square 1.2 m away, not 1.3 m.
        assert!(square(0.0, 0.0, 0.0).overlaps(&square(1.2, 0.0, FRAC_PI_4)));
        assert!(!square(0.0, 0.0, 0.0).overlaps(&square(1.3, 0.0, FRAC_PI_4)));
        // Diagonal neighbours whose bounding boxes overlap but the shapes do not.
        assert!(!square(0.0, 0.0, FRAC_PI_4).overlaps(&square(0.8, 0.8, FRAC_PI_4)));
        assert!(
            square(0.0, 0.0, 0.0)
                .grown(0.11)
                .overlaps(&square(1.1, 0.0, 0.0))
        );
    }

    #[test]
    fn a_ray_enters_where_the_edge_is() {
        let r = square(3.0, 0.0, 0.0);
        assert!((r.ray_entry((0.0, 0.0), (1.0, 0.0)).unwrap() - 2.5).abs() < 1e-12);
        assert!(r.ray_entry((0.0, 0.0), (-1.0, 0.0)).is_none());
        assert!(r.ray_entry((0.0, 0.0), (0.0, 1.0)).is_none());
        assert_eq!(r.ray_entry((3.0, 0.0), (0.0, 1.0)), Some(0.0));
        let d = square(3.0, 0.0, FRAC_PI_4);
        let t = d.ray_entry((0.0, 0.0), (1.0, 0.0)).unwrap();
        assert!((t - (3.0 - 0.5_f64.sqrt())).abs() < 1e-9, "{t}");
    }

    #[test]
    fn inside_counts_corners() {
        let extent = (-1.0, -1.0, 1.0, 1.0);
        assert!(square(0.0, 0.0, 0.0).inside(extent));
        assert!(!square(0.0, 0.0, FRAC_PI_4).grown(0.3).inside(extent));
        assert!(!square(0.6, 0.0, 0.0).inside(extent));
    }
}
