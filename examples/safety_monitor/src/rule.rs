//! The stop decision: the returns inside the corridor the footprint sweeps along its
//! current arc of travel (straight when it does not turn, behind when it reverses), the
//! nearest of them by distance along that arc, and whether it is within the stopping
//! distance `v·reaction + v²/(2·deceleration) + margin`.

use crate::MonitorConfig;

/// The rectangle the robot occupies (centred on its base, as `robot.toml` states it),
/// widened by the lateral margin, between the floor and the top of what can be hit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Corridor {
    /// Half the footprint's length (m).
    pub half_length: f64,
    /// Half the footprint's width (m).
    pub half_width: f64,
    /// Added to each side of the footprint for the corridor that is watched (m).
    pub lateral_margin: f64,
    pub min_height: f64,
    pub max_height: f64,
}

/// What the monitor concluded about one scan.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Verdict {
    /// Free distance from the footprint's edge to the nearest return ahead (m), if any.
    pub nearest: Option<f64>,
    /// The stopping distance at the current speed (m).
    pub stopping_distance: f64,
    pub stop: bool,
}

/// The rule, with its configuration.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StopRule {
    pub config: MonitorConfig,
}

impl StopRule {
    pub fn stopping_distance(&self, speed: f64) -> f64 {
        let c = &self.config;
        let v = speed.abs();
        v * c.reaction + v * v / (2.0 * c.deceleration) + c.margin
    }

    /// Judges one scan. `points` are in the base frame of the robot (x forward, z up
    /// from the floor; NaN for no return), `speed` and `turn_rate` its signed linear and
    /// angular velocity, `last_direction` the sign of its last motion (+1 forward, -1
    /// backwards): a standing robot is held while a return that way is within `margin`
    /// + `start_step`, since its next command could cover that before a scan shows it.
    pub fn judge(
        &self,
        points: impl Iterator<Item = [f64; 3]>,
        [speed, turn_rate]: [f64; 2],
        last_direction: f64,
        corridor: &Corridor,
    ) -> Verdict {
        let standing = speed.abs() < self.config.moving_speed;
        let (stopping_distance, arc) = if standing {
            let d = self.config.margin + self.config.start_step;
            (d, Arc::of(last_direction, 0.0))
        } else {
            (self.stopping_distance(speed), Arc::of(speed, turn_rate))
        };
        let nearest = points
            .filter(|p| p.iter().all(|v| v.is_finite()))
            .filter(|p| p[2] > corridor.min_height && p[2] <= corridor.max_height)
            // Inside the footprint (and just outside, `self_filter`) is the robot or the
            // rack it carries, never an obstacle it could still stop for.
            .filter(|p| {
                let f = self.config.self_filter;
                p[0].abs() > corridor.half_length + f || p[1].abs() > corridor.half_width + f
            })
            .filter_map(|p| arc.along(p[0], p[1]))
            .filter(|(_, lateral)| *lateral <= corridor.half_width + corridor.lateral_margin)
            // Abeam of the body is not ahead of it.
            .map(|(s, _)| s - corridor.half_length)
            .filter(|gap| *gap > 0.0)
            .fold(None, |m: Option<f64>, gap| {
                Some(m.map_or(gap, |m| m.min(gap)))
            });
        Verdict {
            nearest,
            stopping_distance,
            stop: nearest.is_some_and(|gap| gap <= stopping_distance),
        }
    }
}

/// The path the base follows at constant velocity, in a frame mirrored so that it moves
/// forwards and turns left (or not at all).
#[derive(Debug, Clone, Copy)]
struct Arc {
    /// -1 when reversing (x mirrored).
    x_sign: f64,
    /// -1 when turning right (y mirrored).
    y_sign: f64,
    /// Turning radius (m), infinite when straight.
    radius: f64,
}

impl Arc {
    fn of(speed: f64, turn_rate: f64) -> Arc {
        // Reversing is driving forwards in the x-mirrored frame, where the centre of
        // the turn keeps its side: radius v/w with their signs.
        let signed = if turn_rate.abs() < 1e-9 {
            f64::INFINITY
        } else {
            speed / turn_rate
        };
        Arc {
            x_sign: speed.signum(),
            y_sign: if signed < 0.0 { -1.0 } else { 1.0 },
            radius: signed.abs(),
        }
    }

    /// Distance along the arc to where a point is abeam, and its distance from the arc;
    /// `None` for a point behind (more than half a turn away).
    fn along(&self, x: f64, y: f64) -> Option<(f64, f64)> {
        let (x, y) = (x * self.x_sign, y * self.y_sign);
        if self.radius > 1e3 {
            return (x > 0.0).then_some((x, y.abs()));
        }
        let r = self.radius;
        // The centre is at (0, r); the robot at angle -pi/2 around it, moving CCW.
        let swept =
            ((y - r).atan2(x) + std::f64::consts::FRAC_PI_2).rem_euclid(std::f64::consts::TAU);
        (swept <= std::f64::consts::PI).then(|| (r * swept, (x.hypot(y - r) - r).abs()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn corridor() -> Corridor {
        Corridor {
            half_length: 0.25,
            half_width: 0.2,
            lateral_margin: 0.05,
            min_height: 0.05,
            max_height: 0.35,
        }
    }

    fn rule() -> StopRule {
        StopRule {
            config: MonitorConfig {
                deceleration: 1.0,
                ..MonitorConfig::default()
            },
        }
    }

    #[test]
    fn stops_for_a_return_ahead_within_the_stopping_distance_only() {
        let r = rule();
        // 0.5 m/s: 0.1 + 0.125 + 0.1 = 0.325 m.
        assert!((r.stopping_distance(0.5) - 0.325).abs() < 1e-12);
        let near = [[0.25 + 0.3, 0.1, 0.2]];
        let far = [[0.25 + 0.4, 0.1, 0.2]];
        let v = r.judge(near.into_iter(), [0.5, 0.0], 1.0, &corridor());
        assert!(v.stop && (v.nearest.unwrap() - 0.3).abs() < 1e-12, "{v:?}");
        assert!(!r.judge(far.into_iter(), [0.5, 0.0], 1.0, &corridor()).stop);
        // Standing: held only while a return is within margin + start_step (0.2 m) in
        // the direction it last moved.
        assert!(!r.judge(near.into_iter(), [0.0, 0.0], 1.0, &corridor()).stop);
        let close = [[0.25 + 0.15, 0.0, 0.2]];
        assert!(
            r.judge(close.into_iter(), [0.0, 0.0], 1.0, &corridor())
                .stop
        );
        assert!(
            !r.judge(close.into_iter(), [0.0, 0.0], -1.0, &corridor())
                .stop
        );
    }

    #[test]
    fn ignores_the_floor_what_is_above_beside_or_behind_and_no_returns() {
        let r = rule();
        let ignored = [
            [0.4, 0.0, 0.01], // floor
            [0.4, 0.0, 1.0],  // above the robot (a rack's top)
            [0.4, 0.3, 0.2],  // beside the corridor (a rack's leg)
            [-0.4, 0.0, 0.2], // behind, moving forward
            [0.2, 0.1, 0.2],  // inside the footprint (a carried rack's leg)
            [f64::NAN, f64::NAN, f64::NAN],
        ];
        let v = r.judge(ignored.into_iter(), [0.5, 0.0], 1.0, &corridor());
        assert_eq!(v.nearest, None, "{v:?}");
        // Reversing, the return behind counts.
        let v = r.judge(ignored.into_iter(), [-0.5, 0.0], -1.0, &corridor());
        assert!(v.stop && (v.nearest.unwrap() - 0.15).abs() < 1e-12, "{v:?}");
    }

    #[test]
    fn follows_the_arc_of_travel() {
        let r = rule();
        // Turning left on a 1 m radius: a return a quarter turn ahead on the arc, at
        // (1, 1), is pi/2 m along it; the same return is off a straight corridor.
        let on_arc = [[1.0, 1.0, 0.2]];
        let v = r.judge(on_arc.into_iter(), [0.5, 0.5], 1.0, &corridor());
        let expected = std::f64::consts::FRAC_PI_2 - 0.25;
        assert!((v.nearest.unwrap() - expected).abs() < 1e-9, "{v:?}");
        assert_eq!(
            r.judge(on_arc.into_iter(), [0.5, 0.0], 1.0, &corridor())
                .nearest,
            None
        );
        // Turning right, the mirror image; reversing while turning left (w > 0, v < 0)
        // sweeps behind and to the right.
        let right = [[1.0, -1.0, 0.2]];
        assert!(
            r.judge(right.into_iter(), [0.5, -0.5], 1.0, &corridor())
                .nearest
                .is_some()
        );
        let behind_right = [[-1.0, -1.0, 0.2]];
        assert!(
            r.judge(behind_right.into_iter(), [-0.5, 0.5], -1.0, &corridor())
                .nearest
                .is_some()
        );
        // A straight wall ahead of a turning robot, beyond its arc: not in the way.
        let wall = [[1.2, -0.6, 0.2]];
        assert_eq!(
            r.judge(wall.into_iter(), [0.5, 0.5], 1.0, &corridor())
                .nearest,
            None
        );
    }
}
