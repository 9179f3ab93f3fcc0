//! The trust region of one subproblem: bounds on every pose step (position and
//! heading) and on every time step's change, and the proximal regularisation that
//! keeps the step unique. Sized by a scale the SCP loop adapts (1 = the configured
//! radius). Knows nothing of the objective's terms.

use crate::band::Band;
use crate::config::SolverConfig;
use crate::objective::Problem;
use crate::objective::segment::{pc, tc};
use crate::qp::{Qp, Row};

/// Half-widths of the region at one scale.
pub(crate) struct TrustRegion {
    pub scale: f64,
    /// Largest step of a position coordinate, m.
    pub radius: f64,
    /// Largest step of a heading, rad.
    pub heading: f64,
}

impl TrustRegion {
    pub fn new(solver: &SolverConfig, scale: f64) -> TrustRegion {
        TrustRegion {
            scale,
            radius: scale * solver.trust_radius,
            heading: scale * solver.trust_heading,
        }
    }

    /// Adds the proximal terms and the bounds of the region to `qp` (time steps, then
    /// poses, then time-step bounds).
    pub fn constrain(&self, qp: &mut Qp, p: &Problem, band: &Band) {
        let cfg = p.cfg;
        let np = band.poses.len();
        let m = np - 1;
        let (radius, heading, scale) = (self.radius, self.heading, self.scale);
        for k in 0..m {
            qp.add_proximal(tc(m, k), cfg.solver.proximal);
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
        let vlim = p.v_limit();
        let wmax = cfg.limits.max_angular_velocity;
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
            r.add(Some(tc(m, k)), 1.0);
            qp.leq(&r, up - t);
            let mut r = Row::new();
            r.add(Some(tc(m, k)), -1.0);
            qp.leq(&r, t - lo);
        }
    }
}
