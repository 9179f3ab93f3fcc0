//! Reeds-Shepp paths: the shortest curves between two poses for a car of minimum turning
//! radius that may drive forward and backward (Reeds and Shepp, 1990).
//!
//! The solver evaluates the closed-form solutions of the five families of the paper
//! (CSC, CCC, CCCC, CCSC/CSCC and CCSCC; formulas 8.1-8.11) under the time-flip,
//! reflection and backwards symmetries: 44 candidate words. It returns every candidate
//! that exists, so a caller can rank them by its own cost (reverse driving is dearer than
//! forward for the planner). Knows nothing of obstacles.

use crate::angle::wrap;
use crate::motion::Motion;
use aisle_geometry::Pose2;
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
    let phi = wrap(goal.theta - start.theta);
    // The eight symmetric problems each family solves (time flip, reflection, both; then
    // the same of the backwards problem), with the terms their words share.
    let (sp, cp, sm, cm) = (phi.sin(), phi.cos(), (-phi).sin(), (-phi).cos());
    let xb = x * cp + y * sp;
    let yb = x * sp - y * cp;
    let fwd = [
        Variant::new(x, y, phi, sp, cp, true),
        Variant::new(-x, y, -phi, sm, cm, true),
        Variant::new(x, -y, -phi, sm, cm, true),
        Variant::new(-x, -y, phi, sp, cp, true),
    ];
    let back = [
        Variant::new(xb, yb, phi, sp, cp, false),
        Variant::new(-xb, yb, -phi, sm, cm, false),
        Variant::new(xb, -yb, -phi, sm, cm, false),
        Variant::new(-xb, -yb, phi, sp, cp, false),
    ];
    csc(&fwd, out);
    ccc(&fwd, &back, out);
    cccc(&fwd, out);
    ccsc(&fwd, &back, out);
    ccscc(&fwd, out);
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

/// One of the symmetric problems (x, y, phi) and the terms its words share, each
/// computed once by the very expression every word used to evaluate on its own (so the
/// candidates are the same bits; `atan2`, `hypot` and `sin`/`cos` were most of the
/// solver's time, and the free-space heuristic solves once per node).
struct Variant {
    phi: f64,
    /// The polar form (rho, theta) of (`x - sin phi`, `y - 1 + cos phi`): the centre
    /// terms of L+S+L+, L+R-L and L+R-S-L-.
    a_polar: (f64, f64),
    /// `x + sin phi`, `y - 1 - cos phi`: the centre terms of L+S+R+, the CCCC words,
    /// L+R-S-R- and L+R-S-L-R+.
    b: (f64, f64),
    /// Polar form of `b` (forward variants only: the backward problems use `b` in
    /// L+R-S-R- alone, which takes the polar form of (-eta, xi)).
    b_polar: (f64, f64),
}

impl Variant {
    #[inline]
    fn new(x: f64, y: f64, phi: f64, sin: f64, cos: f64, with_b_polar: bool) -> Variant {
        let a = (x - sin, y - 1.0 + cos);
        let b = (x + sin, y - 1.0 - cos);
        Variant {
            phi,
            a_polar: polar(a.0, a.1),
            b,
            b_polar: if with_b_polar {
                polar(b.0, b.1)
            } else {
                (f64::NAN, f64::NAN)
            },
        }
    }
}

#[inline]
fn tau_omega(u: f64, v: f64, xi: f64, eta: f64, phi: f64) -> (f64, f64) {
    let delta = wrap(u - v);
    let a = u.sin() - delta.sin();
    let b = u.cos() - delta.cos() - 1.0;
    let t1 = (eta * a - xi * b).atan2(xi * a + eta * b);
    let t2 = 2.0 * (delta.cos() - v.cos() - u.cos()) + 3.0;
    let tau = if t2 < 0.0 { wrap(t1 + PI) } else { wrap(t1) };
    let omega = wrap(tau - u + v - phi);
    (tau, omega)
}

/// Pushes `word` with the lengths `lengths(t, u, v, h)` makes of each variant's
/// solution, in the order of the variants: the time flip and reflection symmetries of
/// one formula. `h` is the signed quarter turn of the words that have one.
#[inline]
fn push_flips(
    out: &mut Candidates,
    vs: &[Variant; 4],
    formula: fn(&Variant) -> Option<(f64, f64, f64)>,
    word: usize,
    lengths: fn(f64, f64, f64, f64) -> [f64; 5],
) {
    for (k, vr) in vs.iter().enumerate() {
        if let Some((t, u, v)) = formula(vr) {
            // Variants 1 and 3 are time-flipped: every length changes sign (the unused
            // tail stays +0); 2 and 3 are reflected: the mirror word follows in `WORDS`.
            let l = if k % 2 == 1 {
                lengths(-t, -u, -v, -FRAC_PI_2)
            } else {
                lengths(t, u, v, FRAC_PI_2)
            };
            out.push(word + k / 2, l);
        }
    }
}

// Formula 8.1: L+ S+ L+.
fn lp_sp_lp(vr: &Variant) -> Option<(f64, f64, f64)> {
    let (u, t) = vr.a_polar;
    if t >= -ZERO {
        let v = wrap(vr.phi - t);
        if v >= -ZERO {
            return Some((t, u, v));
        }
    }
    None
}

// Formula 8.2: L+ S+ R+.
fn lp_sp_rp(vr: &Variant) -> Option<(f64, f64, f64)> {
    let (u1, t1) = vr.b_polar;
    let u1 = u1 * u1;
    if u1 >= 4.0 {
        let u = (u1 - 4.0).sqrt();
        let theta = 2.0_f64.atan2(u);
        let t = wrap(t1 + theta);
        let v = wrap(t - vr.phi);
        if t >= -ZERO && v >= -ZERO {
            return Some((t, u, v));
        }
    }
    None
}

fn csc(fwd: &[Variant; 4], out: &mut Candidates) {
    push_flips(out, fwd, lp_sp_lp, 14, |t, u, v, _| [t, u, v, 0.0, 0.0]);
    push_flips(out, fwd, lp_sp_rp, 12, |t, u, v, _| [t, u, v, 0.0, 0.0]);
}

// Formulas 8.3 / 8.4: L+ R- L.
fn lp_rm_l(vr: &Variant) -> Option<(f64, f64, f64)> {
    let (u1, theta) = vr.a_polar;
    if u1 <= 4.0 {
        let u = -2.0 * (0.25 * u1).asin();
        let t = wrap(theta + 0.5 * u + PI);
        let v = wrap(vr.phi - t + u);
        if t >= -ZERO && u <= ZERO {
            return Some((t, u, v));
        }
    }
    None
}

fn ccc(fwd: &[Variant; 4], back: &[Variant; 4], out: &mut Candidates) {
    push_flips(out, fwd, lp_rm_l, 0, |t, u, v, _| [t, u, v, 0.0, 0.0]);
    push_flips(out, back, lp_rm_l, 0, |t, u, v, _| [v, u, t, 0.0, 0.0]);
}

// Formula 8.7: L+ R+ L- R-.
fn lp_rup_lum_rm(vr: &Variant) -> Option<(f64, f64, f64)> {
    let (xi, eta) = vr.b;
    let rho = 0.25 * (2.0 + vr.b_polar.0);
    if rho <= 1.0 {
        let u = rho.acos();
        let (t, v) = tau_omega(u, -u, xi, eta, vr.phi);
        if t >= -ZERO && v <= ZERO {
            return Some((t, u, v));
        }
    }
    None
}

// Formula 8.8: L+ R- L- R+.
fn lp_rum_lum_rp(vr: &Variant) -> Option<(f64, f64, f64)> {
    let (xi, eta) = vr.b;
    let rho = (20.0 - xi * xi - eta * eta) / 16.0;
    if (0.0..=1.0).contains(&rho) {
        let u = -rho.acos();
        if u >= -FRAC_PI_2 {
            let (t, v) = tau_omega(u, u, xi, eta, vr.phi);
            if t >= -ZERO && v >= -ZERO {
                return Some((t, u, v));
            }
        }
    }
    None
}

fn cccc(fwd: &[Variant; 4], out: &mut Candidates) {
    push_flips(out, fwd, lp_rup_lum_rm, 2, |t, u, v, _| [t, u, -u, v, 0.0]);
    push_flips(out, fwd, lp_rum_lum_rp, 2, |t, u, v, _| [t, u, u, v, 0.0]);
}

// Formula 8.9: L+ R-(pi/2) S- L-.
fn lp_rm_sm_lm(vr: &Variant) -> Option<(f64, f64, f64)> {
    let (rho, theta) = vr.a_polar;
    if rho >= 2.0 {
        let r = (rho * rho - 4.0).sqrt();
        let u = 2.0 - r;
        let t = wrap(theta + r.atan2(-2.0));
        let v = wrap(vr.phi - FRAC_PI_2 - t);
        if t >= -ZERO && u <= ZERO && v <= ZERO {
            return Some((t, u, v));
        }
    }
    None
}

// Formula 8.10: L+ R-(pi/2) S- R-.
fn lp_rm_sm_rm(vr: &Variant) -> Option<(f64, f64, f64)> {
    let (xi, eta) = vr.b;
    let (rho, theta) = polar(-eta, xi);
    if rho >= 2.0 {
        let t = theta;
        let u = 2.0 - rho;
        let v = wrap(t + FRAC_PI_2 - vr.phi);
        if t >= -ZERO && u <= ZERO && v <= ZERO {
            return Some((t, u, v));
        }
    }
    None
}

fn ccsc(fwd: &[Variant; 4], back: &[Variant; 4], out: &mut Candidates) {
    push_flips(out, fwd, lp_rm_sm_lm, 4, |t, u, v, h| [t, -h, u, v, 0.0]);
    push_flips(out, fwd, lp_rm_sm_rm, 8, |t, u, v, h| [t, -h, u, v, 0.0]);
    push_flips(out, back, lp_rm_sm_lm, 6, |t, u, v, h| [v, u, -h, t, 0.0]);
    push_flips(out, back, lp_rm_sm_rm, 10, |t, u, v, h| [v, u, -h, t, 0.0]);
}

// Formula 8.11: L+ R-(pi/2) S- L-(pi/2) R+.
fn lp_rm_s_lm_rp(vr: &Variant) -> Option<(f64, f64, f64)> {
    let (xi, eta) = vr.b;
    let rho = vr.b_polar.0;
    if rho >= 2.0 {
        let u = 4.0 - (rho * rho - 4.0).sqrt();
        if u <= ZERO {
            let t = wrap(((4.0 - u) * xi - 2.0 * eta).atan2(-2.0 * xi + (u - 4.0) * eta));
            let v = wrap(t - vr.phi);
            if t >= -ZERO && v >= -ZERO {
                return Some((t, u, v));
            }
        }
    }
    None
}

fn ccscc(fwd: &[Variant; 4], out: &mut Candidates) {
    push_flips(out, fwd, lp_rm_s_lm_rp, 16, |t, u, v, h| [t, -h, u, -h, v]);
}

#[cfg(test)]
mod tests;
