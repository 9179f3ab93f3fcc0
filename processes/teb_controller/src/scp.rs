//! Sequential convex programming over a band: each iteration builds the convex model
//! of the objective (`objective/`) around the current band, solves it (`qp.rs`)
//! inside a trust region (`trust_region.rs`), and keeps the step if the exact merit
//! drops. Knows nothing of goals, sections or the bus, nor of the objective's terms: it
//! receives a [`Problem`] and a band and improves the band.
//!
//! Each subproblem costs most of a step's time, so the loop avoids needless ones:
//! - every candidate is repaired before it is judged (kinematic slip projected out,
//!   velocity limits and accelerations restored by lengthening time steps), so steps
//!   are not rejected for the curvature of the linearised constraints;
//! - a rejected step is corrected to second order (`correction.rs`: the clearance
//!   and slip of the trial band relinearised at it, one least-squares solve) and, if
//!   still rejected, retried once at a fraction of its length (one merit evaluation)
//!   before the trust region shrinks;
//! - the loop stops once the band meets every constraint and the next subproblem
//!   promises only a small fraction of the merit. (A step the model foresaw exactly
//!   inside its trust region is no reason to stop: the model is the old band's, and
//!   on a seed record's steps stopping there left bands up to 8 % above their
//!   optimum.)

use crate::band::Band;
use crate::clearance::CellHit;
use crate::correction::Corrector;
use crate::direction::DriveSign;
use crate::kinematics::Projector;
use crate::objective::segment::{d_at, kinematic_residual};
use crate::objective::{self, Problem, Shortfall};
use crate::qp::{self, Qp};
use crate::trust_region::TrustRegion;

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
    corrector: Corrector,
    shortfalls: Vec<Option<Shortfall>>,
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

/// Largest constraint violation (in each constraint's units) of a band that counts as
/// meeting every constraint.
pub(crate) const FEASIBLE: f64 = 1e-3;
/// Gauss-Newton sweeps of the kinematic projection of a candidate.
const PROJECTION_SWEEPS: usize = 2;
/// Fraction of a rejected step tried before the next subproblem.
const LINE_STEP: f64 = 0.3;
/// Least ratio of actual to predicted decrease that keeps a step.
const ACCEPT_RATIO: f64 = 0.1;

impl Scp {
    pub fn new() -> Scp {
        Scp {
            qp: Qp::new(),
            candidate: Band::default(),
            hits: [None; 4],
            proj: Projector::default(),
            slip_target: Vec::new(),
            corrector: Corrector::default(),
            shortfalls: Vec::new(),
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
        let (mut merit, mut worst) = objective::merit(p, band);
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
            let (cand_merit, cand_worst) = objective::merit(p, &self.candidate);
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
            if ratio > ACCEPT_RATIO {
                band.copy_from(&self.candidate);
                merit = cand_merit;
                worst = cand_worst;
                if ratio > 0.75 {
                    scale = (scale * 2.0).min(2.0);
                }
                continue;
            }
            if self.correct(p, scale * cfg.trust_radius) {
                let (corrected, corrected_worst) = objective::merit(p, &self.candidate);
                if corrected.is_finite() && merit - corrected > ACCEPT_RATIO * predicted {
                    band.copy_from(&self.candidate);
                    merit = corrected;
                    worst = corrected_worst;
                    continue;
                }
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
            let (short, short_worst) = objective::merit(p, &self.candidate);
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
        if p.direction.drives() {
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
        p.repair_time_steps(&mut self.candidate);
    }

    /// The second-order correction of the trial band in `candidate` (`correction.rs`):
    /// its slip back to the subproblem's targets and each segment's deepest sample
    /// below the kept clearance back to it, then its time steps repaired as in
    /// [`Scp::polish`]. Returns whether it moved the band (not when the correction
    /// would exceed `limit`, the trust region's radius).
    fn correct(&mut self, p: &Problem, limit: f64) -> bool {
        if !p.direction.drives() {
            return false;
        }
        // One Gauss-Newton sweep: a second one, with the shortfalls found again, left a
        // seed record's steps where they were at 15 % more time.
        objective::shortfalls(p, &self.candidate, &mut self.shortfalls);
        if self.shortfalls.iter().all(Option::is_none)
            || !self.corrector.sweep(
                &mut self.candidate,
                &self.slip_target,
                &self.shortfalls,
                limit,
            )
        {
            return false;
        }
        p.repair_time_steps(&mut self.candidate);
        true
    }

    /// Assembles the subproblem in the step variables around `band`.
    fn build(&mut self, p: &Problem, band: &Band, scale: f64) {
        let region = TrustRegion::new(&p.cfg.solver, scale);
        objective::model(&mut self.qp, p, band, &region, &mut self.hits);
    }

    /// Solves every subproblem to the convergence audit's accuracy ([`qp::EXACT`]) while
    /// `exact`, else to a step's own ([`qp::SETTINGS`]).
    pub fn set_exact_subproblems(&mut self, exact: bool) {
        self.qp.settings = if exact { qp::EXACT } else { qp::SETTINGS };
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
