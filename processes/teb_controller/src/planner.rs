//! The band of one step through its phases: warm start or a new band, a detour around
//! blocking obstacles, the optimisation with one resize round, the homotopy alternative
//! on the other side of a blocker, and the final repair of the timing. Owns the band
//! kept between steps and the optimiser's buffers; knows nothing of sections, the
//! output or the bus.

use aisle_geometry::{Pose2, wrap_angle};

use crate::band::Band;
use crate::config::TebConfig;
use crate::detour::{self, Side};
use crate::direction::DriveSign;
use crate::leg::Leg;
use crate::objective::{self, Problem};
use crate::output::ExitFlag;
use crate::reference::Reference;
use crate::scp::Scp;
use crate::seed;

/// Farthest a blocked pose is pushed sideways before the optimiser runs, m.
const MAX_DETOUR: f64 = 3.0;
/// Initial trust-region scale for a warm band (1 = the configured radius).
const WARM_TRUST_SCALE: f64 = 0.3;
/// Poses searched when pruning the passed part of the band.
const PRUNE_WINDOW: usize = 10;
/// Metres per radian when pruning, so turning on the spot prunes too.
const PRUNE_HEADING_WEIGHT: f64 = 0.3;

/// What the optimisation of a step did.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Optimised {
    /// Subproblems solved.
    pub iterations: usize,
    pub merit: f64,
}

/// The band between steps and the buffers to improve it.
pub(crate) struct Planner {
    pub band: Band,
    /// Side the band was last pushed around a blocker.
    pub side: Option<Side>,
    scp: Scp,
    alt: Band,
}

impl Planner {
    pub fn new(max_poses: usize) -> Planner {
        Planner {
            band: Band::with_capacity(max_poses + 2),
            side: None,
            scp: Scp::new(),
            alt: Band::with_capacity(max_poses + 2),
        }
    }

    /// Forgets the band (a new task or section, or the goal reached).
    pub fn clear(&mut self) {
        self.band.clear();
        self.side = None;
    }

    /// Warm start (prune the passed poses, extend to the new local goal) or a new band
    /// along the reference, resized; the leg's goal heading is made continuous with the
    /// band's end. Returns whether the band is new.
    pub fn start(
        &mut self,
        cfg: &TebConfig,
        reference: &Reference,
        leg: &mut Leg,
        pose: &Pose2,
        v0: f64,
    ) -> bool {
        let mut fresh = self.band.poses.len() < 2;
        if !fresh {
            let d0 = self.band.poses[..self.band.poses.len().min(PRUNE_WINDOW + 1)]
                .iter()
                .map(|p| p.distance(pose))
                .fold(f64::INFINITY, f64::min);
            if d0 > cfg.band.reinit_distance {
                fresh = true;
            } else {
                self.band.prune(pose, PRUNE_WINDOW, PRUNE_HEADING_WEIGHT);
                if leg.section.direction.drives() {
                    fresh = !seed::extend(&mut self.band, reference, leg, cfg);
                }
            }
        }
        if fresh {
            seed::init_band(&mut self.band, reference, leg, pose, v0, cfg);
            self.side = None;
        }
        self.band.unwrap_headings();
        seed::resize(&mut self.band, cfg);
        let last = self.band.poses[self.band.poses.len() - 1].theta;
        leg.goal.theta = last + wrap_angle(leg.goal.theta - last);
        fresh
    }

    /// Pushes a band that runs through an obstacle around it, on the side it went
    /// around before if that is free.
    pub fn detour(&mut self, problem: &Problem) {
        let (map, fp, margin) = (problem.map, &problem.footprint, problem.margin);
        if problem.direction.drives() && detour::blocked(&self.band, map, fp, margin) {
            let side = detour::repair(&mut self.band, map, fp, margin, self.side, MAX_DETOUR);
            if side.is_some() {
                self.side = side;
            }
        }
    }

    /// Optimises the band (resized before, in [`Planner::start`], as TEB's outer loop
    /// does). The optimiser stretches time steps where the band swerves or speeds up,
    /// and between the poses of a long segment the footprint's sweep may cut a corner
    /// the clearance terms (at the poses) do not see. A band with a long segment whose
    /// sweep is clear is kept as the optimiser left it; one whose sweep is not is
    /// resized (long segments split, short ones merged), repaired and optimised again
    /// if that cost merit. (Resizing every band with a long segment and keeping the
    /// resized band unoptimised left a seed record's steps p90 17 % above their
    /// optimum, against 1.2 % without, at the same tolerance.)
    pub fn optimise(&mut self, problem: &Problem, fresh: bool) -> Optimised {
        let cfg = problem.cfg;
        let budget = cfg.solver.max_iterations;
        // A warm band was optimal one period ago: start with a trust region that
        // refines it instead of one sized for bending a fresh band around obstacles.
        let scale = if fresh { 1.0 } else { WARM_TRUST_SCALE };
        let stats = self.scp.optimise(problem, &mut self.band, budget, scale);
        let mut done = Optimised {
            iterations: stats.iterations,
            merit: stats.merit,
        };
        if !self
            .band
            .has_long_segment(&cfg.band.steps(), cfg.band.max_poses)
            || sweep_is_clear(&self.band, problem)
        {
            return done;
        }
        seed::resize(&mut self.band, cfg);
        // A merged segment's chord no longer follows the mean heading of its ends.
        if problem.direction.drives() {
            self.scp.project_kinematics(&mut self.band);
        }
        // A split whose halves follow an arc is longer than the chord it replaces, and
        // halves the span a velocity change is spread over.
        problem.repair_time_steps(&mut self.band);
        // A second, shorter round from the trust region the first round ended with.
        let (resized, _) = objective::merit(problem, &self.band);
        if resized > done.merit + cfg.solver.tolerance {
            let again = self.scp.optimise(
                problem,
                &mut self.band,
                budget.div_ceil(2),
                (2.0 * stats.scale).min(1.0),
            );
            done.iterations += again.iterations;
            done.merit = again.merit;
        } else {
            done.merit = resized;
        }
        done
    }

    /// The merit a copy of the band reaches when the SCP runs on from it on the same
    /// problem until a subproblem promises under 1e-7 of the merit (or
    /// `max_subproblems`): the local optimum the step stopped short of. An offline
    /// measurement; the band is untouched.
    pub fn converged_merit(&mut self, problem: &Problem, max_subproblems: usize) -> f64 {
        let mut tight = problem.cfg.clone();
        tight.solver.tolerance = 1e-9;
        tight.solver.relative_tolerance = 1e-7;
        tight.solver.max_qp_iterations = tight.solver.max_qp_iterations.max(100);
        let problem = Problem {
            cfg: &tight,
            ..*problem
        };
        self.alt.copy_from(&self.band);
        self.scp.set_exact_subproblems(true);
        let merit = self
            .scp
            .optimise(&problem, &mut self.alt, max_subproblems, 1.0)
            .merit;
        self.scp.set_exact_subproblems(false);
        merit
    }

    /// Homotopy: the same band pushed around the blocker on the other side and
    /// optimised; kept if clearly better.
    pub fn try_other_side(
        &mut self,
        problem: &Problem,
        leg: &Leg,
        pose: &Pose2,
        done: &mut Optimised,
    ) {
        let cfg = problem.cfg;
        let Some(side) = self.side else { return };
        if !(cfg.homotopy.enabled && problem.direction.drives()) {
            return;
        }
        self.alt.copy_from(&self.band);
        seed::init_band(&mut self.alt, problem.reference, leg, pose, problem.v0, cfg);
        self.alt.unwrap_headings();
        seed::resize(&mut self.alt, cfg);
        let repaired = detour::repair(
            &mut self.alt,
            problem.map,
            &problem.footprint,
            problem.margin,
            Some(side.other()),
            MAX_DETOUR,
        );
        if repaired.is_none() {
            return;
        }
        let alt = self
            .scp
            .optimise(problem, &mut self.alt, cfg.solver.max_iterations, 1.0);
        done.iterations += alt.iterations;
        if alt.merit < cfg.homotopy.hysteresis * done.merit {
            std::mem::swap(&mut self.band, &mut self.alt);
            done.merit = alt.merit;
            self.side = Some(side.other());
        }
    }

    /// Numerical slack of the cones must not leak into the commands, nor a sharper
    /// acceleration than slowing down can avoid.
    pub fn finish(&mut self, problem: &Problem) {
        problem.repair_time_steps(&mut self.band);
    }
}

/// Whether the footprint swept along `band` (at the exit flag's step) keeps the
/// problem's margin and turning radius everywhere: the controller's verdict on the
/// band, for what a resize may mend.
fn sweep_is_clear(band: &Band, problem: &Problem) -> bool {
    !matches!(
        problem.judge(band).flag,
        ExitFlag::Collision | ExitFlag::MarginViolated | ExitFlag::TurningRadius
    )
}
