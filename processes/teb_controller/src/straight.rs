//! Straight moves ([`crate::Mode::Straight`]): docking under a rack between its legs and
//! undocking out of it, where the optimiser, its grid-inflated margin and its 0.3 s
//! poses cannot thread 0.135 m a side.
//!
//! One step rolls a command timeline out from the robot's pose and measured velocity
//! with the unicycle model ([`crate::kinematics::integrate`]) every `straight.step`
//! seconds: turn on the spot first when the heading is more than `straight.turn_first`
//! off the line, then pure pursuit of a carrot `straight.look_ahead` ahead on the line
//! at `straight.speed`, forwards when the target lies ahead of the robot's projection
//! on the line and backwards otherwise (the heading stays the line's), braking to stop
//! at the target within `[limits]`. The timeline covers `band.look_ahead_time` or ends
//! at rest at the target.
//!
//! Safety: every rolled-out pose is checked against the local map with the goal's
//! footprint grown by `straight.margin` (cells as exact squares). An overlap within
//! the robot's stopping distance (or at a standstill) stops it: exit flag Collision
//! and a single zero command. One farther away cuts the timeline short, ending at rest
//! before it (flag Valid while the robot still gets somewhere; Collision once it cannot).
//! A robot already inside the margin (it stopped there) is held to the bare footprint,
//! so it can leave instead of freezing.
//!
//! Knows nothing of bands, the optimiser or the bus; writes into the caller's reused
//! [`StepOutput`] and allocates nothing.

use aisle_geometry::{Footprint, GridView, Pose2, wrap_angle};

use crate::clearance::overlaps_occupied;
use crate::config::TebConfig;
use crate::kinematics::integrate;
use crate::output::{Command, ExitFlag, MAX_COMMANDS, StepOutput, TimedPose};

/// Remaining distance below which the robot counts as at the target along the line, m.
const ARRIVED: f64 = 1e-4;
/// Heading error below which a turn on the spot is done, rad.
const TURNED: f64 = 1e-3;
/// Share of the acceleration limit planned for braking: the rest absorbs the
/// discretisation of the braking curve, so the limit itself is never exceeded.
const BRAKING_SHARE: f64 = 0.5;
/// A timeline cut short before an obstacle stops this far before the first blocked
/// pose, m.
const STOP_BEFORE: f64 = 0.005;
/// A cut timeline that gets the robot less far than this is no progress, m.
const MIN_PROGRESS: f64 = 0.02;
/// Measured speeds below which the robot counts as standing (m/s, rad/s).
const STANDING: (f64, f64) = (1e-3, 1e-2);

/// The line and how to drive it.
#[derive(Debug, Clone, Copy)]
struct Line {
    target: Pose2,
    /// +1 forwards, -1 backwards.
    sign: f64,
}

impl Line {
    /// The line through `target`, driven forwards when the target lies ahead of the
    /// projection of `pose` (or at it), backwards otherwise.
    fn new(target: Pose2, pose: &Pose2) -> Line {
        let forwards = Line { target, sign: 1.0 };
        let sign = if forwards.along(pose) <= 0.0 {
            1.0
        } else {
            -1.0
        };
        Line { target, sign }
    }

    /// The robot's signed coordinate along the line, from the target (negative: the
    /// target lies ahead in the line's direction).
    fn along(&self, p: &Pose2) -> f64 {
        let (s, c) = self.target.theta.sin_cos();
        c * (p.x - self.target.x) + s * (p.y - self.target.y)
    }

    /// Distance still to drive along the line in the drive direction (0 when past).
    fn remaining(&self, p: &Pose2) -> f64 {
        (-self.sign * self.along(p)).max(0.0)
    }

    /// Pure-pursuit turn rate at speed `speed` (>= 0): the arc through the carrot
    /// `look_ahead` ahead of the projection on the line, in the frame of the motion
    /// (turned by pi when reversing; a turn rate is the same in both frames).
    fn pursuit(&self, p: &Pose2, look_ahead: f64, speed: f64) -> f64 {
        let (s, c) = self.target.theta.sin_cos();
        let a = self.along(p) + self.sign * look_ahead;
        let (dx, dy) = (self.target.x + a * c - p.x, self.target.y + a * s - p.y);
        let (sm, cm) = p.theta.sin_cos();
        let (sm, cm) = (self.sign * sm, self.sign * cm);
        let xm = cm * dx + sm * dy;
        let ym = -sm * dx + cm * dy;
        let d2 = xm * xm + ym * ym;
        if d2 < 1e-12 {
            return 0.0;
        }
        speed * 2.0 * ym / d2
    }
}

/// Moves `from` towards `to` by at most `step`.
fn ramp(from: f64, to: f64, step: f64) -> f64 {
    from + (to - from).clamp(-step, step)
}

/// Speed with which braking at `decel` stops within `d` and within one step of `dt`.
fn braking_speed(d: f64, decel: f64, dt: f64) -> f64 {
    (2.0 * decel * d).sqrt().min(d / dt)
}

/// What a rollout did.
#[derive(Debug, Clone, Copy)]
struct Rolled {
    /// Path length driven, m.
    travel: f64,
    /// Heading turned, rad (absolute sum).
    turned: f64,
}

/// Rolls the timeline out into `out` (poses from the robot's, commands from `t0`),
/// driving at most `max_travel` metres. Ends at rest once nothing is left to do, or
/// at the horizon still moving.
fn roll(
    cfg: &TebConfig,
    line: &Line,
    heading_tolerance: f64,
    start: (Pose2, f64, f64),
    t0: f64,
    max_travel: f64,
    out: &mut StepOutput,
) -> Rolled {
    let st = &cfg.straight;
    let lim = &cfg.limits;
    let dt = st.step;
    let (dv, dw) = (lim.max_acceleration * dt, lim.max_angular_acceleration * dt);
    let (decel, alpha) = (
        BRAKING_SHARE * lim.max_acceleration,
        BRAKING_SHARE * lim.max_angular_acceleration,
    );
    let steps = ((cfg.band.look_ahead_time / dt).ceil() as usize).min(MAX_COMMANDS - 1);
    let (mut p, mut v, mut w) = start;
    out.commands.clear();
    out.poses.clear();
    out.poses.push(TimedPose { t: t0, pose: p });
    let heading_error = |p: &Pose2| wrap_angle(p.theta - line.target.theta);
    let mut turning = heading_error(&p).abs() > st.turn_first;
    let mut done = Rolled {
        travel: 0.0,
        turned: 0.0,
    };
    for k in 0..steps {
        let t = t0 + k as f64 * dt;
        let to_go = line.remaining(&p);
        let d = if to_go <= ARRIVED {
            0.0
        } else {
            to_go.min((max_travel - done.travel).max(0.0))
        };
        let eh = heading_error(&p);
        // At the target with the heading off: turn on the spot once stopped.
        if to_go <= ARRIVED && v == 0.0 && eh.abs() > 0.5 * heading_tolerance {
            turning = true;
        }
        if turning && eh.abs() <= TURNED && w.abs() <= dw {
            turning = false;
        }
        let (vc, wc) = if turning {
            let rate = lim
                .max_angular_velocity
                .min(braking_speed(eh.abs(), alpha, dt));
            (ramp(v, 0.0, dv), ramp(w, -eh.signum() * rate, dw))
        } else {
            let speed = st.speed.min(braking_speed(d, decel, dt));
            let vc = ramp(v, line.sign * speed, dv);
            let wmax = lim.max_angular_velocity;
            let wd = line.pursuit(&p, st.look_ahead, vc.abs()).clamp(-wmax, wmax);
            (vc, ramp(w, wd, dw))
        };
        if vc == 0.0 && wc == 0.0 && v == 0.0 && w == 0.0 {
            // At rest with nothing left to do: the timeline ends here.
            out.commands.push(Command { t, v: 0.0, w: 0.0 });
            return done;
        }
        out.commands.push(Command { t, v: vc, w: wc });
        p = integrate(&p, vc, wc, dt);
        out.poses.push(TimedPose { t: t + dt, pose: p });
        done.travel += vc.abs() * dt;
        done.turned += wc.abs() * dt;
        (v, w) = (vc, wc);
    }
    done
}

/// Index of the first rolled-out pose (after the robot's) whose footprint overlaps an
/// occupied cell, and the path length driven up to it.
fn first_blocked(map: &GridView, fp: &Footprint, out: &StepOutput) -> Option<(usize, f64)> {
    let mut travel = 0.0;
    for i in 1..out.poses.len() {
        travel += out.poses[i].pose.distance(&out.poses[i - 1].pose);
        if overlaps_occupied(map, fp, &out.poses[i].pose) {
            return Some((i, travel));
        }
    }
    None
}

/// Stops the robot: one zero command at `t0`, the robot's pose as the only pose.
fn stop(out: &mut StepOutput, pose: Pose2, flag: ExitFlag) {
    out.poses.clear();
    out.poses.push(TimedPose { t: out.t0, pose });
    out.set_stop();
    out.exit_flag = flag;
    out.last_feasible_index = 0;
}

/// Whether the robot is within `tol` (along, across, heading) of `target`.
fn within(tol: &[f64; 3], robot: &Pose2, target: &Pose2) -> bool {
    let (lx, ly) = target.inverse_transform_point(robot.x, robot.y);
    lx.abs() <= tol[0]
        && ly.abs() <= tol[1]
        && wrap_angle(robot.theta - target.theta).abs() <= tol[2]
}

/// One straight-mode step (see the module doc). `out` has been cleared and its `t0`
/// set by the caller.
#[allow(clippy::too_many_arguments)]
pub(crate) fn step(
    cfg: &TebConfig,
    footprint: &Footprint,
    target: &Pose2,
    tol: &[f64; 3],
    pose: Pose2,
    velocity: (f64, f64),
    map: &GridView,
    out: &mut StepOutput,
) {
    let standing = velocity.0.abs() <= STANDING.0 && velocity.1.abs() <= STANDING.1;
    if standing && within(tol, &pose, target) {
        stop(out, pose, ExitFlag::Valid);
        out.reached_goal = true;
        return;
    }
    if overlaps_occupied(map, footprint, &pose) {
        stop(out, pose, ExitFlag::Collision);
        return;
    }
    let inflated = footprint.inflated(cfg.straight.margin);
    let fp = if overlaps_occupied(map, &inflated, &pose) {
        *footprint
    } else {
        inflated
    };
    let line = Line::new(*target, &pose);
    let start = (pose, velocity.0, velocity.1);
    let t0 = out.t0;
    let rolled = roll(cfg, &line, tol[2], start, t0, f64::INFINITY, out);
    let Some((_, blocked_at)) = first_blocked(map, &fp, out) else {
        out.last_feasible_index = out.poses.len() - 1;
        if rolled.travel == 0.0 && rolled.turned == 0.0 {
            // Nothing to do here. Within the tolerance but still rolling (the last
            // step's braking): stop, and the next step, standing, has the target
            // reached. Otherwise along the line the robot is at the target, across it
            // too far off for a straight move.
            let flag = if within(tol, &pose, target) {
                ExitFlag::Valid
            } else {
                ExitFlag::OffPath
            };
            stop(out, pose, flag);
        }
        return;
    };
    // Blocked: stop before it if braking allows and that still gets somewhere.
    let v0 = velocity.0.abs();
    let stopping = v0 * v0 / (2.0 * cfg.limits.max_acceleration) + v0 * cfg.straight.step;
    let room = blocked_at - STOP_BEFORE;
    if room <= stopping || room < MIN_PROGRESS {
        stop(out, pose, ExitFlag::Collision);
        return;
    }
    let rolled = roll(cfg, &line, tol[2], start, t0, room, out);
    if rolled.travel < MIN_PROGRESS || first_blocked(map, &fp, out).is_some() {
        stop(out, pose, ExitFlag::Collision);
        return;
    }
    out.last_feasible_index = out.poses.len() - 1;
}

#[cfg(test)]
mod tests {
    use super::*;
    use aisle_geometry::GridMap;

    /// A sweep's move out from under a rack reached its target still rolling at 0.013
    /// m/s (the end of its braking): the step had nothing left to roll and called that
    /// off the line (exit flag 5), which the mission takes for a blocked move. At the
    /// target, still rolling, it stops.
    #[test]
    fn arriving_still_rolling_stops_and_is_reached_once_standing() {
        let cfg = TebConfig::default();
        let map = GridMap::new_free(-5.0, -5.0, 0.1, 10.0, 10.0).unwrap();
        let fp = Footprint::new(0.508, 0.43);
        let target = Pose2::new(1.0, 0.5, 0.8);
        let tol = [0.02, 0.02, 0.02];
        let step_at = |pose: Pose2, v: f64| {
            let mut out = StepOutput::default();
            step(
                &cfg,
                &fp,
                &target,
                &tol,
                pose,
                (v, 0.0),
                &map.view(),
                &mut out,
            );
            out
        };
        let rolling = step_at(target, 0.013);
        assert_eq!(rolling.exit_flag, ExitFlag::Valid);
        assert!(!rolling.reached_goal);
        assert_eq!(rolling.command_at(rolling.t0), (0.0, 0.0));
        assert!(step_at(target, 0.0).reached_goal);
        // Off the line across, with nothing to roll: still off the line.
        let beside = Pose2::new(1.0 - 0.1 * 0.8f64.sin(), 0.5 + 0.1 * 0.8f64.cos(), 0.8);
        assert_eq!(step_at(beside, 0.013).exit_flag, ExitFlag::OffPath);
    }
}
