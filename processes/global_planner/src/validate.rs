//! Public checks of a finished path, independent of the search: every pose sampled at
//! most `step` apart (linear interpolation between path poses) keeps the footprint off
//! occupied cells, and consecutive driving poses respect a minimum turning radius.
//! Usable by tests and by the supervisor on paths from anywhere.

use crate::collision::footprint_hits;
use crate::motion::Motion;
use aisle_geometry::{Direction, Footprint, GridView, PathPose, Pose2};

/// Whether `footprint` grown by `margin` at `at` touches an occupied cell of `map` or
/// leaves it: the rule the planner refuses a start or a goal by (a start with no margin
/// at all, since it relieves the margin around the start).
pub fn footprint_touches(map: &GridView, footprint: Footprint, margin: f64, at: &Pose2) -> bool {
    footprint_hits(map, &footprint.inflated(margin), at)
}

/// Where and why a path is not valid.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum PathViolation {
    #[error("the path is empty")]
    Empty,
    #[error("bad arguments (step, footprint, margin or map)")]
    BadArguments,
    #[error("pose {index} is not finite")]
    NotFinite { index: usize },
    #[error("collision between path poses {index} and {} at {at:?}", index + 1)]
    Collision { index: usize, at: Pose2 },
    #[error("turn between poses {index} and {} is tighter than the minimum radius", index + 1)]
    TooTight { index: usize },
}

/// Checks the footprint grown by `margin` at the path poses and at interpolated poses no
/// more than `step` metres (or `step` radians when turning on the spot) apart.
pub fn validate_path(
    path: &[PathPose],
    footprint: Footprint,
    margin: f64,
    map: &GridView,
    step: f64,
) -> Result<(), PathViolation> {
    if path.is_empty() {
        return Err(PathViolation::Empty);
    }
    let args_ok = step.is_finite()
        && step > 0.0
        && margin.is_finite()
        && margin >= 0.0
        && footprint.length.is_finite()
        && footprint.width.is_finite()
        && footprint.length > 0.0
        && footprint.width > 0.0
        && map.cells.len() == map.width * map.height
        && map.resolution.is_finite()
        && map.resolution > 0.0
        && map.origin_x.is_finite()
        && map.origin_y.is_finite();
    if !args_ok {
        return Err(PathViolation::BadArguments);
    }
    let fp = footprint.inflated(margin);
    for (i, p) in path.iter().enumerate() {
        if !p.pose.is_finite() {
            return Err(PathViolation::NotFinite { index: i });
        }
    }
    if footprint_hits(map, &fp, &path[0].pose) {
        return Err(PathViolation::Collision {
            index: 0,
            at: path[0].pose,
        });
    }
    for (i, w) in path.windows(2).enumerate() {
        let a = w[0].pose;
        let m = Motion::Lerp { to: w[1].pose };
        let n = ((m.travel(&a) / step).max(m.turn(&a) / step).ceil() as usize).max(1);
        for k in 1..=n {
            let p = m.at(&a, k as f64 / n as f64);
            if footprint_hits(map, &fp, &p) {
                return Err(PathViolation::Collision { index: i, at: p });
            }
        }
    }
    Ok(())
}

/// Checks that no driving step of the path turns tighter than `radius`: for consecutive
/// poses a, b with a not a rotation, the chord |ab| must be at least the chord of an arc
/// of radius `radius` through the same heading change, `2 r sin(|dtheta| / 2)`.
pub fn check_turning_radius(path: &[PathPose], radius: f64) -> Result<(), PathViolation> {
    for (i, w) in path.windows(2).enumerate() {
        if w[0].direction == Direction::Rotate {
            continue;
        }
        let dth = aisle_geometry::wrap_angle(w[1].pose.theta - w[0].pose.theta).abs();
        let chord = w[0].pose.distance(&w[1].pose);
        if 2.0 * radius * (0.5 * dth).sin() > chord * (1.0 + 1e-6) + 1e-9 {
            return Err(PathViolation::TooTight { index: i });
        }
    }
    Ok(())
}
