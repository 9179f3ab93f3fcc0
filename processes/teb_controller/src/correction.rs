//! The second-order correction of a rejected trial band: the smallest weighted move of
//! its poses that brings every segment's slip to its target and its deepest clearance
//! sample back to the kept clearance, both linearised at the trial band itself.
//!
//! Why: a subproblem linearises the slip and the clearance at the old band. The repair
//! of a trial band (`Scp::polish`) projects out the slip's curvature error by moving
//! poses sideways, and a footprint turning beside an obstacle swings its corners along
//! circles the clearance rows do not follow; either can leave samples inside the kept
//! clearance the subproblem kept to first order. Near a local optimum pressed against
//! an obstacle the step's gain is first order in its length and that error second
//! order, but the L1 penalty charges it at the constraint weight: on a seed record's
//! worst step four of the last six steps were rejected (ratios -24 to -0.2, samples
//! 0.4 to 29 mm inside), the trust region shrank and the step ran out of subproblems
//! 11 % above its optimum. Correcting the trial band (one least-squares solve, no
//! subproblem) keeps the step and its gain.
//!
//! Both constraints of a segment involve its two poses only, so the normal equations
//! are block tridiagonal with 2 x 2 blocks (slip, clearance), solved in O(segments).
//! Knows nothing of the trust-region loop or of how shortfalls are found.

use crate::band::Band;
use crate::kinematics::{END_STIFFNESS, slip};
use crate::objective::Shortfall;

/// Rows of one segment: its slip and its deepest clearance sample.
const ROWS: usize = 2;
type Block = [[f64; ROWS]; ROWS];

/// One segment's two constraint rows: their gradients with respect to the segment's
/// tail pose (k) and head pose (k + 1), and their residuals.
#[derive(Debug, Clone, Copy, Default)]
struct SegmentRows {
    tail: [[f64; 3]; ROWS],
    head: [[f64; 3]; ROWS],
    residual: [f64; ROWS],
}

/// Reusable buffers of the correction.
#[derive(Debug, Default)]
pub(crate) struct Corrector {
    rows: Vec<SegmentRows>,
    diag: Vec<Block>,
    upper: Vec<Block>,
    rhs: Vec<[f64; ROWS]>,
    moves: Vec<[f64; 3]>,
}

fn dot3(a: &[f64; 3], b: &[f64; 3], w: f64) -> f64 {
    w * (a[0] * b[0] + a[1] * b[1] + a[2] * b[2])
}

fn solve2(m: &Block, r: &[f64; ROWS]) -> [f64; ROWS] {
    let det = m[0][0] * m[1][1] - m[0][1] * m[1][0];
    [
        (m[1][1] * r[0] - m[0][1] * r[1]) / det,
        (m[0][0] * r[1] - m[1][0] * r[0]) / det,
    ]
}

/// `a^T m^-1 b` for 2 x 2 blocks (`m` symmetric).
fn schur(a: &Block, m: &Block, b: &Block) -> Block {
    let mut out = [[0.0; ROWS]; ROWS];
    for j in 0..ROWS {
        let x = solve2(m, &[b[0][j], b[1][j]]);
        for (i, row) in out.iter_mut().enumerate() {
            row[j] = a[0][i] * x[0] + a[1][i] * x[1];
        }
    }
    out
}

impl Corrector {
    /// One Gauss-Newton sweep: moves poses 1.. (pose 0 is the robot and stays; the
    /// last pose [`END_STIFFNESS`] times dearer) by the smallest weighted change that
    /// brings, to first order at `band`, the slip of every segment k to
    /// `slip_target[k]` and its shortfall's sample (`shortfalls[k]`, found on `band`)
    /// to the kept clearance. Returns false, leaving `band` as it was, when the
    /// system cannot be solved or the change of a coordinate would exceed `limit` (a
    /// correction is of the order of the step's curvature error; a larger one means
    /// rows that nearly contradict each other, such as a sample squeezed between two
    /// obstacles, where the linearisation says nothing about the move).
    pub fn sweep(
        &mut self,
        band: &mut Band,
        slip_target: &[f64],
        shortfalls: &[Option<Shortfall>],
        limit: f64,
    ) -> bool {
        let m = band.dts.len();
        if m == 0 || slip_target.len() != m || shortfalls.len() != m {
            return false;
        }
        let inv = |i: usize| match i {
            0 => 0.0,
            i if i == m => 1.0 / END_STIFFNESS,
            _ => 1.0,
        };
        self.rows.clear();
        for (k, shortfall) in shortfalls.iter().enumerate() {
            let (a, b) = (band.poses[k], band.poses[k + 1]);
            let (s, c) = (0.5 * (a.theta + b.theta)).sin_cos();
            let lon = c * (b.x - a.x) + s * (b.y - a.y);
            let mut r = SegmentRows {
                tail: [[s, -c, -0.5 * lon], [0.0; 3]],
                head: [[-s, c, -0.5 * lon], [0.0; 3]],
                residual: [slip(band, k) - slip_target[k], 0.0],
            };
            if let Some(f) = shortfall {
                r.tail[1] = f.grad.map(|g| f.weight_prev * g);
                r.head[1] = f.grad.map(|g| (1.0 - f.weight_prev) * g);
                r.residual[1] = f.excess;
            }
            self.rows.push(r);
        }
        self.normal_equations(&inv);
        if !self.solve() {
            return false;
        }
        // Poses -= W J^T lambda, first into `moves` to check the limit.
        self.moves.clear();
        self.moves.resize(m + 1, [0.0; 3]);
        for (k, (r, l)) in self.rows.iter().zip(&self.rhs).enumerate() {
            for (i, grads) in [(k, &r.tail), (k + 1, &r.head)] {
                let w = inv(i);
                for (g, li) in grads.iter().zip(l) {
                    for (d, gc) in self.moves[i].iter_mut().zip(g) {
                        *d -= w * li * gc;
                    }
                }
            }
        }
        if self
            .moves
            .iter()
            .flatten()
            .any(|d| d.is_nan() || d.abs() > limit)
        {
            return false;
        }
        for (q, d) in band.poses.iter_mut().zip(&self.moves) {
            q.x += d[0];
            q.y += d[1];
            q.theta += d[2];
        }
        true
    }

    /// J W J^T as diagonal and upper 2 x 2 blocks, a row without a constraint (no
    /// shortfall) kept as an identity row with a zero residual.
    fn normal_equations(&mut self, inv: &impl Fn(usize) -> f64) {
        let m = self.rows.len();
        self.diag.clear();
        self.upper.clear();
        self.rhs.clear();
        for (k, r) in self.rows.iter().enumerate() {
            let mut d = [[0.0; ROWS]; ROWS];
            for (i, row) in d.iter_mut().enumerate() {
                for (j, v) in row.iter_mut().enumerate() {
                    *v = dot3(&r.tail[i], &r.tail[j], inv(k))
                        + dot3(&r.head[i], &r.head[j], inv(k + 1));
                }
            }
            if d[1][1] == 0.0 {
                d[1][1] = 1.0;
            }
            self.diag.push(d);
            self.rhs.push(r.residual);
            if k + 1 < m {
                // Pose k + 1 is the head of segment k and the tail of segment k + 1.
                let next = &self.rows[k + 1];
                let mut u = [[0.0; ROWS]; ROWS];
                for (i, row) in u.iter_mut().enumerate() {
                    for (j, v) in row.iter_mut().enumerate() {
                        *v = dot3(&r.head[i], &next.tail[j], inv(k + 1));
                    }
                }
                self.upper.push(u);
            }
        }
    }

    /// Block Thomas algorithm; `rhs` becomes the multipliers.
    fn solve(&mut self) -> bool {
        let m = self.diag.len();
        for k in 1..m {
            let u = self.upper[k - 1];
            let s = schur(&u, &self.diag[k - 1], &u);
            let x = solve2(&self.diag[k - 1], &self.rhs[k - 1]);
            for (i, (row, s_row)) in self.diag[k].iter_mut().zip(&s).enumerate() {
                for (d, sv) in row.iter_mut().zip(s_row) {
                    *d -= sv;
                }
                self.rhs[k][i] -= u[0][i] * x[0] + u[1][i] * x[1];
            }
        }
        self.rhs[m - 1] = solve2(&self.diag[m - 1], &self.rhs[m - 1]);
        for k in (0..m - 1).rev() {
            let u = &self.upper[k];
            let next = self.rhs[k + 1];
            let r = [
                self.rhs[k][0] - u[0][0] * next[0] - u[0][1] * next[1],
                self.rhs[k][1] - u[1][0] * next[0] - u[1][1] * next[1],
            ];
            self.rhs[k] = solve2(&self.diag[k], &r);
        }
        self.rhs.iter().flatten().all(|l| l.is_finite())
    }
}

#[cfg(test)]
mod tests {
    use aisle_geometry::Pose2;

    use super::*;

    /// A gentle left arc of 6 poses, 0.4 m apart.
    fn arc() -> Band {
        let mut b = Band::default();
        let mut p = Pose2::new(0.0, 0.0, 0.0);
        b.poses.push(p);
        for k in 0..5 {
            let th = 0.1 * (k + 1) as f64;
            let tm = 0.5 * (p.theta + th);
            p = Pose2::new(p.x + 0.4 * tm.cos(), p.y + 0.4 * tm.sin(), th);
            b.poses.push(p);
            b.dts.push(0.5);
        }
        b
    }

    fn shortfalls() -> Vec<Option<Shortfall>> {
        let mut f = vec![None; 5];
        f[1] = Some(Shortfall {
            excess: -0.01,
            grad: [0.1, -1.0, 0.2],
            weight_prev: 0.5,
        });
        f[3] = Some(Shortfall {
            excess: -0.004,
            grad: [0.0, -0.9, -0.3],
            weight_prev: 0.0,
        });
        f
    }

    #[test]
    fn one_sweep_meets_every_linearised_row() {
        let before = arc();
        let mut band = before.clone();
        let target = [0.0, 0.002, 0.0, -0.001, 0.0];
        let falls = shortfalls();
        assert!(Corrector::default().sweep(&mut band, &target, &falls, 1.0));
        assert_eq!(band.poses[0], before.poses[0], "the robot's pose moved");
        let d = |i: usize| {
            let (a, b) = (before.poses[i], band.poses[i]);
            [b.x - a.x, b.y - a.y, b.theta - a.theta]
        };
        let dot = |g: &[f64; 3], d: [f64; 3], w: f64| w * (g[0] * d[0] + g[1] * d[1] + g[2] * d[2]);
        for k in 0..5 {
            let (a, b) = (before.poses[k], before.poses[k + 1]);
            let (s, c) = (0.5 * (a.theta + b.theta)).sin_cos();
            let lon = c * (b.x - a.x) + s * (b.y - a.y);
            // The slip's first-order change brings it to its target.
            let change =
                dot(&[s, -c, -0.5 * lon], d(k), 1.0) + dot(&[-s, c, -0.5 * lon], d(k + 1), 1.0);
            let slip0 = slip(&before, k);
            assert!((slip0 + change - target[k]).abs() < 1e-12, "segment {k}");
            // The shortfall's sample reaches the kept clearance to first order.
            if let Some(f) = falls[k] {
                let moved =
                    dot(&f.grad, d(k), f.weight_prev) + dot(&f.grad, d(k + 1), 1.0 - f.weight_prev);
                assert!((f.excess + moved).abs() < 1e-12, "segment {k}");
            }
        }
        // The correction is of the size of what it corrects.
        for i in 1..6 {
            assert!(d(i).iter().all(|v| v.abs() < 0.05), "pose {i}: {:?}", d(i));
        }
    }

    #[test]
    fn a_correction_beyond_the_limit_leaves_the_band() {
        let before = arc();
        let mut band = before.clone();
        let falls = shortfalls();
        let ok = Corrector::default().sweep(&mut band, &[0.0; 5], &falls, 1e-4);
        assert!(!ok);
        assert_eq!(band, before);
    }
}
