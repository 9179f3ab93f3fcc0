//! The non-negative part of the cone, all rows at once (most of a TEB subproblem's
//! rows): the scaling w = sqrt(s / z), lambda = sqrt(s z), W^-2 = z / s, the scaled
//! complementarity target of a step and the longest step. Flat loops over slices, the
//! scalar case of `cone.rs`. Knows nothing of the rows' meaning.

use super::Step;

/// Shifts `v` into the interior if any entry is not positive: by 1 + its most
/// negative entry, every entry alike (CVXOPT's and clarabel's start).
pub(super) fn shift_into_interior(v: &mut [f64]) {
    let worst = v.iter().fold(f64::NEG_INFINITY, |m, x| m.max(-x));
    if worst > -1e-8 {
        v.iter_mut().for_each(|x| *x += 1.0 + worst);
    }
}

/// The scaling of (s, z); false when some pair is not strictly positive.
pub(super) fn scale(
    s: &[f64],
    z: &[f64],
    w: &mut [f64],
    d: &mut [f64],
    lambda: &mut [f64],
) -> bool {
    let mut ok = true;
    for r in 0..s.len() {
        ok &= s[r] > 0.0 && z[r] > 0.0;
        w[r] = (s[r] / z[r]).sqrt();
        d[r] = z[r] / s[r];
        lambda[r] = (s[r] * z[r]).sqrt();
    }
    ok
}

/// The target t with W^-1 ds + W dz = t: -lambda for the predictor; for the
/// corrector (sigma mu - lambda^2 - c (ds_a / w)(w dz_a)) / lambda, from the
/// predictor's (ds_a, dz_a) (the product is ds_a dz_a: w cancels).
pub(super) fn target(step: Step, lambda: &[f64], ds: &[f64], dz: &[f64], t: &mut [f64]) {
    match step {
        Step::Predictor => {
            for r in 0..lambda.len() {
                t[r] = -lambda[r];
            }
        }
        Step::Corrector {
            sigma_mu,
            correction,
            ..
        } => {
            for r in 0..lambda.len() {
                let l = lambda[r];
                // (ds / w) (w dz) = ds dz.
                t[r] = (sigma_mu - l * l - correction * ds[r] * dz[r]) / l;
            }
        }
    }
}

/// The largest alpha (at most `cap`) with u + alpha d >= 0, u > 0.
pub(super) fn step_length(u: &[f64], d: &[f64], cap: f64) -> f64 {
    let mut alpha = cap;
    for r in 0..u.len() {
        if d[r] < 0.0 {
            alpha = alpha.min(-u[r] / d[r]);
        }
    }
    alpha
}
