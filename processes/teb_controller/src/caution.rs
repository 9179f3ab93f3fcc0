//! How fast a band that enters its margin is driven. The margin is what the robot keeps
//! for what its map does not show: the part of an obstacle below the lidar's lowest
//! ray, a corner a passing ray cleared, an edge the grid rounded off. A band the
//! optimiser could only find inside it (exit flag 2) is still driven, so the robot can
//! get out of a tight spot, but inside the margin nothing is left to absorb surprises
//! except speed. So each segment that comes within 0.9 x the margin of an obstacle is
//! slowed until the fastest point of the footprint could stop within the clearance the
//! segment keeps, after the reaction time (a new scan reaches the commands one
//! controller period later), and the segments before it brake into it at the
//! acceleration limit. Only the time steps grow: the poses, and so the clearances, stay.
//!
//! Knows the band, each segment's clearance and the limits; nothing of the map or of
//! the optimiser.

use crate::band::Band;

/// What the slowing down needs to know.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Caution {
    /// Seconds from an obstacle entering the map to the command that reacts to it.
    pub reaction_time: f64,
    /// Braking of the footprint's fastest point, m/s^2.
    pub deceleration: f64,
    /// Speed the fastest point may always keep, m/s (so a band touching its margin
    /// still moves).
    pub min_speed: f64,
    /// Distance from the pose to the footprint's farthest point, m: turning at w moves
    /// that point w x this faster than the pose.
    pub reach: f64,
    /// Clearance below which a segment is slowed (0.9 x the margin), m.
    pub below: f64,
}

/// Speed from which a point stops within `clearance` m, moving on at that speed for
/// `reaction` s and then braking at `deceleration`: v t + v^2 / (2 a) = d.
pub(crate) fn stopping_speed(clearance: f64, reaction: f64, deceleration: f64) -> f64 {
    let d = clearance.max(0.0);
    let (t, a) = (reaction, deceleration);
    a * ((t * t + 2.0 * d / a).sqrt() - t)
}

/// Path length of the footprint's fastest point over segment `k`, m.
fn point_travel(band: &Band, k: usize, reach: f64) -> f64 {
    let (a, b) = (band.poses[k], band.poses[k + 1]);
    a.distance(&b) + (b.theta - a.theta).abs() * reach
}

/// Stretches the time steps of `band` so that no segment whose clearance
/// (`clearances[k]`, the least along segment `k`) lies below `c.below` moves the
/// footprint's fastest point faster than its stopping speed, and the segments before
/// it slow down into it at `c.deceleration`. Returns whether any time step grew.
pub(crate) fn slow_down(band: &mut Band, clearances: &[f64], c: &Caution) -> bool {
    let m = band.dts.len().min(clearances.len());
    if m == 0 || band.poses.len() != band.dts.len() + 1 {
        return false;
    }
    // Backwards: the cap of a segment is its own (when inside the margin) or what
    // braking over it reaches from the next segment's cap.
    let mut next_cap = f64::INFINITY;
    let mut stretched = false;
    for k in (0..m).rev() {
        let travel = point_travel(band, k, c.reach);
        let own = if clearances[k] < c.below {
            stopping_speed(clearances[k], c.reaction_time, c.deceleration).max(c.min_speed)
        } else {
            f64::INFINITY
        };
        let braking = (next_cap * next_cap + 2.0 * c.deceleration * travel).sqrt();
        let cap = own.min(braking);
        if travel > cap * band.dts[k] {
            band.dts[k] = travel / cap;
            stretched = true;
        }
        next_cap = cap;
    }
    stretched
}

#[cfg(test)]
mod tests {
    use super::*;
    use aisle_geometry::Pose2;

    fn straight_band(speed: f64, segments: usize) -> Band {
        let mut band = Band::default();
        for k in 0..=segments {
            band.poses
                .push(Pose2::new(0.3 * speed * k as f64, 0.0, 0.0));
        }
        band.dts = vec![0.3; segments];
        band
    }

    fn caution() -> Caution {
        Caution {
            reaction_time: 0.5,
            deceleration: 2.4,
            min_speed: 0.05,
            reach: 0.7,
            below: 0.36,
        }
    }

    #[test]
    fn the_stopping_speed_stops_within_the_clearance() {
        for d in [0.0, 0.01, 0.05, 0.2, 1.0] {
            let v = stopping_speed(d, 0.5, 2.4);
            assert!((v * 0.5 + v * v / 4.8 - d).abs() < 1e-12, "{d}: {v}");
        }
        assert_eq!(stopping_speed(-0.1, 0.5, 2.4), 0.0);
    }

    #[test]
    fn a_band_clear_of_its_margin_keeps_its_timing() {
        let mut band = straight_band(2.0, 6);
        let before = band.clone();
        assert!(!slow_down(&mut band, &[0.4; 6], &caution()));
        assert_eq!(band, before);
    }

    #[test]
    fn a_segment_inside_the_margin_is_slowed_and_braked_into() {
        let mut band = straight_band(2.0, 8);
        let poses = band.poses.clone();
        let mut clear = [0.4; 8];
        clear[5] = 0.05;
        assert!(slow_down(&mut band, &clear, &caution()));
        assert_eq!(band.poses, poses, "only the timing changes");
        let speed = |k: usize| 0.6 / band.dts[k];
        let cap = stopping_speed(0.05, 0.5, 2.4);
        assert!((speed(5) - cap).abs() < 1e-12);
        // Before it, no faster than braking at 2.4 m/s^2 reaches the cap.
        for k in 0..5 {
            let braking = (cap * cap + 2.0 * 2.4 * 0.6 * (5 - k) as f64).sqrt();
            assert!(speed(k) <= braking + 1e-12, "{k}: {}", speed(k));
        }
        // 1.7 m/s one segment before it; two before, braking allows more than 2 m/s.
        assert!(
            speed(4) < 2.0 && (speed(3) - 2.0).abs() < 1e-12,
            "{}",
            speed(4)
        );
        // After it, the band's own speed.
        assert!((speed(6) - 2.0).abs() < 1e-12 && (speed(7) - 2.0).abs() < 1e-12);
    }

    #[test]
    fn turning_counts_at_the_footprint_s_far_corner() {
        // On the spot at 1 rad/s: the corner 0.7 m out moves at 0.7 m/s.
        let mut band = Band::default();
        for k in 0..=3 {
            band.poses.push(Pose2::new(0.0, 0.0, -0.3 * k as f64));
        }
        band.dts = vec![0.3; 3];
        slow_down(&mut band, &[0.0; 3], &caution());
        let corner = 0.3 * 0.7 / band.dts[0];
        assert!((corner - 0.05).abs() < 1e-12, "{corner}");
    }
}
