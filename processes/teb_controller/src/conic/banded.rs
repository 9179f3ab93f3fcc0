//! A symmetric positive definite matrix with a band of half-width `bw` below its
//! diagonal, stored row by row, factored in place as L D L' and solved. O(n bw^2) to
//! factor, O(n bw) to solve, no allocation once sized. Knows nothing of what the rows
//! are.

/// Lower band of a symmetric matrix: entry (i, j), i - bw <= j <= i, at
/// `i * (bw + 1) + (i - j)`.
#[derive(Default)]
pub(super) struct Banded {
    n: usize,
    bw: usize,
    a: Vec<f64>,
    /// D of the factorisation, then scratch.
    d: Vec<f64>,
    /// One column of L below its diagonal, while it updates the rest.
    column: Vec<f64>,
}

impl Banded {
    /// A zero n x n matrix of half-bandwidth `bw` (capped at n - 1).
    pub fn reset(&mut self, n: usize, bw: usize) {
        self.n = n;
        self.bw = bw.min(n.saturating_sub(1));
        self.a.clear();
        self.a.resize(n * (self.bw + 1), 0.0);
        self.d.clear();
        self.d.resize(n, 0.0);
        self.column.clear();
        self.column.resize(self.bw, 0.0);
    }

    /// Sets every entry to zero, keeping the shape.
    pub fn clear(&mut self) {
        self.a.fill(0.0);
    }

    /// Adds `v` to entries (i, j) and (j, i); |i - j| must be within the band.
    #[cfg(test)]
    pub fn add(&mut self, i: usize, j: usize, v: f64) {
        let at = self.offset(i, j);
        self.a[at] += v;
    }

    /// Where entries (i, j) and (j, i) are stored, for [`Banded::add_at`]; |i - j| must
    /// be within the band.
    #[inline]
    pub fn offset(&self, i: usize, j: usize) -> usize {
        let (i, j) = if i >= j { (i, j) } else { (j, i) };
        debug_assert!(i - j <= self.bw);
        i * (self.bw + 1) + (i - j)
    }

    /// Adds `v` to the entries stored at `offset`.
    #[inline]
    pub fn add_at(&mut self, offset: usize, v: f64) {
        self.a[offset] += v;
    }

    /// Factors in place as L D L'. False when a pivot is not positive (the matrix is
    /// not positive definite to working precision).
    ///
    /// Right-looking: once column k is final, every entry it updates is updated at
    /// once. Entry (i, j) still receives its terms (l_ik l_jk) d_k in increasing k and
    /// is divided by d_j last, the operations and order of the row-by-row (left-looking)
    /// form, so the bits are the same; but the updates of one k are independent of
    /// each other, where the row-by-row sums were chains of dependent subtractions.
    pub fn factor(&mut self) -> bool {
        let (n, w) = (self.n, self.bw + 1);
        let Banded { a, d, column, .. } = self;
        for k in 0..n {
            let dk = a[k * w];
            if dk.is_nan() || dk <= 0.0 || dk.is_infinite() {
                return false;
            }
            d[k] = dk;
            let below = (k + w).min(n) - k - 1;
            // Column k below its diagonal, l_ik for i = k + 1 ..= k + below, kept apart:
            // each row's update reads all of it.
            for (t, l) in column[..below].iter_mut().enumerate() {
                let i = k + 1 + t;
                let at = i * w + (i - k);
                a[at] /= dk;
                *l = a[at];
            }
            // Row i's entries (i, j), j = k + 1 ..= i, sit at i w + (i - j): the
            // slice i w + 0 ..= i w + (i - k - 1), in decreasing j.
            for (t, &lik) in column[..below].iter().enumerate() {
                let i = k + 1 + t;
                let row = &mut a[i * w..i * w + t + 1];
                for (entry, &ljk) in row.iter_mut().zip(column[..=t].iter().rev()) {
                    *entry -= lik * ljk * dk;
                }
            }
        }
        true
    }

    /// Solves (L D L') x = b in place, after [`Banded::factor`].
    pub fn solve(&self, b: &mut [f64]) {
        let (n, bw, w) = (self.n, self.bw, self.bw + 1);
        for i in 0..n {
            let lo = i.saturating_sub(bw);
            let row_i = &self.a[i * w..(i + 1) * w];
            let (done, rest) = b.split_at_mut(i);
            let mut v = rest[0];
            for (l, bk) in row_i[1..=i - lo].iter().rev().zip(&done[lo..]) {
                v -= l * bk;
            }
            rest[0] = v;
        }
        for (bi, di) in b[..n].iter_mut().zip(&self.d) {
            *bi /= di;
        }
        for i in (0..n).rev() {
            let (head, later) = b[..n].split_at_mut(i + 1);
            let mut v = head[i];
            for (j, bk) in later.iter().enumerate().take(w - 1) {
                let k = i + 1 + j;
                v -= self.a[k * w + (k - i)] * bk;
            }
            head[i] = v;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn solves_a_tridiagonal_system() {
        // [4 1 0; 1 4 1; 0 1 4] x = [5 6 5] -> x = [1 1 1].
        let mut m = Banded::default();
        m.reset(3, 1);
        for i in 0..3 {
            m.add(i, i, 4.0);
        }
        m.add(1, 0, 1.0);
        m.add(2, 1, 1.0);
        assert!(m.factor());
        let mut b = [5.0, 6.0, 5.0];
        m.solve(&mut b);
        for v in b {
            assert!((v - 1.0).abs() < 1e-14, "{b:?}");
        }
    }

    #[test]
    fn matches_a_dense_solve_with_a_wider_band() {
        // A = B B' + I with B lower-banded (half-width 2): A has half-width 4.
        let n = 9;
        let bw = 4;
        let b_at = |i: usize, j: usize| {
            if j <= i && i - j <= 2 {
                1.0 + 0.1 * (i * 3 + j) as f64
            } else {
                0.0
            }
        };
        let mut dense = vec![0.0; n * n];
        for i in 0..n {
            for j in 0..n {
                let v: f64 = (0..n).map(|k| b_at(i, k) * b_at(j, k)).sum();
                dense[i * n + j] = v + if i == j { 1.0 } else { 0.0 };
            }
        }
        let mut m = Banded::default();
        m.reset(n, bw);
        for i in 0..n {
            for j in i.saturating_sub(bw)..=i {
                m.add(i, j, dense[i * n + j]);
            }
        }
        assert!(m.factor());
        let x: Vec<f64> = (0..n).map(|i| (i as f64 * 0.7).sin()).collect();
        let mut b: Vec<f64> = (0..n)
            .map(|i| (0..n).map(|j| dense[i * n + j] * x[j]).sum())
            .collect();
        m.solve(&mut b);
        for i in 0..n {
            assert!((b[i] - x[i]).abs() < 1e-10, "{i}: {} vs {}", b[i], x[i]);
        }
    }

    #[test]
    fn refuses_an_indefinite_matrix() {
        let mut m = Banded::default();
        m.reset(2, 1);
        m.add(0, 0, 1.0);
        m.add(1, 1, 1.0);
        m.add(1, 0, 2.0);
        assert!(!m.factor());
    }
}
