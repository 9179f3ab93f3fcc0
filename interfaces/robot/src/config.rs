//! `config/robot.toml`: the robot's numbers (kinematics, footprints, sensor and carry
//! mounts, watchdog, spawn pose) with the seed's values as defaults.
//!
//! Knows nothing of the URDF's content (only its file name) nor of the world: it
//! parses and validates numbers (load it with `aisle_config::load::<RobotConfig>`).
//! Every key is optional (missing keys take the seed's value) but unknown keys are
//! refused, so a typo is an error rather than a silent default.

use aisle_config::checks::{at_least, at_most, finite, non_empty, non_negative, positive};
use aisle_config::{InvalidKey, Validate};
use aisle_geometry::{Footprint, Pose2};
use serde::Deserialize;
use std::path::{Path, PathBuf};

/// Differential-drive numbers used for motion (the seed's, not the URDF's).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct KinematicsConfig {
    /// Distance between the wheel contact lines, metres.
    pub track_width: f64,
    /// Wheel radius, metres.
    pub wheel_radius: f64,
    /// Each wheel is clamped to [-limit, +limit] rad/s.
    pub wheel_speed_limit: f64,
}

impl Default for KinematicsConfig {
    fn default() -> Self {
        Self {
            track_width: 0.3765,
            wheel_radius: 0.065,
            wheel_speed_limit: 34.0,
        }
    }
}

/// A planning footprint: rectangle centred on `base_link` plus a safety margin.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FootprintSpec {
    pub length: f64,
    pub width: f64,
    pub margin: f64,
}

impl FootprintSpec {
    pub fn footprint(&self) -> Footprint {
        Footprint::new(self.length, self.width)
    }
}

/// The two footprints of the seed: robot alone and robot carrying a pallet rack.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FootprintConfig {
    pub alone: FootprintSpec,
    pub carrying: FootprintSpec,
}

impl Default for FootprintConfig {
    fn default() -> Self {
        Self {
            alone: FootprintSpec {
                length: 0.508,
                width: 0.43,
                margin: 0.1,
            },
            carrying: FootprintSpec {
                length: 0.88,
                width: 0.8,
                margin: 0.4,
            },
        }
    }
}

/// The robot's collision body: `footprint.alone` extruded from the floor to `height`.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct BodyConfig {
    pub height: f64,
}

impl Default for BodyConfig {
    fn default() -> Self {
        Self { height: 0.25 }
    }
}

/// Where a sensor sits: a URDF link plus a fixed pose in that link's frame.
///
/// The lidar's mount is stated here, in the robot's description, and nowhere else:
/// where a sensor is bolted on is a fact about the robot (the simulator, the lidar and
/// any tool drawing the robot read it), while `lidar.toml` describes the sensor itself.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MountConfig {
    pub link: String,
    /// Offset of the sensor origin in the link frame, metres.
    pub offset: [f64; 3],
    /// Roll, pitch, yaw of the sensor in the link frame, radians (URDF convention).
    pub rpy: [f64; 3],
}

impl Default for MountConfig {
    fn default() -> Self {
        Self {
            link: "front_fender_link".into(),
            offset: [0.25, 0.1, 0.2],
            rpy: [0.0, 0.0, 0.0],
        }
    }
}

/// The URDF link a carried rack is rigidly attached to.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CarryConfig {
    pub link: String,
}

impl Default for CarryConfig {
    fn default() -> Self {
        Self {
            link: "mid_mount".into(),
        }
    }
}

/// How long the last command of a timeline stays in force before the robot stops.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct WatchdogConfig {
    /// Seconds. The controller's timelines cover its 3 s look-ahead, so the hold only
    /// matters once the controller has gone quiet: the fault-tolerance requirement is a
    /// stop no later than 0.3 s after the timeline runs out (Clearpath's own command
    /// timeout is 0.25 s).
    pub hold_last_command: f64,
    /// Seconds a trajectory may be late before the robot stops, whatever its timeline
    /// still holds: a timeline is in force until the next one is due (one controller
    /// period after its tick) plus this. A hung controller cannot drive the robot on.
    pub late_trajectory: f64,
}

impl Default for WatchdogConfig {
    fn default() -> Self {
        Self {
            hold_last_command: 0.3,
            late_trajectory: 0.3,
        }
    }
}

/// Where the simulator spawns the robot (map frame).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct StartConfig {
    /// x, y (metres), yaw (radians).
    pub pose: [f64; 3],
}

impl Default for StartConfig {
    fn default() -> Self {
        Self {
            pose: [0.0, 0.0, 0.0],
        }
    }
}

/// The whole of `robot.toml`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RobotConfig {
    /// URDF file, relative to the directory of `robot.toml` unless absolute.
    pub urdf: PathBuf,
    pub kinematics: KinematicsConfig,
    pub body: BodyConfig,
    pub footprint: FootprintConfig,
    pub lidar_mount: MountConfig,
    pub carry: CarryConfig,
    pub watchdog: WatchdogConfig,
    pub start: StartConfig,
}

impl Default for RobotConfig {
    fn default() -> Self {
        Self {
            urdf: PathBuf::from("jackal.urdf"),
            kinematics: KinematicsConfig::default(),
            body: BodyConfig::default(),
            footprint: FootprintConfig::default(),
            lidar_mount: MountConfig::default(),
            carry: CarryConfig::default(),
            watchdog: WatchdogConfig::default(),
            start: StartConfig::default(),
        }
    }
}

/// The largest length `robot.toml` takes (m): sizes, track, wheel radius, margins.
const MAX_SIZE_M: f64 = 10.0;
/// The smallest wheel radius (m).
const MIN_WHEEL_RADIUS_M: f64 = 0.001;
/// The fastest wheel (rad/s).
const MAX_WHEEL_SPEED: f64 = 10_000.0;
/// The longest watchdog time (s).
const MAX_WATCHDOG_S: f64 = 3600.0;

impl Validate for RobotConfig {
    /// Checks every number; the error names the first offending key.
    fn validate(&self) -> Result<(), InvalidKey> {
        non_empty("urdf", &self.urdf.to_string_lossy())?;
        let k = &self.kinematics;
        // Upper bounds far beyond any mobile robot: a number past them is a typo or a
        // unit slip, refused here rather than met as a robot that cannot move.
        positive("kinematics.track_width", k.track_width)?;
        at_most("kinematics.track_width", k.track_width, MAX_SIZE_M, " m")?;
        at_least(
            "kinematics.wheel_radius",
            k.wheel_radius,
            MIN_WHEEL_RADIUS_M,
        )?;
        at_most("kinematics.wheel_radius", k.wheel_radius, MAX_SIZE_M, " m")?;
        positive("kinematics.wheel_speed_limit", k.wheel_speed_limit)?;
        at_most(
            "kinematics.wheel_speed_limit",
            k.wheel_speed_limit,
            MAX_WHEEL_SPEED,
            " rad/s",
        )?;
        positive("body.height", self.body.height)?;
        at_most("body.height", self.body.height, MAX_SIZE_M, " m")?;
        for (name, f) in [
            ("alone", &self.footprint.alone),
            ("carrying", &self.footprint.carrying),
        ] {
            for (what, v) in [("length", f.length), ("width", f.width)] {
                let key = format!("footprint.{name}.{what}");
                positive(&key, v)?;
                at_most(&key, v, MAX_SIZE_M, " m")?;
            }
            let key = format!("footprint.{name}.margin");
            non_negative(&key, f.margin)?;
            at_most(&key, f.margin, MAX_SIZE_M, " m")?;
        }
        non_empty("lidar_mount.link", &self.lidar_mount.link)?;
        finite("lidar_mount.offset", &self.lidar_mount.offset)?;
        finite("lidar_mount.rpy", &self.lidar_mount.rpy)?;
        non_empty("carry.link", &self.carry.link)?;
        for (key, v) in [
            (
                "watchdog.hold_last_command",
                self.watchdog.hold_last_command,
            ),
            ("watchdog.late_trajectory", self.watchdog.late_trajectory),
        ] {
            positive(key, v)?;
            at_most(key, v, MAX_WATCHDOG_S, " s")?;
        }
        finite("start.pose", &self.start.pose)?;
        Ok(())
    }
}

impl RobotConfig {
    /// The URDF's path: `urdf` resolved against the directory holding `robot_toml`.
    pub fn urdf_path(&self, robot_toml: &Path) -> PathBuf {
        if self.urdf.is_absolute() {
            self.urdf.clone()
        } else {
            robot_toml
                .parent()
                .unwrap_or_else(|| Path::new("."))
                .join(&self.urdf)
        }
    }

    pub fn start_pose(&self) -> Pose2 {
        let [x, y, theta] = self.start.pose;
        Pose2::new(x, y, theta)
    }

    /// The watchdog hold in integer nanoseconds (rounded).
    pub fn watchdog_hold_ns(&self) -> u64 {
        (self.watchdog.hold_last_command * 1e9).round() as u64
    }

    /// How late a trajectory may be, in integer nanoseconds (rounded).
    pub fn late_trajectory_ns(&self) -> u64 {
        (self.watchdog.late_trajectory * 1e9).round() as u64
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use aisle_config::{load, parse, testing::shipped};

    #[test]
    fn shipped_file_equals_the_seed_defaults() {
        let cfg = load::<RobotConfig>(&shipped("robot.toml")).unwrap();
        assert_eq!(cfg, RobotConfig::default());
        assert_eq!(cfg.kinematics.track_width, 0.3765);
        assert_eq!(cfg.kinematics.wheel_radius, 0.065);
        assert_eq!(cfg.kinematics.wheel_speed_limit, 34.0);
        assert_eq!(cfg.footprint.carrying.margin, 0.4);
        assert_eq!(cfg.watchdog_hold_ns(), 300_000_000);
        assert!(
            cfg.urdf_path(&shipped("robot.toml"))
                .ends_with("config/jackal.urdf")
        );
    }

    #[test]
    fn unknown_key_is_refused_with_file_line_and_key() {
        let text = "[kinematics]\ntrack_width = 0.3765\nwheel_radus = 0.065\n";
        let e = parse::<RobotConfig>(Path::new("robot.toml"), text)
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("robot.toml:3:"), "{e}");
        assert!(e.contains("wheel_radus"), "{e}");
    }

    #[test]
    fn negative_size_names_the_key_and_line() {
        let text = "[footprint.alone]\nlength = 0.508\nwidth = -0.43\nmargin = 0.1\n";
        let e = parse::<RobotConfig>(Path::new("robot.toml"), text)
            .unwrap_err()
            .to_string();
        assert!(e.contains("robot.toml:3:"), "{e}");
        assert!(e.contains("footprint.alone.width"), "{e}");
    }

    #[test]
    fn absurd_numbers_are_refused_naming_key_line_and_value() {
        for (text, line, key, got) in [
            (
                "[kinematics]\nwheel_radius = 1e-300\n",
                2,
                "kinematics.wheel_radius",
                "1e-300",
            ),
            (
                "[kinematics]\n\nwheel_speed_limit = 1e300\n",
                3,
                "kinematics.wheel_speed_limit",
                "1e300 rad/s",
            ),
            ("[body]\nheight = 40.0\n", 2, "body.height", "40 m"),
            (
                "[footprint.carrying]\nlength = 0.88\nwidth = 0.8\nmargin = 12.0\n",
                4,
                "footprint.carrying.margin",
                "12 m",
            ),
            (
                "[watchdog]\nlate_trajectory = 86400.0\n",
                2,
                "watchdog.late_trajectory",
                "86400 s",
            ),
        ] {
            let e = parse::<RobotConfig>(Path::new("robot.toml"), text)
                .unwrap_err()
                .to_string();
            assert!(e.starts_with(&format!("robot.toml:{line}:")), "{e}");
            assert!(e.contains(key) && e.contains(got), "{e}");
            assert!(e.len() < 200, "{e}");
        }
    }

    #[test]
    fn partial_file_keeps_other_defaults_and_validate_names_keys() {
        let cfg = parse::<RobotConfig>(Path::new("r.toml"), "[body]\nheight = 0.3\n").unwrap();
        assert_eq!(cfg.body.height, 0.3);
        assert_eq!(cfg.kinematics, KinematicsConfig::default());

        let mut bad = RobotConfig::default();
        bad.kinematics.wheel_speed_limit = f64::NAN;
        assert_eq!(
            bad.validate().unwrap_err().key,
            "kinematics.wheel_speed_limit"
        );
        let mut bad = RobotConfig::default();
        bad.lidar_mount.link = String::new();
        assert_eq!(bad.validate().unwrap_err().key, "lidar_mount.link");
        let mut bad = RobotConfig::default();
        bad.watchdog.hold_last_command = 0.0;
        assert_eq!(
            bad.validate().unwrap_err().key,
            "watchdog.hold_last_command"
        );
    }
}
