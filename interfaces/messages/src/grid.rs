//! From an [`OccupancyGrid`] message to what algorithms read: a checked
//! [`GridView`] of the message in place ([`OccupancyGrid::view`]), or an owned
//! [`GridCopy`] a node keeps between messages.
//!
//! Knows the message's fields and `aisle_geometry`'s grid types only; nothing of who
//! publishes the grid or what is planned on it.

use crate::OccupancyGrid;
use aisle_geometry::{GridError, GridView};

/// The first `width x height` cells of `m` (fewer if the message holds fewer).
fn cells_of(m: &OccupancyGrid) -> &[u8] {
    let n = (m.width as usize)
        .saturating_mul(m.height as usize)
        .min(m.cells.len());
    &m.cells[..n]
}

impl OccupancyGrid {
    /// The grid as a view into the message: an error when its resolution is not
    /// positive, it is empty, or `width x height` exceeds the cells it can hold.
    pub fn view(&self) -> Result<GridView<'_>, GridError> {
        GridView::new(
            self.origin_x,
            self.origin_y,
            self.resolution,
            self.width as usize,
            self.height as usize,
            cells_of(self),
        )
    }
}

/// An owned copy of a grid message (geometry and cells), reusing its buffer from one
/// copy to the next. Copies whatever the message holds; [`GridCopy::view`] checks it.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct GridCopy {
    origin: (f64, f64),
    resolution: f64,
    width: usize,
    height: usize,
    cells: Vec<u8>,
}

impl GridCopy {
    /// An empty copy whose buffer already holds `cells` cells (no allocation later).
    pub fn with_capacity(cells: usize) -> GridCopy {
        GridCopy {
            cells: Vec::with_capacity(cells),
            ..GridCopy::default()
        }
    }

    /// Takes `m`'s geometry and its first `width x height` cells.
    pub fn copy_from(&mut self, m: &OccupancyGrid) {
        self.origin = (m.origin_x, m.origin_y);
        self.resolution = m.resolution;
        self.width = m.width as usize;
        self.height = m.height as usize;
        self.cells.clear();
        self.cells.extend_from_slice(cells_of(m));
    }

    /// Takes `other`'s geometry and its cells passed through `f` (a layer of a map,
    /// such as the static cells only).
    pub fn copy_mapped(&mut self, other: &GridCopy, f: impl Fn(u8) -> u8) {
        self.origin = other.origin;
        self.resolution = other.resolution;
        self.width = other.width;
        self.height = other.height;
        self.cells.clear();
        self.cells.extend(other.cells.iter().map(|&c| f(c)));
    }

    /// Passes every cell through `f`, in place.
    pub fn map_in_place(&mut self, f: impl Fn(u8) -> u8) {
        self.cells.iter_mut().for_each(|c| *c = f(*c));
    }

    /// Width and height, as copied (unchecked).
    pub fn shape(&self) -> (usize, usize) {
        (self.width, self.height)
    }

    /// The cells, to write in place (changes of the map they hold).
    pub fn cells_mut(&mut self) -> &mut [u8] {
        &mut self.cells
    }

    /// No cells: nothing was copied yet (or the message held none).
    pub fn is_empty(&self) -> bool {
        self.cells.is_empty()
    }

    /// The copy as a view, checked as [`OccupancyGrid::view`] checks the message.
    pub fn view(&self) -> Result<GridView<'_>, GridError> {
        GridView::new(
            self.origin.0,
            self.origin.1,
            self.resolution,
            self.width,
            self.height,
            &self.cells,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid(width: u32, height: u32) -> Box<OccupancyGrid> {
        let layout = std::alloc::Layout::new::<OccupancyGrid>();
        // SAFETY: all-zero bytes are a valid OccupancyGrid (ZeroedValid), the layout is
        // the type's own, and the allocation is checked before the Box owns it.
        let mut m = unsafe {
            let ptr = std::alloc::alloc_zeroed(layout) as *mut OccupancyGrid;
            assert!(!ptr.is_null());
            Box::from_raw(ptr)
        };
        m.width = width;
        m.height = height;
        m.origin_x = -5.0;
        m.origin_y = -10.0;
        m.resolution = 0.1;
        m.cells[1] = 2;
        m
    }

    #[test]
    fn view_and_copy_agree_and_check_the_grid() {
        let m = grid(3, 2);
        let v = m.view().unwrap();
        assert_eq!((v.width, v.height, v.cells.len()), (3, 2, 6));
        let mut c = GridCopy::with_capacity(16);
        assert!(c.is_empty() && c.view().is_err());
        c.copy_from(&m);
        let w = c.view().unwrap();
        assert_eq!((w.origin_x, w.origin_y, w.resolution), (-5.0, -10.0, 0.1));
        assert_eq!(w.cells, v.cells);
        let mut s = GridCopy::default();
        s.copy_mapped(&c, |x| if x == 2 { 0 } else { x });
        assert_eq!(s.view().unwrap().cells, &[0; 6]);

        assert!(grid(0, 2).view().is_err());
        let mut bad = grid(3, 2);
        bad.resolution = 0.0;
        assert!(bad.view().is_err());
        let huge = grid(u32::MAX, 2);
        assert!(huge.view().is_err());
        c.copy_from(&huge);
        assert!(c.view().is_err());
    }
}
