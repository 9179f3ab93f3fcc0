//! `MapConfig`: the global map's geometry, the local window and the obstacle layer's
//! parameters, read from `config/mapper.toml`.
//!
//! Defaults are the seed's numbers (MATLAB `binaryOccupancyMap(scenario,
//! MapHeightLimits=[0 5], GridOriginInLocal=[-5 -10], MapSize=[20 30])` at its default
//! 10 cells/m, a 1 m boundary band, a 15 m local map, a 12 m lidar). Load it with
//! `aisle_config::load::<MapConfig>`; `validate` names the offending key. Knows nothing
//! of the scene, the lidar's scan pattern or the bus.

use aisle_config::checks::{interval, non_negative, positive};
use aisle_config::{InvalidKey, Validate};
use serde::Deserialize;
use std::path::{Path, PathBuf};

/// Cells per metre above this are far finer than a lidar at 12 m can resolve.
const MAX_CELLS_PER_METRE: f64 = 50.0;

/// Most cells the local map may have, the capacity of its message (`OccupancyGrid`,
/// 2^21 cells in any shape); kept here so the algorithm does not depend on the message
/// crate. The node adapter asserts the limits here and there agree.
pub const MAX_GRID_CELLS: usize = 1 << 21;
/// Longest local map side, in cells (at most `MAX_GRID_CELLS` in all).
pub const MAX_GRID_SIDE: usize = 4096;
/// Most cells the global map may have, the capacity of its message (`GlobalGrid`, 2^24
/// cells: a 100 x 200 m warehouse at 20 cells/m is 2000 x 4000).
pub const MAX_GLOBAL_GRID_CELLS: usize = 1 << 24;
/// Longest global map side, in cells.
pub const MAX_GLOBAL_GRID_SIDE: usize = 8192;
/// Changed cells the node lists before it publishes the map whole again (the
/// `MapChanges` capacity): the change log reserves this many, so listing them allocates
/// nothing.
pub const MAX_LISTED_CHANGES: usize = 1 << 14;

/// The rolling local map handed to the controller every tick.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct LocalMapConfig {
    /// Side of the square window centred on the robot, metres.
    pub size: f64,
}

impl Default for LocalMapConfig {
    fn default() -> Self {
        Self { size: 15.0 }
    }
}

/// The lidar obstacle layer.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ObstacleConfig {
    /// Points with a world height in `[lo, hi]` metres are obstacles. 0.05 m clears the
    /// floor and its range noise; 1.2 m is the carried rack's load (boxes up to 1.0 m)
    /// plus a margin: nothing higher can touch the robot or what it carries.
    pub height_band: [f64; 2],
    /// Range of the lidar, metres: a ray without return clears up to here.
    pub max_range: f64,
    /// Ignored rectangles (robot, carried rack, rack being approached) grow by this on
    /// every side, metres, so range noise on their own edges is not taken for obstacles.
    pub ignore_margin: f64,
    /// A ray clears a detection only where it passes within this distance, metres, of
    /// the cell's centre (and crosses the surface the cell is part of). A cell holding a
    /// wall's face is only partly free: a ray grazing along the face crosses the cell
    /// without hitting anything, and clearing on "crosses the cell" erased walls the
    /// robot had seen and later backed into.
    pub clear_radius: f64,
}

impl Default for ObstacleConfig {
    fn default() -> Self {
        Self {
            height_band: [0.05, 1.2],
            max_range: 12.0,
            ignore_margin: 0.05,
            clear_radius: 0.01,
        }
    }
}

/// Everything in `config/mapper.toml`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct MapConfig {
    /// Grid resolution in cells per metre (MATLAB's convention; the grid stores its
    /// inverse, metres per cell).
    pub cells_per_metre: f64,
    /// World coordinates of the map's lower-left corner, metres.
    pub origin: [f64; 2],
    /// Extent of the map along x and y, metres.
    pub size: [f64; 2],
    /// Only box parts whose vertical extent meets `[lo, hi]` (metres above the floor)
    /// are rasterised.
    pub height_limits: [f64; 2],
    /// Width of the occupied band along the map edge, metres.
    pub boundary_band: f64,
    /// A ROS map_server YAML to use as the static map instead of the scene. A relative
    /// path is taken from the directory of `mapper.toml` by `aisle_config::load`.
    pub ros_map: Option<PathBuf>,
    pub local: LocalMapConfig,
    pub obstacles: ObstacleConfig,
}

impl Default for MapConfig {
    fn default() -> Self {
        Self {
            cells_per_metre: 10.0,
            origin: [-5.0, -10.0],
            size: [20.0, 30.0],
            height_limits: [0.0, 5.0],
            boundary_band: 1.0,
            ros_map: None,
            local: LocalMapConfig::default(),
            obstacles: ObstacleConfig::default(),
        }
    }
}

fn invalid(key: &str, reason: impl Into<String>) -> InvalidKey {
    InvalidKey::new(key, reason)
}

/// Whether `metres * cells_per_metre` is a whole number of cells (within rounding).
fn whole_cells(metres: f64, cells_per_metre: f64) -> bool {
    let n = metres * cells_per_metre;
    (n - n.round()).abs() < 1e-6
}

impl MapConfig {
    /// Metres per cell.
    pub fn resolution(&self) -> f64 {
        1.0 / self.cells_per_metre
    }

    /// Cells of the local map along each side.
    pub fn local_cells(&self) -> usize {
        (self.local.size * self.cells_per_metre).round().max(1.0) as usize
    }
}

impl Validate for MapConfig {
    fn validate(&self) -> Result<(), InvalidKey> {
        positive("cells_per_metre", self.cells_per_metre)?;
        if self.cells_per_metre > MAX_CELLS_PER_METRE {
            return Err(invalid(
                "cells_per_metre",
                format!(
                    "{} is finer than the supported {MAX_CELLS_PER_METRE}",
                    self.cells_per_metre
                ),
            ));
        }
        if !self.origin.iter().all(|v| v.is_finite()) {
            return Err(invalid("origin", "not finite"));
        }
        for v in self.size {
            positive("size", v)?;
            if !whole_cells(v, self.cells_per_metre) {
                return Err(invalid(
                    "size",
                    format!(
                        "{v} m is not a whole number of cells at {} cells/m",
                        self.cells_per_metre
                    ),
                ));
            }
            if (v * self.cells_per_metre).round() > MAX_GLOBAL_GRID_SIDE as f64 {
                return Err(invalid(
                    "size",
                    format!(
                        "{v} m is more than {MAX_GLOBAL_GRID_SIDE} cells at {} cells/m, the \
                         longest side a global map message holds",
                        self.cells_per_metre
                    ),
                ));
            }
        }
        let cells = self.size.map(|v| (v * self.cells_per_metre).round());
        if cells[0] * cells[1] > MAX_GLOBAL_GRID_CELLS as f64 {
            return Err(invalid(
                "size",
                format!(
                    "{} x {} cells is more than the {MAX_GLOBAL_GRID_CELLS} cells a global map \
                     message holds",
                    cells[0], cells[1]
                ),
            ));
        }
        interval("height_limits", self.height_limits)?;
        non_negative("boundary_band", self.boundary_band)?;
        if 2.0 * self.boundary_band >= self.size[0].min(self.size[1]) {
            return Err(invalid(
                "boundary_band",
                "the band would cover the whole map",
            ));
        }
        positive("local.size", self.local.size)?;
        let local = (self.local.size * self.cells_per_metre).round();
        if local > MAX_GRID_SIDE as f64 || local * local > MAX_GRID_CELLS as f64 {
            return Err(invalid(
                "local.size",
                format!(
                    "{local} x {local} cells is more than a local map message holds \
                     ({MAX_GRID_CELLS} cells, {MAX_GRID_SIDE} a side)"
                ),
            ));
        }
        interval("obstacles.height_band", self.obstacles.height_band)?;
        positive("obstacles.max_range", self.obstacles.max_range)?;
        non_negative("obstacles.ignore_margin", self.obstacles.ignore_margin)?;
        positive("obstacles.clear_radius", self.obstacles.clear_radius)?;
        if self.obstacles.clear_radius >= 0.5 * self.resolution() {
            return Err(invalid(
                "obstacles.clear_radius",
                format!(
                    "{} m is not under half a cell ({} m): a ray would clear returns in cells it never crosses",
                    self.obstacles.clear_radius,
                    0.5 * self.resolution()
                ),
            ));
        }
        Ok(())
    }

    /// `ros_map` is taken from the directory of `mapper.toml`.
    fn relative_to(&mut self, dir: &Path) {
        if let Some(p) = &self.ros_map
            && p.is_relative()
        {
            self.ros_map = Some(dir.join(p));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    use aisle_config::{load, testing::shipped};

    #[test]
    fn defaults_are_the_seed_and_valid() {
        let c = MapConfig::default();
        c.validate().unwrap();
        assert_eq!(c.origin, [-5.0, -10.0]);
        assert_eq!(c.size, [20.0, 30.0]);
        assert_eq!(c.height_limits, [0.0, 5.0]);
        assert_eq!(c.local_cells(), 150);
        assert!((c.resolution() - 0.1).abs() < 1e-15);
    }

    #[test]
    fn shipped_file_equals_the_defaults() {
        let c = load::<MapConfig>(&shipped("mapper.toml")).unwrap();
        assert_eq!(c, MapConfig::default());
    }

    #[test]
    fn bad_values_name_the_key_and_line() {
        let dir = std::env::temp_dir().join(format!("aisle-mapper-cfg-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("mapper.toml");
        std::fs::write(
            &path,
            "cells_per_metre = 10.0\n[obstacles]\nheight_band = [1.2, 0.05]\n",
        )
        .unwrap();
        let e = load::<MapConfig>(&path).unwrap_err().to_string();
        assert!(e.contains("mapper.toml:3:"), "{e}");
        assert!(e.contains("obstacles.height_band"), "{e}");
        std::fs::write(&path, "cells_per_metre = 10.25\n").unwrap();
        let e = load::<MapConfig>(&path).unwrap_err().to_string();
        assert!(e.contains("key `size`"), "{e}");
        std::fs::write(&path, "[obstacles]\nclear_radius = 0.05\n").unwrap();
        let e = load::<MapConfig>(&path).unwrap_err().to_string();
        assert!(e.contains("obstacles.clear_radius"), "{e}");
        assert!(e.contains("half a cell"), "{e}");
        // Any shape up to the cells the global map message holds: 100 x 200 m fits at 20
        // cells/m, 410 x 410 m not at 10, nor a side over 8192 cells.
        std::fs::write(&path, "cells_per_metre = 20.0\nsize = [100.0, 200.0]\n").unwrap();
        load::<MapConfig>(&path).unwrap();
        std::fs::write(&path, "size = [410.0, 410.0]\n").unwrap();
        let e = load::<MapConfig>(&path).unwrap_err().to_string();
        assert!(
            e.contains("key `size`") && e.contains("16777216 cells"),
            "{e}"
        );
        std::fs::write(&path, "size = [820.0, 10.0]\n").unwrap();
        let e = load::<MapConfig>(&path).unwrap_err().to_string();
        assert!(e.contains("key `size`") && e.contains("8192"), "{e}");
        std::fs::write(&path, "cell_per_metre = 10.0\n").unwrap();
        let e = load::<MapConfig>(&path).unwrap_err().to_string();
        assert!(e.contains("mapper.toml:1:"), "{e}");
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn twenty_cells_per_metre_is_supported() {
        let c = MapConfig {
            cells_per_metre: 20.0,
            ..MapConfig::default()
        };
        c.validate().unwrap();
        assert_eq!(c.local_cells(), 300);
        let bad = MapConfig {
            boundary_band: f64::NAN,
            ..MapConfig::default()
        };
        assert_eq!(bad.validate().unwrap_err().key, "boundary_band");
    }
}
