//! Sequential convex programming over a band: each iteration linearises the kinematics,
//! accelerations, drive direction and obstacle clearances around the current band,
//! solves the convex subproblem with clarabel inside a trust region, and keeps the step
//! if the exact merit (minimum time + weights + L1 constraint violations) drops.
//!
//! Velocity limits are exact second-order cones (|dp| <= v_max dT) and linear bounds
//! (|dtheta| <= w_max dT), so every accepted band meets them. Knows nothing of goals,
//! sections or the bus: it receives a [`Problem`] and a band and improves the band.
//!
//! Each subproblem costs most of a step's time, so the loop avoids needless ones:
//! - every candidate is repaired before it is judged (kinematic slip projected out,
//!   velocity limits and accelerations restored by lengthening time steps), so steps
//!   are not rejected for the curvature of the linearised constraints;
//! - clearance rows the trust region cannot make active are left out;
//! - a rejected step is retried once at a fraction of its length (one merit
//!   evaluation) before the trust region shrinks;
//! - the loop stops as soon as the model predicted the merit exactly for a step that
//!   stayed inside its trust region, or once the band meets every constraint and the
//!   next subproblem promises only a small fraction of the merit.

use aisle_geometry::{Footprint, GridView, Pose2};

use crate::band::Band;
use crate::clearance::{CellHit, min_clearance, nearest_per_sector};
use crate::config::TebConfig;
use crate::kinematics::Projector;
use crate::qp::{Qp, Row};
use crate::reference::{Reference, Section};
use crate::timing::{Timing, retime};

/// Everything fixed during one step's optimisation.
pub(crate) struct Problem<'a> {
    pub cfg: &'a TebConfig,
    pub map: &'a GridView<'a>,
    pub footprint: Footprint,
    pub margin: f64,
    /// Measured velocity at the start pose (v m/s, w rad/s).
    pub v0: f64,
    pub w0: f64,
    /// Where the band should end; heading continuous with the band's last pose.
    pub goal: Pose2,
    /// End at rest (the goal of the section lies inside the horizon).
    pub at_rest: bool,
    /// +1 forward, -1 reverse, 0 turn on the spot.
    pub sigma: f64,
    pub reference: &'a Reference,
    pub section: Section,
    /// Arc-length window of the reference the band may project onto.
    pub s_lo: f64,
    pub s_hi: f64,
}

impl Problem<'_> {
    /// Boundary conditions and limits of the acceleration retiming.
    pub fn timing(&self) -> Timing {
        Timing {
            v0: self.v0,
            w0: self.w0,
            at_rest: self.at_rest,
            max_acceleration: self.cfg.limits.max_acceleration,
            max_angular_acceleration: self.cfg.limits.max_angular_acceleration,
        }
    }

    pub fn v_limit(&self) -> f64 {
        if self.sigma < 0.0 {
            self.cfg.limits.max_reverse_velocity
        } else {
            self.cfg.limits.max_velocity
        }
    }
}

/// What one optimisation did.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub(crate) struct ScpStats {
    pub iterations: usize,
    pub merit: f64,
    /// Trust-region scale the optimiser ended with (1 = the configured radius).
    pub scale: f64,
}

/// Reusable buffers of the optimiser.
pub(crate) struct Scp {
    qp: Qp,
    candidate: Band,
    hits: [Option<CellHit>; 4],
    proj: Projector,
    slip_target: Vec<f64>,
}

/// Column of pose `i`'s coordinate `c` (0 x, 1 y, 2 theta); pose 0 is fixed.
#[inline]
fn pc(i: usize, c: usize) -> Option<usize> {
    if i == 0 { None } else { Some(3 * (i - 1) + c) }
}

/// Component `c` of pose `i`'s step in `d` (zero for the fixed pose 0).
#[inline]
fn d_at(d: &[f64], i: usize, c: usize) -> f64 {
    pc(i, c).map_or(0.0, |k| d[k])
}

/// Linearised v_k = (dp_k . h_k) / T_k: value and gradient row.
fn lin_v(band: &Band, k: usize, t_col: usize) -> (f64, Row) {
    let a = band.poses[k];
    let b = band.poses[k + 1];
    let tm = 0.5 * (a.theta + b.theta);
    let (s, c) = tm.sin_cos();
    let t = band.dts[k];
    let n = (b.x - a.x) * c + (b.y - a.y) * s;
    let mut r = Row::new();
    r.add(pc(k + 1, 0), c / t)
        .add(pc(k + 1, 1), s / t)
        .add(pc(k, 0), -c / t)
        .add(pc(k, 1), -s / t)
        .add(Some(t_col), -n / (t * t));
    (n / t, r)
}

/// Linearised w_k = dtheta_k / T_k.
fn lin_w(band: &Band, k: usize, t_col: usize) -> (f64, Row) {
    let t = band.dts[k];
    let d = band.poses[k + 1].theta - band.poses[k].theta;
    let mut r = Row::new();
    r.add(pc(k + 1, 2), 1.0 / t)
        .add(pc(k, 2), -1.0 / t)
        .add(Some(t_col), -d / (t * t));
    (d / t, r)
}

/// `candidate` = `band` moved by `alpha` times the step `x` (pose steps, then time
/// steps), with every time step kept at least `min_dt`.
fn apply_step(candidate: &mut Band, band: &Band, x: &[f64], alpha: f64, min_dt: f64) {
    candidate.copy_from(band);
    for i in 1..band.poses.len() {
        let q = &mut candidate.poses[i];
        q.x += alpha * x[3 * (i - 1)];
        q.y += alpha * x[3 * (i - 1) + 1];
        q.theta += alpha * x[3 * (i - 1) + 2];
    }
    let t0 = 3 * (band.poses.len() - 1);
    for k in 0..band.dts.len() {
        candidate.dts[k] = (band.dts[k] + alpha * x[t0 + k]).max(min_dt);
    }
}

/// Stretches every time step that is too short for its segment under the velocity
/// limits `vlim` (m/s) and `wmax` (rad/s).
pub(crate) fn fit_time_steps(band: &mut Band, vlim: f64, wmax: f64) {
    for k in 0..band.dts.len() {
        let a = band.poses[k];
        let b = band.poses[k + 1];
        let need = (chord(&a, &b) / vlim).max((b.theta - a.theta).abs() / wmax);
        if band.dts[k] < need {
            band.dts[k] = need;
        }
    }
}

/// Distance between two band poses: a plain root, as band coordinates cannot overflow
/// and `hypot`'s care for that costs several times more on these hot paths.
#[inline]
fn chord(a: &Pose2, b: &Pose2) -> f64 {
    let (dx, dy) = (b.x - a.x, b.y - a.y);
    (dx * dx + dy * dy).sqrt()
}

/// Pose a fraction `u` of the way from `a` to `b`.
fn lerp(a: &Pose2, b: &Pose2, u: f64) -> Pose2 {
    Pose2::new(
        a.x + u * (b.x - a.x),
        a.y + u * (b.y - a.y),
        a.theta + u * (b.theta - a.theta),
    )
}

/// Clearance samples strictly between two poses: one per started `SAMPLE_SPACING`,
/// at least one (the midpoint), at most `MAX_INTERIOR_SAMPLES`. A stretched segment
/// would otherwise cut a corner unchecked.
fn interior_samples(a: &Pose2, b: &Pose2) -> usize {
    let n = (chord(a, b) / SAMPLE_SPACING).ceil();
    if n.is_finite() {
        (n as usize).clamp(1, MAX_INTERIOR_SAMPLES)
    } else {
        1
    }
}

const SAMPLE_SPACING: f64 = 0.3;
/// Largest constraint violation (in each constraint's units) of a band that counts as
/// meeting every constraint.
pub(crate) const FEASIBLE: f64 = 1e-3;
/// Gauss-Newton sweeps of the kinematic projection of a candidate.
const PROJECTION_SWEEPS: usize = 2;
/// Relative error of the predicted merit decrease below which the model counts as exact.
const EXACT_MODEL: f64 = 1e-2;
/// Fraction of the trust region an interior step stays within.
const INTERIOR: f64 = 0.5;
/// Fraction of a rejected step tried before the next subproblem.
const LINE_STEP: f64 = 0.3;
const MAX_INTERIOR_SAMPLES: usize = 6;

/// Signed velocity of segment k along its mid heading, m/s.
pub(crate) fn segment_velocity(band: &Band, k: usize) -> f64 {
    let a = band.poses[k];
    let b = band.poses[k + 1];
    let (s, c) = (0.5 * (a.theta + b.theta)).sin_cos();
    ((b.x - a.x) * c + (b.y - a.y) * s) / band.dts[k]
}

pub(crate) fn segment_rate(band: &Band, k: usize) -> f64 {
    (band.poses[k + 1].theta - band.poses[k].theta) / band.dts[k]
}

/// Lateral slip of segment k: zero when both poses lie on one circular arc.
fn kinematic_residual(a: &Pose2, b: &Pose2) -> f64 {
    let (s, c) = (0.5 * (a.theta + b.theta)).sin_cos();
    -s * (b.x - a.x) + c * (b.y - a.y)
}

/// Normal offset of (x, y) from the reference (zero on degenerate sections).
fn reference_offset(p: &Problem, x: f64, y: f64) -> (f64, f64, f64) {
    let pr = p.reference.project(&p.section, x, y, p.s_lo, p.s_hi);
    let (nx, ny) = (-pr.ty, pr.tx);
    (nx * (x - pr.x) + ny * (y - pr.y), nx, ny)
}

/// The individual constraint violations of a band, in their own units.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub(crate) struct Violations {
    pub velocity: f64,
    pub acceleration: f64,
    pub kinematics: f64,
    pub clearance: f64,
    pub direction: f64,
}

impl Violations {
    pub fn max(&self) -> f64 {
        self.velocity
            .max(self.acceleration)
            .max(self.kinematics)
            .max(self.clearance)
            .max(self.direction)
    }
}

/// Accumulates violations both as a sum (merit) and a maximum (report).
#[derive(Default)]
struct Tally {
    sum: f64,
    worst: Violations,
}

fn evaluate(p: &Problem, band: &Band) -> (f64, Violations) {
    let cfg = p.cfg;
    let w = &cfg.weights;
    let lim = &cfg.limits;
    let m = band.dts.len();
    let mut t = Tally::default();
    let mut cost = w.time * band.duration();
    let vlim = p.v_limit();
    for k in 0..m {
        let a = band.poses[k];
        let b = band.poses[k + 1];
        let dt = band.dts[k];
        let vel = (chord(&a, &b) - vlim * dt).max(0.0) / dt;
        let rate = ((b.theta - a.theta).abs() - lim.max_angular_velocity * dt).max(0.0) / dt;
        t.sum += vel * dt + rate * dt;
        t.worst.velocity = t.worst.velocity.max(vel).max(rate);
        if p.sigma == 0.0 {
            let d = (b.x - a.x).abs() + (b.y - a.y).abs();
            t.sum += d;
            t.worst.kinematics = t.worst.kinematics.max(d);
        } else {
            let f = kinematic_residual(&a, &b).abs();
            t.sum += f;
            t.worst.kinematics = t.worst.kinematics.max(f);
            let (s, c) = (0.5 * (a.theta + b.theta)).sin_cos();
            let n = (b.x - a.x) * c + (b.y - a.y) * s;
            let back = (-p.sigma * n).max(0.0);
            t.sum += back;
            t.worst.direction = t.worst.direction.max(back);
        }
    }
    // Accelerations: from the measured velocity, between segments, to rest at the goal.
    let (amax, alpha) = (lim.max_acceleration, lim.max_angular_acceleration);
    let accel = |dv: f64, span: f64, limit: f64, t: &mut Tally| {
        let g = (dv.abs() - limit * span).max(0.0);
        t.sum += g;
        t.worst.acceleration = t.worst.acceleration.max(g / span);
    };
    if m > 0 {
        accel(segment_velocity(band, 0) - p.v0, band.dts[0], amax, &mut t);
        accel(segment_rate(band, 0) - p.w0, band.dts[0], alpha, &mut t);
        for k in 0..m.saturating_sub(1) {
            let span = 0.5 * (band.dts[k] + band.dts[k + 1]);
            accel(
                segment_velocity(band, k + 1) - segment_velocity(band, k),
                span,
                amax,
                &mut t,
            );
            accel(
                segment_rate(band, k + 1) - segment_rate(band, k),
                span,
                alpha,
                &mut t,
            );
        }
        if p.at_rest {
            accel(segment_velocity(band, m - 1), band.dts[m - 1], amax, &mut t);
            accel(segment_rate(band, m - 1), band.dts[m - 1], alpha, &mut t);
        }
    }
    // Clearance at every pose but the fixed start, and at points between poses.
    for i in 1..band.poses.len() {
        let (a, b) = (band.poses[i - 1], band.poses[i]);
        let n = interior_samples(&a, &b);
        for j in 0..=n {
            let q = if j == 0 {
                b
            } else {
                lerp(&a, &b, j as f64 / (n + 1) as f64)
            };
            let g = (p.margin - min_clearance(p.map, &p.footprint, &q, p.margin)).max(0.0);
            t.sum += g;
            t.worst.clearance = t.worst.clearance.max(g);
        }
    }
    cost += w.constraint * t.sum;
    // Reference, smoothness, goal.
    if p.sigma != 0.0 {
        for q in &band.poses[1..] {
            let (r, _, _) = reference_offset(p, q.x, q.y);
            cost += w.reference * r * r;
        }
    }
    for i in 1..band.poses.len().saturating_sub(1) {
        let d2 = band.poses[i + 1].theta - 2.0 * band.poses[i].theta + band.poses[i - 1].theta;
        cost += w.smoothness * d2 * d2;
    }
    let end = band.poses[band.poses.len() - 1];
    cost += w.goal * (end.distance(&p.goal) + (end.theta - p.goal.theta).abs());
    (cost, t.worst)
}

/// Merit and violations of `band` under `p`, for reporting.
pub(crate) fn assess(p: &Problem, band: &Band) -> (f64, Violations) {
    evaluate(p, band)
}

impl Scp {
    pub fn new() -> Scp {
        Scp {
            qp: Qp::new(),
            candidate: Band::default(),
            hits: [None; 4],
            proj: Projector::default(),
            slip_target: Vec::new(),
        }
    }

    /// Improves `band` in place with at most `max_iterations` subproblems;
    /// `band.poses[0]` stays where it is.
    /// `scale` is the initial trust-region scale (1 = the configured radius).
    pub fn optimise(
        &mut self,
        p: &Problem,
        band: &mut Band,
        max_iterations: usize,
        scale: f64,
    ) -> ScpStats {
        let cfg = &p.cfg.solver;
        let mut scale = scale;
        let (mut merit, mut worst) = evaluate(p, band);
        let mut stats = ScpStats {
            iterations: 0,
            merit,
            scale,
        };
        if band.poses.len() < 2 {
            return stats;
        }
        while stats.iterations < max_iterations {
            if scale * cfg.trust_radius < cfg.min_trust_radius {
                break;
            }
            stats.iterations += 1;
            self.build(p, band, scale);
            let r = self.qp.solve(cfg.max_qp_iterations);
            if !r.ok {
                scale *= 0.3;
                continue;
            }
            apply_step(
                &mut self.candidate,
                band,
                &self.qp.x,
                1.0,
                p.cfg.band.min_dt,
            );
            self.polish(p, band, 1.0);
            let (cand_merit, cand_worst) = evaluate(p, &self.candidate);
            let predicted = merit - r.model;
            let actual = merit - cand_merit;
            let polishing =
                worst.max() <= FEASIBLE && predicted <= cfg.relative_tolerance * merit.abs();
            if predicted <= cfg.tolerance || polishing {
                if actual >= 0.0 && cand_worst.max() <= worst.max().max(FEASIBLE) {
                    band.copy_from(&self.candidate);
                    merit = cand_merit;
                }
                break;
            }
            let ratio = if cand_merit.is_finite() {
                actual / predicted
            } else {
                f64::NEG_INFINITY
            };
            if ratio > 0.1 {
                band.copy_from(&self.candidate);
                merit = cand_merit;
                worst = cand_worst;
                // The model foresaw the merit exactly and the step did not touch the
                // trust region: the band is where the convex model has its minimum, and
                // another subproblem would only confirm it.
                if (ratio - 1.0).abs() <= EXACT_MODEL && self.step_is_interior(band, scale, cfg) {
                    break;
                }
                if ratio > 0.75 {
                    scale = (scale * 2.0).min(2.0);
                }
                continue;
            }
            scale *= 0.3;
            // The convex model is minimised along the whole step, so a shorter step
            // along it still promises at least that fraction of the decrease; trying
            // it costs one merit evaluation instead of a subproblem.
            apply_step(
                &mut self.candidate,
                band,
                &self.qp.x,
                LINE_STEP,
                p.cfg.band.min_dt,
            );
            self.polish(p, band, LINE_STEP);
            let (short, short_worst) = evaluate(p, &self.candidate);
            if short.is_finite() && merit - short > 0.1 * LINE_STEP * predicted {
                band.copy_from(&self.candidate);
                merit = short;
                worst = short_worst;
            }
        }
        stats.merit = merit;
        stats.scale = scale;
        stats
    }

    /// Repairs in `candidate` (= `band` + `alpha` x the last subproblem's step) what
    /// the linearised constraints got wrong by curvature alone, so the merit judges the
    /// step and not its second-order error (which the exact L1 penalty charges at the
    /// constraint weight, rejecting good steps: the Maratos effect):
    /// - the slip the linearised kinematics did not foresee: each segment's slip is
    ///   brought to the model's value (zero wherever the subproblem met the constraint);
    /// - the velocity limits, exact in every subproblem, by lengthening time steps;
    /// - accelerations (v = chord / T is curved in T), by lengthening time steps.
    fn polish(&mut self, p: &Problem, band: &Band, alpha: f64) {
        if p.sigma != 0.0 {
            let x = &self.qp.x;
            self.slip_target.clear();
            for k in 0..band.dts.len() {
                let (a, b) = (band.poses[k], band.poses[k + 1]);
                let (sm, cm) = (0.5 * (a.theta + b.theta)).sin_cos();
                let lon = cm * (b.x - a.x) + sm * (b.y - a.y);
                let change = -sm * (d_at(x, k + 1, 0) - d_at(x, k, 0))
                    + cm * (d_at(x, k + 1, 1) - d_at(x, k, 1))
                    - 0.5 * lon * (d_at(x, k, 2) + d_at(x, k + 1, 2));
                self.slip_target
                    .push(kinematic_residual(&a, &b) + alpha * change);
            }
            self.proj
                .project(&mut self.candidate, &self.slip_target, PROJECTION_SWEEPS);
        }
        fit_time_steps(
            &mut self.candidate,
            p.v_limit(),
            p.cfg.limits.max_angular_velocity,
        );
        retime(&mut self.candidate, &p.timing());
    }

    /// Whether the last step kept every pose well inside its trust region.
    fn step_is_interior(&self, band: &Band, scale: f64, cfg: &crate::config::SolverConfig) -> bool {
        let radius = INTERIOR * scale * cfg.trust_radius;
        let heading = INTERIOR * scale * cfg.trust_heading;
        let x = &self.qp.x;
        (0..band.poses.len() - 1).all(|i| {
            x[3 * i].abs() < radius && x[3 * i + 1].abs() < radius && x[3 * i + 2].abs() < heading
        })
    }

    /// Assembles the subproblem in the step variables around `band`.
    fn build(&mut self, p: &Problem, band: &Band, scale: f64) {
        let cfg = p.cfg;
        let w = &cfg.weights;
        let lim = &cfg.limits;
        let np = band.poses.len();
        let m = np - 1;
        let t0 = 3 * m;
        let tc = |k: usize| t0 + k;
        let qp = &mut self.qp;
        qp.reset(4 * m);
        let radius = scale * cfg.solver.trust_radius;
        let heading = scale * cfg.solver.trust_heading;
        let vlim = p.v_limit();
        let wmax = lim.max_angular_velocity;

        // Objective: minimum time, proximal regularisation, trust region.
        for k in 0..m {
            qp.add_linear_cost(tc(k), w.time);
            qp.add_constant(w.time * band.dts[k]);
            qp.add_proximal(tc(k), cfg.solver.proximal);
        }
        for i in 1..np {
            for c in 0..3 {
                let col = pc(i, c).unwrap_or(0);
                qp.add_proximal(col, cfg.solver.proximal);
                let bound = if c == 2 { heading } else { radius };
                let mut r = Row::new();
                r.add(Some(col), 1.0);
                qp.leq(&r, bound);
                let mut r = Row::new();
                r.add(Some(col), -1.0);
                qp.leq(&r, bound);
            }
        }
        for k in 0..m {
            let t = band.dts[k];
            let a = band.poses[k];
            let b = band.poses[k + 1];
            let lo = cfg.band.min_dt.max(t * (1.0 - 0.5 * scale.min(1.0)));
            // The upper bound always leaves room for the velocity limits to hold.
            let reach = 2.0 * std::f64::consts::SQRT_2 * radius;
            let up = (t * (1.0 + scale))
                .max((a.distance(&b) + reach) / vlim)
                .max(((b.theta - a.theta).abs() + 2.0 * heading) / wmax)
                .max(lo);
            let mut r = Row::new();
            r.add(Some(tc(k)), 1.0);
            qp.leq(&r, up - t);
            let mut r = Row::new();
            r.add(Some(tc(k)), -1.0);
            qp.leq(&r, t - lo);
        }

        // Reference path and heading smoothness.
        if p.sigma != 0.0 && w.reference > 0.0 {
            for i in 1..np {
                let q = band.poses[i];
                let (r0, nx, ny) = reference_offset(p, q.x, q.y);
                if nx != 0.0 || ny != 0.0 {
                    let mut r = Row::new();
                    r.add(pc(i, 0), nx).add(pc(i, 1), ny);
                    qp.add_square(w.reference, r0, &r);
                }
            }
        }
        if w.smoothness > 0.0 {
            for i in 1..np - 1 {
                let r0 =
                    band.poses[i + 1].theta - 2.0 * band.poses[i].theta + band.poses[i - 1].theta;
                let mut r = Row::new();
                r.add(pc(i + 1, 2), 1.0)
                    .add(pc(i, 2), -2.0)
                    .add(pc(i - 1, 2), 1.0);
                qp.add_square(w.smoothness, r0, &r);
            }
        }

        for k in 0..m {
            let a = band.poses[k];
            let b = band.poses[k + 1];
            let (dx, dy) = (b.x - a.x, b.y - a.y);
            // Velocity: ||dp|| <= v_max T (exact cone).
            let mut rt = Row::new();
            rt.add(Some(tc(k)), -vlim);
            let mut rx = Row::new();
            rx.add(pc(k + 1, 0), -1.0).add(pc(k, 0), 1.0);
            let mut ry = Row::new();
            ry.add(pc(k + 1, 1), -1.0).add(pc(k, 1), 1.0);
            qp.soc3([(&rt, vlim * band.dts[k]), (&rx, dx), (&ry, dy)]);
            // Turn rate: |dtheta| <= w_max T (exact, linear).
            let dth = b.theta - a.theta;
            for sgn in [1.0, -1.0] {
                let mut r = Row::new();
                r.add(pc(k + 1, 2), sgn)
                    .add(pc(k, 2), -sgn)
                    .add(Some(tc(k)), -wmax);
                qp.leq(&r, wmax * band.dts[k] - sgn * dth);
            }
            if p.sigma == 0.0 {
                // Turning on the spot: the position must not move.
                for (c, d) in [(0, dx), (1, dy)] {
                    let s = qp.new_column(w.constraint);
                    let mut r = Row::new();
                    r.add(pc(k + 1, c), 1.0)
                        .add(pc(k, c), -1.0)
                        .add(Some(s), -1.0);
                    qp.leq(&r, -d);
                    let mut r = Row::new();
                    r.add(pc(k + 1, c), -1.0)
                        .add(pc(k, c), 1.0)
                        .add(Some(s), -1.0);
                    qp.leq(&r, d);
                }
            } else {
                // Non-holonomic kinematics: both poses on one arc (lateral slip zero).
                let tm = 0.5 * (a.theta + b.theta);
                let (sm, cm) = tm.sin_cos();
                let f0 = -sm * dx + cm * dy;
                let lon = cm * dx + sm * dy;
                let mut r = Row::new();
                r.add(pc(k + 1, 0), -sm)
                    .add(pc(k, 0), sm)
                    .add(pc(k + 1, 1), cm)
                    .add(pc(k, 1), -cm)
                    .add(pc(k + 1, 2), -0.5 * lon)
                    .add(pc(k, 2), -0.5 * lon);
                let s = qp.new_column(w.constraint);
                let mut up = r;
                up.add(Some(s), -1.0);
                qp.leq(&up, -f0);
                let mut dn = Row::new();
                dn.add_row(&r, -1.0).add(Some(s), -1.0);
                qp.leq(&dn, f0);
                // Drive direction: sigma (dp . h) >= 0.
                let s = qp.new_column(w.constraint);
                let mut r = Row::new();
                r.add(pc(k + 1, 0), -p.sigma * cm)
                    .add(pc(k, 0), p.sigma * cm)
                    .add(pc(k + 1, 1), -p.sigma * sm)
                    .add(pc(k, 1), p.sigma * sm)
                    .add(Some(s), -1.0);
                qp.leq(&r, p.sigma * lon);
                let mut r = Row::new();
                r.add(Some(s), -1.0);
                qp.leq(&r, 0.0);
            }
        }

        // Accelerations, each |difference| - limit * span <= slack.
        let (amax, alpha) = (lim.max_acceleration, lim.max_angular_acceleration);
        let soft_abs = |qp: &mut Qp, val: f64, row: &Row, span: f64, span_row: &Row, limit: f64| {
            let s = qp.new_column(w.constraint);
            for sgn in [1.0, -1.0] {
                let mut r = Row::new();
                r.add_row(row, sgn)
                    .add_row(span_row, -limit)
                    .add(Some(s), -1.0);
                qp.leq(&r, limit * span - sgn * val);
            }
            let mut r = Row::new();
            r.add(Some(s), -1.0);
            qp.leq(&r, 0.0);
        };
        let mut span0 = Row::new();
        span0.add(Some(tc(0)), 1.0);
        let (v, rv) = lin_v(band, 0, tc(0));
        soft_abs(qp, v - p.v0, &rv, band.dts[0], &span0, amax);
        let (wv, rw) = lin_w(band, 0, tc(0));
        soft_abs(qp, wv - p.w0, &rw, band.dts[0], &span0, alpha);
        for k in 0..m.saturating_sub(1) {
            let mut span = Row::new();
            span.add(Some(tc(k)), 0.5).add(Some(tc(k + 1)), 0.5);
            let s = 0.5 * (band.dts[k] + band.dts[k + 1]);
            let (va, ra) = lin_v(band, k, tc(k));
            let (vb, rb) = lin_v(band, k + 1, tc(k + 1));
            let mut r = rb;
            r.add_row(&ra, -1.0);
            soft_abs(qp, vb - va, &r, s, &span, amax);
            let (wa, ra) = lin_w(band, k, tc(k));
            let (wb, rb) = lin_w(band, k + 1, tc(k + 1));
            let mut r = rb;
            r.add_row(&ra, -1.0);
            soft_abs(qp, wb - wa, &r, s, &span, alpha);
        }
        if p.at_rest {
            let mut span = Row::new();
            span.add(Some(tc(m - 1)), 1.0);
            let (v, rv) = lin_v(band, m - 1, tc(m - 1));
            soft_abs(qp, v, &rv, band.dts[m - 1], &span, amax);
            let (wv, rw) = lin_w(band, m - 1, tc(m - 1));
            soft_abs(qp, wv, &rw, band.dts[m - 1], &span, alpha);
        }

        // Clearance: the nearest cell in each sector of every pose and of points between,
        // margin - (c + g.d) <= slack (one slack per sample, as the merit takes the
        // worst cell of a sample).
        let reach = p.margin + cfg.solver.obstacle_influence + radius;
        for i in 1..np {
            let (a, b) = (band.poses[i - 1], band.poses[i]);
            let n = interior_samples(&a, &b);
            for sample in 0..=n {
                let (pose, weight_prev) = if sample == 0 {
                    (b, 0.0)
                } else {
                    let u = sample as f64 / (n + 1) as f64;
                    (lerp(&a, &b, u), 1.0 - u)
                };
                nearest_per_sector(p.map, &p.footprint, &pose, reach, &mut self.hits);
                // A cell the trust region cannot bring inside the margin gives a row
                // that is never active: leaving it out does not change the subproblem.
                for h in self.hits.iter_mut() {
                    if let Some(hit) = h {
                        let change = (hit.grad[0].abs() + hit.grad[1].abs()) * radius
                            + hit.grad[2].abs() * heading;
                        if hit.clearance - change > p.margin {
                            *h = None;
                        }
                    }
                }
                if self.hits.iter().all(|h| h.is_none()) {
                    continue;
                }
                let s = qp.new_column(w.constraint);
                for hit in self.hits.iter().flatten() {
                    let mut r = Row::new();
                    let own = 1.0 - weight_prev;
                    for c in 0..3 {
                        r.add(pc(i, c), -own * hit.grad[c]);
                        r.add(pc(i - 1, c), -weight_prev * hit.grad[c]);
                    }
                    r.add(Some(s), -1.0);
                    qp.leq(&r, hit.clearance - p.margin);
                }
                let mut r = Row::new();
                r.add(Some(s), -1.0);
                qp.leq(&r, 0.0);
            }
        }

        // Goal: ||p_end - goal|| <= s (cone) and |theta_end - goal| <= s.
        let end = band.poses[np - 1];
        let sg = qp.new_column(w.goal);
        let mut r0 = Row::new();
        r0.add(Some(sg), -1.0);
        let mut rx = Row::new();
        rx.add(pc(np - 1, 0), -1.0);
        let mut ry = Row::new();
        ry.add(pc(np - 1, 1), -1.0);
        qp.soc3([(&r0, 0.0), (&rx, end.x - p.goal.x), (&ry, end.y - p.goal.y)]);
        let sh = qp.new_column(w.goal);
        let e = end.theta - p.goal.theta;
        let mut r = Row::new();
        r.add(pc(np - 1, 2), 1.0).add(Some(sh), -1.0);
        qp.leq(&r, -e);
        let mut r = Row::new();
        r.add(pc(np - 1, 2), -1.0).add(Some(sh), -1.0);
        qp.leq(&r, e);
    }

    /// Removes the slip of every segment (see [`Projector`]): for bands whose poses were
    /// moved or merged outside the optimiser.
    pub fn project_kinematics(&mut self, band: &mut Band) {
        self.proj.project(band, &[], PROJECTION_SWEEPS);
    }

    /// Interior-point iterations of the last subproblem (for diagnostics).
    #[allow(dead_code)]
    pub fn last_ip_iterations(&self) -> u32 {
        self.qp.ip_iterations
    }
}
