//! Assembly of one convex subproblem for clarabel: a quadratic objective over the band
//! variables, linear inequalities and 3-dimensional second-order cones, and the call to
//! the interior-point solver.
//!
//! Solved by the band's own interior-point solver (`conic/`), which knows the
//! subproblems' structure; clarabel solves whatever that one reports it cannot (a
//! structure it does not support, no convergence). Buffers are kept between calls, so
//! after the first steps neither side grows (clarabel, when it runs, copies the data
//! into its own workspace). Knows nothing of what the variables mean beyond the
//! elimination order of the core columns it is given.

use crate::conic::{Conic, Data, Settings};
use clarabel::algebra::CscMatrix;
use clarabel::solver::{DefaultSettings, DefaultSolver, IPSolver, SolverStatus, SupportedConeT};

/// A sparse row: up to 16 (column, coefficient) pairs, duplicates merged.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Row {
    cols: [usize; 16],
    vals: [f64; 16],
    len: usize,
}

impl Row {
    pub fn new() -> Row {
        Row {
            cols: [0; 16],
            vals: [0.0; 16],
            len: 0,
        }
    }

    /// Adds `coef` to column `col`; `None` (a fixed quantity) is ignored.
    pub fn add(&mut self, col: Option<usize>, coef: f64) -> &mut Row {
        let Some(c) = col else { return self };
        if let Some(k) = self.cols[..self.len].iter().position(|&x| x == c) {
            self.vals[k] += coef;
        } else if self.len < 16 {
            self.cols[self.len] = c;
            self.vals[self.len] = coef;
            self.len += 1;
        }
        self
    }

    /// Adds `scale` times every entry of `other`.
    pub fn add_row(&mut self, other: &Row, scale: f64) -> &mut Row {
        for k in 0..other.len {
            self.add(Some(other.cols[k]), scale * other.vals[k]);
        }
        self
    }

    pub fn iter(&self) -> impl Iterator<Item = (usize, f64)> + '_ {
        self.cols[..self.len]
            .iter()
            .copied()
            .zip(self.vals[..self.len].iter().copied())
    }
}

/// Accuracy of a step's subproblems. A trust-region step needs far less than clarabel's
/// 1e-8 default: the exact merit judges every step, and the candidate's velocity limits
/// are restored exactly afterwards. 1e-4 on the gap saves two or three interior-point
/// iterations (about 10 % of a subproblem) over 1e-6; a relative gap of 1e-3 (of a
/// model whose value is the merit, a few units) one more, 4-7 % of a seed record's
/// slowest steps, with their cost / converged cost unchanged at p90. (A relative gap of
/// 3e-2 took 16 % fewer iterations over 1,624 recorded steps of nine missions at the
/// same cost, but the closed loops lost four `gap` scenarios of two sweeps: README.)
pub(crate) const SETTINGS: Settings = Settings {
    max_iter: 0,
    tol_gap_abs: 1e-4,
    tol_gap_rel: 1e-3,
    tol_feas: 1e-5,
};

/// Accuracy of a subproblem in the convergence audit, which measures how far a step's
/// band is from the local optimum: clarabel's defaults, so the reference does not move
/// with the accuracy of the steps it judges.
pub(crate) const EXACT: Settings = Settings {
    max_iter: 0,
    tol_gap_abs: 1e-8,
    tol_gap_rel: 1e-8,
    tol_feas: 1e-8,
};

/// Outcome of one subproblem solve.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct QpResult {
    /// Objective of the model at the solution, without the proximal term.
    pub model: f64,
    pub ok: bool,
}

/// minimise const + q.x + 1/2 x'Px  s.t.  A x <= b (rows),  b - A x in SOC(3) (blocks).
pub(crate) struct Qp {
    n_core: usize,
    n: usize,
    p_dense: Vec<f64>,
    prox: Vec<f64>,
    q: Vec<f64>,
    constant: f64,
    lin: Vec<(usize, usize, f64)>,
    lin_b: Vec<f64>,
    soc: Vec<(usize, usize, f64)>,
    soc_b: Vec<f64>,
    col_counts: Vec<usize>,
    p: CscMatrix<f64>,
    a: CscMatrix<f64>,
    b: Vec<f64>,
    cones: Vec<SupportedConeT<f64>>,
    /// Elimination position of each core column (banded order for `conic`).
    position: Vec<usize>,
    conic: Conic,
    /// Solution of the last successful solve.
    pub x: Vec<f64>,
    /// Interior-point iterations of the last solve.
    pub ip_iterations: u32,
    /// Subproblems the band's solver handed to clarabel (diagnostics).
    pub fallbacks: u64,
    /// The accuracy every solve is held to ([`SETTINGS`] unless the caller asks more).
    pub settings: Settings,
}

impl Qp {
    pub fn new() -> Qp {
        Qp {
            n_core: 0,
            n: 0,
            p_dense: Vec::new(),
            prox: Vec::new(),
            q: Vec::new(),
            constant: 0.0,
            lin: Vec::new(),
            lin_b: Vec::new(),
            soc: Vec::new(),
            soc_b: Vec::new(),
            col_counts: Vec::new(),
            p: CscMatrix::new(0, 0, vec![0], Vec::new(), Vec::new()),
            a: CscMatrix::new(0, 0, vec![0], Vec::new(), Vec::new()),
            b: Vec::new(),
            cones: Vec::new(),
            position: Vec::new(),
            conic: Conic::default(),
            x: Vec::new(),
            ip_iterations: 0,
            fallbacks: 0,
            settings: SETTINGS,
        }
    }

    /// Starts a problem whose first `n_core` columns may carry quadratic terms; core
    /// column c is eliminated at `position(c)` (a permutation of 0..n_core that keeps
    /// the coupled columns close: the Newton systems are banded in that order).
    pub fn reset(&mut self, n_core: usize, position: impl Fn(usize) -> usize) {
        self.n_core = n_core;
        self.position.clear();
        self.position.extend((0..n_core).map(position));
        self.n = n_core;
        self.p_dense.clear();
        self.p_dense.resize(n_core * n_core, 0.0);
        self.prox.clear();
        self.prox.resize(n_core, 0.0);
        self.q.clear();
        self.q.resize(n_core, 0.0);
        self.constant = 0.0;
        self.lin.clear();
        self.lin_b.clear();
        self.soc.clear();
        self.soc_b.clear();
    }

    /// A new linear-only column (a slack) with objective coefficient `cost`.
    pub fn new_column(&mut self, cost: f64) -> usize {
        self.q.push(cost);
        self.n += 1;
        self.n - 1
    }

    pub fn add_linear_cost(&mut self, col: usize, coef: f64) {
        self.q[col] += coef;
    }

    pub fn add_constant(&mut self, c: f64) {
        self.constant += c;
    }

    /// Adds `weight * (r0 + row.x)^2`; every column of `row` must be a core column.
    pub fn add_square(&mut self, weight: f64, r0: f64, row: &Row) {
        self.constant += weight * r0 * r0;
        for (ci, vi) in row.iter() {
            self.q[ci] += 2.0 * weight * r0 * vi;
            for (cj, vj) in row.iter() {
                if ci <= cj {
                    // P enters as 1/2 x'Px, so the Hessian 2 w a a' goes in as is.
                    self.p_dense[ci * self.n_core + cj] += 2.0 * weight * vi * vj;
                }
            }
        }
    }

    /// Adds `weight * x_col^2`, excluded from the reported model value.
    pub fn add_proximal(&mut self, col: usize, weight: f64) {
        self.p_dense[col * self.n_core + col] += 2.0 * weight;
        self.prox[col] += weight;
    }

    /// row.x <= rhs.
    pub fn leq(&mut self, row: &Row, rhs: f64) {
        let r = self.lin_b.len();
        for (c, v) in row.iter() {
            self.lin.push((r, c, v));
        }
        self.lin_b.push(rhs);
    }

    /// (b0 - a0.x, b1 - a1.x, b2 - a2.x) in the second-order cone.
    pub fn soc3(&mut self, rows: [(&Row, f64); 3]) {
        for (row, b) in rows {
            let r = self.soc_b.len();
            for (c, v) in row.iter() {
                self.soc.push((r, c, v));
            }
            self.soc_b.push(b);
        }
    }

    fn build(&mut self) {
        let n = self.n;
        // P: upper triangle of the dense core block, column by column.
        self.p.m = n;
        self.p.n = n;
        self.p.colptr.clear();
        self.p.rowval.clear();
        self.p.nzval.clear();
        self.p.colptr.push(0);
        for c in 0..n {
            if c < self.n_core {
                for r in 0..=c {
                    let v = self.p_dense[r * self.n_core + c];
                    if v != 0.0 {
                        self.p.rowval.push(r);
                        self.p.nzval.push(v);
                    }
                }
            }
            self.p.colptr.push(self.p.rowval.len());
        }
        // A: linear rows first, then the cone rows, so the cone list is [R+, SOC, ...].
        let m_lin = self.lin_b.len();
        let m = m_lin + self.soc_b.len();
        self.col_counts.clear();
        self.col_counts.resize(n + 1, 0);
        for &(_, c, _) in self.lin.iter().chain(self.soc.iter()) {
            self.col_counts[c + 1] += 1;
        }
        for c in 0..n {
            self.col_counts[c + 1] += self.col_counts[c];
        }
        let nnz = self.col_counts[n];
        self.a.m = m;
        self.a.n = n;
        self.a.colptr.clear();
        self.a.colptr.extend_from_slice(&self.col_counts);
        self.a.rowval.clear();
        self.a.rowval.resize(nnz, 0);
        self.a.nzval.clear();
        self.a.nzval.resize(nnz, 0.0);
        // Entries were pushed in increasing row order, so each column stays sorted.
        for &(r, c, v) in self.lin.iter() {
            let k = self.col_counts[c];
            self.a.rowval[k] = r;
            self.a.nzval[k] = v;
            self.col_counts[c] += 1;
        }
        for &(r, c, v) in self.soc.iter() {
            let k = self.col_counts[c];
            self.a.rowval[k] = m_lin + r;
            self.a.nzval[k] = v;
            self.col_counts[c] += 1;
        }
        self.b.clear();
        self.b.extend_from_slice(&self.lin_b);
        self.b.extend_from_slice(&self.soc_b);
        self.cones.clear();
        if m_lin > 0 {
            self.cones.push(SupportedConeT::NonnegativeConeT(m_lin));
        }
        for _ in 0..self.soc_b.len() / 3 {
            self.cones.push(SupportedConeT::SecondOrderConeT(3));
        }
    }

    /// Solves; on success `x` holds the minimiser.
    pub fn solve(&mut self, max_iter: u32) -> QpResult {
        let data = Data {
            n_core: self.n_core,
            n: self.n,
            p_dense: &self.p_dense,
            q: &self.q,
            lin: &self.lin,
            lin_b: &self.lin_b,
            soc: &self.soc,
            soc_b: &self.soc_b,
            position: &self.position,
        };
        let solved = self
            .conic
            .solve(&data, &self.settings.with_max_iter(max_iter));
        if solved {
            self.ip_iterations = self.conic.iterations;
            self.x.clear();
            self.x.extend_from_slice(&self.conic.x[..self.n]);
            return QpResult {
                model: self.model_value(),
                ok: true,
            };
        }
        self.fallbacks += 1;
        tracing::debug!(
            "subproblem ({} columns, {} rows) handed to clarabel ({} so far)",
            self.n,
            self.lin_b.len() + self.soc_b.len(),
            self.fallbacks
        );
        self.solve_clarabel(max_iter)
    }

    /// The same subproblem with clarabel.
    fn solve_clarabel(&mut self, max_iter: u32) -> QpResult {
        self.build();
        let settings = DefaultSettings::<f64> {
            max_iter,
            verbose: false,
            // Single-threaded and deterministic; the wall-clock limit stays infinite.
            max_threads: 1,
            tol_gap_abs: self.settings.tol_gap_abs,
            tol_gap_rel: self.settings.tol_gap_rel,
            tol_feas: self.settings.tol_feas,
            tol_ktratio: 1e-5,
            iterative_refinement_enable: false,
            ..DefaultSettings::default()
        };
        let Ok(mut solver) =
            DefaultSolver::new(&self.p, &self.q, &self.a, &self.b, &self.cones, settings)
        else {
            return QpResult {
                model: f64::INFINITY,
                ok: false,
            };
        };
        solver.solve();
        self.ip_iterations = solver.solution.iterations;
        let ok = matches!(
            solver.solution.status,
            SolverStatus::Solved | SolverStatus::AlmostSolved
        ) && solver.solution.x.iter().all(|v| v.is_finite());
        if !ok {
            return QpResult {
                model: f64::INFINITY,
                ok: false,
            };
        }
        self.x.clear();
        self.x.extend_from_slice(&solver.solution.x);
        QpResult {
            model: self.model_value(),
            ok: true,
        }
    }

    /// const + q.x + 1/2 x'Px - proximal terms, at `self.x`.
    fn model_value(&self) -> f64 {
        let x = &self.x;
        let mut v = self.constant;
        for (c, &qc) in self.q.iter().enumerate() {
            v += qc * x[c];
        }
        for c in 0..self.n_core {
            for r in 0..=c {
                let p = self.p_dense[r * self.n_core + c];
                if p != 0.0 {
                    v += if r == c {
                        0.5 * p * x[r] * x[c]
                    } else {
                        p * x[r] * x[c]
                    };
                }
            }
            v -= self.prox[c] * x[c] * x[c];
        }
        v
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn small_socp_matches_the_hand_solution() {
        // min (x0 - 1)^2 + (x1 - 1)^2  s.t. ||(x0, x1)|| <= 1, x0 <= 0.5.
        let mut qp = Qp::new();
        qp.reset(2, |c| c);
        let mut r0 = Row::new();
        r0.add(Some(0), 1.0);
        let mut r1 = Row::new();
        r1.add(Some(1), 1.0);
        qp.add_square(1.0, -1.0, &r0);
        qp.add_square(1.0, -1.0, &r1);
        qp.leq(&r0, 0.5);
        let zero = Row::new();
        let mut n0 = Row::new();
        n0.add(Some(0), -1.0);
        let mut n1 = Row::new();
        n1.add(Some(1), -1.0);
        qp.soc3([(&zero, 1.0), (&n0, 0.0), (&n1, 0.0)]);
        qp.settings = EXACT;
        let r = qp.solve(50);
        assert!(r.ok);
        assert!((qp.x[0] - 0.5).abs() < 1e-6, "{:?}", qp.x);
        assert!((qp.x[1] - 0.75f64.sqrt()).abs() < 1e-6, "{:?}", qp.x);
        let expect = 0.25 + (1.0 - 0.75f64.sqrt()).powi(2);
        assert!((r.model - expect).abs() < 1e-6, "{} vs {expect}", r.model);
    }

    /// A band-shaped subproblem: `m` segments, each pose (x, y, theta) and time step a
    /// core column; a proximal term and a smoothing square; trust-region boxes; L1
    /// penalties through slack columns coupling neighbouring poses; a velocity cone per
    /// segment. Coefficients from a fixed linear congruential sequence.
    fn band_like(m: usize, seed: u64) -> Qp {
        let mut state = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        let mut rnd = move || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        let pc = |i: usize, c: usize| 3 * (i - 1) + c;
        let tc = |k: usize| 3 * m + k;
        let mut qp = Qp::new();
        qp.reset(4 * m, |c| crate::objective::segment::band_position(m, c));
        for c in 0..4 * m {
            qp.add_proximal(c, 1e-3);
            qp.add_linear_cost(c, 0.5 * rnd());
            for sign in [1.0, -1.0] {
                let mut r = Row::new();
                r.add(Some(c), sign);
                qp.leq(&r, 0.6);
            }
        }
        for i in 2..m {
            let mut r = Row::new();
            r.add(Some(pc(i - 1, 2)), 1.0)
                .add(Some(pc(i, 2)), -2.0)
                .add(Some(pc(i + 1, 2)), 1.0);
            qp.add_square(0.2, 0.1 * rnd(), &r);
        }
        for k in 0..m {
            // |a . (pose k+1 - pose k) + b dt_k - c| <= slack, at weight 200.
            let s = qp.new_column(200.0);
            let mut r = Row::new();
            for c in 0..2 {
                let a = rnd();
                r.add(Some(pc(k + 1, c)), a);
                if k > 0 {
                    r.add(Some(pc(k, c)), -a);
                }
            }
            r.add(Some(tc(k)), 0.3 * rnd());
            let rhs = 0.2 * rnd();
            for sign in [1.0, -1.0] {
                let mut row = Row::new();
                row.add_row(&r, sign).add(Some(s), -1.0);
                qp.leq(&row, sign * rhs);
            }
            let mut nonneg = Row::new();
            nonneg.add(Some(s), -1.0);
            qp.leq(&nonneg, 0.0);
            // || pose k+1 - pose k + d || <= 2 (T + dt_k), T = 0.3.
            let (dx, dy) = (0.5 + 0.1 * rnd(), 0.1 * rnd());
            let mut rt = Row::new();
            rt.add(Some(tc(k)), -2.0);
            let mut rx = Row::new();
            rx.add(Some(pc(k + 1, 0)), -1.0);
            let mut ry = Row::new();
            ry.add(Some(pc(k + 1, 1)), -1.0);
            if k > 0 {
                rx.add(Some(pc(k, 0)), 1.0);
                ry.add(Some(pc(k, 1)), 1.0);
            }
            qp.soc3([(&rt, 0.6), (&rx, dx), (&ry, dy)]);
        }
        qp
    }

    #[test]
    fn the_band_solver_agrees_with_clarabel_on_band_shaped_problems() {
        for (m, seed) in [(3, 1), (8, 2), (25, 3), (40, 4)] {
            let mut qp = band_like(m, seed);
            qp.settings = EXACT;
            let ours = qp.solve(50);
            assert!(ours.ok, "m {m}: not solved");
            assert_eq!(qp.fallbacks, 0, "m {m}: handed to clarabel");
            assert!(qp.conic.bandwidth() <= 11, "m {m}: not banded");
            let theirs = qp.solve_clarabel(50);
            assert!(theirs.ok, "m {m}: clarabel failed");
            let tol = 1e-6 * theirs.model.abs().max(1.0);
            assert!(
                (ours.model - theirs.model).abs() <= tol,
                "m {m}: model {} vs clarabel {}",
                ours.model,
                theirs.model
            );
        }
    }

    #[test]
    fn a_step_s_subproblem_stops_within_its_gap_of_the_optimum() {
        for (m, seed) in [(3, 1), (8, 2), (25, 3), (40, 4)] {
            let mut qp = band_like(m, seed);
            let step = qp.solve(50);
            let step_iterations = qp.ip_iterations;
            qp.settings = EXACT;
            let exact = qp.solve(50);
            assert!(step.ok && exact.ok, "m {m}: not solved");
            let gap = SETTINGS.tol_gap_rel * exact.model.abs().max(1.0);
            assert!(
                (step.model - exact.model).abs() <= gap,
                "m {m}: model {} vs {} exactly",
                step.model,
                exact.model
            );
            assert!(
                step_iterations < qp.ip_iterations,
                "m {m}: no iteration saved"
            );
        }
    }

    #[test]
    fn a_solve_does_not_depend_on_the_ones_before() {
        let mut fresh = band_like(25, 3);
        let a = fresh.solve(50);
        let mut used = band_like(40, 4);
        used.solve(50);
        let mut b_qp = band_like(8, 2);
        b_qp.solve(50);
        // Reuse `used`'s buffers for problem (25, 3).
        let mut reused = band_like(25, 3);
        std::mem::swap(&mut reused.conic, &mut used.conic);
        let b = reused.solve(50);
        assert_eq!(a.model.to_bits(), b.model.to_bits());
        assert!(
            fresh
                .x
                .iter()
                .zip(&reused.x)
                .all(|(p, q)| p.to_bits() == q.to_bits())
        );
    }
}
