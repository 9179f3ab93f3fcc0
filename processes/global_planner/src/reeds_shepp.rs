//! Reeds-Shepp paths: the shortest curves between two poses for a car of minimum turning
//! radius that may drive forward and backward (Reeds and Shepp, 1990).
//!
//! The solver evaluates the closed-form solutions of the five families of the paper
//! (CSC, CCC, CCCC, CCSC/CSCC and CCSCC; formulas 8.1-8.11) under the time-flip,
//! reflection and backwards symmetries: 44 candidate words. It returns every candidate
//! that exists, so a caller can rank them by its own cost (reverse driving is dearer than
//! forward for the planner). Knows nothing of obstacles.

use crate::motion::Motion;
use aisle_geometry::{Pose2, wrap_angle};
use std::f64::consts::{FRAC_PI_2, PI};

/// Tolerance on the sign conditions of the closed-form solutions.
const ZERO: f64 = 1e-10;

/// What one segment of a Reeds-Shepp word does.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Steer {
    Left,
    Straight,
    Right,
}

use Steer::{Left as L, Right as R, Straight as S};

/// The 18 word shapes; unused tails are `Straight` with zero length.
const WORDS: [[Steer; 5]; 18] = [
    [L, R, L, S, S],
    [R, L, R, S, S],
    [L, R, L, R, S],
    [R, L, R, L, S],
    [L, R, S, L, S],
    [R, L, S, R, S],
    [L, S, R, L, S],
    [R, S, L, R, S],
    [L, R, S, R, S],
    [R, L, S, L, S],
    [R, S, R, L, S],
    [L, S, L, R, S],
    [L, S, R, S, S],
    [R, S, L, S, S],
    [L, S, L, S, S],
    [R, S, R, S, S],
    [L, R, S, L, R],
    [R, L, S, R, L],
];

/// One candidate path: up to five segments.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RsPath {
    pub steer: [Steer; 5],
    /// Signed segment lengths in units of the turning radius (radians for arcs);
    /// positive drives forward.
    pub lengths: [f64; 5],
}

impl RsPath {
    /// Total length in units of the turning radius.
    pub fn total(&self) -> f64 {
        self.lengths.iter().map(|l| l.abs()).sum()
    }

    /// The non-empty segments as motions for a car of turning radius `radius`.
    pub fn motions(&self, radius: f64) -> impl Iterator<Item = Motion> + '_ {
        self.steer
            .iter()
            .zip(self.lengths.iter())
            .filter(|(_, l)| l.abs() > 1e-12)
            .map(move |(s, l)| Motion::Drive {
                length: l * radius,
                curvature: match s {
                    Steer::Left => 1.0 / radius,
                    Steer::Straight => 0.0,
                    Steer::Right => -1.0 / radius,
                },
            })
    }

    /// Integrates the segments from `start`: where the path really ends.
    pub fn end_pose(&self, start: &Pose2, radius: f64) -> Pose2 {
        self.motions(radius).fold(*start, |p, m| m.end(&p))
    }
}

/// A fixed-capacity list of candidates (no allocation on the planner's hot path).
#[derive(Debug, Clone)]
pub struct Candidates {
    paths: [RsPath; 48],
    len: usize,
}

impl Default for Candidates {
    fn default() -> Self {
        Self {
            paths: [RsPath {
                steer: [S; 5],
                lengths: [0.0; 5],
            }; 48],
            len: 0,
        }
    }
}

impl Candidates {
    pub fn as_slice(&self) -> &[RsPath] {
        &self.paths[..self.len]
    }

    fn push(&mut self, word: usize, lengths: [f64; 5]) {
        if self.len < self.paths.len() {
            self.paths[self.len] = RsPath {
                steer: WORDS[word],
                lengths,
            };
            self.len += 1;
        }
    }
}

/// Fills `out` with every Reeds-Shepp candidate from `start` to `goal` for turning radius
/// `radius` (> 0). At least one candidate always exists for finite input.
pub fn solve(start: &Pose2, goal: &Pose2, radius: f64, out: &mut Candidates) {
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

/// The shortest candidate, if any.
pub fn shortest(start: &Pose2, goal: &Pose2, radius: f64) -> Option<RsPath> {
    let mut c = Candidates::default();
    solve(start, goal, radius, &mut c);
    c.as_slice()
        .iter()
        .copied()
        .min_by(|a, b| a.total().total_cmp(&b.total()))
}

/// Length in metres of the shortest Reeds-Shepp path.
pub fn distance(start: &Pose2, goal: &Pose2, radius: f64) -> f64 {
    shortest(start, goal, radius).map_or(f64::INFINITY, |p| p.total() * radius)
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

#[cfg(test)]
mod tests {
    use super::*;

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
}
