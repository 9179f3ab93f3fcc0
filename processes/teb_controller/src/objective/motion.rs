//! The per-segment terms of the motion, all penalised (L1) at `w_constraint`:
//! - velocity: |dp| <= v_max T and |dtheta| <= w_max T; in the model an exact cone and
//!   two linear rows (hard), so every accepted band meets them;
//! - kinematics: both poses on one circular arc (lateral slip zero), or, on the spot,
//!   no change of position; linearised with a slack;
//! - direction: the chord along the heading has the section's sign; linearised with a
//!   slack.
//!
//! The merit visits these three per segment in this order, and so does the model.

use aisle_geometry::Direction;

use super::segment::{kinematic_residual, pc, slack_non_negative, tc};
use super::{Problem, Tally};
use crate::band::{Band, chord};
use crate::direction::DriveSign;
use crate::qp::{Qp, Row};

/// Velocity of segment k: the excess over the limits (per second), charged in metres
/// and radians.
pub(super) fn velocity_merit(p: &Problem, band: &Band, k: usize, vlim: f64, t: &mut Tally) {
    let a = band.poses[k];
    let b = band.poses[k + 1];
    let dt = band.dts[k];
    let vel = (chord(&a, &b) - vlim * dt).max(0.0) / dt;
    let rate = ((b.theta - a.theta).abs() - p.cfg.limits.max_angular_velocity * dt).max(0.0) / dt;
    t.sum += vel * dt + rate * dt;
    t.worst.velocity = t.worst.velocity.max(vel).max(rate);
}

/// Velocity of segment k: ||dp|| <= v_max T (exact cone) and |dtheta| <= w_max T
/// (exact, linear).
pub(super) fn velocity_linearise(qp: &mut Qp, band: &Band, k: usize, vlim: f64, wmax: f64) {
    let m = band.poses.len() - 1;
    let a = band.poses[k];
    let b = band.poses[k + 1];
    let (dx, dy) = (b.x - a.x, b.y - a.y);
    let mut rt = Row::new();
    rt.add(Some(tc(m, k)), -vlim);
    let mut rx = Row::new();
    rx.add(pc(k + 1, 0), -1.0).add(pc(k, 0), 1.0);
    let mut ry = Row::new();
    ry.add(pc(k + 1, 1), -1.0).add(pc(k, 1), 1.0);
    qp.soc3([(&rt, vlim * band.dts[k]), (&rx, dx), (&ry, dy)]);
    let dth = b.theta - a.theta;
    for sgn in [1.0, -1.0] {
        let mut r = Row::new();
        r.add(pc(k + 1, 2), sgn)
            .add(pc(k, 2), -sgn)
            .add(Some(tc(m, k)), -wmax);
        qp.leq(&r, wmax * band.dts[k] - sgn * dth);
    }
}

/// Kinematics of segment k: |slip|, or on the spot the L1 change of position.
pub(super) fn kinematics_merit(p: &Problem, band: &Band, k: usize, t: &mut Tally) {
    let a = band.poses[k];
    let b = band.poses[k + 1];
    let f = if p.direction == Direction::Rotate {
        (b.x - a.x).abs() + (b.y - a.y).abs()
    } else {
        kinematic_residual(&a, &b).abs()
    };
    t.sum += f;
    t.worst.kinematics = t.worst.kinematics.max(f);
}

/// Kinematics of segment k, each |linearised residual| <= slack.
pub(super) fn kinematics_linearise(qp: &mut Qp, p: &Problem, band: &Band, k: usize) {
    let w = &p.cfg.weights;
    let a = band.poses[k];
    let b = band.poses[k + 1];
    let (dx, dy) = (b.x - a.x, b.y - a.y);
    if p.direction == Direction::Rotate {
        // Turning on the spot: the position must not move.
        for (c, d) in [(0, dx), (1, dy)] {
            let s = qp.new_column(w.constraint);
            let mut r = Row::new();
            r.add(pc(k + 1, c), 1.0)
                .add(pc(k, c), -1.0)
                .add(Some(s), -1.0);
            qp.leq(&r, -d);
            let mut r = Row::new();
            r.add(pc(k + 1, c), -1.0)
                .add(pc(k, c), 1.0)
                .add(Some(s), -1.0);
            qp.leq(&r, d);
        }
        return;
    }
    // Non-holonomic kinematics: both poses on one arc (lateral slip zero).
    let tm = 0.5 * (a.theta + b.theta);
    let (sm, cm) = tm.sin_cos();
    let f0 = -sm * dx + cm * dy;
    let lon = cm * dx + sm * dy;
    let mut r = Row::new();
    r.add(pc(k + 1, 0), -sm)
        .add(pc(k, 0), sm)
        .add(pc(k + 1, 1), cm)
        .add(pc(k, 1), -cm)
        .add(pc(k + 1, 2), -0.5 * lon)
        .add(pc(k, 2), -0.5 * lon);
    let s = qp.new_column(w.constraint);
    let mut up = r;
    up.add(Some(s), -1.0);
    qp.leq(&up, -f0);
    let mut dn = Row::new();
    dn.add_row(&r, -1.0).add(Some(s), -1.0);
    qp.leq(&dn, f0);
}

/// Direction of segment k: how far its chord along the mid heading goes the wrong way
/// (nothing on the spot).
pub(super) fn direction_merit(p: &Problem, band: &Band, k: usize, t: &mut Tally) {
    if !p.direction.drives() {
        return;
    }
    let a = band.poses[k];
    let b = band.poses[k + 1];
    let (s, c) = (0.5 * (a.theta + b.theta)).sin_cos();
    let n = (b.x - a.x) * c + (b.y - a.y) * s;
    let back = (-p.direction.sign() * n).max(0.0);
    t.sum += back;
    t.worst.direction = t.worst.direction.max(back);
}

/// Direction of segment k: sign (dp . h) >= -slack, linear in the step.
pub(super) fn direction_linearise(qp: &mut Qp, p: &Problem, band: &Band, k: usize) {
    if !p.direction.drives() {
        return;
    }
    let a = band.poses[k];
    let b = band.poses[k + 1];
    let (dx, dy) = (b.x - a.x, b.y - a.y);
    let (sm, cm) = (0.5 * (a.theta + b.theta)).sin_cos();
    let lon = cm * dx + sm * dy;
    let sign = p.direction.sign();
    let s = qp.new_column(p.cfg.weights.constraint);
    let mut r = Row::new();
    r.add(pc(k + 1, 0), -sign * cm)
        .add(pc(k, 0), sign * cm)
        .add(pc(k + 1, 1), -sign * sm)
        .add(pc(k, 1), sign * sm)
        .add(Some(s), -1.0);
    qp.leq(&r, sign * lon);
    slack_non_negative(qp, s);
}
