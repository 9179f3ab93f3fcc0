//! The exit flag of an optimised band: collision and margin checks along the band
//! (poses, and between them the arcs the segments' commands drive), time steps, turning
//! radius and accelerations.
//!
//! Knows nothing of the optimiser; it judges whatever band it is given.

use aisle_geometry::{Footprint, GridView, Pose2};

use crate::band::Band;
use crate::clearance::{min_clearance, overlaps_occupied};
use crate::output::ExitFlag;
use crate::timing::Timing;

/// An acceleration counts as exceeded beyond this factor of its limit (MATLAB's 10 %
/// for the margin).
const ACCELERATION_TOLERANCE: f64 = 1.1;

/// How much deeper than the robot stands now (inside a cell's disc, outside its square)
/// a band leaving that spot may reach between its poses, m: the interpolation's own
/// wobble, not a way further in.
const LEAVING_TOLERANCE: f64 = 1e-3;

/// First segment whose velocity change (from the measured velocity, from the previous
/// segment, or to rest at the end) exceeds `ACCELERATION_TOLERANCE` x its limit,
/// measured as the optimiser measures it: over the mean duration of the two segments
/// (from the measured velocity, `Timing::start_span`).
fn first_excessive_acceleration(band: &Band, t: &Timing) -> Option<usize> {
    let m = band.dts.len();
    if m == 0 || band.poses.len() != m + 1 {
        return None;
    }
    let motion = |k: usize| {
        let (a, b) = (band.poses[k], band.poses[k + 1]);
        let (s, c) = (0.5 * (a.theta + b.theta)).sin_cos();
        let dt = band.dts[k];
        (
            (c * (b.x - a.x) + s * (b.y - a.y)) / dt,
            (b.theta - a.theta) / dt,
        )
    };
    let over = |dv: f64, dw: f64, span: f64| {
        dv.abs() > ACCELERATION_TOLERANCE * t.max_acceleration * span
            || dw.abs() > ACCELERATION_TOLERANCE * t.max_angular_acceleration * span
    };
    let (v, w) = motion(0);
    if over(v - t.v0, w - t.w0, t.start_span(band.dts[0])) {
        return Some(0);
    }
    for k in 0..m - 1 {
        let (va, wa) = motion(k);
        let (vb, wb) = motion(k + 1);
        if over(vb - va, wb - wa, 0.5 * (band.dts[k] + band.dts[k + 1])) {
            return Some(k + 1);
        }
    }
    let (v, w) = motion(m - 1);
    if t.at_rest && over(v, w, band.dts[m - 1]) {
        return Some(m - 1);
    }
    None
}

/// The path of the segment from `a` to `b` as the robot drives it: the
/// segment's commands (`segment_velocity`, `segment_rate`: the chord projected on the
/// mean heading, and the heading change, spread evenly over the segment's time) held
/// from `a`, which is a circular arc, not the chord. A 0.63 m segment turning by 1 rad
/// bulges 8 cm off its chord: checking the chord let a band pass whose arc touched a
/// cell. Where the arc ends short of `b` (its chord is the projected one shortened by
/// the turn; a band that slips sideways leaves `b` off the arc altogether) the rest is
/// spread along it in proportion to `u`, so the path always ends at `b`: a band may not
/// jump through a wall by slipping, the arc alone would never cross it.
pub(crate) struct SegmentPath {
    a: Pose2,
    turn: f64,
    /// The chord projected on the mean heading: the arc's length.
    along: f64,
    /// From where the arc ends to `b`, spread along it in proportion to `u`.
    end_gap: [f64; 2],
}

impl SegmentPath {
    pub(crate) fn new(a: &Pose2, b: &Pose2) -> SegmentPath {
        let (s, c) = (0.5 * (a.theta + b.theta)).sin_cos();
        let mut path = SegmentPath {
            a: *a,
            turn: b.theta - a.theta,
            along: (b.x - a.x) * c + (b.y - a.y) * s,
            end_gap: [0.0; 2],
        };
        let end = path.arc(1.0);
        path.end_gap = [b.x - end.x, b.y - end.y];
        path
    }

    fn arc(&self, u: f64) -> Pose2 {
        let a = &self.a;
        let half = 0.5 * u * self.turn;
        let sinc = if half.abs() < 1e-6 {
            1.0 - half * half / 6.0
        } else {
            half.sin() / half
        };
        let (hs, hc) = (a.theta + half).sin_cos();
        let reach = u * self.along * sinc;
        Pose2::new(a.x + reach * hc, a.y + reach * hs, a.theta + u * self.turn)
    }

    /// The pose at fraction `u` (0 at `a`, 1 at `b`).
    pub(crate) fn at(&self, u: f64) -> Pose2 {
        let p = self.arc(u);
        Pose2::new(
            p.x + u * self.end_gap[0],
            p.y + u * self.end_gap[1],
            p.theta,
        )
    }
}

/// [`SegmentPath::at`] of the segment from `a` to `b`, for a single pose.
#[cfg(test)]
fn segment_pose(a: &Pose2, b: &Pose2, u: f64) -> Pose2 {
    SegmentPath::new(a, b).at(u)
}

pub(crate) struct Verdict {
    pub flag: ExitFlag,
    pub last_feasible_index: usize,
    /// Smallest clearance found along the band, m (capped at the margin).
    pub min_clearance: f64,
}

/// Checks the band. Pose 0 (the robot now) counts only for collision, since the
/// robot cannot undo a margin it has already lost, and the way from it to pose 1 only
/// for getting closer than it stands. `timing` holds the measured start
/// velocity and the acceleration limits.
#[allow(clippy::too_many_arguments)]
pub(crate) fn check(
    band: &Band,
    map: &GridView,
    footprint: &Footprint,
    margin: f64,
    step: f64,
    min_turning_radius: f64,
    timing: &Timing,
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
    if start < 0.0 && overlaps_occupied(map, footprint, &band.poses[0]) {
        v.flag = ExitFlag::Collision;
        v.last_feasible_index = 0;
        v.min_clearance = start;
        return v;
    }
    // The clearance takes each cell as its circumscribed disc, up to 0.02 m wider than
    // the square at 0.1 m cells: a robot can stand inside a disc without touching a
    // cell. Judged by the discs alone it could never move again; the band may leave at
    // that depth or less, judged by the squares, until it is clear of every disc.
    let mut leaving = (start < 0.0).then_some(start);
    let mut first_margin: Option<usize> = None;
    for k in 0..n - 1 {
        let a = band.poses[k];
        let b = band.poses[k + 1];
        let path = SegmentPath::new(&a, &b);
        let pieces = ((a.distance(&b) / step)
            .max((b.theta - a.theta).abs() / step)
            .ceil() as usize)
            .clamp(1, 1000);
        for j in 1..=pieces {
            let p = if j == pieces {
                b
            } else {
                path.at(j as f64 / pieces as f64)
            };
            let d = min_clearance(map, footprint, &p, margin);
            v.min_clearance = v.min_clearance.min(d);
            if d >= 0.0 {
                leaving = None;
            } else if !leaving.is_some_and(|depth| d >= depth - LEAVING_TOLERANCE)
                || overlaps_occupied(map, footprint, &p)
            {
                v.flag = ExitFlag::Collision;
                v.last_feasible_index = k;
                return v;
            }
            // The first segment leaves from where the robot stands: within the margin
            // there, its way out may be as close as the start (no closer) until pose 1,
            // which the optimiser places.
            let allowed = if k == 0 && j < pieces {
                (0.9 * margin).min(start - LEAVING_TOLERANCE)
            } else {
                0.9 * margin
            };
            if d < allowed && first_margin.is_none() {
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
        return v;
    }
    if let Some(k) = first_excessive_acceleration(band, timing) {
        v.flag = ExitFlag::AccelerationExceeded;
        v.last_feasible_index = k;
    }
    v
}

#[cfg(test)]
mod tests {
    use super::*;
    use aisle_geometry::GridMap;

    #[test]
    fn a_band_braking_too_hard_is_flagged() {
        // 2 m/s for 0.6 s, then 0.5 m/s: 1.5 m/s lost over 0.3 s is 5 m/s^2.
        let mut band = Band::default();
        band.poses.push(Pose2::new(0.0, 0.0, 0.0));
        for (k, v) in [2.0, 2.0, 0.5].iter().enumerate() {
            let x = band.poses[k].x + v * 0.3;
            band.poses.push(Pose2::new(x, 0.0, 0.0));
            band.dts.push(0.3);
        }
        let map = GridMap::new_free(-5.0, -5.0, 0.1, 10.0, 10.0).unwrap();
        let fp = Footprint::new(0.5, 0.4);
        let mut timing = Timing {
            v0: 2.0,
            w0: 0.0,
            at_rest: false,
            max_acceleration: 2.4,
            max_angular_acceleration: 4.8,
            max_start_span: f64::INFINITY,
        };
        let verdict = check(&band, &map.view(), &fp, 0.1, 0.05, 0.0, &timing);
        assert_eq!(verdict.flag, ExitFlag::AccelerationExceeded);
        assert_eq!(verdict.last_feasible_index, 2);
        // The same band under a 6 m/s^2 limit is valid.
        timing.max_acceleration = 6.0;
        let verdict = check(&band, &map.view(), &fp, 0.1, 0.05, 0.0, &timing);
        assert_eq!(verdict.flag, ExitFlag::Valid);
        // Starting from rest into 2 m/s over 0.3 s (6.7 m/s^2) is flagged at segment 0.
        timing.max_acceleration = 2.4;
        timing.v0 = 0.0;
        let verdict = check(&band, &map.view(), &fp, 0.1, 0.05, 0.0, &timing);
        assert_eq!(verdict.flag, ExitFlag::AccelerationExceeded);
        assert_eq!(verdict.last_feasible_index, 0);
        assert_eq!(verdict.flag.code(), 6);
        assert!(!verdict.flag.stops_robot());
    }

    /// A straight band of six poses along x from `x0`, `dx` apart, 0.2 s a segment.
    fn straight(x0: f64, dx: f64) -> Band {
        let mut band = Band::default();
        for k in 0..6 {
            band.poses.push(Pose2::new(x0 + dx * k as f64, 0.0, 0.0));
        }
        band.dts = vec![0.2; 5];
        band
    }

    #[test]
    fn a_robot_inside_a_cells_disc_but_clear_of_its_square_may_leave_it() {
        // One occupied cell, its square [0.4, 0.5] x [-0.05, 0.05]; the 0.5 m long
        // robot's front 4 mm short of it (inside the 0.0707 m disc: clearance -0.017).
        let mut map = GridMap::new_free(-2.0, -2.05, 0.1, 4.0, 4.1).unwrap();
        let cell = map.view().cell_of(0.45, 0.0);
        map.set(cell, aisle_geometry::OCCUPIED_STATIC);
        let fp = Footprint::new(0.5, 0.4);
        let timing = Timing {
            v0: 0.0,
            w0: 0.0,
            at_rest: true,
            max_acceleration: 2.4,
            max_angular_acceleration: 4.8,
            max_start_span: f64::INFINITY,
        };
        let judge = |band: &Band| check(band, &map.view(), &fp, 0.1, 0.02, 0.0, &timing);
        // Backing away: driven (inside the margin for its first poses), not a collision.
        let back = judge(&straight(0.146, -0.1));
        assert_eq!(back.flag, ExitFlag::MarginViolated);
        assert!(!back.flag.stops_robot());
        // Further in, not yet touching the square (0.3 mm a pose): a collision all the same.
        let forward = judge(&straight(0.146, 0.0003));
        assert_eq!(forward.flag, ExitFlag::Collision);
        // Standing in the square itself: a collision, whatever the band does.
        let inside = judge(&straight(0.16, -0.1));
        assert_eq!(inside.flag, ExitFlag::Collision);
        assert_eq!(inside.last_feasible_index, 0);
        // Clear of the disc at the start: a band reaching into it is a collision.
        let into = judge(&straight(-0.2, 0.08));
        assert_eq!(into.flag, ExitFlag::Collision);
    }

    #[test]
    fn a_long_first_segment_from_rest_is_judged_over_the_reference_step() {
        let map = GridMap::new_free(-2.0, -2.0, 0.1, 6.0, 4.0).unwrap();
        let band = Band {
            poses: vec![Pose2::new(0.0, 0.0, 0.0), Pose2::new(1.88, 0.0, 0.0)],
            dts: vec![0.94],
        };
        let mut timing = Timing {
            v0: 0.0,
            w0: 0.0,
            at_rest: false,
            max_acceleration: 2.4,
            max_angular_acceleration: 4.8,
            max_start_span: f64::INFINITY,
        };
        let fp = Footprint::new(0.5, 0.4);
        let judge = |t: &Timing| check(&band, &map.view(), &fp, 0.1, 0.05, 0.0, t).flag;
        assert_eq!(judge(&timing), ExitFlag::Valid);
        // 2 m/s commanded at once from rest.
        timing.max_start_span = 0.3;
        assert_eq!(judge(&timing), ExitFlag::AccelerationExceeded);
    }

    #[test]
    fn a_segment_is_driven_along_its_arc_and_ends_at_its_pose() {
        // 0.6 m turning right by 1 rad, kinematically consistent (the chord along the
        // mean heading): halfway, the arc lies left of the chord's midpoint by nearly its
        // sagitta R (1 - cos 0.5), 7.7 cm.
        let a = Pose2::new(0.0, 0.0, 0.0);
        let b = Pose2::new(0.6 * (-0.5f64).cos(), 0.6 * (-0.5f64).sin(), -1.0);
        let mid = segment_pose(&a, &b, 0.5);
        assert!((mid.theta + 0.5).abs() < 1e-12);
        let (cx, cy) = (0.5 * b.x, 0.5 * b.y);
        // Left of the chord (whose direction is -0.5 rad): the normal (sin 0.5, cos 0.5).
        let off = (mid.x - cx) * 0.5f64.sin() + (mid.y - cy) * 0.5f64.cos();
        let radius = 0.6 / (2.0 * 0.5f64.sin());
        let sagitta = radius * (1.0 - 0.5f64.cos());
        assert!(
            off > 0.7 * sagitta && off <= sagitta + 1e-9,
            "{off} vs {sagitta}"
        );
        let end = segment_pose(&a, &b, 1.0);
        assert!(end.distance(&b) < 1e-12 && end.theta == b.theta, "{end:?}");
        // A straight segment is its chord, forwards and backwards.
        let back = segment_pose(&a, &Pose2::new(-0.4, 0.0, 0.0), 0.25);
        assert!((back.x + 0.1).abs() < 1e-12 && back.y == 0.0);
        // A band slipping sideways 1.35 m (its commands would only creep 6.5 cm
        // forwards) still passes between its poses, not along the creep alone.
        let slip = Pose2::new(0.065, 1.35, 0.0);
        let half = segment_pose(&a, &slip, 0.5);
        assert!((half.y - 0.675).abs() < 1e-9, "{half:?}");
    }

    #[test]
    fn a_cell_the_arc_touches_but_the_chord_clears_stops_the_robot() {
        // One long right-turning segment; a cell just outside the chord's sweep on the
        // outside of the turn, where the robot's left side passes as it drives the arc.
        let a = Pose2::new(0.0, 0.0, 0.0);
        let b = Pose2::new(1.2 * (-0.6f64).cos(), 1.2 * (-0.6f64).sin(), -1.2);
        let band = Band {
            poses: vec![a, b],
            dts: vec![1.2],
        };
        let fp = Footprint::new(0.5, 0.4);
        let timing = Timing {
            v0: 1.0,
            w0: -1.0,
            at_rest: false,
            max_acceleration: 10.0,
            max_angular_acceleration: 10.0,
            max_start_span: f64::INFINITY,
        };
        let chord = |u: f64| {
            Pose2::new(
                a.x + u * (b.x - a.x),
                a.y + u * (b.y - a.y),
                a.theta + u * (b.theta - a.theta),
            )
        };
        // The first cell centre, moving out from the chord's midpoint along its left
        // normal, that every chord sample clears.
        let normal = (0.6f64.sin(), 0.6f64.cos());
        let clear_of_chord = |map: &GridMap| {
            (0..=100).all(|j| min_clearance(&map.view(), &fp, &chord(j as f64 / 100.0), 0.1) > 0.0)
        };
        let mut placed = None;
        for step in 0..40 {
            let d = 0.2 + 0.01 * step as f64;
            let mut map = GridMap::new_free(-3.0, -3.0, 0.1, 6.0, 6.0).unwrap();
            let cell = map
                .view()
                .cell_of(0.5 * b.x + d * normal.0, 0.5 * b.y + d * normal.1);
            map.set(cell, aisle_geometry::OCCUPIED_DETECTED);
            if clear_of_chord(&map) {
                placed = Some(map);
                break;
            }
        }
        let map = placed.expect("a cell beside the chord");
        let verdict = check(&band, &map.view(), &fp, 0.1, 0.02, 0.0, &timing);
        assert_eq!(verdict.flag, ExitFlag::Collision);
        assert!(verdict.flag.stops_robot());
    }
}
