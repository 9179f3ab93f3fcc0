//! `config/robot.toml`: the robot's numbers (kinematics, footprints, mounting links,
//! watchdog, spawn pose) with the seed's values as defaults.
//!
//! Knows nothing of the URDF's content (only its file name) nor of the world: it
//! parses and validates numbers. Every key is optional (missing keys take the seed's
//! value) but unknown keys are refused, so a typo is an error rather than a silent
//! default.

use aisle_config::ConfigError;
use aisle_geometry::{Footprint, Pose2};
use serde::Deserialize;
use std::path::{Path, PathBuf};

/// A value that parsed but makes no sense, with the dotted key that holds it.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("key `{key}`: {reason}")]
pub struct InvalidKey {
    pub key: String,
    pub reason: String,
}

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

/// Where the lidar sits: a URDF link plus a fixed offset in that link's frame.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LidarMountConfig {
    pub link: String,
    pub offset: [f64; 3],
}

impl Default for LidarMountConfig {
    fn default() -> Self {
        Self {
            link: "front_fender_link".into(),
            offset: [0.25, 0.1, 0.2],
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
}

impl Default for WatchdogConfig {
    fn default() -> Self {
        Self {
            hold_last_command: 0.3,
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
    pub lidar_mount: LidarMountConfig,
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
            lidar_mount: LidarMountConfig::default(),
            carry: CarryConfig::default(),
            watchdog: WatchdogConfig::default(),
            start: StartConfig::default(),
        }
    }
}

fn positive(key: &str, v: f64) -> Result<(), InvalidKey> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(InvalidKey {
            key: key.into(),
            reason: format!("must be positive and finite, got {v}"),
        })
    }
}

fn non_negative(key: &str, v: f64) -> Result<(), InvalidKey> {
    if v.is_finite() && v >= 0.0 {
        Ok(())
    } else {
        Err(InvalidKey {
            key: key.into(),
            reason: format!("must be >= 0 and finite, got {v}"),
        })
    }
}

fn finite(key: &str, v: &[f64]) -> Result<(), InvalidKey> {
    if v.iter().all(|x| x.is_finite()) {
        Ok(())
    } else {
        Err(InvalidKey {
            key: key.into(),
            reason: format!("must be finite, got {v:?}"),
        })
    }
}

fn non_empty(key: &str, s: &str) -> Result<(), InvalidKey> {
    if s.trim().is_empty() {
        Err(InvalidKey {
            key: key.into(),
            reason: "must not be empty".into(),
        })
    } else {
        Ok(())
    }
}

impl RobotConfig {
    /// Reads, parses and validates `path`. Errors name the file, the line and the key.
    pub fn load(path: &Path) -> Result<RobotConfig, ConfigError> {
        let (cfg, text) = aisle_config::load_toml::<RobotConfig>(path)?;
        cfg.checked(path, &text)
    }

    /// As [`RobotConfig::load`], from text already in memory (`path` names it in errors).
    pub fn parse(path: &Path, text: &str) -> Result<RobotConfig, ConfigError> {
        let cfg = aisle_config::parse_toml::<RobotConfig>(path, text)?;
        cfg.checked(path, text)
    }

    fn checked(self, path: &Path, text: &str) -> Result<RobotConfig, ConfigError> {
        self.validate()
            .map_err(|e| ConfigError::invalid(path, text, &e.key, e.reason))?;
        Ok(self)
    }

    /// Checks every number; the error names the first offending key.
    pub fn validate(&self) -> Result<(), InvalidKey> {
        non_empty("urdf", &self.urdf.to_string_lossy())?;
        let k = &self.kinematics;
        positive("kinematics.track_width", k.track_width)?;
        positive("kinematics.wheel_radius", k.wheel_radius)?;
        positive("kinematics.wheel_speed_limit", k.wheel_speed_limit)?;
        positive("body.height", self.body.height)?;
        for (name, f) in [
            ("alone", &self.footprint.alone),
            ("carrying", &self.footprint.carrying),
        ] {
            positive(&format!("footprint.{name}.length"), f.length)?;
            positive(&format!("footprint.{name}.width"), f.width)?;
            non_negative(&format!("footprint.{name}.margin"), f.margin)?;
        }
        non_empty("lidar_mount.link", &self.lidar_mount.link)?;
        finite("lidar_mount.offset", &self.lidar_mount.offset)?;
        non_empty("carry.link", &self.carry.link)?;
        positive(
            "watchdog.hold_last_command",
            self.watchdog.hold_last_command,
        )?;
        finite("start.pose", &self.start.pose)?;
        Ok(())
    }

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
}

#[cfg(test)]
mod tests {
    use super::*;

    fn shipped() -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config/robot.toml")
    }

    #[test]
    fn shipped_file_equals_the_seed_defaults() {
        let cfg = RobotConfig::load(&shipped()).unwrap();
        assert_eq!(cfg, RobotConfig::default());
        assert_eq!(cfg.kinematics.track_width, 0.3765);
        assert_eq!(cfg.kinematics.wheel_radius, 0.065);
        assert_eq!(cfg.kinematics.wheel_speed_limit, 34.0);
        assert_eq!(cfg.footprint.carrying.margin, 0.4);
        assert_eq!(cfg.watchdog_hold_ns(), 300_000_000);
        assert!(cfg.urdf_path(&shipped()).ends_with("config/jackal.urdf"));
    }

    #[test]
    fn unknown_key_is_refused_with_file_line_and_key() {
        let text = "[kinematics]\ntrack_width = 0.3765\nwheel_radus = 0.065\n";
        let e = RobotConfig::parse(Path::new("robot.toml"), text)
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("robot.toml:3:"), "{e}");
        assert!(e.contains("wheel_radus"), "{e}");
    }

    #[test]
    fn negative_size_names_the_key_and_line() {
        let text = "[footprint.alone]\nlength = 0.508\nwidth = -0.43\nmargin = 0.1\n";
        let e = RobotConfig::parse(Path::new("robot.toml"), text)
            .unwrap_err()
            .to_string();
        assert!(e.contains("robot.toml:3:"), "{e}");
        assert!(e.contains("footprint.alone.width"), "{e}");
    }

    #[test]
    fn partial_file_keeps_other_defaults_and_validate_names_keys() {
        let cfg = RobotConfig::parse(Path::new("r.toml"), "[body]\nheight = 0.3\n").unwrap();
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
