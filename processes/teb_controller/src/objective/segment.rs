//! Band geometry the terms share: the step variables' columns, a segment's signed
//! velocity, turn rate and lateral slip, and their linearisations in the step.
//!
//! The subproblem's variables are the steps of poses 1.. (x, y, theta each; pose 0 is
//! the robot and fixed), then the steps of the time steps, then slack columns.

use aisle_geometry::Pose2;

use crate::band::Band;
use crate::qp::Row;

/// Column of pose `i`'s coordinate `c` (0 x, 1 y, 2 theta); pose 0 is fixed.
#[inline]
pub(crate) fn pc(i: usize, c: usize) -> Option<usize> {
    if i == 0 { None } else { Some(3 * (i - 1) + c) }
}

/// Column of time step `k` in a band of `m` segments.
#[inline]
pub(crate) fn tc(m: usize, k: usize) -> usize {
    3 * m + k
}

/// Where column `col` of a band of `m` segments goes in the subproblem's elimination
/// order: pose i's three coordinates, then the time step that ends at it, pose by pose.
/// Every term couples at most three consecutive poses and their time steps, so the
/// Newton systems are banded in this order (a half-bandwidth of about 12).
pub(crate) fn band_position(m: usize, col: usize) -> usize {
    if col < 3 * m {
        4 * (col / 3) + col % 3
    } else {
        4 * (col - 3 * m) + 3
    }
}

/// Component `c` of pose `i`'s step in `d` (zero for the fixed pose 0).
#[inline]
pub(crate) fn d_at(d: &[f64], i: usize, c: usize) -> f64 {
    pc(i, c).map_or(0.0, |k| d[k])
}

/// Signed velocity of segment k along its mid heading, m/s.
pub(crate) fn segment_velocity(band: &Band, k: usize) -> f64 {
    let a = band.poses[k];
    let b = band.poses[k + 1];
    let (s, c) = (0.5 * (a.theta + b.theta)).sin_cos();
    ((b.x - a.x) * c + (b.y - a.y) * s) / band.dts[k]
}

/// Turn rate of segment k, rad/s.
pub(crate) fn segment_rate(band: &Band, k: usize) -> f64 {
    (band.poses[k + 1].theta - band.poses[k].theta) / band.dts[k]
}

/// Lateral slip of segment k: zero when both poses lie on one circular arc.
pub(crate) fn kinematic_residual(a: &Pose2, b: &Pose2) -> f64 {
    let (s, c) = (0.5 * (a.theta + b.theta)).sin_cos();
    -s * (b.x - a.x) + c * (b.y - a.y)
}

/// Linearised v_k = (dp_k . h_k) / T_k: value and gradient row.
pub(crate) fn lin_v(band: &Band, k: usize, t_col: usize) -> (f64, Row) {
    let a = band.poses[k];
    let b = band.poses[k + 1];
    let tm = 0.5 * (a.theta + b.theta);
    let (s, c) = tm.sin_cos();
    let t = band.dts[k];
    let n = (b.x - a.x) * c + (b.y - a.y) * s;
    let mut r = Row::new();
    r.add(pc(k + 1, 0), c / t)
        .add(pc(k + 1, 1), s / t)
        .add(pc(k, 0), -c / t)
        .add(pc(k, 1), -s / t)
        .add(Some(t_col), -n / (t * t));
    (n / t, r)
}

/// Linearised w_k = dtheta_k / T_k.
pub(crate) fn lin_w(band: &Band, k: usize, t_col: usize) -> (f64, Row) {
    let t = band.dts[k];
    let d = band.poses[k + 1].theta - band.poses[k].theta;
    let mut r = Row::new();
    r.add(pc(k + 1, 2), 1.0 / t)
        .add(pc(k, 2), -1.0 / t)
        .add(Some(t_col), -d / (t * t));
    (d / t, r)
}

/// `row.x <= rhs` where `row` is `slack` times -1: a slack column kept non-negative.
pub(crate) fn slack_non_negative(qp: &mut crate::qp::Qp, slack: usize) {
    let mut r = Row::new();
    r.add(Some(slack), -1.0);
    qp.leq(&r, 0.0);
}
