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
use crate::reference::Reference;
use crate::scp::{self, Scp};
use crate::seed;
use crate::timing;

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

    /// Optimises the band, then TEB's outer loop once: the optimiser stretches segments
    /// where the band swerves or speeds up, so a long segment is split (and short ones
    /// merged) and the band repaired, re-optimised only if that left it infeasible.
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
        if !seed::has_long_segment(&self.band, cfg) {
            return done;
        }
        seed::resize(&mut self.band, cfg);
        // A merged segment's chord no longer follows the mean heading of its ends.
        if problem.direction.drives() {
            self.scp.project_kinematics(&mut self.band);
        }
        // A split whose halves follow an arc is longer than the chord it replaces.
        stretch_to_velocity_limits(&mut self.band, problem);
        // A split halves the span a velocity change is spread over.
        timing::retime(&mut self.band, &problem.timing());
        // Splits follow the band's arcs and the repairs above keep it within every
        // limit, so the resized band usually only costs a little more (the next step
        // starts from it anyway). One that still violates a constraint gets a
        // shorter second round from the trust region the first round ended with.
        let (resized, rv) = objective::merit(problem, &self.band);
        if rv.max() > scp::FEASIBLE && resized > done.merit + cfg.solver.tolerance {
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
        stretch_to_velocity_limits(&mut self.band, problem);
        timing::retime(&mut self.band, &problem.timing());
    }
}

/// [`timing::stretch_to_velocity_limits`] under the problem's limits.
fn stretch_to_velocity_limits(band: &mut Band, problem: &Problem) {
    timing::stretch_to_velocity_limits(
        band,
        problem.v_limit(),
        problem.cfg.limits.max_angular_velocity,
    );
}
