//! Occupancy grids in the map frame: an owned [`GridMap`] and a borrowed [`GridView`].
//!
//! Cells are row-major from the origin corner (x grows with the column, y with the row).
//! A cell value of [`FREE`] is free; any other value is occupied ([`OCCUPIED_STATIC`] from
//! the static map, [`OCCUPIED_DETECTED`] from the lidar). Outside the grid counts as
//! occupied for planning (`occupied_or_outside`), as MATLAB's map boundary band does.

pub const FREE: u8 = 0;
pub const OCCUPIED_STATIC: u8 = 1;
pub const OCCUPIED_DETECTED: u8 = 2;

/// A cell address: column `ix`, row `iy`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct CellIndex {
    pub ix: i64,
    pub iy: i64,
}

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum GridError {
    #[error("grid resolution {0} is not a positive number of metres per cell")]
    NonPositiveResolution(f64),
    #[error("grid has {got} cells, width x height needs {expected}")]
    CellCount { expected: usize, got: usize },
    #[error("grid has zero width or height")]
    Empty,
}

/// A borrowed occupancy grid: what algorithms read.
#[derive(Debug, Clone, Copy)]
pub struct GridView<'a> {
    /// World coordinates of the outer corner of cell (0, 0).
    pub origin_x: f64,
    pub origin_y: f64,
    /// Edge length of a cell in metres.
    pub resolution: f64,
    pub width: usize,
    pub height: usize,
    pub cells: &'a [u8],
}

impl<'a> GridView<'a> {
    pub fn new(
        origin_x: f64,
        origin_y: f64,
        resolution: f64,
        width: usize,
        height: usize,
        cells: &'a [u8],
    ) -> Result<Self, GridError> {
        check(resolution, width, height, cells.len())?;
        Ok(Self {
            origin_x,
            origin_y,
            resolution,
            width,
            height,
            cells,
        })
    }

    #[inline]
    pub fn cell_of(&self, x: f64, y: f64) -> CellIndex {
        CellIndex {
            ix: ((x - self.origin_x) / self.resolution).floor() as i64,
            iy: ((y - self.origin_y) / self.resolution).floor() as i64,
        }
    }

    #[inline]
    pub fn cell_center(&self, c: CellIndex) -> (f64, f64) {
        (
            self.origin_x + (c.ix as f64 + 0.5) * self.resolution,
            self.origin_y + (c.iy as f64 + 0.5) * self.resolution,
        )
    }

    #[inline]
    pub fn contains_cell(&self, c: CellIndex) -> bool {
        c.ix >= 0 && c.iy >= 0 && (c.ix as usize) < self.width && (c.iy as usize) < self.height
    }

    /// The cell value, or `None` outside the grid.
    #[inline]
    pub fn get(&self, c: CellIndex) -> Option<u8> {
        if self.contains_cell(c) {
            Some(self.cells[c.iy as usize * self.width + c.ix as usize])
        } else {
            None
        }
    }

    /// True for an occupied cell and for anything outside the grid.
    #[inline]
    pub fn occupied_or_outside(&self, c: CellIndex) -> bool {
        self.get(c).is_none_or(|v| v != FREE)
    }

    /// True only for an occupied cell inside the grid (outside counts as free, as
    /// MATLAB's controllerTEB treats space beyond its local map).
    #[inline]
    pub fn occupied_inside(&self, c: CellIndex) -> bool {
        self.get(c).is_some_and(|v| v != FREE)
    }

    pub fn occupied_at(&self, x: f64, y: f64) -> bool {
        self.occupied_or_outside(self.cell_of(x, y))
    }

    /// World extent as (min_x, min_y, max_x, max_y).
    pub fn bounds(&self) -> (f64, f64, f64, f64) {
        (
            self.origin_x,
            self.origin_y,
            self.origin_x + self.width as f64 * self.resolution,
            self.origin_y + self.height as f64 * self.resolution,
        )
    }
}

/// An owned occupancy grid.
#[derive(Debug, Clone, PartialEq)]
pub struct GridMap {
    pub origin_x: f64,
    pub origin_y: f64,
    pub resolution: f64,
    pub width: usize,
    pub height: usize,
    pub cells: Vec<u8>,
}

impl GridMap {
    /// An all-free grid covering `size_x` x `size_y` metres from the origin corner.
    pub fn new_free(
        origin_x: f64,
        origin_y: f64,
        resolution: f64,
        size_x: f64,
        size_y: f64,
    ) -> Result<Self, GridError> {
        if !resolution.is_finite() || resolution <= 0.0 {
            return Err(GridError::NonPositiveResolution(resolution));
        }
        let width = (size_x / resolution).round() as usize;
        let height = (size_y / resolution).round() as usize;
        check(resolution, width, height, width * height)?;
        Ok(Self {
            origin_x,
            origin_y,
            resolution,
            width,
            height,
            cells: vec![FREE; width * height],
        })
    }

    pub fn from_cells(
        origin_x: f64,
        origin_y: f64,
        resolution: f64,
        width: usize,
        height: usize,
        cells: Vec<u8>,
    ) -> Result<Self, GridError> {
        check(resolution, width, height, cells.len())?;
        Ok(Self {
            origin_x,
            origin_y,
            resolution,
            width,
            height,
            cells,
        })
    }

    pub fn view(&self) -> GridView<'_> {
        GridView {
            origin_x: self.origin_x,
            origin_y: self.origin_y,
            resolution: self.resolution,
            width: self.width,
            height: self.height,
            cells: &self.cells,
        }
    }

    pub fn set(&mut self, c: CellIndex, value: u8) -> bool {
        if self.view().contains_cell(c) {
            self.cells[c.iy as usize * self.width + c.ix as usize] = value;
            true
        } else {
            false
        }
    }
}

fn check(resolution: f64, width: usize, height: usize, len: usize) -> Result<(), GridError> {
    if !resolution.is_finite() || resolution <= 0.0 {
        return Err(GridError::NonPositiveResolution(resolution));
    }
    if width == 0 || height == 0 {
        return Err(GridError::Empty);
    }
    if width * height != len {
        return Err(GridError::CellCount {
            expected: width * height,
            got: len,
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cell_addressing_round_trips() {
        let mut g = GridMap::new_free(-5.0, -10.0, 0.1, 20.0, 30.0).unwrap();
        assert_eq!((g.width, g.height), (200, 300));
        let c = g.view().cell_of(0.0, 0.0);
        assert_eq!(c, CellIndex { ix: 50, iy: 100 });
        let (cx, cy) = g.view().cell_center(c);
        assert!((cx - 0.05).abs() < 1e-9 && (cy - 0.05).abs() < 1e-9);
        assert!(g.set(c, OCCUPIED_STATIC));
        assert!(g.view().occupied_at(0.01, 0.09));
        assert!(!g.view().occupied_at(0.11, 0.0));
        assert!(
            g.view().occupied_at(-6.0, 0.0),
            "outside counts as occupied"
        );
        assert!(!g.view().occupied_inside(CellIndex { ix: -1, iy: 0 }));
    }

    #[test]
    fn wrong_cell_count_is_refused() {
        assert!(GridMap::from_cells(0.0, 0.0, 0.1, 3, 3, vec![0; 8]).is_err());
        assert!(GridMap::new_free(0.0, 0.0, 0.0, 1.0, 1.0).is_err());
    }
}
