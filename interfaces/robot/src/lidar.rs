//! `LidarConfig`: the sensor itself (scan pattern, range, rate, noise) from
//! `config/lidar.toml`, and the [`BeamGeometry`] its pattern gives.
//!
//! Defaults are the seed's numbers (SCENARIO.md). `validate` names the offending key.
//! Knows nothing of the scene or of raycasting; where the sensor sits on the robot is
//! not here but in `robot.toml` (`lidar_mount`, see [`crate::MountConfig`]).

use crate::BeamGeometry;
use aisle_config::checks::{at_most, positive};
use aisle_config::{InvalidKey, Validate};
use serde::Deserialize;

/// Zero-mean Gaussian range noise, drawn from a seeded stream (see `noise`).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct NoiseConfig {
    pub enabled: bool,
    /// One standard deviation, metres.
    pub sigma: f64,
    pub seed: u64,
}

impl Default for NoiseConfig {
    fn default() -> Self {
        Self {
            enabled: true,
            sigma: 0.002,
            seed: 1,
        }
    }
}

/// The whole lidar configuration.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct LidarConfig {
    /// Returns farther than this (metres, along the ray) are NaN.
    pub max_range: f64,
    pub azimuth_min_deg: f64,
    pub azimuth_max_deg: f64,
    pub azimuth_step_deg: f64,
    pub elevation_min_deg: f64,
    pub elevation_max_deg: f64,
    pub elevation_step_deg: f64,
    pub rate_hz: f64,
    /// Organised output keeps one slot per ray (NaN for no return). When false the node
    /// packs the returns to the front with [`crate::compact_returns`].
    pub organized: bool,
    /// Whether the floor plane z = 0 returns rays. With the seed's elevations (0..30 deg)
    /// and a level mount no ray points down, so this only matters for tilted poses or
    /// negative elevations.
    pub hit_floor: bool,
    /// Threads a scan from a tilted sensor uses: 1, or 2 to sweep half its columns on a
    /// second thread (the points are the same either way; a level sensor's scan uses
    /// one). One as shipped: where the two cores share their resources, as on the 2-vCPU
    /// machines this is measured on, the second thread gains little and takes a core
    /// from the other nodes.
    pub scan_threads: u32,
    pub noise: NoiseConfig,
}

impl Default for LidarConfig {
    fn default() -> Self {
        Self {
            max_range: 12.0,
            azimuth_min_deg: -120.0,
            azimuth_max_deg: 120.0,
            azimuth_step_deg: 0.2,
            elevation_min_deg: 0.0,
            elevation_max_deg: 30.0,
            elevation_step_deg: 1.0,
            rate_hz: 10.0,
            organized: true,
            hit_floor: true,
            scan_threads: 1,
            noise: NoiseConfig::default(),
        }
    }
}

fn invalid(key: &str, reason: impl Into<String>) -> InvalidKey {
    InvalidKey::new(key, reason)
}

/// Rays beyond this count would make the organised cloud unreasonably large for one
/// shared-memory sample; it also keeps the channel arithmetic far from overflow.
const MAX_CHANNELS: usize = 100_000;

/// Number of channels of a `[min, max]` span sampled every `step`, both ends included.
fn channels(min: f64, max: f64, step: f64, keys: [&'static str; 3]) -> Result<usize, InvalidKey> {
    let [kmin, kmax, kstep] = keys;
    if !min.is_finite() {
        return Err(invalid(kmin, format!("must be finite, got {min}")));
    }
    if !max.is_finite() {
        return Err(invalid(kmax, format!("must be finite, got {max}")));
    }
    if max < min {
        return Err(invalid(kmax, format!("{max} is below the minimum {min}")));
    }
    if !(step.is_finite() && step > 0.0) {
        return Err(invalid(kstep, format!("must be positive, got {step}")));
    }
    let intervals = (max - min) / step;
    if intervals + 1.0 > MAX_CHANNELS as f64 {
        return Err(invalid(
            kstep,
            format!("gives more than {MAX_CHANNELS} channels"),
        ));
    }
    let n = intervals.round();
    // Relative tolerance: 240 / 0.2 is 1199.9999999999998 in binary floating point.
    if (intervals - n).abs() > 1e-6 * intervals.max(1.0) {
        return Err(invalid(
            kstep,
            format!("{step} does not divide the span {min}..{max}"),
        ));
    }
    Ok(n as usize + 1)
}

impl LidarConfig {
    /// The beam directions a consumer of the cloud needs (the mapper clears along rays
    /// without a return): channel counts and first and last angles.
    pub fn beams(&self) -> Result<BeamGeometry, InvalidKey> {
        let rows = self.rows()?;
        let cols = self.columns()?;
        Ok(BeamGeometry {
            rows,
            cols,
            elevation_first_deg: self.elevation_min_deg,
            elevation_last_deg: self.elevation_min_deg
                + (rows - 1) as f64 * self.elevation_step_deg,
            azimuth_first_deg: self.azimuth_min_deg,
            azimuth_last_deg: self.azimuth_min_deg + (cols - 1) as f64 * self.azimuth_step_deg,
        })
    }

    /// Number of azimuth channels (columns). Call after `validate`.
    pub fn columns(&self) -> Result<usize, InvalidKey> {
        channels(
            self.azimuth_min_deg,
            self.azimuth_max_deg,
            self.azimuth_step_deg,
            ["azimuth_min_deg", "azimuth_max_deg", "azimuth_step_deg"],
        )
    }

    /// Number of elevation channels (rows).
    pub fn rows(&self) -> Result<usize, InvalidKey> {
        channels(
            self.elevation_min_deg,
            self.elevation_max_deg,
            self.elevation_step_deg,
            [
                "elevation_min_deg",
                "elevation_max_deg",
                "elevation_step_deg",
            ],
        )
    }
}

/// The longest `max_range` taken (m).
const MAX_RANGE_M: f64 = 1000.0;

impl Validate for LidarConfig {
    fn validate(&self) -> Result<(), InvalidKey> {
        positive("max_range", self.max_range)?;
        // No lidar reaches a kilometre; a larger number is a unit slip (mm for m).
        at_most("max_range", self.max_range, MAX_RANGE_M, " m")?;
        self.columns()?;
        if self.azimuth_max_deg - self.azimuth_min_deg > 360.0 {
            return Err(invalid(
                "azimuth_max_deg",
                "the azimuth span exceeds 360 deg",
            ));
        }
        if self.elevation_min_deg < -90.0 {
            return Err(invalid("elevation_min_deg", "must be >= -90 deg"));
        }
        if self.elevation_max_deg > 90.0 {
            return Err(invalid("elevation_max_deg", "must be <= 90 deg"));
        }
        self.rows()?;
        if self.rows()? * self.columns()? > MAX_CHANNELS * 10 {
            return Err(invalid(
                "azimuth_step_deg",
                "rows x columns exceeds one million rays",
            ));
        }
        if !(1..=2).contains(&self.scan_threads) {
            return Err(invalid(
                "scan_threads",
                format!("must be 1 or 2, got {}", self.scan_threads),
            ));
        }
        if !(self.rate_hz.is_finite() && self.rate_hz > 0.0) {
            return Err(invalid(
                "rate_hz",
                format!("must be positive, got {}", self.rate_hz),
            ));
        }
        if !(self.noise.sigma.is_finite() && self.noise.sigma >= 0.0) {
            return Err(invalid(
                "noise.sigma",
                format!("must be >= 0, got {}", self.noise.sigma),
            ));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use aisle_config::{load, parse, testing::shipped};
    use std::path::Path;

    #[test]
    fn shipped_file_equals_the_seed_defaults() {
        let cfg = load::<LidarConfig>(&shipped("lidar.toml")).unwrap();
        assert_eq!(cfg, LidarConfig::default());
        assert_eq!(cfg.columns().unwrap(), 1201);
        assert_eq!(cfg.rows().unwrap(), 31);
        assert_eq!(cfg.beams().unwrap(), BeamGeometry::default());
    }

    #[test]
    fn unknown_key_is_named() {
        let e = parse::<LidarConfig>(Path::new("l.toml"), "max_range = 12.0\nmax_rnage = 3\n")
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("l.toml:2:") && e.contains("max_rnage"), "{e}");
        let e = parse::<LidarConfig>(Path::new("l.toml"), "[noise]\nsigmaa = 0.1\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("sigmaa"), "{e}");
    }

    #[test]
    fn negative_range_is_named() {
        let e = parse::<LidarConfig>(Path::new("l.toml"), "rate_hz = 10.0\nmax_range = -1.0\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("l.toml:2:") && e.contains("`max_range`"), "{e}");
        let e = parse::<LidarConfig>(Path::new("l.toml"), "max_range = 12000.0\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("must be at most 1000 m, got 12000 m"), "{e}");
    }

    #[test]
    fn step_that_does_not_divide_the_span_is_named() {
        let e = parse::<LidarConfig>(Path::new("l.toml"), "azimuth_step_deg = 0.7\n")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("`azimuth_step_deg`") && e.contains("divide"),
            "{e}"
        );
        let e = parse::<LidarConfig>(Path::new("l.toml"), "elevation_step_deg = 0.0\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("`elevation_step_deg`"), "{e}");
    }

    #[test]
    fn other_bad_values_are_named() {
        let cases = [
            ("elevation_max_deg = 95.0", "elevation_max_deg"),
            (
                "azimuth_min_deg = -200.0\nazimuth_max_deg = 200.0",
                "azimuth_max_deg",
            ),
            ("rate_hz = 0.0", "rate_hz"),
            ("[noise]\nsigma = -0.1", "noise.sigma"),
        ];
        for (text, key) in cases {
            let e = parse::<LidarConfig>(Path::new("l.toml"), text)
                .unwrap_err()
                .to_string();
            assert!(e.contains(&format!("`{key}`")), "{text}: {e}");
        }
    }
}
