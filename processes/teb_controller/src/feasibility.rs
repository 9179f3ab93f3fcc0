//! The exit flag of an optimised band: collision and margin checks along the band
//! (poses and interpolated states between them), time steps and turning radius.
//!
//! Knows nothing of the optimiser; it judges whatever band it is given.

use aisle_geometry::{Footprint, GridView, Pose2};

use crate::band::Band;
use crate::clearance::min_clearance;
use crate::output::ExitFlag;

pub(crate) struct Verdict {
    pub flag: ExitFlag,
    pub last_feasible_index: usize,
    /// Smallest clearance found along the band, m (capped at the margin).
    pub min_clearance: f64,
}

/// Checks the band. Pose 0 (the robot now) counts only for collision, since the
/// robot cannot undo a margin it has already lost.
pub(crate) fn check(
    band: &Band,
    map: &GridView,
    footprint: &Footprint,
    margin: f64,
    step: f64,
    min_turning_radius: f64,
) -> Verdict {
    let n = band.poses.len();
    let mut v = Verdict {
        flag: ExitFlag::Valid,
        last_feasible_index: n.saturating_sub(1),
        min_clearance: margin,
    };
    if n == 0 {
        return v;
    }
    let start = min_clearance(map, footprint, &band.poses[0], margin);
    if start < 0.0 {
        v.flag = ExitFlag::Collision;
        v.last_feasible_index = 0;
        v.min_clearance = start;
        return v;
    }
    let mut first_margin: Option<usize> = None;
    for k in 0..n - 1 {
        let a = band.poses[k];
        let b = band.poses[k + 1];
        let pieces = ((a.distance(&b) / step)
            .max((b.theta - a.theta).abs() / step)
            .ceil() as usize)
            .clamp(1, 1000);
        for j in 1..=pieces {
            let u = j as f64 / pieces as f64;
            let p = Pose2::new(
                a.x + u * (b.x - a.x),
                a.y + u * (b.y - a.y),
                a.theta + u * (b.theta - a.theta),
            );
            let d = min_clearance(map, footprint, &p, margin);
            v.min_clearance = v.min_clearance.min(d);
            if d < 0.0 {
                v.flag = ExitFlag::Collision;
                v.last_feasible_index = k;
                return v;
            }
            if d < 0.9 * margin && first_margin.is_none() {
                first_margin = Some(k);
            }
        }
    }
    if let Some(k) = first_margin {
        v.flag = ExitFlag::MarginViolated;
        v.last_feasible_index = k;
        return v;
    }
    if min_turning_radius > 0.0 {
        for k in 0..n - 1 {
            let a = band.poses[k];
            let b = band.poses[k + 1];
            let dth = (b.theta - a.theta).abs();
            if dth > 1e-9
                && a.distance(&b) / dth < 0.9 * min_turning_radius
                && a.distance(&b) > 1e-9
            {
                v.flag = ExitFlag::TurningRadius;
                v.last_feasible_index = k;
                return v;
            }
        }
    }
    if let Some(k) = band.dts.iter().position(|t| !(t.is_finite() && *t > 0.0)) {
        v.flag = ExitFlag::TimeNotIncreasing;
        v.last_feasible_index = k;
    }
    v
}
