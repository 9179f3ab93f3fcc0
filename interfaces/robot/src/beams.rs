//! `BeamGeometry`: the directions of a lidar's beams, as a consumer of its organised
//! cloud needs them (row r, column c -> elevation, azimuth). Built from `lidar.toml` by
//! [`crate::LidarConfig::beams`]. Knows angles only.

/// The lidar's scan pattern: evenly spaced channels, first and last angle included.
/// `first > last` is allowed (a lidar that orders its rows top-down).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BeamGeometry {
    pub rows: usize,
    pub cols: usize,
    /// Elevation of row 0 and of the last row, degrees.
    pub elevation_first_deg: f64,
    pub elevation_last_deg: f64,
    /// Azimuth of column 0 and of the last column, degrees.
    pub azimuth_first_deg: f64,
    pub azimuth_last_deg: f64,
}

impl Default for BeamGeometry {
    /// The seed's lidar: elevation 0..30 deg at 1 deg, azimuth -120..120 deg at 0.2 deg.
    fn default() -> Self {
        Self {
            rows: 31,
            cols: 1201,
            elevation_first_deg: 0.0,
            elevation_last_deg: 30.0,
            azimuth_first_deg: -120.0,
            azimuth_last_deg: 120.0,
        }
    }
}

/// Angle of channel `i` of `n` spread evenly from `first` to `last` (degrees in, radians out).
fn channel(first: f64, last: f64, n: usize, i: usize) -> f64 {
    let t = if n > 1 {
        i as f64 / (n - 1) as f64
    } else {
        0.0
    };
    (first + t * (last - first)).to_radians()
}

impl BeamGeometry {
    pub fn elevation(&self, row: usize) -> f64 {
        channel(
            self.elevation_first_deg,
            self.elevation_last_deg,
            self.rows,
            row,
        )
    }

    pub fn azimuth(&self, col: usize) -> f64 {
        channel(
            self.azimuth_first_deg,
            self.azimuth_last_deg,
            self.cols,
            col,
        )
    }
}
