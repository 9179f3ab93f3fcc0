//! `ScanPattern`: the fixed ray directions of an organised scan, computed once.
//!
//! Row `r` is elevation channel `r` (row 0 = the lowest elevation), column `c` is
//! azimuth channel `c` (column 0 = the most clockwise azimuth). The direction of ray
//! (r, c) in the sensor frame (x forward, y left, z up) is
//! `(cos e cos a, cos e sin a, sin e)`. This module knows angles only: no scene, no pose.

use crate::LidarConfig;
use crate::error::LidarError;
use aisle_config::Validate;

/// Per-channel trigonometry in the precision the raycasters use.
#[derive(Debug, Clone)]
pub struct ScanPattern {
    rows: usize,
    cols: usize,
    azimuth_rad: Vec<f64>,
    elevation_rad: Vec<f64>,
    pub(crate) cos_az: Vec<f32>,
    pub(crate) sin_az: Vec<f32>,
    pub(crate) cos_el: Vec<f32>,
    pub(crate) sin_el: Vec<f32>,
    pub(crate) tan_el: Vec<f32>,
    pub(crate) max_range: f32,
}

impl ScanPattern {
    pub fn new(config: &LidarConfig) -> Result<ScanPattern, LidarError> {
        config.validate()?;
        let cols = config.columns()?;
        let rows = config.rows()?;
        // From the integer index, so that rounding does not accumulate along the span.
        let azimuth_rad: Vec<f64> = (0..cols)
            .map(|c| (config.azimuth_min_deg + c as f64 * config.azimuth_step_deg).to_radians())
            .collect();
        let elevation_rad: Vec<f64> = (0..rows)
            .map(|r| (config.elevation_min_deg + r as f64 * config.elevation_step_deg).to_radians())
            .collect();
        Ok(ScanPattern {
            rows,
            cols,
            cos_az: azimuth_rad.iter().map(|a| a.cos() as f32).collect(),
            sin_az: azimuth_rad.iter().map(|a| a.sin() as f32).collect(),
            cos_el: elevation_rad.iter().map(|e| e.cos() as f32).collect(),
            sin_el: elevation_rad.iter().map(|e| e.sin() as f32).collect(),
            tan_el: elevation_rad.iter().map(|e| e.tan() as f32).collect(),
            azimuth_rad,
            elevation_rad,
            max_range: config.max_range as f32,
        })
    }

    pub fn rows(&self) -> usize {
        self.rows
    }

    pub fn columns(&self) -> usize {
        self.cols
    }

    /// rows x columns: the length of the organised cloud.
    pub fn len(&self) -> usize {
        self.rows * self.cols
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Azimuth of each column, radians.
    pub fn azimuths(&self) -> &[f64] {
        &self.azimuth_rad
    }

    /// Elevation of each row, radians.
    pub fn elevations(&self) -> &[f64] {
        &self.elevation_rad
    }

    pub fn max_range(&self) -> f64 {
        f64::from(self.max_range)
    }

    /// Unit direction of ray (row, col) in the sensor frame.
    #[inline]
    pub fn direction(&self, row: usize, col: usize) -> [f32; 3] {
        let ce = self.cos_el[row];
        [
            ce * self.cos_az[col],
            ce * self.sin_az[col],
            self.sin_el[row],
        ]
    }

    /// Same direction, computed in f64 (for the reference caster).
    pub fn direction_f64(&self, row: usize, col: usize) -> [f64; 3] {
        let (se, ce) = self.elevation_rad[row].sin_cos();
        let (sa, ca) = self.azimuth_rad[col].sin_cos();
        [ce * ca, ce * sa, se]
    }

    /// Index of (row, col) in the row-major organised cloud.
    #[inline]
    pub fn index(&self, row: usize, col: usize) -> usize {
        row * self.cols + col
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn seed_pattern_has_37231_rays_in_the_documented_order() {
        let p = ScanPattern::new(&LidarConfig::default()).unwrap();
        assert_eq!((p.rows(), p.columns(), p.len()), (31, 1201, 37_231));
        assert!((p.azimuths()[0] + 120f64.to_radians()).abs() < 1e-12);
        assert!((p.azimuths()[1200] - 120f64.to_radians()).abs() < 1e-12);
        assert!(p.azimuths()[600].abs() < 1e-12);
        assert_eq!(p.elevations()[0], 0.0);
        assert!((p.elevations()[30] - 30f64.to_radians()).abs() < 1e-12);
        let d = p.direction(0, 600);
        assert!((d[0] - 1.0).abs() < 1e-6 && d[1].abs() < 1e-6 && d[2] == 0.0);
        for (r, c) in [(0, 0), (7, 333), (30, 1200)] {
            let d = p.direction(r, c);
            let n = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            assert!((n - 1.0).abs() < 1e-6);
        }
    }
}
