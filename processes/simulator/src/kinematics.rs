//! Differential-drive kinematics: (v, w) -> clamped wheel speeds -> applied (v, w),
//! and the exact pose update for a constant twist.
//!
//! Model (as the seed, MATLAB's differential-drive kinematics with speed and
//! heading-rate inputs). With d = track / 2 and r = wheel radius:
//!
//! ```text
//! wL = (v - w d) / r          wR = (v + w d) / r
//! wL, wR clamped each to [-limit, +limit]
//! v' = r (wR + wL) / 2        w' = r (wR - wL) / (2 d)
//! ```
//!
//! Clamping each wheel separately (not scaling both) can change the turning radius:
//! this is the seed's behaviour and is kept.
//!
//! Integration is exact for a constant (v, w) held over dt: the robot moves along a
//! circular arc. Written as chord length times the direction of the chord,
//!
//! ```text
//! dth = w dt
//! chord = v dt sinc(dth / 2)        (sinc(a) = sin(a) / a)
//! x += chord cos(th + dth / 2)      y += chord sin(th + dth / 2)      th += dth
//! ```
//!
//! which equals the textbook `(v / w)(sin(th + dth) - sin th)` form but has no
//! division by w, so a straight line (w = 0) and a tiny w need no special case and
//! suffer no cancellation; sinc uses its Taylor series near 0.
//!
//! Knows nothing of time stamps, commands or the world.

use aisle_geometry::{Pose2, wrap_angle};
use aisle_robot::KinematicsConfig;

/// Wheel angular speeds, rad/s (positive drives the robot forward).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct WheelSpeeds {
    pub left: f64,
    pub right: f64,
}

/// Body twist: forward speed (m/s) and heading rate (rad/s, counter-clockwise).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Twist {
    pub v: f64,
    pub w: f64,
}

/// The outcome of pushing a commanded twist through the wheels.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Applied {
    pub wheels: WheelSpeeds,
    pub twist: Twist,
    /// Whether either wheel hit its limit.
    pub clamped: bool,
}

/// A differential drive with symmetric wheel-speed limits.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DiffDrive {
    half_track: f64,
    radius: f64,
    limit: f64,
}

impl DiffDrive {
    /// The numbers are validated by `RobotConfig`'s `Validate` impl (aisle-robot).
    pub fn new(cfg: &KinematicsConfig) -> Self {
        Self {
            half_track: 0.5 * cfg.track_width,
            radius: cfg.wheel_radius,
            limit: cfg.wheel_speed_limit,
        }
    }

    /// Unclamped wheel speeds for a twist.
    pub fn wheel_speeds(&self, cmd: Twist) -> WheelSpeeds {
        WheelSpeeds {
            left: (cmd.v - cmd.w * self.half_track) / self.radius,
            right: (cmd.v + cmd.w * self.half_track) / self.radius,
        }
    }

    /// The twist produced by given wheel speeds.
    pub fn twist(&self, wheels: WheelSpeeds) -> Twist {
        Twist {
            v: self.radius * (wheels.right + wheels.left) * 0.5,
            w: self.radius * (wheels.right - wheels.left) / (2.0 * self.half_track),
        }
    }

    /// Commanded twist -> clamped wheels -> applied twist. A non-finite command
    /// applies nothing (both wheels stopped) rather than poisoning the pose.
    pub fn apply(&self, cmd: Twist) -> Applied {
        if !(cmd.v.is_finite() && cmd.w.is_finite()) {
            return Applied {
                clamped: true,
                ..Applied::default()
            };
        }
        let raw = self.wheel_speeds(cmd);
        let wheels = WheelSpeeds {
            left: raw.left.clamp(-self.limit, self.limit),
            right: raw.right.clamp(-self.limit, self.limit),
        };
        Applied {
            wheels,
            twist: self.twist(wheels),
            clamped: wheels != raw,
        }
    }
}

/// sin(a) / a, accurate near 0.
fn sinc(a: f64) -> f64 {
    if a.abs() < 1e-4 {
        // Next term a^4 / 120 < 1e-18: below f64 resolution relative to 1.
        1.0 - a * a / 6.0
    } else {
        a.sin() / a
    }
}

/// Pose after holding `twist` for `dt` seconds from `pose` (exact circular arc).
pub fn integrate(pose: &Pose2, twist: Twist, dt: f64) -> Pose2 {
    let dth = twist.w * dt;
    let chord = twist.v * dt * sinc(0.5 * dth);
    let (s, c) = (pose.theta + 0.5 * dth).sin_cos();
    Pose2 {
        x: pose.x + chord * c,
        y: pose.y + chord * s,
        theta: wrap_angle(pose.theta + dth),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::{PI, TAU};

    fn seed() -> DiffDrive {
        DiffDrive::new(&KinematicsConfig::default())
    }

    fn close(a: f64, b: f64, tol: f64) -> bool {
        (a - b).abs() <= tol
    }

    #[test]
    fn seed_max_speed_command_needs_no_clamping() {
        // v = 2, w = 1: wL = (2 - 0.18825) / 0.065 = 27.8731, wR = 2.18825 / 0.065 = 33.6654.
        let a = seed().apply(Twist { v: 2.0, w: 1.0 });
        assert!(close(a.wheels.left, 1.81175 / 0.065, 1e-12));
        assert!(close(a.wheels.right, 2.18825 / 0.065, 1e-12));
        assert!(a.wheels.right < 34.0 && !a.clamped);
        assert!(close(a.twist.v, 2.0, 1e-12) && close(a.twist.w, 1.0, 1e-12));
    }

    #[test]
    fn one_wheel_clamps() {
        // v = 2.2, w = 1: wR = 2.38825 / 0.065 = 36.742 -> 34; wL = 2.01175 / 0.065 = 30.950.
        let a = seed().apply(Twist { v: 2.2, w: 1.0 });
        let wl = 2.01175 / 0.065;
        assert!(a.clamped);
        assert_eq!(a.wheels.right, 34.0);
        assert!(close(a.wheels.left, wl, 1e-12));
        // v' = 0.065 (34 + 30.950) / 2 = 2.11088; w' = (2.21 - 2.01175) / 0.3765 = 0.526560.
        assert!(close(a.twist.v, 0.065 * (34.0 + wl) / 2.0, 1e-12));
        assert!(close(a.twist.v, 2.110875, 1e-6), "{}", a.twist.v);
        assert!(close(a.twist.w, 0.065 * (34.0 - wl) / 0.3765, 1e-12));
        assert!(close(a.twist.w, 0.526560, 1e-6), "{}", a.twist.w);
    }

    #[test]
    fn both_wheels_clamp_when_spinning_in_place() {
        // w = 20: |wheel| = 20 * 0.18825 / 0.065 = 57.92 -> 34 each, w' = 0.065 * 68 / 0.3765.
        let a = seed().apply(Twist { v: 0.0, w: 20.0 });
        assert_eq!(
            a.wheels,
            WheelSpeeds {
                left: -34.0,
                right: 34.0
            }
        );
        assert_eq!(a.twist.v, 0.0);
        assert!(close(a.twist.w, 0.065 * 68.0 / 0.3765, 1e-12));
        // Reverse flat out.
        let b = seed().apply(Twist { v: -5.0, w: 0.0 });
        assert_eq!(
            b.wheels,
            WheelSpeeds {
                left: -34.0,
                right: -34.0
            }
        );
        assert!(close(b.twist.v, -34.0 * 0.065, 1e-12));
    }

    #[test]
    fn non_finite_command_stops_the_wheels() {
        let a = seed().apply(Twist {
            v: f64::NAN,
            w: 0.0,
        });
        assert_eq!(a.twist, Twist::default());
        assert!(a.clamped);
    }

    #[test]
    fn straight_line_and_tiny_turn_rate() {
        let p = Pose2::new(1.0, 2.0, PI / 6.0);
        let q = integrate(&p, Twist { v: 1.5, w: 0.0 }, 0.1);
        assert!(close(q.x, 1.0 + 0.15 * (PI / 6.0).cos(), 1e-15));
        assert!(close(q.y, 2.0 + 0.15 * (PI / 6.0).sin(), 1e-15));
        assert_eq!(q.theta, p.theta);
        let t = integrate(&p, Twist { v: 1.5, w: 1e-13 }, 0.1);
        assert!(close(t.x, q.x, 1e-15) && close(t.y, q.y, 1e-15));
    }

    #[test]
    fn arc_matches_the_closed_form() {
        let p = Pose2::new(-0.5, 0.25, 0.3);
        let (v, w, dt) = (0.8, 0.7, 0.37);
        let q = integrate(&p, Twist { v, w }, dt);
        let r = v / w;
        let th = p.theta + w * dt;
        assert!(close(q.x, p.x + r * (th.sin() - p.theta.sin()), 1e-14));
        assert!(close(q.y, p.y - r * (th.cos() - p.theta.cos()), 1e-14));
        assert!(close(q.theta, th, 1e-15));
        // Near the sinc switch both branches agree.
        for w in [0.99e-3, 1.01e-3] {
            let q = integrate(&p, Twist { v, w }, 0.2);
            let th = p.theta + w * 0.2;
            assert!(close(q.x, p.x + v / w * (th.sin() - p.theta.sin()), 1e-12));
        }
    }

    #[test]
    fn a_full_circle_in_many_steps_returns_to_the_start() {
        let start = Pose2::new(3.0, -1.0, 1.0);
        let steps = 63;
        let dt = 0.1;
        let w = TAU / (steps as f64 * dt);
        let mut p = start;
        let mut max_r: f64 = 0.0;
        for _ in 0..steps {
            p = integrate(&p, Twist { v: 1.0, w }, dt);
            max_r = max_r.max(p.distance(&start));
        }
        assert!(p.distance(&start) < 1e-12, "{p:?}");
        assert!(p.heading_error(&start) < 1e-12);
        // The circle's diameter is 2 v / w.
        assert!(close(max_r, 2.0 / w, 0.01), "{max_r}");
    }
}
