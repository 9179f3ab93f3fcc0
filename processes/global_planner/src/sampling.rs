//! Turns a chain of motions into path poses about `spacing` metres apart (rotations on
//! the spot in steps of at most `rotation_step` radians). Each pose carries the direction
//! of the motion that leaves it; the last pose repeats the direction of the last motion.
//! Knows nothing of search or collision.

use crate::motion::Motion;
use aisle_geometry::{Direction, PathPose, Pose2};

/// Appends the poses of `motion` from `from`, excluding its end pose.
pub(crate) fn append_motion(
    out: &mut Vec<PathPose>,
    from: &Pose2,
    motion: &Motion,
    spacing: f64,
    rotation_step: f64,
) {
    let dir = motion.direction(from);
    let n = match *motion {
        Motion::Rotate { angle } => (angle.abs() / rotation_step).ceil(),
        _ => (motion.travel(from) / spacing).ceil(),
    }
    .max(1.0) as usize;
    for k in 0..n {
        out.push(PathPose::new(motion.at(from, k as f64 / n as f64), dir));
    }
}

/// Closes a path: appends `end` with the direction of the pose before it.
pub(crate) fn finish(out: &mut Vec<PathPose>, end: Pose2) {
    let dir = out.last().map_or(Direction::Forward, |p| p.direction);
    out.push(PathPose::new(end, dir));
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spacing_and_directions() {
        let mut out = Vec::new();
        let o = Pose2::default();
        let m = Motion::Drive {
            length: -0.35,
            curvature: 0.0,
        };
        append_motion(&mut out, &o, &m, 0.1, 0.1);
        let e = m.end(&o);
        let r = Motion::Rotate { angle: 0.25 };
        append_motion(&mut out, &e, &r, 0.1, 0.1);
        finish(&mut out, r.end(&e));
        assert_eq!(out.len(), 4 + 3 + 1);
        assert!(out[..4].iter().all(|p| p.direction == Direction::Reverse));
        assert!(out[4..].iter().all(|p| p.direction == Direction::Rotate));
        assert!((out[1].pose.x + 0.0875).abs() < 1e-12);
    }
}
