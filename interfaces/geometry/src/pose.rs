//! SE(2) poses and angle arithmetic.

use serde::{Deserialize, Serialize};

/// Wraps an angle to (-pi, pi].
#[inline]
pub fn wrap_angle(a: f64) -> f64 {
    let two_pi = std::f64::consts::TAU;
    // `%` is a call to fmod, which returns a within a turn unchanged: most callers
    // wrap a sum or difference of wrapped angles, and skip the call.
    let mut r = if a.abs() < two_pi { a } else { a % two_pi };
    if r > std::f64::consts::PI {
        r -= two_pi;
    } else if r <= -std::f64::consts::PI {
        r += two_pi;
    }
    r
}

/// A planar pose: position in metres, heading in radians (counter-clockwise from +x).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Pose2 {
    pub x: f64,
    pub y: f64,
    pub theta: f64,
}

impl Pose2 {
    pub const fn new(x: f64, y: f64, theta: f64) -> Self {
        Self { x, y, theta }
    }

    /// `self * other`: `other` expressed in the frame of `self`, mapped to the parent frame.
    pub fn compose(&self, other: &Pose2) -> Pose2 {
        let (s, c) = self.theta.sin_cos();
        Pose2 {
            x: self.x + c * other.x - s * other.y,
            y: self.y + s * other.x + c * other.y,
            theta: wrap_angle(self.theta + other.theta),
        }
    }

    pub fn inverse(&self) -> Pose2 {
        let (s, c) = self.theta.sin_cos();
        Pose2 {
            x: -c * self.x - s * self.y,
            y: s * self.x - c * self.y,
            theta: wrap_angle(-self.theta),
        }
    }

    /// Maps a point given in this pose's frame to the parent frame.
    #[inline]
    pub fn transform_point(&self, px: f64, py: f64) -> (f64, f64) {
        let (s, c) = self.theta.sin_cos();
        (self.x + c * px - s * py, self.y + s * px + c * py)
    }

    /// Maps a point given in the parent frame into this pose's frame.
    #[inline]
    pub fn inverse_transform_point(&self, px: f64, py: f64) -> (f64, f64) {
        let (s, c) = self.theta.sin_cos();
        let dx = px - self.x;
        let dy = py - self.y;
        (c * dx + s * dy, -s * dx + c * dy)
    }

    pub fn distance(&self, other: &Pose2) -> f64 {
        (self.x - other.x).hypot(self.y - other.y)
    }

    /// Absolute heading difference, wrapped to [0, pi].
    pub fn heading_error(&self, other: &Pose2) -> f64 {
        wrap_angle(self.theta - other.theta).abs()
    }

    pub fn is_finite(&self) -> bool {
        self.x.is_finite() && self.y.is_finite() && self.theta.is_finite()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wrap_stays_in_half_open_interval() {
        for k in -20..=20 {
            let a = k as f64 * 0.7;
            let w = wrap_angle(a);
            assert!(w > -std::f64::consts::PI - 1e-12 && w <= std::f64::consts::PI + 1e-12);
            assert!(
                ((a - w) / std::f64::consts::TAU).round() * std::f64::consts::TAU - (a - w) < 1e-9
            );
        }
        assert_eq!(wrap_angle(std::f64::consts::PI), std::f64::consts::PI);
        // The same bits as the remainder it skips, at the ends of a turn and beyond.
        let tau = std::f64::consts::TAU;
        for a in [
            0.0,
            -0.0,
            tau.next_down(),
            -tau.next_down(),
            tau,
            -tau,
            tau.next_up(),
            1e-300,
            3.0 * tau + 0.1,
            -7.5,
            f64::MAX,
        ] {
            let mut r = a % tau;
            if r > std::f64::consts::PI {
                r -= tau;
            } else if r <= -std::f64::consts::PI {
                r += tau;
            }
            assert_eq!(wrap_angle(a).to_bits(), r.to_bits(), "{a}");
        }
        assert!(wrap_angle(f64::NAN).is_nan() && wrap_angle(f64::INFINITY).is_nan());
    }

    #[test]
    fn compose_with_inverse_is_identity() {
        let p = Pose2::new(1.5, -2.0, 0.8);
        let q = p.compose(&p.inverse());
        assert!(q.x.abs() < 1e-12 && q.y.abs() < 1e-12 && q.theta.abs() < 1e-12);
        let (x, y) = p.transform_point(0.3, 0.4);
        let (bx, by) = p.inverse_transform_point(x, y);
        assert!((bx - 0.3).abs() < 1e-12 && (by - 0.4).abs() < 1e-12);
    }
}
