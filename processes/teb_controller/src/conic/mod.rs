//! A primal-dual interior-point solver for the TEB subproblems: minimise
//! 1/2 x'Px + q'x subject to G x + s = h with s in a product of non-negative rays and
//! 3-dimensional second-order cones. Mehrotra predictor-corrector steps in the
//! Nesterov-Todd scaling, with clarabel's choices (centring (1 - alpha)^3, residuals
//! reduced with the gap, a damped correction in the first iteration), but each Newton
//! system reduced to the band's structure (`kkt.rs`): slack columns eliminated one by
//! one and the rest factored as a banded matrix, O(poses) per iteration instead of a
//! general sparse LDL' of the whole KKT matrix, with no setup, no ordering and no
//! allocation once its buffers have grown.
//!
//! | file        | holds                                                   |
//! |-------------|---------------------------------------------------------|
//! | `cone.rs`   | scaling, Jordan product and step length of one cone     |
//! | `data.rs`   | the subproblem as the caller hands it over              |
//! | `banded.rs` | the banded L D L' factorisation                         |
//! | `kkt.rs`    | the rows, the slacks and the reduced Newton system      |
//! | `pairs.rs`  | where each row's products land in the banded matrix     |
//!
//! The cost is scaled to unit size and the rows to a largest coefficient of 1, which
//! leaves the minimiser as it is but starts the iterations near the central path (with
//! the TEB's L1 weights of 200 the unscaled start sat five orders of magnitude away).
//!
//! Reports failure (never a wrong answer) when the structure is not the band's or the
//! iterations do not converge; the caller then solves with clarabel. Deterministic:
//! the same data give the same bits. Knows nothing of bands or the SCP loop.

mod banded;
mod cone;
mod data;
mod kkt;
mod pairs;
mod rays;
#[cfg(test)]
mod tests;

pub(crate) use data::Data;

use cone::{Scaling, divide, product, step_length, violation};
use kkt::Kkt;

/// Stopping rule and iteration limit, clarabel's meaning.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Settings {
    pub max_iter: u32,
    pub tol_gap_abs: f64,
    pub tol_gap_rel: f64,
    pub tol_feas: f64,
}

impl Settings {
    /// The same settings with another iteration limit.
    pub const fn with_max_iter(self, max_iter: u32) -> Settings {
        Settings { max_iter, ..self }
    }
}

/// Fraction of the longest feasible step taken.
const STEP_FRACTION: f64 = 0.99;

/// The solver and its buffers. Rows of G: the rays first, then three per cone.
#[derive(Default)]
pub(crate) struct Conic {
    kkt: Kkt,
    /// Scaled cost and right-hand side.
    q: Vec<f64>,
    h: Vec<f64>,
    cost_scale: f64,
    s: Vec<f64>,
    z: Vec<f64>,
    lambda: Vec<f64>,
    /// Rays: w = sqrt(s / z) and W^-2 = z / s.
    ray_w: Vec<f64>,
    ray_d: Vec<f64>,
    cones: Vec<Scaling>,
    cone_m: Vec<[f64; 9]>,
    rx: Vec<f64>,
    rz: Vec<f64>,
    dx: Vec<f64>,
    ds: Vec<f64>,
    dz: Vec<f64>,
    t: Vec<f64>,
    tmp: Vec<f64>,
    work: Vec<f64>,
    /// P x of the current iterate.
    px: Vec<f64>,
    /// Whether `rx` and `rz` were computed from the iterate, not carried.
    fresh: bool,
    /// s'z of the iterate the stopping rule last judged.
    s_z: f64,
    /// Largest entries of the scaled q and h (constant through a solve).
    q_norm: f64,
    h_norm: f64,
    /// Solution of the last successful solve.
    pub x: Vec<f64>,
    /// Interior-point iterations of the last solve.
    pub iterations: u32,
}

/// Which step of an iteration a right-hand side is for.
#[derive(Clone, Copy, PartialEq)]
pub(super) enum Step {
    Predictor,
    /// Centring target sigma mu, the residuals' factor 1 - sigma, and the weight of
    /// the second-order correction.
    Corrector {
        sigma_mu: f64,
        keep: f64,
        correction: f64,
    },
}

impl Conic {
    /// Solves; true with the minimiser in `x`, false when this solver cannot (the
    /// structure is not banded as required, or no convergence within the limit).
    pub fn solve(&mut self, d: &Data, set: &Settings) -> bool {
        self.iterations = 0;
        let p_max = d.p_dense.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let q_max = d.q.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        self.cost_scale = 1.0 / p_max.max(q_max).max(1.0);
        if !self.kkt.analyse(d, self.cost_scale) {
            return false;
        }
        self.size(d);
        self.start();
        self.fresh = false;
        let degree = (self.kkt.n_ray + self.kkt.n_cone) as f64;
        while self.iterations < set.max_iter {
            if self.converged(d.n, set) {
                return self.x.iter().all(|v| v.is_finite());
            }
            self.iterations += 1;
            if !self.scale() || !self.kkt.factor(&self.ray_d, &self.cone_m) {
                return false;
            }
            // s'z of this iterate, from the stopping rule just applied to it.
            let mu = self.s_z / degree;
            self.direction(d.n, Step::Predictor);
            let alpha = self.max_step(1.0);
            let sigma = (1.0 - alpha).powi(3);
            // The first iterate is badly centred: a damped correction (clarabel).
            let correction = if self.iterations == 1 { alpha } else { 1.0 };
            self.direction(
                d.n,
                Step::Corrector {
                    sigma_mu: sigma * mu,
                    keep: 1.0 - sigma,
                    correction,
                },
            );
            let alpha = (STEP_FRACTION * self.max_step(f64::INFINITY)).min(1.0);
            for (x, dx) in self.x.iter_mut().zip(&self.dx) {
                *x += alpha * dx;
            }
            for (s, ds) in self.s.iter_mut().zip(&self.ds) {
                *s += alpha * ds;
            }
            for (z, dz) in self.z.iter_mut().zip(&self.dz) {
                *z += alpha * dz;
            }
            // The corrector's direction solves P dx + G'dz = -keep r_x and
            // G dx + ds = -keep r_z, so a step of alpha scales both residuals by
            // 1 - alpha keep: carried instead of two more products with G.
            let shrink = 1.0 - alpha * (1.0 - sigma);
            self.rx.iter_mut().for_each(|v| *v *= shrink);
            self.rz.iter_mut().for_each(|v| *v *= shrink);
            self.fresh = false;
        }
        false
    }

    /// Sizes every buffer and fills the scaled cost and right-hand side.
    fn size(&mut self, d: &Data) {
        let (n, m) = (d.n, d.rows());
        self.q.clear();
        self.q.extend(d.q.iter().map(|v| v * self.cost_scale));
        self.h.clear();
        self.h
            .extend((0..m).map(|r| self.kkt.row_scale[r] * d.h(r)));
        self.q_norm = inf_norm(&self.q);
        self.h_norm = inf_norm(&self.h);
        for v in [
            &mut self.x,
            &mut self.rx,
            &mut self.dx,
            &mut self.work,
            &mut self.px,
        ] {
            v.clear();
            v.resize(n, 0.0);
        }
        for v in [
            &mut self.s,
            &mut self.z,
            &mut self.lambda,
            &mut self.rz,
            &mut self.ds,
            &mut self.dz,
            &mut self.t,
            &mut self.tmp,
        ] {
            v.clear();
            v.resize(m, 0.0);
        }
        let (rays, cones) = (self.kkt.n_ray, self.kkt.n_cone);
        self.ray_w.clear();
        self.ray_w.resize(rays, 1.0);
        self.ray_d.clear();
        self.ray_d.resize(rays, 1.0);
        self.cones.clear();
        self.cones.resize(cones, Scaling::default());
        self.cone_m.clear();
        self.cone_m.resize(cones, [0.0; 9]);
    }

    /// A starting point: x = 0 (the band as it is: a subproblem's columns are steps
    /// from it), s = h shifted into the interior (the rays together, each cone on its
    /// own) and z = e, the cones' identity. The least-squares start of CVXOPT and
    /// clarabel ((P + G'G) x = -q + G'h) cost a factorisation and, with the L1 weights
    /// two orders above the quadratic terms, put every slack column near -1 and the
    /// first gap five orders above the last: 16.9 iterations a subproblem on a seed
    /// mission's steps against 15.8 from here.
    fn start(&mut self) {
        self.x.iter_mut().for_each(|v| *v = 0.0);
        self.s.copy_from_slice(&self.h);
        let rays = self.kkt.n_ray;
        rays::shift_into_interior(&mut self.s[..rays]);
        for c in self.s[rays..].chunks_exact_mut(3) {
            let off = violation(3, c);
            if off > -1e-8 {
                c[0] += 1.0 + off;
            }
        }
        self.z[..rays].iter_mut().for_each(|v| *v = 1.0);
        for c in self.z[rays..].chunks_exact_mut(3) {
            c.copy_from_slice(&[1.0, 0.0, 0.0]);
        }
    }

    /// Residuals r_x = Px + q + G'z and r_z = Gx + s - h, from scratch.
    fn residuals(&mut self) {
        self.rx.copy_from_slice(&self.px);
        self.kkt.add_gty(&self.z, &mut self.rx);
        for (r, q) in self.rx.iter_mut().zip(&self.q) {
            *r += q;
        }
        self.rz.iter_mut().for_each(|v| *v = 0.0);
        self.kkt.add_gx(&self.x, &mut self.rz);
        for r in 0..self.rz.len() {
            self.rz[r] += self.s[r] - self.h[r];
        }
        self.fresh = true;
    }

    /// Whether clarabel's stopping rule holds on the caller's objective (feasibility
    /// relative to the data and the iterate, the gap absolute or relative to the
    /// objective). Between iterations the residuals are carried (`solve`); when the
    /// carried ones pass, they are computed afresh and judged again, so convergence is
    /// never reported on a residual that drifted.
    fn converged(&mut self, n: usize, set: &Settings) -> bool {
        self.px.iter_mut().for_each(|v| *v = 0.0);
        self.kkt.add_px(&self.x, &mut self.px);
        // Nothing is carried into the first iteration.
        if self.iterations > 0 && !self.fresh && !self.stopping(n, set) {
            return false;
        }
        if !self.fresh {
            self.residuals();
        }
        self.stopping(n, set)
    }

    /// Clarabel's rule, with the norms and products over the columns and over the rows
    /// in one pass each (each sum in index order, as a pass of its own would take it:
    /// the same bits). Remembers s'z for `solve`.
    fn stopping(&mut self, n: usize, set: &Settings) -> bool {
        let c = self.cost_scale;
        // Sums start at -0.0, as `Iterator::sum` does.
        let (mut x_px, mut q_x) = (-0.0, -0.0);
        let (mut px_norm, mut x_norm, mut rx_norm) = (0.0f64, 0.0f64, 0.0f64);
        let columns = self.x.iter().zip(&self.px).zip(&self.q).zip(&self.rx);
        for (((&x, &px), &q), &rx) in columns.take(n) {
            x_px += x * px;
            q_x += x * q;
            px_norm = px_norm.max(px.abs());
            x_norm = x_norm.max(x.abs());
            rx_norm = rx_norm.max(rx.abs());
        }
        let (mut h_z, mut s_z) = (-0.0, -0.0);
        let (mut s_norm, mut z_norm, mut rz_norm) = (0.0f64, 0.0f64, 0.0f64);
        let rows = self.s.iter().zip(&self.z).zip(&self.h).zip(&self.rz);
        for (((&s, &z), &h), &rz) in rows {
            h_z += h * z;
            s_z += s * z;
            s_norm = s_norm.max(s.abs());
            z_norm = z_norm.max(z.abs());
            rz_norm = rz_norm.max(rz.abs());
        }
        self.s_z = s_z;
        let primal_ok = rz_norm <= set.tol_feas * (1.0 + self.h_norm + x_norm + s_norm);
        let dual_ok = rx_norm / c <= set.tol_feas * (1.0 + (self.q_norm + px_norm + z_norm) / c);
        let pobj = (0.5 * x_px + q_x) / c;
        let dobj = (-0.5 * x_px - h_z) / c;
        let gap = s_z / c;
        let gap_ok =
            gap <= set.tol_gap_abs || gap <= set.tol_gap_rel * pobj.abs().min(dobj.abs()).max(1.0);
        primal_ok && dual_ok && gap_ok
    }

    /// The Nesterov-Todd scaling of every ray and cone, lambda = W z and W^-2.
    fn scale(&mut self) -> bool {
        let rays = self.kkt.n_ray;
        if !rays::scale(
            &self.s[..rays],
            &self.z[..rays],
            &mut self.ray_w,
            &mut self.ray_d,
            &mut self.lambda[..rays],
        ) {
            return false;
        }
        for k in 0..self.kkt.n_cone {
            let o = rays + 3 * k;
            let Some(sc) = Scaling::new(3, &self.s[o..o + 3], &self.z[o..o + 3]) else {
                return false;
            };
            sc.apply(3, &self.z[o..o + 3], &mut self.lambda[o..o + 3]);
            self.cone_m[k] = sc.inverse_squared(3);
            self.cones[k] = sc;
        }
        true
    }

    /// The Newton direction (dx, ds, dz) of a predictor or corrector step:
    /// (P + G'W^-2 G) dx = -k r_x - G'(k W^-2 r_z + W^-1 t), ds = -k r_z - G dx,
    /// dz = W^-1 (t - W^-1 ds), with t = lambda \ r_c the scaled complementarity target
    /// and k the residuals' factor.
    fn direction(&mut self, n: usize, step: Step) {
        let rays = self.kkt.n_ray;
        let keep = match step {
            Step::Predictor => 1.0,
            Step::Corrector { keep, .. } => keep,
        };
        rays::target(
            step,
            &self.lambda[..rays],
            &self.ds[..rays],
            &self.dz[..rays],
            &mut self.t[..rays],
        );
        for r in 0..rays {
            self.tmp[r] = keep * self.ray_d[r] * self.rz[r] + self.t[r] / self.ray_w[r];
        }
        for k in 0..self.kkt.n_cone {
            self.cone_target(rays + 3 * k, k, step, keep);
        }
        self.dx.iter_mut().for_each(|v| *v = 0.0);
        self.kkt.add_gty(&self.tmp, &mut self.dx);
        for c in 0..n {
            self.dx[c] = -keep * self.rx[c] - self.dx[c];
        }
        self.kkt.solve(&mut self.dx, &mut self.work);
        self.ds.iter_mut().for_each(|v| *v = 0.0);
        self.kkt.add_gx(&self.dx, &mut self.ds);
        for (ds, rz) in self.ds.iter_mut().zip(&self.rz) {
            *ds = -*ds - keep * rz;
        }
        for r in 0..rays {
            let w = self.ray_w[r];
            self.dz[r] = (self.t[r] - self.ds[r] / w) / w;
        }
        for k in 0..self.kkt.n_cone {
            let o = rays + 3 * k;
            let sc = &self.cones[k];
            let (mut a, mut v) = ([0.0; 3], [0.0; 3]);
            sc.apply_inverse(3, &self.ds[o..o + 3], &mut a);
            for r in 0..3 {
                v[r] = self.t[o + r] - a[r];
            }
            sc.apply_inverse(3, &v, &mut self.dz[o..o + 3]);
        }
    }

    /// Cone k (rows from `o`): its target t and its part of W^-2 r_z + W^-1 t in `tmp`.
    fn cone_target(&mut self, o: usize, k: usize, step: Step, keep: f64) {
        let lam = &self.lambda[o..o + 3];
        let sc = &self.cones[k];
        let mut target = [0.0; 3];
        match step {
            Step::Predictor => {
                for r in 0..3 {
                    target[r] = -lam[r];
                }
            }
            Step::Corrector {
                sigma_mu,
                correction,
                ..
            } => {
                // r_c = sigma mu e - lambda o lambda - (W^-1 ds_a) o (W dz_a).
                let (mut a, mut b, mut ll, mut cross, mut rc) =
                    ([0.0; 3], [0.0; 3], [0.0; 3], [0.0; 3], [0.0; 3]);
                sc.apply_inverse(3, &self.ds[o..o + 3], &mut a);
                sc.apply(3, &self.dz[o..o + 3], &mut b);
                product(3, lam, lam, &mut ll);
                product(3, &a, &b, &mut cross);
                for r in 0..3 {
                    rc[r] = -ll[r] - correction * cross[r];
                }
                rc[0] += sigma_mu;
                divide(3, lam, &rc, &mut target);
            }
        }
        self.t[o..o + 3].copy_from_slice(&target);
        let mut wt = [0.0; 3];
        sc.apply_inverse(3, &target, &mut wt);
        let m = &self.cone_m[k];
        for r in 0..3 {
            let mr = m[3 * r] * self.rz[o]
                + m[3 * r + 1] * self.rz[o + 1]
                + m[3 * r + 2] * self.rz[o + 2];
            self.tmp[o + r] = keep * mr + wt[r];
        }
    }

    /// The longest step (at most `cap`) keeping s and z in their cones.
    fn max_step(&self, cap: f64) -> f64 {
        let rays = self.kkt.n_ray;
        let mut alpha = rays::step_length(&self.s[..rays], &self.ds[..rays], cap);
        alpha = rays::step_length(&self.z[..rays], &self.dz[..rays], alpha);
        for k in 0..self.kkt.n_cone {
            let r = rays + 3 * k..rays + 3 * k + 3;
            alpha = step_length(3, &self.s[r.clone()], &self.ds[r.clone()], alpha);
            alpha = step_length(3, &self.z[r.clone()], &self.dz[r], alpha);
        }
        alpha
    }

    /// The reduced matrix's half-bandwidth in the last solve (diagnostics).
    #[cfg(test)]
    pub fn bandwidth(&self) -> usize {
        self.kkt.bandwidth
    }
}

fn inf_norm(v: &[f64]) -> f64 {
    v.iter().fold(0.0f64, |m, x| m.max(x.abs()))
}
