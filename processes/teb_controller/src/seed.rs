//! The band a step starts from: a new band along the reference from the robot to the
//! local goal, a warm band extended to the new local goal, and the resizing of either
//! around the reference time step. Knows nothing of costs or the optimiser.

use aisle_geometry::{Direction, Pose2, wrap_angle};

use crate::band::Band;
use crate::config::TebConfig;
use crate::leg::Leg;
use crate::reference::Reference;

/// Resizes the band around the reference time step (with hysteresis) and splits it up
/// to the minimum number of poses.
pub(crate) fn resize(band: &mut Band, cfg: &TebConfig) {
    let b = &cfg.band;
    band.resize(&b.steps(), b.min_poses, b.max_poses);
    ensure_min_poses(band, b.min_poses);
}

/// Splits the longest segment until the band has `min_poses` poses.
fn ensure_min_poses(band: &mut Band, min_poses: usize) {
    while band.poses.len() < min_poses && !band.dts.is_empty() {
        let (k, _) =
            band.dts.iter().enumerate().fold(
                (0, f64::MIN),
                |acc, (i, &t)| if t > acc.1 { (i, t) } else { acc },
            );
        let a = band.poses[k];
        let b = band.poses[k + 1];
        band.poses.insert(
            k + 1,
            Pose2::new(
                0.5 * (a.x + b.x),
                0.5 * (a.y + b.y),
                0.5 * (a.theta + b.theta),
            ),
        );
        let t = band.dts[k];
        band.dts[k] = 0.5 * t;
        band.dts.insert(k + 1, 0.5 * t);
    }
}

/// Appends reference poses between the band's end and the leg's local goal. Returns
/// false when the band no longer fits the reference (then it is rebuilt).
pub(crate) fn extend(band: &mut Band, reference: &Reference, leg: &Leg, cfg: &TebConfig) -> bool {
    let sec = &leg.section;
    let end = band.poses[band.poses.len() - 1];
    let pe = reference.project(sec, end.x, end.y, leg.s_lo - 1.0, leg.s_hi + 1.0);
    let s_goal = leg.s_hi - 1.0;
    if pe.distance > cfg.band.reinit_distance || pe.s > s_goal + cfg.band.reinit_distance {
        return false;
    }
    let vlim = cfg.limits.speed_limit(sec.direction);
    let ds = vlim * cfg.band.dt_ref;
    let gap = s_goal - pe.s;
    if gap < 0.25 * ds {
        return true;
    }
    let n = (gap / ds).ceil() as usize;
    for j in 1..=n {
        if band.poses.len() >= cfg.band.max_poses {
            break;
        }
        let p = if j == n {
            leg.goal
        } else {
            reference.sample(sec, pe.s + gap * j as f64 / n as f64)
        };
        let prev = band.poses[band.poses.len() - 1];
        let dt = (prev.distance(&p) / vlim)
            .max(wrap_angle(p.theta - prev.theta).abs() / cfg.limits.max_angular_velocity)
            .max(cfg.band.dt_ref);
        band.poses.push(p);
        band.dts.push(dt);
    }
    true
}

/// A band along the reference from the robot to the leg's local goal, timed by a
/// trapezoidal speed profile from the measured speed `v0` (or, on the spot, by the
/// turn rate).
pub(crate) fn init_band(
    band: &mut Band,
    reference: &Reference,
    leg: &Leg,
    robot: &Pose2,
    v0: f64,
    cfg: &TebConfig,
) {
    let vlim = cfg.limits.speed_limit(leg.section.direction);
    init_band_at(band, reference, leg, robot, v0, vlim, cfg);
}

/// [`init_band`] with its cruise speed capped at `vlim`, m/s.
pub(crate) fn init_band_at(
    band: &mut Band,
    reference: &Reference,
    leg: &Leg,
    robot: &Pose2,
    v0: f64,
    vlim: f64,
    cfg: &TebConfig,
) {
    band.clear();
    band.poses.push(*robot);
    if leg.section.direction == Direction::Rotate {
        turn_on_the_spot(band, robot, &leg.goal, cfg);
        return;
    }
    let lim = &cfg.limits;
    let b = &cfg.band;
    let (sec, goal, s_robot, at_rest) = (&leg.section, &leg.goal, leg.s_robot, leg.at_rest);
    let vlim = vlim.min(lim.speed_limit(sec.direction));
    let s_end = reference
        .project(
            sec,
            goal.x,
            goal.y,
            s_robot,
            s_robot + cfg.look_ahead_distance() + 1.0,
        )
        .s;
    let length = (s_end - s_robot).max(0.0);
    let ds = vlim * b.dt_ref;
    let n = ((length / ds).ceil() as usize).clamp(b.min_poses - 1, b.max_poses - 1);
    let speed_at = |s: f64| -> f64 {
        let mut v = vlim.min((v0 * v0 + 2.0 * lim.max_acceleration * s).sqrt());
        if at_rest {
            v = v.min((2.0 * lim.max_acceleration * (length - s).max(0.0)).sqrt());
        }
        v.max(0.2 * vlim)
    };
    for j in 1..=n {
        let s = length * j as f64 / n as f64;
        let p = if j == n {
            *goal
        } else {
            reference.sample(sec, s_robot + s)
        };
        let prev = band.poses[band.poses.len() - 1];
        let s_prev = length * (j - 1) as f64 / n as f64;
        let v = 0.5 * (speed_at(s_prev) + speed_at(s));
        let dt = (prev.distance(&p) / v)
            .max(wrap_angle(p.theta - prev.theta).abs() / (0.8 * lim.max_angular_velocity))
            .max(b.min_dt * 2.0);
        band.poses.push(p);
        band.dts.push(dt);
    }
}

/// The poses of a turn on the spot from `robot` (already in `band`) to the heading of
/// `goal`, at 70 % of the turn-rate limit.
fn turn_on_the_spot(band: &mut Band, robot: &Pose2, goal: &Pose2, cfg: &TebConfig) {
    let lim = &cfg.limits;
    let b = &cfg.band;
    let turn = wrap_angle(goal.theta - robot.theta);
    let n = ((turn.abs() / (0.7 * lim.max_angular_velocity * b.dt_ref)).ceil() as usize)
        .clamp(b.min_poses - 1, b.max_poses - 1);
    let dt = (turn.abs() / n as f64 / (0.7 * lim.max_angular_velocity)).max(b.dt_ref);
    for j in 1..=n {
        let u = j as f64 / n as f64;
        band.poses
            .push(Pose2::new(robot.x, robot.y, robot.theta + u * turn));
        band.dts.push(dt);
    }
}
