//! Tests of the Reeds-Shepp solver, and the solver as it was before its variants shared
//! their terms (`reference_solve`), against which the solver is checked bit for bit.

use super::*;
use aisle_geometry::wrap_angle;
use std::f64::consts::TAU;

/// A small deterministic generator so the property tests need no RNG crate.
struct Lcg(u64);
impl Lcg {
    fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
    fn pose(&mut self, span: f64) -> Pose2 {
        Pose2::new(
            (self.next() - 0.5) * span,
            (self.next() - 0.5) * span,
            (self.next() - 0.5) * 2.0 * PI,
        )
    }
}

fn close(a: &Pose2, b: &Pose2, tol: f64) -> bool {
    a.distance(b) < tol && a.heading_error(b) < tol
}

#[test]
fn every_candidate_ends_at_the_goal() {
    let mut rng = Lcg(7);
    let mut c = Candidates::default();
    let mut seen_words = [false; 18];
    for _ in 0..3000 {
        let a = rng.pose(8.0);
        let b = rng.pose(8.0);
        let radius = 0.3 + rng.next() * 1.5;
        solve(&a, &b, radius, &mut c);
        assert!(!c.as_slice().is_empty());
        for p in c.as_slice() {
            let e = p.end_pose(&a, radius);
            assert!(
                close(&e, &b, 1e-6),
                "{p:?} from {a:?} ends at {e:?}, not {b:?}"
            );
            let w = WORDS.iter().position(|w| *w == p.steer).unwrap();
            seen_words[w] = true;
        }
    }
    assert!(
        seen_words.iter().all(|s| *s),
        "every word shape occurs: {seen_words:?}"
    );
}

#[test]
fn sampled_path_ends_at_the_goal() {
    let a = Pose2::new(1.0, 2.0, 0.3);
    let b = Pose2::new(-2.0, 1.0, 2.5);
    let p = shortest(&a, &b, 0.8).unwrap();
    let mut pose = a;
    for m in p.motions(0.8) {
        let n = 17;
        let mut last = pose;
        for k in 1..=n {
            last = m.at(&pose, k as f64 / n as f64);
        }
        pose = last;
    }
    assert!(close(&pose, &b, 1e-9));
}

#[test]
fn known_lengths() {
    let o = Pose2::default();
    assert!((distance(&o, &Pose2::new(3.0, 0.0, 0.0), 1.0) - 3.0).abs() < 1e-12);
    assert!((distance(&o, &Pose2::new(-3.0, 0.0, 0.0), 1.0) - 3.0).abs() < 1e-12);
    // A quarter circle of radius 2 to the left.
    let q = distance(&o, &Pose2::new(2.0, 2.0, FRAC_PI_2), 2.0);
    assert!((q - PI).abs() < 1e-9, "{q}");
    assert_eq!(distance(&o, &o, 1.0), 0.0);
    // Sideways by 1 with the same heading needs more than the straight distance.
    assert!(distance(&o, &Pose2::new(0.0, 1.0, 0.0), 1.0) > 1.0 + 1e-3);
}

#[test]
fn symmetric_triangle_and_lower_bound() {
    let mut rng = Lcg(11);
    for _ in 0..1500 {
        let a = rng.pose(6.0);
        let b = rng.pose(6.0);
        let c = rng.pose(6.0);
        let r = 0.5 + rng.next();
        let ab = distance(&a, &b, r);
        let ba = distance(&b, &a, r);
        assert!((ab - ba).abs() < 1e-6 * (1.0 + ab), "{ab} vs {ba}");
        let bc = distance(&b, &c, r);
        let ac = distance(&a, &c, r);
        assert!(ac <= ab + bc + 1e-6, "{ac} > {ab} + {bc}");
        assert!(ab + 1e-9 >= a.distance(&b));
        // Shortest path is invariant under a common rigid motion of both poses.
        let t = Pose2::new(0.7, -1.3, 0.9);
        let moved = distance(&t.compose(&a), &t.compose(&b), r);
        assert!((moved - ab).abs() < 1e-6 * (1.0 + ab));
    }
}

/// The solver gives the very candidates (order, words, length bits) of the solver as it
/// was before its variants shared their terms, on random poses and on the special ones
/// (same pose, straight ahead, pure turns).
#[test]
fn same_bits_as_the_reference_solver() {
    let mut rng = Lcg(23);
    let mut pairs = vec![
        (Pose2::default(), Pose2::default()),
        (Pose2::default(), Pose2::new(3.0, 0.0, 0.0)),
        (Pose2::default(), Pose2::new(-3.0, 0.0, 0.0)),
        (Pose2::default(), Pose2::new(0.0, 0.0, PI)),
        (Pose2::default(), Pose2::new(0.0, 0.0, -PI)),
        (Pose2::default(), Pose2::new(2.0, 2.0, FRAC_PI_2)),
        (Pose2::default(), Pose2::new(0.0, 1.0, 0.0)),
        (Pose2::new(2.0, 13.0, -1.4292), Pose2::new(6.0, -7.0, 0.0)),
    ];
    for k in 0..50_000 {
        let span = [0.5, 4.0, 30.0][k % 3];
        pairs.push((rng.pose(span), rng.pose(span)));
    }
    // Headings on whole bins and positions on a 0.1 m grid, as the search's nodes are.
    for _ in 0..20_000 {
        let mut grid = |n: f64| ((rng.next() - 0.5) * n).round();
        let a = Pose2::new(
            grid(100.0) * 0.1,
            grid(100.0) * 0.1,
            grid(72.0) * TAU / 72.0,
        );
        let b = Pose2::new(
            grid(100.0) * 0.1,
            grid(100.0) * 0.1,
            grid(72.0) * TAU / 72.0,
        );
        pairs.push((a, b));
    }
    let (mut new, mut old) = (Candidates::default(), Candidates::default());
    let mut compared = 0;
    for (a, b) in pairs {
        for radius in [1.0, 0.7] {
            solve(&a, &b, radius, &mut new);
            reference_solve(&a, &b, radius, &mut old);
            assert_eq!(new.len, old.len, "{a:?} {b:?}");
            for (n, o) in new.as_slice().iter().zip(old.as_slice()) {
                assert_eq!(n.steer, o.steer, "{a:?} {b:?}");
                let bits = |p: &RsPath| p.lengths.map(f64::to_bits);
                assert_eq!(bits(n), bits(o), "{a:?} {b:?}");
                compared += 1;
            }
        }
    }
    assert!(compared > 500_000, "{compared}");
}

/// The solver as it was before its variants shared their terms (`Variant`): every
/// formula on its own, kept to prove the solver the same bit for bit.
fn reference_solve(start: &Pose2, goal: &Pose2, radius: f64, out: &mut Candidates) {
    out.len = 0;
    let (lx, ly) = start.inverse_transform_point(goal.x, goal.y);
    let x = lx / radius;
    let y = ly / radius;
    let phi = wrap_angle(goal.theta - start.theta);
    csc(x, y, phi, out);
    ccc(x, y, phi, out);
    cccc(x, y, phi, out);
    ccsc(x, y, phi, out);
    ccscc(x, y, phi, out);
}

#[inline]
fn polar(x: f64, y: f64) -> (f64, f64) {
    (x.hypot(y), y.atan2(x))
}

#[inline]
fn tau_omega(u: f64, v: f64, xi: f64, eta: f64, phi: f64) -> (f64, f64) {
    let delta = wrap_angle(u - v);
    let a = u.sin() - delta.sin();
    let b = u.cos() - delta.cos() - 1.0;
    let t1 = (eta * a - xi * b).atan2(xi * a + eta * b);
    let t2 = 2.0 * (delta.cos() - v.cos() - u.cos()) + 3.0;
    let tau = if t2 < 0.0 {
        wrap_angle(t1 + PI)
    } else {
        wrap_angle(t1)
    };
    let omega = wrap_angle(tau - u + v - phi);
    (tau, omega)
}

// Formula 8.1: L+ S+ L+.
fn lp_sp_lp(x: f64, y: f64, phi: f64) -> Option<(f64, f64, f64)> {
    let (u, t) = polar(x - phi.sin(), y - 1.0 + phi.cos());
    if t >= -ZERO {
        let v = wrap_angle(phi - t);
        if v >= -ZERO {
            return Some((t, u, v));
        }
    }
    None
}

// Formula 8.2: L+ S+ R+.
fn lp_sp_rp(x: f64, y: f64, phi: f64) -> Option<(f64, f64, f64)> {
    let (u1, t1) = polar(x + phi.sin(), y - 1.0 - phi.cos());
    let u1 = u1 * u1;
    if u1 >= 4.0 {
        let u = (u1 - 4.0).sqrt();
        let theta = 2.0_f64.atan2(u);
        let t = wrap_angle(t1 + theta);
        let v = wrap_angle(t - phi);
        if t >= -ZERO && v >= -ZERO {
            return Some((t, u, v));
        }
    }
    None
}

fn csc(x: f64, y: f64, phi: f64, out: &mut Candidates) {
    if let Some((t, u, v)) = lp_sp_lp(x, y, phi) {
        out.push(14, [t, u, v, 0.0, 0.0]);
    }
    if let Some((t, u, v)) = lp_sp_lp(-x, y, -phi) {
        out.push(14, [-t, -u, -v, 0.0, 0.0]);
    }
    if let Some((t, u, v)) = lp_sp_lp(x, -y, -phi) {
        out.push(15, [t, u, v, 0.0, 0.0]);
    }
    if let Some((t, u, v)) = lp_sp_lp(-x, -y, phi) {
        out.push(15, [-t, -u, -v, 0.0, 0.0]);
    }
    if let Some((t, u, v)) = lp_sp_rp(x, y, phi) {
        out.push(12, [t, u, v, 0.0, 0.0]);
    }
    if let Some((t, u, v)) = lp_sp_rp(-x, y, -phi) {
        out.push(12, [-t, -u, -v, 0.0, 0.0]);
    }
    if let Some((t, u, v)) = lp_sp_rp(x, -y, -phi) {
        out.push(13, [t, u, v, 0.0, 0.0]);
    }
    if let Some((t, u, v)) = lp_sp_rp(-x, -y, phi) {
        out.push(13, [-t, -u, -v, 0.0, 0.0]);
    }
}

// Formulas 8.3 / 8.4: L+ R- L.
fn lp_rm_l(x: f64, y: f64, phi: f64) -> Option<(f64, f64, f64)> {
    let xi = x - phi.sin();
    let eta = y - 1.0 + phi.cos();
    let (u1, theta) = polar(xi, eta);
    if u1 <= 4.0 {
        let u = -2.0 * (0.25 * u1).asin();
        let t = wrap_angle(theta + 0.5 * u + PI);
        let v = wrap_angle(phi - t + u);
        if t >= -ZERO && u <= ZERO {
            return Some((t, u, v));
        }
    }
    None
}

fn ccc(x: f64, y: f64, phi: f64, out: &mut Candidates) {
    if let Some((t, u, v)) = lp_rm_l(x, y, phi) {
        out.push(0, [t, u, v, 0.0, 0.0]);
    }
    if let Some((t, u, v)) = lp_rm_l(-x, y, -phi) {
        out.push(0, [-t, -u, -v, 0.0, 0.0]);
    }
    if let Some((t, u, v)) = lp_rm_l(x, -y, -phi) {
        out.push(1, [t, u, v, 0.0, 0.0]);
    }
    if let Some((t, u, v)) = lp_rm_l(-x, -y, phi) {
        out.push(1, [-t, -u, -v, 0.0, 0.0]);
    }
    let xb = x * phi.cos() + y * phi.sin();
    let yb = x * phi.sin() - y * phi.cos();
    if let Some((t, u, v)) = lp_rm_l(xb, yb, phi) {
        out.push(0, [v, u, t, 0.0, 0.0]);
    }
    if let Some((t, u, v)) = lp_rm_l(-xb, yb, -phi) {
        out.push(0, [-v, -u, -t, 0.0, 0.0]);
    }
    if let Some((t, u, v)) = lp_rm_l(xb, -yb, -phi) {
        out.push(1, [v, u, t, 0.0, 0.0]);
    }
    if let Some((t, u, v)) = lp_rm_l(-xb, -yb, phi) {
        out.push(1, [-v, -u, -t, 0.0, 0.0]);
    }
}

// Formula 8.7: L+ R+ L- R-.
fn lp_rup_lum_rm(x: f64, y: f64, phi: f64) -> Option<(f64, f64, f64)> {
    let xi = x + phi.sin();
    let eta = y - 1.0 - phi.cos();
    let rho = 0.25 * (2.0 + xi.hypot(eta));
    if rho <= 1.0 {
        let u = rho.acos();
        let (t, v) = tau_omega(u, -u, xi, eta, phi);
        if t >= -ZERO && v <= ZERO {
            return Some((t, u, v));
        }
    }
    None
}

// Formula 8.8: L+ R- L- R+.
fn lp_rum_lum_rp(x: f64, y: f64, phi: f64) -> Option<(f64, f64, f64)> {
    let xi = x + phi.sin();
    let eta = y - 1.0 - phi.cos();
    let rho = (20.0 - xi * xi - eta * eta) / 16.0;
    if (0.0..=1.0).contains(&rho) {
        let u = -rho.acos();
        if u >= -FRAC_PI_2 {
            let (t, v) = tau_omega(u, u, xi, eta, phi);
            if t >= -ZERO && v >= -ZERO {
                return Some((t, u, v));
            }
        }
    }
    None
}

fn cccc(x: f64, y: f64, phi: f64, out: &mut Candidates) {
    if let Some((t, u, v)) = lp_rup_lum_rm(x, y, phi) {
        out.push(2, [t, u, -u, v, 0.0]);
    }
    if let Some((t, u, v)) = lp_rup_lum_rm(-x, y, -phi) {
        out.push(2, [-t, -u, u, -v, 0.0]);
    }
    if let Some((t, u, v)) = lp_rup_lum_rm(x, -y, -phi) {
        out.push(3, [t, u, -u, v, 0.0]);
    }
    if let Some((t, u, v)) = lp_rup_lum_rm(-x, -y, phi) {
        out.push(3, [-t, -u, u, -v, 0.0]);
    }
    if let Some((t, u, v)) = lp_rum_lum_rp(x, y, phi) {
        out.push(2, [t, u, u, v, 0.0]);
    }
    if let Some((t, u, v)) = lp_rum_lum_rp(-x, y, -phi) {
        out.push(2, [-t, -u, -u, -v, 0.0]);
    }
    if let Some((t, u, v)) = lp_rum_lum_rp(x, -y, -phi) {
        out.push(3, [t, u, u, v, 0.0]);
    }
    if let Some((t, u, v)) = lp_rum_lum_rp(-x, -y, phi) {
        out.push(3, [-t, -u, -u, -v, 0.0]);
    }
}

// Formula 8.9: L+ R-(pi/2) S- L-.
fn lp_rm_sm_lm(x: f64, y: f64, phi: f64) -> Option<(f64, f64, f64)> {
    let xi = x - phi.sin();
    let eta = y - 1.0 + phi.cos();
    let (rho, theta) = polar(xi, eta);
    if rho >= 2.0 {
        let r = (rho * rho - 4.0).sqrt();
        let u = 2.0 - r;
        let t = wrap_angle(theta + r.atan2(-2.0));
        let v = wrap_angle(phi - FRAC_PI_2 - t);
        if t >= -ZERO && u <= ZERO && v <= ZERO {
            return Some((t, u, v));
        }
    }
    None
}

// Formula 8.10: L+ R-(pi/2) S- R-.
fn lp_rm_sm_rm(x: f64, y: f64, phi: f64) -> Option<(f64, f64, f64)> {
    let xi = x + phi.sin();
    let eta = y - 1.0 - phi.cos();
    let (rho, theta) = polar(-eta, xi);
    if rho >= 2.0 {
        let t = theta;
        let u = 2.0 - rho;
        let v = wrap_angle(t + FRAC_PI_2 - phi);
        if t >= -ZERO && u <= ZERO && v <= ZERO {
            return Some((t, u, v));
        }
    }
    None
}

fn ccsc(x: f64, y: f64, phi: f64, out: &mut Candidates) {
    let h = FRAC_PI_2;
    if let Some((t, u, v)) = lp_rm_sm_lm(x, y, phi) {
        out.push(4, [t, -h, u, v, 0.0]);
    }
    if let Some((t, u, v)) = lp_rm_sm_lm(-x, y, -phi) {
        out.push(4, [-t, h, -u, -v, 0.0]);
    }
    if let Some((t, u, v)) = lp_rm_sm_lm(x, -y, -phi) {
        out.push(5, [t, -h, u, v, 0.0]);
    }
    if let Some((t, u, v)) = lp_rm_sm_lm(-x, -y, phi) {
        out.push(5, [-t, h, -u, -v, 0.0]);
    }
    if let Some((t, u, v)) = lp_rm_sm_rm(x, y, phi) {
        out.push(8, [t, -h, u, v, 0.0]);
    }
    if let Some((t, u, v)) = lp_rm_sm_rm(-x, y, -phi) {
        out.push(8, [-t, h, -u, -v, 0.0]);
    }
    if let Some((t, u, v)) = lp_rm_sm_rm(x, -y, -phi) {
        out.push(9, [t, -h, u, v, 0.0]);
    }
    if let Some((t, u, v)) = lp_rm_sm_rm(-x, -y, phi) {
        out.push(9, [-t, h, -u, -v, 0.0]);
    }
    let xb = x * phi.cos() + y * phi.sin();
    let yb = x * phi.sin() - y * phi.cos();
    if let Some((t, u, v)) = lp_rm_sm_lm(xb, yb, phi) {
        out.push(6, [v, u, -h, t, 0.0]);
    }
    if let Some((t, u, v)) = lp_rm_sm_lm(-xb, yb, -phi) {
        out.push(6, [-v, -u, h, -t, 0.0]);
    }
    if let Some((t, u, v)) = lp_rm_sm_lm(xb, -yb, -phi) {
        out.push(7, [v, u, -h, t, 0.0]);
    }
    if let Some((t, u, v)) = lp_rm_sm_lm(-xb, -yb, phi) {
        out.push(7, [-v, -u, h, -t, 0.0]);
    }
    if let Some((t, u, v)) = lp_rm_sm_rm(xb, yb, phi) {
        out.push(10, [v, u, -h, t, 0.0]);
    }
    if let Some((t, u, v)) = lp_rm_sm_rm(-xb, yb, -phi) {
        out.push(10, [-v, -u, h, -t, 0.0]);
    }
    if let Some((t, u, v)) = lp_rm_sm_rm(xb, -yb, -phi) {
        out.push(11, [v, u, -h, t, 0.0]);
    }
    if let Some((t, u, v)) = lp_rm_sm_rm(-xb, -yb, phi) {
        out.push(11, [-v, -u, h, -t, 0.0]);
    }
}

// Formula 8.11: L+ R-(pi/2) S- L-(pi/2) R+.
fn lp_rm_s_lm_rp(x: f64, y: f64, phi: f64) -> Option<(f64, f64, f64)> {
    let xi = x + phi.sin();
    let eta = y - 1.0 - phi.cos();
    let (rho, _) = polar(xi, eta);
    if rho >= 2.0 {
        let u = 4.0 - (rho * rho - 4.0).sqrt();
        if u <= ZERO {
            let t = wrap_angle(((4.0 - u) * xi - 2.0 * eta).atan2(-2.0 * xi + (u - 4.0) * eta));
            let v = wrap_angle(t - phi);
            if t >= -ZERO && v >= -ZERO {
                return Some((t, u, v));
            }
        }
    }
    None
}

fn ccscc(x: f64, y: f64, phi: f64, out: &mut Candidates) {
    let h = FRAC_PI_2;
    if let Some((t, u, v)) = lp_rm_s_lm_rp(x, y, phi) {
        out.push(16, [t, -h, u, -h, v]);
    }
    if let Some((t, u, v)) = lp_rm_s_lm_rp(-x, y, -phi) {
        out.push(16, [-t, h, -u, h, -v]);
    }
    if let Some((t, u, v)) = lp_rm_s_lm_rp(x, -y, -phi) {
        out.push(17, [t, -h, u, -h, v]);
    }
    if let Some((t, u, v)) = lp_rm_s_lm_rp(-x, -y, phi) {
        out.push(17, [-t, h, -u, h, -v]);
    }
}
