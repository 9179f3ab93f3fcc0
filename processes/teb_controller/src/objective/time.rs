//! Minimum time: `w_time` x the band's duration. Linear in the time steps, so the
//! model is exact.

use super::Problem;
use super::segment::tc;
use crate::band::Band;
use crate::qp::Qp;

/// Exact value; the merit starts from it.
pub(super) fn merit(p: &Problem, band: &Band) -> f64 {
    p.cfg.weights.time * band.duration()
}

/// The same in the step variables: a linear cost on every time step's change and the
/// current duration as a constant.
pub(super) fn linearise(qp: &mut Qp, p: &Problem, band: &Band) {
    let w = &p.cfg.weights;
    let m = band.poses.len() - 1;
    for k in 0..m {
        qp.add_linear_cost(tc(m, k), w.time);
        qp.add_constant(w.time * band.dts[k]);
    }
}
