//! Projection of a band onto the differential drive's non-holonomic constraint: every
//! segment's chord along the mean heading of its two poses (both poses on one circular
//! arc, zero lateral slip).
//!
//! The optimiser linearises that constraint, so each step leaves a slip of second order
//! in the step; at the constraint weight that slip costs more merit than a small step
//! gains, and good steps were rejected (the Maratos effect). A minimum-norm
//! Gauss-Newton correction of positions and headings removes it at the cost of a
//! tridiagonal solve per sweep. Also the forward model itself, [`integrate`]: the
//! exact arc of a constant (v, w), for timelines rolled out rather than optimised
//! (`straight.rs`). Knows nothing of costs, obstacles or the optimiser.

use aisle_geometry::{Pose2, wrap_angle};

use crate::band::Band;

/// sin(a) / a, accurate near 0.
fn sinc(a: f64) -> f64 {
    if a.abs() < 1e-4 {
        // The next term, a^4 / 120, is below f64 resolution relative to 1.
        1.0 - a * a / 6.0
    } else {
        a.sin() / a
    }
}

/// Pose after holding (v, w) for `dt` from `pose`: the circular arc whose chord runs
/// along the mean heading of its ends (the model [`slip`] measures deviations from),
/// written without a division by w so a straight line needs no special case.
pub(crate) fn integrate(pose: &Pose2, v: f64, w: f64, dt: f64) -> Pose2 {
    let dth = w * dt;
    let chord = v * dt * sinc(0.5 * dth);
    let (s, c) = (pose.theta + 0.5 * dth).sin_cos();
    Pose2::new(
        pose.x + chord * c,
        pose.y + chord * s,
        wrap_angle(pose.theta + dth),
    )
}

/// Lateral slip of segment k: zero when both poses lie on one circular arc.
pub(crate) fn slip(band: &Band, k: usize) -> f64 {
    let (a, b) = (band.poses[k], band.poses[k + 1]);
    let (s, c) = (0.5 * (a.theta + b.theta)).sin_cos();
    -s * (b.x - a.x) + c * (b.y - a.y)
}

/// How much more a change of the last pose costs than one of an interior pose: the
/// band's end is held at the local goal by a heavy penalty, so the correction should
/// come from the poses in between.
pub(crate) const END_STIFFNESS: f64 = 100.0;

/// Reusable buffers of the projection.
#[derive(Debug, Default)]
pub(crate) struct Projector {
    /// Per segment: sin and cos of the mean heading, and the chord along it.
    seg: Vec<(f64, f64, f64)>,
    diag: Vec<f64>,
    upper: Vec<f64>,
    rhs: Vec<f64>,
}

impl Projector {
    /// Moves poses 1.. (pose 0 is the robot and stays) by the smallest weighted change
    /// (positions and headings; the last pose [`END_STIFFNESS`] times dearer) that
    /// brings the slip of every segment k to `target[k]` (zero when `target` is empty).
    /// One Gauss-Newton sweep per `sweeps`; the slip is bilinear in chord and heading,
    /// so each sweep squares the remaining error (relatively).
    pub fn project(&mut self, band: &mut Band, target: &[f64], sweeps: usize) {
        let m = band.dts.len();
        if m == 0 || band.poses.len() != m + 1 || !(target.is_empty() || target.len() == m) {
            return;
        }
        // Inverse weights of pose i's position and heading changes.
        let inv = |i: usize| if i == m { 1.0 / END_STIFFNESS } else { 1.0 };
        for _ in 0..sweeps {
            self.seg.clear();
            self.diag.clear();
            self.upper.clear();
            self.rhs.clear();
            for k in 0..m {
                let (a, b) = (band.poses[k], band.poses[k + 1]);
                let (s, c) = (0.5 * (a.theta + b.theta)).sin_cos();
                let lon = c * (b.x - a.x) + s * (b.y - a.y);
                self.seg.push((s, c, lon));
                self.rhs
                    .push(slip(band, k) - target.get(k).copied().unwrap_or(0.0));
                // Slip k has gradient (-s, c, -lon/2) at its head, (s, -c, -lon/2) at
                // its tail; the tail of segment 0 is the fixed robot pose.
                let per_pose = 1.0 + 0.25 * lon * lon;
                let tail = if k == 0 { 0.0 } else { per_pose * inv(k) };
                self.diag.push(per_pose * inv(k + 1) + tail);
            }
            for k in 0..m.saturating_sub(1) {
                let (s0, c0, l0) = self.seg[k];
                let (s1, c1, l1) = self.seg[k + 1];
                // Pose k+1 is the head of segment k and the tail of segment k+1.
                self.upper
                    .push((-(s0 * s1 + c0 * c1) + 0.25 * l0 * l1) * inv(k + 1));
            }
            // Thomas algorithm on the symmetric positive definite tridiagonal J W J^T:
            // forward elimination, then back substitution (rhs becomes the multipliers).
            for k in 1..m {
                let f = self.upper[k - 1] / self.diag[k - 1];
                self.diag[k] -= f * self.upper[k - 1];
                self.rhs[k] -= f * self.rhs[k - 1];
            }
            self.rhs[m - 1] /= self.diag[m - 1];
            for k in (0..m - 1).rev() {
                self.rhs[k] = (self.rhs[k] - self.upper[k] * self.rhs[k + 1]) / self.diag[k];
            }
            if self.rhs.iter().any(|l| !l.is_finite()) {
                return;
            }
            // Poses -= W J^T lambda.
            for k in 0..m {
                let (s, c, lon) = self.seg[k];
                let l = self.rhs[k];
                let w = inv(k + 1);
                let head = &mut band.poses[k + 1];
                head.x += w * l * s;
                head.y -= w * l * c;
                head.theta += w * l * 0.5 * lon;
                if k > 0 {
                    let w = inv(k);
                    let tail = &mut band.poses[k];
                    tail.x -= w * l * s;
                    tail.y += w * l * c;
                    tail.theta += w * l * 0.5 * lon;
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn integration_follows_the_arc_and_the_line() {
        // A quarter circle of radius 1 from the origin heading +x ends at (1, 1, pi/2).
        let q = std::f64::consts::FRAC_PI_2;
        let p = integrate(&Pose2::new(0.0, 0.0, 0.0), q, q, 1.0);
        assert!(
            (p.x - 1.0).abs() < 1e-12 && (p.y - 1.0).abs() < 1e-12,
            "{p:?}"
        );
        assert!((p.theta - q).abs() < 1e-12);
        // Straight backwards along a heading of pi / 2.
        let p = integrate(&Pose2::new(1.0, 2.0, q), -0.5, 0.0, 2.0);
        assert!(
            (p.x - 1.0).abs() < 1e-12 && (p.y - 1.0).abs() < 1e-12,
            "{p:?}"
        );
    }

    #[test]
    fn projection_removes_slip_and_keeps_headings_and_start() {
        // A gentle left turn whose positions were disturbed sideways.
        let mut band = Band::default();
        let mut p = Pose2::new(1.0, 2.0, 0.2);
        band.poses.push(p);
        for k in 0..8 {
            let th = 0.2 + 0.1 * (k + 1) as f64;
            let tm = 0.5 * (p.theta + th);
            p = Pose2::new(p.x + 0.5 * tm.cos(), p.y + 0.5 * tm.sin(), th);
            let wobble = 0.02 * if k % 2 == 0 { 1.0 } else { -0.7 };
            band.poses
                .push(Pose2::new(p.x - wobble * th.sin(), p.y + wobble, th));
            band.dts.push(0.3);
        }
        let before = band.clone();
        let worst = |b: &Band| {
            (0..b.dts.len())
                .map(|k| slip(b, k).abs())
                .fold(0.0, f64::max)
        };
        assert!(worst(&before) > 1e-2);
        let mut proj = Projector::default();
        proj.project(&mut band, &[], 3);
        assert!(worst(&band) < 1e-10, "slip {}", worst(&band));
        assert_eq!(band.poses[0], before.poses[0]);
        for (a, b) in band.poses.iter().zip(&before.poses) {
            // Minimum-norm: the correction is of the size of the disturbance.
            assert!(a.distance(b) < 0.05, "{a:?} vs {b:?}");
            assert!((a.theta - b.theta).abs() < 0.1, "{a:?} vs {b:?}");
        }
        // The end, held at the local goal by a heavy penalty, moves least.
        let moved = |i: usize| band.poses[i].distance(&before.poses[i]);
        assert!(moved(8) < 0.1 * moved(4), "{} vs {}", moved(8), moved(4));
    }
}
