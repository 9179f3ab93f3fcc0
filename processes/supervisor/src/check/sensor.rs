//! Is the lidar able to see what the robot can drive into before it can stop? A
//! cross-file check of `lidar.toml` against the robot's speed and deceleration limits
//! (`teb.toml`), the controller's reaction time (`mission.toml`), the footprint and the
//! lidar mount (`robot.toml`) and the smallest body part of the scene. Each refusal
//! names `lidar.toml`, the key and the formula with its inputs. Knows nothing of the
//! processes, only the numbers their configs hold.
//!
//! The model (forward travel; the sensor faces forward, see the module's report):
//! - the robot reacts to a new scan one controller period `T` later, then brakes at the
//!   acceleration limit `a` from the speed limit `v`: it stops within
//!   `d = v·T + v²/(2a)`, so the scan must reach `d` plus the part of the footprint
//!   ahead of the sensor;
//! - turning at most at `w` (rad/s), the robot can reach points up to
//!   `w·(T/2 + v/(4a))` off its heading within `d` (the chord of an arc of curvature
//!   `w/v` and length `d` makes half its turning angle with the heading, largest at
//!   full speed), and its body sweeps `atan((W/2 + margin)/d)` either side of that line:
//!   the scan must cover that sector either side of the heading;
//! - at the required range, neighbouring rays must be close enough for the smallest
//!   body part to get two of them (one ray grazing an edge is easily lost to noise).

use aisle_config::ConfigError;
use aisle_config::scene::Scene;
use aisle_robot::{LidarConfig, RobotConfig, SensorPose};
use aisle_teb_controller::TebConfig;
use std::path::Path;

/// What the robot can drive into, derived from its limits.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Reach {
    /// Distance from the sensor the scan must reach (m).
    pub range: f64,
    /// Stopping distance `v·T + v²/(2a)` (m).
    pub stop: f64,
    /// Half-angle either side of the heading the scan must cover (rad).
    pub half_angle: f64,
}

/// The inputs of the model, each with the file and key it came from (for messages).
pub struct Limits {
    pub v: f64,
    pub a: f64,
    pub w: f64,
    pub t: f64,
    /// Footprint length ahead of the sensor (m, >= 0).
    pub front: f64,
    /// Half-width of the footprint plus the safety margin (m).
    pub half_width: f64,
}

impl Limits {
    pub fn new(
        teb: &TebConfig,
        controller_period_s: f64,
        robot: &RobotConfig,
        mount: &SensorPose,
    ) -> Limits {
        let fp = &robot.footprint.alone;
        Limits {
            v: teb.limits.max_velocity,
            a: teb.limits.max_acceleration,
            w: teb.limits.max_angular_velocity,
            t: controller_period_s,
            front: (0.5 * fp.length - mount.position[0]).max(0.0),
            half_width: 0.5 * fp.width + fp.margin,
        }
    }

    pub fn reach(&self) -> Reach {
        let (v, a, w, t) = (self.v, self.a, self.w, self.t);
        let stop = v * t + v * v / (2.0 * a);
        let turn = w * (0.5 * t + v / (4.0 * a));
        let sweep = self.half_width.atan2(stop.max(1e-9));
        Reach {
            range: stop + self.front,
            stop,
            half_angle: (turn + sweep).min(std::f64::consts::PI),
        }
    }

    fn formula(&self) -> String {
        format!(
            "v = {} m/s (teb.toml limits.max_velocity), a = {} m/s² (limits.max_acceleration), \
             T = {} s (one controller period, mission.toml controller_period_s)",
            self.v, self.a, self.t
        )
    }
}

/// The smallest horizontal size of any box part of the scene, with its body's name.
pub fn smallest_part(scene: &Scene) -> Option<(f64, &str)> {
    scene
        .bodies
        .iter()
        .flat_map(|b| {
            b.parts
                .iter()
                .map(move |p| (p.size[0].min(p.size[1]), b.name.as_str()))
        })
        .filter(|(s, _)| s.is_finite() && *s > 0.0)
        .min_by(|x, y| x.0.total_cmp(&y.0))
}

/// Checks `lidar` (read from `path`, whose text `text` locates the keys) against what
/// the robot can reach; `mount_yaw` is the sensor's heading on the robot (rad).
pub fn check_lidar(
    lidar: &LidarConfig,
    path: &Path,
    text: &str,
    limits: &Limits,
    mount_yaw: f64,
    scene: &Scene,
) -> Result<Reach, ConfigError> {
    let bad = |key: &str, why: String| ConfigError::invalid(path, text, key, why);
    let reach = limits.reach();
    if lidar.max_range.is_nan() || lidar.max_range < reach.range {
        return Err(bad(
            "max_range",
            format!(
                "{} m is below the range the robot needs to stop before what it sees: \
                 {:.2} m = v·T + v²/(2a) + {:.3} m of footprint ahead of the sensor, with {}",
                number(lidar.max_range),
                reach.range,
                limits.front,
                limits.formula()
            ),
        ));
    }
    let beams = lidar.beams().map_err(|e| bad(&e.key, e.reason))?;
    let need = reach.half_angle.to_degrees();
    // Sample the sector every 0.05 deg: finer than any useful scan step.
    let samples = (2.0 * need / 0.05).ceil().max(1.0) as usize;
    for i in 0..=samples {
        let heading = -need + 2.0 * need * i as f64 / samples as f64;
        let az = heading - mount_yaw.to_degrees();
        if !covered(az, beams.azimuth_first_deg, beams.azimuth_last_deg) {
            let key = if az < beams.azimuth_first_deg {
                "azimuth_min_deg"
            } else {
                "azimuth_max_deg"
            };
            return Err(bad(
                key,
                format!(
                    "the scan covers {}..{} deg ({} column(s)) but the robot can drive into \
                     ±{need:.1} deg of its heading before it can stop (w·(T/2 + v/(4a)) + \
                     atan((W/2 + margin)/d), w = {} rad/s (teb.toml limits.max_angular_velocity), \
                     W/2 + margin = {} m (robot.toml footprint.alone), d = {:.2} m, {}); \
                     {heading:.1} deg off the heading is not scanned",
                    beams.azimuth_first_deg,
                    beams.azimuth_last_deg,
                    beams.cols,
                    limits.w,
                    limits.half_width,
                    reach.stop,
                    limits.formula()
                ),
            ));
        }
    }
    if let Some((size, body)) = smallest_part(scene)
        && beams.cols > 1
    {
        let max_step = (size / (2.0 * reach.range)).to_degrees();
        if lidar.azimuth_step_deg > max_step {
            return Err(bad(
                "azimuth_step_deg",
                format!(
                    "{} deg between rays leaves {:.3} m between them at {:.2} m (the range the \
                     robot needs to stop): the smallest body part of the scene, {size} m wide \
                     (`{body}`), must get two rays, so at most {max_step:.3} deg",
                    lidar.azimuth_step_deg,
                    lidar.azimuth_step_deg.to_radians() * reach.range,
                    reach.range
                ),
            ));
        }
    }
    Ok(reach)
}

/// A value as written in a config file: plain unless tiny or huge (1e-300, not 300
/// digits).
fn number(v: f64) -> String {
    if v != 0.0 && !(1e-3..1e6).contains(&v.abs()) {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}

/// Whether azimuth `az` (deg, sensor frame) lies within the scanned span, any turn.
fn covered(az: f64, first: f64, last: f64) -> bool {
    if last - first >= 360.0 - 1e-9 {
        return true;
    }
    let rel = (az - first).rem_euclid(360.0);
    rel <= last - first + 1e-9
}

#[cfg(test)]
mod tests {
    use super::*;
    use aisle_config::testing::shipped;

    struct Fixture {
        scene: Scene,
        limits: Limits,
        yaw: f64,
    }

    fn fixture() -> Fixture {
        let scene = Scene::load(&shipped("warehouse.toml")).unwrap();
        let (robot, model) = aisle_robot::load_robot(&shipped("robot.toml")).unwrap();
        let mount = model.mount_in_base(&robot.lidar_mount).unwrap();
        let teb = aisle_config::load::<TebConfig>(&shipped("teb.toml")).unwrap();
        let limits = Limits::new(&teb, 0.5, &robot, &mount);
        Fixture {
            scene,
            limits,
            yaw: mount.level_yaw().unwrap(),
        }
    }

    /// The shipped lidar.toml with `from` replaced by `to`, checked.
    fn check_with(f: &Fixture, from: &str, to: &str) -> Result<Reach, ConfigError> {
        let path = shipped("lidar.toml");
        let text = std::fs::read_to_string(&path).unwrap().replace(from, to);
        let lidar = aisle_config::parse::<LidarConfig>(&path, &text).unwrap();
        check_lidar(&lidar, &path, &text, &f.limits, f.yaw, &f.scene)
    }

    #[test]
    fn the_shipped_lidar_sees_far_and_wide_enough() {
        let f = fixture();
        let r = check_with(&f, "", "").unwrap();
        // 2 m/s, 0.5 s, 2.4 m/s²: 1 + 0.833 m, plus 4 mm of footprint ahead of the mount.
        assert!((r.stop - 1.8333).abs() < 1e-3, "{r:?}");
        assert!((r.range - 1.8373).abs() < 1e-3, "{r:?}");
        let deg = r.half_angle.to_degrees();
        assert!(deg > 30.0 && deg < 40.0, "{deg}");
    }

    #[test]
    fn a_range_below_the_stopping_distance_is_refused_with_the_formula() {
        let f = fixture();
        let e = check_with(&f, "max_range = 12.0", "max_range = 1e-300")
            .unwrap_err()
            .to_string();
        assert!(e.contains("lidar.toml:5: key `max_range`: 1e-300 m"), "{e}");
        assert!(e.contains("1.84 m = v·T + v²/(2a)"), "{e}");
        assert!(e.contains("teb.toml limits.max_velocity"), "{e}");
        let e = check_with(&f, "max_range = 12.0", "max_range = 1.5")
            .unwrap_err()
            .to_string();
        assert!(e.contains("`max_range`"), "{e}");
    }

    #[test]
    fn a_scan_that_misses_the_direction_of_travel_is_refused() {
        let f = fixture();
        // One column, pointing back-left.
        let e = check_with(&f, "azimuth_max_deg = 120.0", "azimuth_max_deg = -120.0")
            .unwrap_err()
            .to_string();
        assert!(e.contains("key `azimuth_max_deg`"), "{e}");
        assert!(e.contains("(1 column(s))"), "{e}");
        // A narrow forward sector: still too narrow on the left.
        let e = check_with(
            &f,
            "azimuth_min_deg = -120.0\nazimuth_max_deg = 120.0",
            "azimuth_min_deg = -10.0\nazimuth_max_deg = 10.0",
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("key `azimuth_min_deg`"), "{e}");
        // Only the right half: the left is blind.
        let e = check_with(&f, "azimuth_max_deg = 120.0", "azimuth_max_deg = 0.0")
            .unwrap_err()
            .to_string();
        assert!(e.contains("key `azimuth_max_deg`"), "{e}");
        // 40 deg either side is enough for the shipped limits.
        check_with(
            &f,
            "azimuth_min_deg = -120.0\nazimuth_max_deg = 120.0",
            "azimuth_min_deg = -40.0\nazimuth_max_deg = 40.0",
        )
        .unwrap();
    }

    #[test]
    fn rays_too_far_apart_for_the_smallest_part_are_refused() {
        let f = fixture();
        assert_eq!(smallest_part(&f.scene).map(|s| s.0), Some(0.05));
        let e = check_with(&f, "azimuth_step_deg = 0.2", "azimuth_step_deg = 2.0")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("key `azimuth_step_deg`") && e.contains("0.05 m wide"),
            "{e}"
        );
        check_with(&f, "azimuth_step_deg = 0.2", "azimuth_step_deg = 0.5").unwrap();
    }

    #[test]
    fn coverage_wraps_around_a_full_turn() {
        assert!(covered(170.0, -180.0, 179.8));
        assert!(covered(-170.0, 90.0, 270.0));
        assert!(!covered(0.0, 90.0, 270.0));
        assert!(covered(0.0, -120.0, 120.0));
        assert!(!covered(-121.0, -120.0, 120.0));
    }
}
