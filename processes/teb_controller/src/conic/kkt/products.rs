//! The reduced system's solve and the products with P and G the iterations need
//! (residuals, right-hand sides, directions), over the structure `kkt.rs` read. Loops
//! over each row's entries as slices, in the entries' order: the sums are the same
//! floating-point operations whatever the loop shape.

use super::Kkt;

impl Kkt {
    /// Solves the factored system for `rhs` (columns in the caller's order) in place;
    /// `work` has at least n_core entries.
    pub fn solve(&self, rhs: &mut [f64], work: &mut [f64]) {
        let nc = self.n_core;
        for (r, &p) in rhs[..nc].iter().zip(&self.pos) {
            work[p] = *r;
        }
        let slacks = self.nb_ptr.windows(2).zip(&self.hss);
        for ((nb, hss), r) in slacks.clone().zip(&rhs[nc..]) {
            let f = r / hss;
            let (pos, hcs) = (&self.nb_pos[nb[0]..nb[1]], &self.hcs[nb[0]..nb[1]]);
            for (&p, h) in pos.iter().zip(hcs) {
                work[p] -= h * f;
            }
        }
        self.band.solve(&mut work[..nc]);
        for (r, &p) in rhs[..nc].iter_mut().zip(&self.pos) {
            *r = work[p];
        }
        for ((nb, hss), r) in slacks.zip(&mut rhs[nc..]) {
            let mut v = *r;
            let (pos, hcs) = (&self.nb_pos[nb[0]..nb[1]], &self.hcs[nb[0]..nb[1]]);
            for (&p, h) in pos.iter().zip(hcs) {
                v -= h * work[p];
            }
            *r = v / hss;
        }
    }

    /// out += P x (columns in the caller's order).
    pub fn add_px(&self, x: &[f64], out: &mut [f64]) {
        for &(r, c, v) in &self.p_cols {
            out[r] += v * x[c];
            if r != c {
                out[c] += v * x[r];
            }
        }
    }

    /// out += G x (out: one entry per row).
    pub fn add_gx(&self, x: &[f64], out: &mut [f64]) {
        for (o, ends) in out[..self.n_ray].iter_mut().zip(self.ray_ptr.windows(2)) {
            let entries = ends[0]..ends[1];
            let mut v = 0.0;
            for (g, &c) in self.ray_val[entries.clone()]
                .iter()
                .zip(&self.ray_col[entries])
            {
                v += g * x[c];
            }
            *o += v;
        }
        let cones = out[self.n_ray..].chunks_exact_mut(3);
        for (o, ends) in cones.zip(self.cone_ptr.windows(2)) {
            let entries = ends[0]..ends[1];
            for (g, &c) in self.cone_val[entries.clone()]
                .iter()
                .zip(&self.cone_col[entries])
            {
                let xc = x[c];
                o[0] += g[0] * xc;
                o[1] += g[1] * xc;
                o[2] += g[2] * xc;
            }
        }
    }

    /// out += G' y (out: one entry per column).
    pub fn add_gty(&self, y: &[f64], out: &mut [f64]) {
        for (&yr, ends) in y[..self.n_ray].iter().zip(self.ray_ptr.windows(2)) {
            let entries = ends[0]..ends[1];
            for (g, &c) in self.ray_val[entries.clone()]
                .iter()
                .zip(&self.ray_col[entries])
            {
                out[c] += g * yr;
            }
        }
        let cones = y[self.n_ray..].chunks_exact(3);
        for (yc, ends) in cones.zip(self.cone_ptr.windows(2)) {
            let entries = ends[0]..ends[1];
            for (g, &c) in self.cone_val[entries.clone()]
                .iter()
                .zip(&self.cone_col[entries])
            {
                out[c] += g[0] * yc[0] + g[1] * yc[1] + g[2] * yc[2];
            }
        }
    }
}
