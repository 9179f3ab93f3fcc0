//! Retiming a band so its accelerations meet their limits, without moving a pose:
//! segments that speed up or slow down too sharply are slowed (their time steps
//! lengthened) until every linear and angular acceleration, measured as the optimiser
//! and the exit flag measure it, is within its limit.
//!
//! Only time steps grow, so speeds only drop and the velocity limits stay met. The
//! optimiser linearises v = chord / T, whose curvature in T left accelerations slightly
//! violated after good steps, and splitting a segment halves the span its velocity
//! change is spread over; both are repaired here instead of by another subproblem.
//! Knows nothing of obstacles or costs.

use crate::band::{Band, chord};

/// Limits and boundary conditions of the retiming.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Timing {
    /// Measured velocity at the start pose (m/s, rad/s).
    pub v0: f64,
    pub w0: f64,
    /// The band ends at rest.
    pub at_rest: bool,
    pub max_acceleration: f64,
    pub max_angular_acceleration: f64,
    /// The longest span over which the first segment's velocity may be reached from
    /// the measured one (the band's reference time step): its command applies at once,
    /// so a long first segment does not earn a larger change.
    pub max_start_span: f64,
}

impl Timing {
    /// The span over which the first segment (of duration `dt0`) reaches its velocity.
    pub fn start_span(&self, dt0: f64) -> f64 {
        dt0.min(self.max_start_span)
    }
}

/// Lengthens every time step too short for its segment under the velocity limits
/// `vlim` (m/s) and `wmax` (rad/s): the cones' numerical slack, or a split whose halves
/// follow an arc and so are together longer than the chord they replace.
pub(crate) fn stretch_to_velocity_limits(band: &mut Band, vlim: f64, wmax: f64) {
    for k in 0..band.dts.len() {
        let a = band.poses[k];
        let b = band.poses[k + 1];
        let need = (chord(&a, &b) / vlim).max((b.theta - a.theta).abs() / wmax);
        if band.dts[k] < need {
            band.dts[k] = need;
        }
    }
}

/// Passes over the band at most (slowing one segment can make the pair after it too
/// sharp); each pass only lowers speeds, so the passes settle.
const SWEEPS: usize = 6;

/// Chord along the mean heading and heading change of segment k.
fn motion(band: &Band, k: usize) -> (f64, f64) {
    let (a, b) = (band.poses[k], band.poses[k + 1]);
    let (s, c) = (0.5 * (a.theta + b.theta)).sin_cos();
    (c * (b.x - a.x) + s * (b.y - a.y), b.theta - a.theta)
}

/// Largest rate s (= 1 / T) at which a segment moving `q` per unit rate changes from
/// the velocity `u` of its neighbour within `limit` x (`other_t` + T) / 2. `None` when
/// no slower rate helps (the neighbour is faster in the same direction).
fn max_rate_pair(q: f64, u: f64, other_t: f64, limit: f64) -> Option<f64> {
    let qa = q.abs();
    if qa < 1e-12 {
        return None;
    }
    let h = 0.5 * limit * other_t;
    // |q| s - (+-|u|) = limit (other_t + 1 / s) / 2, as a quadratic in s.
    let b = if q * u >= 0.0 {
        u.abs() + h
    } else {
        h - u.abs()
    };
    Some((b + (b * b + 2.0 * limit * qa).sqrt()) / (2.0 * qa))
}

/// Largest rate at which a segment moving `q` per unit rate starts from the velocity
/// `u` within `limit` x its span, which is its own duration T up to `max_span`.
fn max_rate_start(q: f64, u: f64, limit: f64, max_span: f64) -> Option<f64> {
    let qa = q.abs();
    if qa < 1e-12 {
        return None;
    }
    let b = if q * u >= 0.0 { u.abs() } else { -u.abs() };
    // With the span T: |q| s - b <= limit / s.
    let s = (b + (b * b + 4.0 * limit * qa).sqrt()) / (2.0 * qa);
    if 1.0 / s <= max_span {
        return Some(s);
    }
    // Longer than `max_span`: |q| s - b <= limit x max_span.
    let reach = b + limit * max_span;
    (reach > 0.0).then_some(reach / qa)
}

/// Lengthens time steps until every acceleration is within its limit (up to rounding)
/// where slowing down can achieve it; a deceleration the measured start velocity makes
/// impossible is left for the optimiser and the exit flag. Returns whether any time step
/// changed.
pub(crate) fn retime(band: &mut Band, t: &Timing) -> bool {
    let m = band.dts.len();
    if m == 0 || band.poses.len() != m + 1 {
        return false;
    }
    let limits = [t.max_acceleration, t.max_angular_acceleration];
    let starts = [t.v0, t.w0];
    let mut changed = false;
    for _ in 0..SWEEPS {
        let mut any = false;
        // Lower the rate of segment k to `cap` if that is lower.
        let mut cap = |band: &mut Band, k: usize, s: Option<f64>| {
            if let Some(s) = s
                && s.is_finite()
                && s > 0.0
                && 1.0 / s > band.dts[k] * (1.0 + 1e-12)
            {
                band.dts[k] = 1.0 / s;
                any = true;
            }
        };
        let (l0, th0) = motion(band, 0);
        for (q0, (&limit, &start)) in [l0, th0].into_iter().zip(limits.iter().zip(&starts)) {
            let u0 = q0 / band.dts[0];
            // Only a segment faster than the start velocity can be helped by slowing.
            if u0.abs() > start.abs() || u0 * start < 0.0 {
                cap(band, 0, max_rate_start(q0, start, limit, t.max_start_span));
            }
        }
        for k in 0..m.saturating_sub(1) {
            for (c, &limit) in limits.iter().enumerate() {
                let pick = |band: &Band, i: usize| {
                    let (l, th) = motion(band, i);
                    if c == 0 { l } else { th }
                };
                let (qa, qb) = (pick(band, k), pick(band, k + 1));
                let (ta, tb) = (band.dts[k], band.dts[k + 1]);
                let (ua, ub) = (qa / ta, qb / tb);
                let span = 0.5 * (ta + tb);
                if (ub - ua).abs() <= limit * span {
                    continue;
                }
                // Slow the faster of the two, holding the other.
                if ub.abs() >= ua.abs() {
                    cap(band, k + 1, max_rate_pair(qb, ua, ta, limit));
                } else {
                    cap(band, k, max_rate_pair(qa, ub, tb, limit));
                }
            }
        }
        if t.at_rest {
            let (l, th) = motion(band, m - 1);
            for (q, limit) in [(l, limits[0]), (th, limits[1])] {
                if q.abs() > 1e-12 {
                    // |q| s <= limit / s.
                    cap(band, m - 1, Some((limit / q.abs()).sqrt()));
                }
            }
        }
        changed |= any;
        if !any {
            break;
        }
    }
    changed
}

#[cfg(test)]
mod tests {
    use super::*;
    use aisle_geometry::Pose2;

    fn worst_excess(band: &Band, t: &Timing) -> f64 {
        let m = band.dts.len();
        let vel = |k: usize| {
            let (l, th) = motion(band, k);
            (l / band.dts[k], th / band.dts[k])
        };
        let mut worst: f64 = 0.0;
        let (v, w) = vel(0);
        worst = worst
            .max((v - t.v0).abs() - t.max_acceleration * t.start_span(band.dts[0]))
            .max((w - t.w0).abs() - t.max_angular_acceleration * t.start_span(band.dts[0]));
        for k in 0..m - 1 {
            let (va, wa) = vel(k);
            let (vb, wb) = vel(k + 1);
            let span = 0.5 * (band.dts[k] + band.dts[k + 1]);
            worst = worst
                .max((vb - va).abs() - t.max_acceleration * span)
                .max((wb - wa).abs() - t.max_angular_acceleration * span);
        }
        if t.at_rest {
            let (v, w) = vel(m - 1);
            worst = worst
                .max(v.abs() - t.max_acceleration * band.dts[m - 1])
                .max(w.abs() - t.max_angular_acceleration * band.dts[m - 1]);
        }
        worst
    }

    #[test]
    fn retiming_meets_the_accelerations_and_only_slows_down() {
        // A band that jumps from 0.5 to 2 m/s, zig-zags its heading and stops dead.
        let mut band = Band::default();
        let mut p = Pose2::new(0.0, 0.0, 0.0);
        band.poses.push(p);
        let speeds = [0.5, 2.0, 2.0, 0.6, 2.0, 2.0];
        for (k, v) in speeds.iter().enumerate() {
            let th = if k % 2 == 0 { 0.25 } else { -0.25 };
            let tm = 0.5 * (p.theta + th);
            p = Pose2::new(p.x + v * 0.3 * tm.cos(), p.y + v * 0.3 * tm.sin(), th);
            band.poses.push(p);
            band.dts.push(0.3);
        }
        let t = Timing {
            v0: 0.4,
            w0: 0.0,
            at_rest: true,
            max_acceleration: 2.4,
            max_angular_acceleration: 4.8,
            max_start_span: f64::INFINITY,
        };
        assert!(worst_excess(&band, &t) > 0.5);
        let before = band.clone();
        assert!(retime(&mut band, &t));
        assert!(
            worst_excess(&band, &t) < 1e-9,
            "{}",
            worst_excess(&band, &t)
        );
        assert_eq!(band.poses, before.poses);
        for (a, b) in band.dts.iter().zip(&before.dts) {
            assert!(a >= b);
        }
        // Already feasible: nothing changes.
        let again = band.clone();
        assert!(!retime(&mut band, &t));
        assert_eq!(band, again);
    }

    #[test]
    fn a_long_first_segment_from_rest_earns_no_larger_start() {
        // 1.88 m in 0.94 s from rest: 2 m/s at once. Over its own duration that is within
        // 2.4 m/s^2; over the reference step it is not, and slowing it means 0.72 m/s.
        let mut band = Band::default();
        band.poses.push(Pose2::new(0.0, 0.0, 0.0));
        band.poses.push(Pose2::new(1.88, 0.0, 0.0));
        band.dts.push(0.94);
        let mut t = Timing {
            v0: 0.0,
            w0: 0.0,
            at_rest: false,
            max_acceleration: 2.4,
            max_angular_acceleration: 4.8,
            max_start_span: f64::INFINITY,
        };
        assert!(!retime(&mut band, &t));
        t.max_start_span = 0.3;
        assert!(worst_excess(&band, &t) > 1.0);
        assert!(retime(&mut band, &t));
        assert!(worst_excess(&band, &t) < 1e-9);
        let v = 1.88 / band.dts[0];
        assert!((v - 0.72).abs() < 1e-9, "{v}");
    }
}
