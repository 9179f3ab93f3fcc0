//! What one subproblem is, as the caller hands it over: P's core block, q, and the rows
//! of G with h (non-negative rows, then three rows per second-order cone), plus the
//! elimination order of the core columns. Knows nothing of how it is solved.

/// The subproblem: minimise 1/2 x'Px + q'x s.t. G x + s = h, s in the cones, where the
/// rows of G are `lin` (non-negative) then `soc` (three rows a second-order cone).
pub(crate) struct Data<'a> {
    pub n_core: usize,
    pub n: usize,
    /// Upper triangle of P's core block: (r, c), r <= c, at `r * n_core + c`.
    pub p_dense: &'a [f64],
    pub q: &'a [f64],
    /// (row, column, value), rows in increasing order.
    pub lin: &'a [(usize, usize, f64)],
    pub lin_b: &'a [f64],
    /// (row, column, value), rows in increasing order.
    pub soc: &'a [(usize, usize, f64)],
    pub soc_b: &'a [f64],
    /// Elimination position of each core column (a permutation of 0..n_core).
    pub position: &'a [usize],
}

impl Data<'_> {
    /// Rows of G (= the length of s, z and h).
    pub fn rows(&self) -> usize {
        self.lin_b.len() + self.soc_b.len()
    }

    /// h, row `r`.
    pub fn h(&self, r: usize) -> f64 {
        let m_lin = self.lin_b.len();
        if r < m_lin {
            self.lin_b[r]
        } else {
            self.soc_b[r - m_lin]
        }
    }
}
