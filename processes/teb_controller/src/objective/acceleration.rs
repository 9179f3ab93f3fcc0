//! Accelerations, penalised (L1) at `w_constraint`: from the measured velocity over the
//! first segment (at most the reference time step: its command applies at once, so a
//! long first segment earns no larger change), between consecutive segments over the
//! mean of their time steps, and to rest over the last segment when the band ends at
//! the goal; each |velocity change| - limit x span, linear and angular. The model
//! linearises v = (dp . h) / T and w = dtheta / T (curved in T; see `timing.rs` for the
//! repair).

use super::segment::{lin_v, lin_w, segment_rate, segment_velocity, slack_non_negative, tc};
use super::{Problem, Tally};
use crate::band::Band;
use crate::qp::{Qp, Row};

/// Charges one velocity change `dv` over `span` against `limit`.
fn charge(dv: f64, span: f64, limit: f64, t: &mut Tally) {
    let g = (dv.abs() - limit * span).max(0.0);
    t.sum += g;
    t.worst.acceleration = t.worst.acceleration.max(g / span);
}

/// Exact value, in the order start, between segments, to rest.
pub(super) fn merit(p: &Problem, band: &Band, t: &mut Tally) {
    let lim = &p.cfg.limits;
    let m = band.dts.len();
    let (amax, alpha) = (lim.max_acceleration, lim.max_angular_acceleration);
    if m == 0 {
        return;
    }
    let span0 = p.timing().start_span(band.dts[0]);
    charge(segment_velocity(band, 0) - p.v0, span0, amax, t);
    charge(segment_rate(band, 0) - p.w0, span0, alpha, t);
    for k in 0..m.saturating_sub(1) {
        let span = 0.5 * (band.dts[k] + band.dts[k + 1]);
        charge(
            segment_velocity(band, k + 1) - segment_velocity(band, k),
            span,
            amax,
            t,
        );
        charge(
            segment_rate(band, k + 1) - segment_rate(band, k),
            span,
            alpha,
            t,
        );
    }
    if p.at_rest {
        charge(segment_velocity(band, m - 1), band.dts[m - 1], amax, t);
        charge(segment_rate(band, m - 1), band.dts[m - 1], alpha, t);
    }
}

/// One linearised |change| - limit x span <= slack: the change `val` + `row`.x over the
/// span `span` + `span_row`.x.
fn soft_abs(qp: &mut Qp, weight: f64, val: f64, row: &Row, span: f64, span_row: &Row, limit: f64) {
    let s = qp.new_column(weight);
    for sgn in [1.0, -1.0] {
        let mut r = Row::new();
        r.add_row(row, sgn)
            .add_row(span_row, -limit)
            .add(Some(s), -1.0);
        qp.leq(&r, limit * span - sgn * val);
    }
    slack_non_negative(qp, s);
}

/// The same rows in the step variables, in the same order.
pub(super) fn linearise(qp: &mut Qp, p: &Problem, band: &Band) {
    let lim = &p.cfg.limits;
    let wc = p.cfg.weights.constraint;
    let m = band.poses.len() - 1;
    let tc = |k: usize| tc(m, k);
    let (amax, alpha) = (lim.max_acceleration, lim.max_angular_acceleration);
    // The span from the measured velocity is the first time step up to its cap, and
    // fixed once capped.
    let timing = p.timing();
    let span0 = timing.start_span(band.dts[0]);
    let mut span0_row = Row::new();
    if band.dts[0] <= timing.max_start_span {
        span0_row.add(Some(tc(0)), 1.0);
    }
    let (v, rv) = lin_v(band, 0, tc(0));
    soft_abs(qp, wc, v - p.v0, &rv, span0, &span0_row, amax);
    let (wv, rw) = lin_w(band, 0, tc(0));
    soft_abs(qp, wc, wv - p.w0, &rw, span0, &span0_row, alpha);
    for k in 0..m.saturating_sub(1) {
        let mut span = Row::new();
        span.add(Some(tc(k)), 0.5).add(Some(tc(k + 1)), 0.5);
        let s = 0.5 * (band.dts[k] + band.dts[k + 1]);
        let (va, ra) = lin_v(band, k, tc(k));
        let (vb, rb) = lin_v(band, k + 1, tc(k + 1));
        let mut r = rb;
        r.add_row(&ra, -1.0);
        soft_abs(qp, wc, vb - va, &r, s, &span, amax);
        let (wa, ra) = lin_w(band, k, tc(k));
        let (wb, rb) = lin_w(band, k + 1, tc(k + 1));
        let mut r = rb;
        r.add_row(&ra, -1.0);
        soft_abs(qp, wc, wb - wa, &r, s, &span, alpha);
    }
    if p.at_rest {
        let mut span = Row::new();
        span.add(Some(tc(m - 1)), 1.0);
        let (v, rv) = lin_v(band, m - 1, tc(m - 1));
        soft_abs(qp, wc, v, &rv, band.dts[m - 1], &span, amax);
        let (wv, rw) = lin_w(band, m - 1, tc(m - 1));
        soft_abs(qp, wc, wv, &rw, band.dts[m - 1], &span, alpha);
    }
}
