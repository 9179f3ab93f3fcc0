//! Assembly of one convex subproblem for clarabel: a quadratic objective over the band
//! variables, linear inequalities and 3-dimensional second-order cones, and the call to
//! the interior-point solver.
//!
//! Buffers are kept between calls, so after the first steps our side does not grow;
//! clarabel copies the data into its own workspace on every solve. Knows nothing of
//! what the variables mean.

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
    /// Solution of the last successful solve.
    pub x: Vec<f64>,
    /// Interior-point iterations of the last solve.
    pub ip_iterations: u32,
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
            x: Vec::new(),
            ip_iterations: 0,
        }
    }

    /// Starts a problem whose first `n_core` columns may carry quadratic terms.
    pub fn reset(&mut self, n_core: usize) {
        self.n_core = n_core;
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
        self.build();
        let settings = DefaultSettings::<f64> {
            max_iter,
            verbose: false,
            // Single-threaded and deterministic; the wall-clock limit stays infinite.
            max_threads: 1,
            // A trust-region step needs far less than clarabel's 1e-8 default accuracy:
            // the exact merit judges every step, and the candidate's velocity limits
            // are restored exactly afterwards. 1e-4 on the gap saves two or three
            // interior-point iterations (about 10 % of a subproblem) over 1e-6.
            tol_gap_abs: 1e-4,
            tol_gap_rel: 1e-4,
            tol_feas: 1e-5,
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
        qp.reset(2);
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
        let r = qp.solve(50);
        assert!(r.ok);
        // Solved to the accuracy the controller asks of clarabel (gap 1e-4).
        assert!((qp.x[0] - 0.5).abs() < 1e-4, "{:?}", qp.x);
        assert!((qp.x[1] - 0.75f64.sqrt()).abs() < 1e-4, "{:?}", qp.x);
        let expect = 0.25 + (1.0 - 0.75f64.sqrt()).powi(2);
        assert!((r.model - expect).abs() < 1e-4, "{} vs {expect}", r.model);
    }
}
