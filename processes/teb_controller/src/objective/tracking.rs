//! The soft shape terms: closeness to the reference path, heading smoothness and the
//! end at the local goal. Reference and smoothness are squares (exact in the model);
//! the goal is a distance plus a heading error, modelled exactly as a cone and an
//! absolute value over slack columns.

use super::Problem;
use super::segment::pc;
use crate::band::Band;
use crate::direction::DriveSign;
use crate::qp::{Qp, Row};

/// Normal offset of (x, y) from the reference and the normal (zero on degenerate
/// sections).
fn reference_offset(p: &Problem, x: f64, y: f64) -> (f64, f64, f64) {
    let pr = p.reference.project(&p.section, x, y, p.s_lo, p.s_hi);
    let (nx, ny) = (-pr.ty, pr.tx);
    (nx * (x - pr.x) + ny * (y - pr.y), nx, ny)
}

/// Reference: `w_reference` x the squared normal offset of every pose but the robot's
/// (none when turning on the spot).
pub(super) fn reference_merit(p: &Problem, band: &Band, cost: &mut f64) {
    if p.direction.drives() {
        for q in &band.poses[1..] {
            let (r, _, _) = reference_offset(p, q.x, q.y);
            *cost += p.cfg.weights.reference * r * r;
        }
    }
}

/// Reference, with the offset linear in the pose step along the projection's normal.
pub(super) fn reference_linearise(qp: &mut Qp, p: &Problem, band: &Band) {
    let w = &p.cfg.weights;
    if p.direction.drives() && w.reference > 0.0 {
        for i in 1..band.poses.len() {
            let q = band.poses[i];
            let (r0, nx, ny) = reference_offset(p, q.x, q.y);
            if nx != 0.0 || ny != 0.0 {
                let mut r = Row::new();
                r.add(pc(i, 0), nx).add(pc(i, 1), ny);
                qp.add_square(w.reference, r0, &r);
            }
        }
    }
}

/// Smoothness: `w_smoothness` x the squared second difference of the headings.
pub(super) fn smoothness_merit(p: &Problem, band: &Band, cost: &mut f64) {
    for i in 1..band.poses.len().saturating_sub(1) {
        let d2 = band.poses[i + 1].theta - 2.0 * band.poses[i].theta + band.poses[i - 1].theta;
        *cost += p.cfg.weights.smoothness * d2 * d2;
    }
}

/// Smoothness: linear in the headings, so the square is exact.
pub(super) fn smoothness_linearise(qp: &mut Qp, p: &Problem, band: &Band) {
    let w = &p.cfg.weights;
    let np = band.poses.len();
    if w.smoothness > 0.0 {
        for i in 1..np - 1 {
            let r0 = band.poses[i + 1].theta - 2.0 * band.poses[i].theta + band.poses[i - 1].theta;
            let mut r = Row::new();
            r.add(pc(i + 1, 2), 1.0)
                .add(pc(i, 2), -2.0)
                .add(pc(i - 1, 2), 1.0);
            qp.add_square(w.smoothness, r0, &r);
        }
    }
}

/// Goal: `w_goal` x (distance of the band's end from the local goal + heading error).
pub(super) fn goal_merit(p: &Problem, band: &Band, cost: &mut f64) {
    let end = band.poses[band.poses.len() - 1];
    *cost += p.cfg.weights.goal * (end.distance(&p.goal) + (end.theta - p.goal.theta).abs());
}

/// Goal: ||p_end - goal|| <= s (cone) and |theta_end - goal| <= s', both slacks at
/// `w_goal`.
pub(super) fn goal_linearise(qp: &mut Qp, p: &Problem, band: &Band) {
    let w = &p.cfg.weights;
    let np = band.poses.len();
    let end = band.poses[np - 1];
    let sg = qp.new_column(w.goal);
    let mut r0 = Row::new();
    r0.add(Some(sg), -1.0);
    let mut rx = Row::new();
    rx.add(pc(np - 1, 0), -1.0);
    let mut ry = Row::new();
    ry.add(pc(np - 1, 1), -1.0);
    qp.soc3([(&r0, 0.0), (&rx, end.x - p.goal.x), (&ry, end.y - p.goal.y)]);
    let sh = qp.new_column(w.goal);
    let e = end.theta - p.goal.theta;
    let mut r = Row::new();
    r.add(pc(np - 1, 2), 1.0).add(Some(sh), -1.0);
    qp.leq(&r, -e);
    let mut r = Row::new();
    r.add(pc(np - 1, 2), -1.0).add(Some(sh), -1.0);
    qp.leq(&r, e);
}
