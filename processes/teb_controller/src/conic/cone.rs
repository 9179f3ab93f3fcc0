//! The two cones of the subproblems, one block at a time: a non-negative scalar and the
//! 3-dimensional second-order cone {(u0, u1) : u0 >= |u1|}. For each, the Nesterov-Todd
//! scaling W of a pair (s, z) in the cone's interior (W z = W^-1 s = lambda), the Jordan
//! product and its inverse, and the longest step that stays in the cone.
//!
//! Second-order cone formulas (W symmetric, J = diag(1, -1, -1)):
//! s_bar = s / sqrt(s'Js), z_bar = z / sqrt(z'Jz), gamma = sqrt((1 + s_bar'z_bar) / 2),
//! w = (s_bar + J z_bar) / (2 gamma) (w'Jw = 1), eta = (s'Js / z'Jz)^(1/4),
//! W = eta [w0, w1'; w1, I + w1 w1' / (1 + w0)], W^2 = eta^2 (2 w w' - J),
//! W^-1 = [w0, -w1'; -w1, I + w1 w1' / (1 + w0)] / eta, W^-2 = (2 Jw (Jw)' - J) / eta^2.
//! Knows nothing of the problem the blocks belong to.

/// The scaling of one block at the current iterate.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct Scaling {
    /// Non-negative: w = sqrt(s / z) in `w[0]`. Cone: the normalised point w.
    w: [f64; 3],
    /// Cone: eta. Non-negative: unused.
    eta: f64,
}

/// A block's dimension: 1 (non-negative) or 3 (second-order cone).
pub(super) type Dim = usize;

/// u0^2 - |u1|^2 of a cone vector.
#[inline]
fn det(u: &[f64]) -> f64 {
    u[0] * u[0] - u[1] * u[1] - u[2] * u[2]
}

/// How far `u` lies outside the cone: the smallest t with u + t e in the cone (negative
/// when inside).
pub(super) fn violation(dim: Dim, u: &[f64]) -> f64 {
    if dim == 1 {
        -u[0]
    } else {
        u[1].hypot(u[2]) - u[0]
    }
}

impl Scaling {
    /// The scaling of (s, z), both strictly inside; None when they are not.
    pub fn new(dim: Dim, s: &[f64], z: &[f64]) -> Option<Scaling> {
        if dim == 1 {
            if !(s[0] > 0.0 && z[0] > 0.0) {
                return None;
            }
            return Some(Scaling {
                w: [(s[0] / z[0]).sqrt(), 0.0, 0.0],
                eta: 1.0,
            });
        }
        let (ds, dz) = (det(s), det(z));
        if !(ds > 0.0 && dz > 0.0 && s[0] > 0.0 && z[0] > 0.0) {
            return None;
        }
        let (ns, nz) = (ds.sqrt(), dz.sqrt());
        let sb = [s[0] / ns, s[1] / ns, s[2] / ns];
        let zb = [z[0] / nz, z[1] / nz, z[2] / nz];
        let gamma = (0.5 * (1.0 + sb[0] * zb[0] + sb[1] * zb[1] + sb[2] * zb[2])).sqrt();
        let w = [
            (sb[0] + zb[0]) / (2.0 * gamma),
            (sb[1] - zb[1]) / (2.0 * gamma),
            (sb[2] - zb[2]) / (2.0 * gamma),
        ];
        Some(Scaling {
            w,
            eta: (ns / nz).sqrt(),
        })
    }

    /// out = W v.
    pub fn apply(&self, dim: Dim, v: &[f64], out: &mut [f64]) {
        if dim == 1 {
            out[0] = self.w[0] * v[0];
            return;
        }
        self.apply_cone(v, out, 1.0, self.eta);
    }

    /// out = W^-1 v.
    pub fn apply_inverse(&self, dim: Dim, v: &[f64], out: &mut [f64]) {
        if dim == 1 {
            out[0] = v[0] / self.w[0];
            return;
        }
        self.apply_cone(v, out, -1.0, 1.0 / self.eta);
    }

    /// eta [w0, sign w1'; sign w1, I + w1 w1' / (1 + w0)] v.
    fn apply_cone(&self, v: &[f64], out: &mut [f64], sign: f64, eta: f64) {
        let w = &self.w;
        let w1v1 = w[1] * v[1] + w[2] * v[2];
        let c = sign * v[0] + w1v1 / (1.0 + w[0]);
        out[0] = eta * (w[0] * v[0] + sign * w1v1);
        out[1] = eta * (v[1] + c * w[1]);
        out[2] = eta * (v[2] + c * w[2]);
    }

    /// W^-2 as a symmetric matrix (row-major 3 x 3; only `[0]` for a scalar block).
    pub fn inverse_squared(&self, dim: Dim) -> [f64; 9] {
        let mut m = [0.0; 9];
        if dim == 1 {
            m[0] = 1.0 / (self.w[0] * self.w[0]);
            return m;
        }
        let jw = [self.w[0], -self.w[1], -self.w[2]];
        let k = 1.0 / (self.eta * self.eta);
        for r in 0..3 {
            for c in 0..3 {
                let j = if r == c {
                    if r == 0 { 1.0 } else { -1.0 }
                } else {
                    0.0
                };
                m[3 * r + c] = k * (2.0 * jw[r] * jw[c] - j);
            }
        }
        m
    }
}

/// Jordan product u o v.
pub(super) fn product(dim: Dim, u: &[f64], v: &[f64], out: &mut [f64]) {
    if dim == 1 {
        out[0] = u[0] * v[0];
        return;
    }
    out[0] = u[0] * v[0] + u[1] * v[1] + u[2] * v[2];
    out[1] = u[0] * v[1] + v[0] * u[1];
    out[2] = u[0] * v[2] + v[0] * u[2];
}

/// x with lambda o x = v (lambda strictly inside the cone).
pub(super) fn divide(dim: Dim, lambda: &[f64], v: &[f64], out: &mut [f64]) {
    if dim == 1 {
        out[0] = v[0] / lambda[0];
        return;
    }
    let l1v1 = lambda[1] * v[1] + lambda[2] * v[2];
    let x0 = (lambda[0] * v[0] - l1v1) / det(lambda);
    out[0] = x0;
    out[1] = (v[1] - x0 * lambda[1]) / lambda[0];
    out[2] = (v[2] - x0 * lambda[2]) / lambda[0];
}

/// The largest alpha (at most `cap`) with u + alpha d in the cone, u inside it.
pub(super) fn step_length(dim: Dim, u: &[f64], d: &[f64], cap: f64) -> f64 {
    let mut alpha = cap;
    if d[0] < 0.0 {
        alpha = alpha.min(-u[0] / d[0]);
    }
    if dim == 1 {
        return alpha;
    }
    // (u0 + a d0)^2 - |u1 + a d1|^2 = qa a^2 + qb a + qc, qc > 0: its first positive
    // root (if any) is where the step leaves the cone.
    let qa = det(d);
    let qb = 2.0 * (u[0] * d[0] - u[1] * d[1] - u[2] * d[2]);
    let qc = det(u);
    let root = if qa == 0.0 {
        if qb < 0.0 { -qc / qb } else { f64::INFINITY }
    } else {
        let disc = qb * qb - 4.0 * qa * qc;
        if disc < 0.0 {
            f64::INFINITY
        } else {
            // Both roots without cancellation.
            let sq = disc.sqrt();
            let t = -0.5 * (qb + qb.signum() * sq);
            let (r1, r2) = (t / qa, if t != 0.0 { qc / t } else { f64::INFINITY });
            [r1, r2]
                .into_iter()
                .filter(|r| *r > 0.0)
                .fold(f64::INFINITY, f64::min)
        }
    };
    alpha.min(root)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: &[f64], b: &[f64]) -> bool {
        a.iter()
            .zip(b)
            .all(|(x, y)| (x - y).abs() <= 1e-12 * (1.0 + y.abs()))
    }

    #[test]
    fn nt_scaling_maps_z_and_s_to_one_point() {
        let s = [2.0, 0.5, -1.2];
        let z = [1.5, -0.3, 0.9];
        let sc = Scaling::new(3, &s, &z).unwrap();
        let (mut wz, mut winv_s) = ([0.0; 3], [0.0; 3]);
        sc.apply(3, &z, &mut wz);
        sc.apply_inverse(3, &s, &mut winv_s);
        assert!(close(&wz, &winv_s), "{wz:?} {winv_s:?}");
        // W^-2 v = W^-1 (W^-1 v).
        let m = sc.inverse_squared(3);
        let v = [0.3, -0.7, 0.2];
        let (mut a, mut b) = ([0.0; 3], [0.0; 3]);
        sc.apply_inverse(3, &v, &mut a);
        sc.apply_inverse(3, &a, &mut b);
        let mv: Vec<f64> = (0..3)
            .map(|r| (0..3).map(|c| m[3 * r + c] * v[c]).sum())
            .collect();
        assert!(close(&mv, &b), "{mv:?} {b:?}");
    }

    #[test]
    fn divide_inverts_the_product() {
        let l = [2.0, 0.4, -1.1];
        let x = [0.3, -2.0, 0.8];
        let mut v = [0.0; 3];
        product(3, &l, &x, &mut v);
        let mut back = [0.0; 3];
        divide(3, &l, &v, &mut back);
        assert!(close(&back, &x), "{back:?}");
    }

    #[test]
    fn step_length_stops_on_the_cone_boundary() {
        let u = [1.0, 0.0, 0.0];
        let d = [0.0, 1.0, 0.0];
        assert!((step_length(3, &u, &d, 10.0) - 1.0).abs() < 1e-12);
        let d = [1.0, 0.5, 0.0];
        assert_eq!(step_length(3, &u, &d, 10.0), 10.0);
        let d = [-1.0, 0.0, 0.0];
        assert!((step_length(3, &u, &d, 10.0) - 1.0).abs() < 1e-12);
        assert!((step_length(1, &[2.0], &[-4.0], 10.0) - 0.5).abs() < 1e-12);
    }
}
