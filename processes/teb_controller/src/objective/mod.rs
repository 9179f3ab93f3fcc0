//! The TEB objective over a band: the exact merit a band is judged by, and the convex
//! model of it around a band that one subproblem minimises. One term group per file,
//! each term's exact value beside its linearisation:
//!
//! | term          | file              | weight         | model                          |
//! |---------------|-------------------|----------------|--------------------------------|
//! | time          | `time.rs`         | `time`         | linear (exact)                 |
//! | reference     | `tracking.rs`     | `reference`    | square of a linearised offset  |
//! | smoothness    | `tracking.rs`     | `smoothness`   | square (exact)                 |
//! | goal          | `tracking.rs`     | `goal`         | cone + absolute value (exact)  |
//! | velocity      | `motion.rs`       | `constraint`   | hard cone + rows (exact)       |
//! | kinematics    | `motion.rs`       | `constraint`   | linearised, slack              |
//! | direction     | `motion.rs`       | `constraint`   | linear, slack                  |
//! | acceleration  | `acceleration.rs` | `constraint`   | linearised, slack              |
//! | clearance     | `clearance.rs`    | `constraint`   | nearest cells, linear, slack   |
//!
//! `clearance.rs` also finds each segment's deepest sample below the kept clearance
//! ([`shortfalls`]), what the SCP loop's second-order correction restores.
//!
//! The constraint terms are L1 penalties: the merit is an exact penalty function, and
//! [`Violations`] reports each constraint's worst value in its own unit.
//!
//! [`merit`] and [`model`] visit the terms in a fixed order that is part of the
//! behaviour: floating-point sums (the merit, the model's constant and Hessian) and the
//! subproblem's row order depend on it, and the controller's output is pinned bit for
//! bit by a test. Knows nothing of the trust-region loop (`scp.rs`) beyond the region it
//! is given, nor of goals, sections or the bus.

mod acceleration;
mod clearance;
mod motion;
pub(crate) mod segment;
mod time;
mod tracking;

pub(crate) use clearance::{Shortfall, shortfalls};

use aisle_geometry::{Direction, Footprint, GridView, Pose2};

use crate::band::Band;
use crate::clearance::CellHit;
use crate::config::TebConfig;
use crate::qp::Qp;
use crate::reference::{Reference, Section};
use crate::timing::Timing;
use crate::trust_region::TrustRegion;

/// Everything fixed during one step's optimisation.
#[derive(Clone, Copy)]
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
    /// Forward, reverse, or turning on the spot.
    pub direction: Direction,
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
            max_start_span: self.cfg.band.dt_ref,
        }
    }

    /// Restores in `band`, by lengthening time steps, the velocity limits and then the
    /// accelerations (as far as slowing down can: `timing::retime`).
    pub fn repair_time_steps(&self, band: &mut Band) {
        crate::timing::stretch_to_velocity_limits(
            band,
            self.v_limit(),
            self.cfg.limits.max_angular_velocity,
        );
        crate::timing::retime(band, &self.timing());
    }

    /// Speed limit in the section's direction, m/s.
    pub fn v_limit(&self) -> f64 {
        self.cfg.limits.speed_limit(self.direction)
    }

    /// The exit flag's verdict on `band` under this problem's map, footprint, margin
    /// and limits.
    pub fn judge(&self, band: &Band) -> crate::feasibility::Verdict {
        crate::feasibility::check(
            band,
            self.map,
            &self.footprint,
            self.margin,
            self.cfg.solver.check_step,
            self.cfg.limits.min_turning_radius,
            &self.timing(),
        )
    }
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

/// Exact merit of `band` (minimum time + weighted terms + `w_constraint` x the L1
/// violations) and its worst violations.
pub(crate) fn merit(p: &Problem, band: &Band) -> (f64, Violations) {
    let mut t = Tally::default();
    let mut cost = time::merit(p, band);
    let vlim = p.v_limit();
    for k in 0..band.dts.len() {
        motion::velocity_merit(p, band, k, vlim, &mut t);
        motion::kinematics_merit(p, band, k, &mut t);
        motion::direction_merit(p, band, k, &mut t);
    }
    acceleration::merit(p, band, &mut t);
    clearance::merit(p, band, &mut t);
    cost += p.cfg.weights.constraint * t.sum;
    tracking::reference_merit(p, band, &mut cost);
    tracking::smoothness_merit(p, band, &mut cost);
    tracking::goal_merit(p, band, &mut cost);
    (cost, t.worst)
}

/// Assembles in `qp` the subproblem in the step variables around `band` inside
/// `region`; `hits` is a reusable buffer of the clearance rows.
pub(crate) fn model(
    qp: &mut Qp,
    p: &Problem,
    band: &Band,
    region: &TrustRegion,
    hits: &mut [Option<CellHit>; 4],
) {
    let m = band.poses.len() - 1;
    qp.reset(4 * m, |c| segment::band_position(m, c));
    time::linearise(qp, p, band);
    // The region's proximal terms enter the Hessian's diagonal before the squares.
    region.constrain(qp, p, band);
    tracking::reference_linearise(qp, p, band);
    tracking::smoothness_linearise(qp, p, band);
    let (vlim, wmax) = (p.v_limit(), p.cfg.limits.max_angular_velocity);
    for k in 0..m {
        motion::velocity_linearise(qp, band, k, vlim, wmax);
        motion::kinematics_linearise(qp, p, band, k);
        motion::direction_linearise(qp, p, band, k);
    }
    acceleration::linearise(qp, p, band);
    clearance::linearise(qp, p, band, region, hits);
    tracking::goal_linearise(qp, p, band);
}
