//! Elementary motions of a differential-drive robot in the plane: driving a constant
//! curvature arc (or a straight line) forward or backward, turning on the spot, and the
//! straight interpolation between two path poses that tests and validators sweep along.
//!
//! Knows nothing of grids, costs or search; every motion is a pure function of its start
//! pose and a fraction in [0, 1], so samples are reproducible bit for bit.

// Bit for bit `aisle_geometry::wrap_angle`, without its `fmod` call within one turn.
use crate::angle::wrap as wrap_angle;
use aisle_geometry::{Direction, Pose2};

/// One motion with constant controls.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Motion {
    /// Drive `length` metres along the path (negative: backwards) with constant
    /// `curvature` (1/m, positive turns left; 0 is a straight line).
    Drive { length: f64, curvature: f64 },
    /// Turn on the spot by `angle` radians (positive: counter-clockwise).
    Rotate { angle: f64 },
    /// Move in a straight line from the start pose to `to`, heading interpolated along
    /// the shorter way round. Used to sweep between consecutive path poses.
    Lerp { to: Pose2 },
}

impl Motion {
    /// The pose reached after the fraction `s` in [0, 1] of the motion.
    #[inline]
    pub fn at(&self, from: &Pose2, s: f64) -> Pose2 {
        match *self {
            Motion::Drive { length, curvature } => {
                drive_at(from, length, curvature, s, from.theta.sin_cos())
            }
            Motion::Rotate { angle } => {
                Pose2::new(from.x, from.y, wrap_angle(from.theta + angle * s))
            }
            Motion::Lerp { to } => {
                let dth = wrap_angle(to.theta - from.theta);
                Pose2::new(
                    from.x + (to.x - from.x) * s,
                    from.y + (to.y - from.y) * s,
                    wrap_angle(from.theta + dth * s),
                )
            }
        }
    }

    /// The pose at the end of the motion.
    #[inline]
    pub fn end(&self, from: &Pose2) -> Pose2 {
        match *self {
            Motion::Lerp { to } => to,
            _ => self.at(from, 1.0),
        }
    }

    /// [`Motion::at`] with `turn`, the sine and cosine of `from.theta`, given: a sweep
    /// samples many fractions of one motion, and an expansion many motions from one
    /// pose. The same bits as `at`.
    #[inline]
    pub(crate) fn at_turned(&self, from: &Pose2, s: f64, turn: (f64, f64)) -> Pose2 {
        match *self {
            Motion::Drive { length, curvature } => drive_at(from, length, curvature, s, turn),
            _ => self.at(from, s),
        }
    }

    /// [`Motion::end`] with the sine and cosine of `from.theta` given.
    #[inline]
    pub(crate) fn end_turned(&self, from: &Pose2, turn: (f64, f64)) -> Pose2 {
        match *self {
            Motion::Lerp { to } => to,
            _ => self.at_turned(from, 1.0, turn),
        }
    }

    /// Which way the robot moves during the motion.
    pub fn direction(&self, from: &Pose2) -> Direction {
        match *self {
            Motion::Drive { length, .. } => {
                if length < 0.0 {
                    Direction::Reverse
                } else {
                    Direction::Forward
                }
            }
            Motion::Rotate { .. } => Direction::Rotate,
            Motion::Lerp { to } => {
                let (dx, dy) = (to.x - from.x, to.y - from.y);
                if dx.hypot(dy) < 1e-12 {
                    Direction::Rotate
                } else if dx * from.theta.cos() + dy * from.theta.sin() < 0.0 {
                    Direction::Reverse
                } else {
                    Direction::Forward
                }
            }
        }
    }

    /// Distance travelled by the reference point.
    pub fn travel(&self, from: &Pose2) -> f64 {
        match *self {
            Motion::Drive { length, .. } => length.abs(),
            Motion::Rotate { .. } => 0.0,
            Motion::Lerp { to } => from.distance(&to),
        }
    }

    /// Absolute heading change over the motion.
    pub fn turn(&self, from: &Pose2) -> f64 {
        match *self {
            Motion::Drive { length, curvature } => (length * curvature).abs(),
            Motion::Rotate { angle } => angle.abs(),
            Motion::Lerp { to } => wrap_angle(to.theta - from.theta).abs(),
        }
    }

    /// Upper bound on how far any body point within `body_radius` of the reference point
    /// moves over the whole motion. The bound is linear in the fraction, so a fraction
    /// step `ds` moves no body point farther than `ds * sweep_bound`.
    pub fn sweep_bound(&self, from: &Pose2, body_radius: f64) -> f64 {
        self.travel(from) + body_radius * self.turn(from)
    }
}

/// A pose's bits, to know a result computed from it again.
#[inline]
pub(crate) fn pose_bits(p: &Pose2) -> [u64; 3] {
    [p.x.to_bits(), p.y.to_bits(), p.theta.to_bits()]
}

/// The pose after the fraction `s` of driving `length` at `curvature` from `from`, whose
/// heading has the sine and cosine `(sn, cs)`.
#[inline]
fn drive_at(from: &Pose2, length: f64, curvature: f64, s: f64, (sn, cs): (f64, f64)) -> Pose2 {
    let d = length * s;
    let dth = d * curvature;
    let (lx, ly) = if curvature.abs() < 1e-12 {
        (d, 0.0)
    } else {
        (dth.sin() / curvature, (1.0 - dth.cos()) / curvature)
    };
    Pose2::new(
        from.x + cs * lx - sn * ly,
        from.y + sn * lx + cs * ly,
        wrap_angle(from.theta + dth),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::FRAC_PI_2;

    #[test]
    fn quarter_arc_ends_where_geometry_says() {
        let m = Motion::Drive {
            length: FRAC_PI_2,
            curvature: 1.0,
        };
        let e = m.end(&Pose2::new(1.0, 0.0, 0.0));
        assert!((e.x - 2.0).abs() < 1e-12 && (e.y - 1.0).abs() < 1e-12);
        assert!((e.theta - FRAC_PI_2).abs() < 1e-12);
        let back = Motion::Drive {
            length: -FRAC_PI_2,
            curvature: 1.0,
        }
        .end(&e);
        assert!((back.x - 1.0).abs() < 1e-12 && back.y.abs() < 1e-12 && back.theta.abs() < 1e-12);
    }

    #[test]
    fn sweep_bound_dominates_corner_motion() {
        let from = Pose2::new(0.0, 0.0, 0.3);
        let m = Motion::Drive {
            length: 0.4,
            curvature: -1.5,
        };
        let rho = 0.5_f64.hypot(0.3);
        let bound = m.sweep_bound(&from, rho);
        for k in 0..10 {
            let a = m.at(&from, k as f64 / 10.0);
            let b = m.at(&from, (k + 1) as f64 / 10.0);
            let (ax, ay) = a.transform_point(0.5, 0.3);
            let (bx, by) = b.transform_point(0.5, 0.3);
            assert!((ax - bx).hypot(ay - by) <= bound / 10.0 + 1e-12);
        }
        assert_eq!(m.direction(&from), Direction::Forward);
        assert_eq!(
            Motion::Rotate { angle: 1.0 }.direction(&from),
            Direction::Rotate
        );
    }
}
