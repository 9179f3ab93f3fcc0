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
    let out = w.iter_mut().zip(d.iter_mut()).zip(lambda.iter_mut());
    for ((&s, &z), ((w, d), lambda)) in s.iter().zip(z).zip(out) {
        // Without a branch per row: every row's three values are computed anyway.
        ok &= (s > 0.0) & (z > 0.0);
        *w = (s / z).sqrt();
        *d = z / s;
        *lambda = (s * z).sqrt();
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
    // The least of a set of quotients is the same whichever order it is taken in, so
    // four running minima without a branch per row (whose sign is unpredictable) give
    // the bits one loop gives.
    let ratio = |u: f64, d: f64| if d < 0.0 { -u / d } else { f64::INFINITY };
    let mut lanes = [cap; 4];
    let (u4, d4) = (u.chunks_exact(4), d.chunks_exact(4));
    let (u_rest, d_rest) = (u4.remainder(), d4.remainder());
    for (uq, dq) in u4.zip(d4) {
        for k in 0..4 {
            lanes[k] = lanes[k].min(ratio(uq[k], dq[k]));
        }
    }
    for (&u, &d) in u_rest.iter().zip(d_rest) {
        lanes[0] = lanes[0].min(ratio(u, d));
    }
    lanes.into_iter().fold(cap, f64::min)
}
