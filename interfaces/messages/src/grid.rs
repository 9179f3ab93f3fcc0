//! From a grid message ([`OccupancyGrid`], the local map, or [`GlobalGrid`], the global
//! map: the same fields, different capacities) to what algorithms read: a checked
//! [`GridView`] of the message in place ([`GridMessage::view`]), or an owned
//! [`GridCopy`] a node keeps between messages; and back, a map written into a loaned
//! message ([`GridMessage::write`]).
//!
//! Knows the messages' fields and `aisle_geometry`'s grid types only; nothing of who
//! publishes the grid or what is planned on it.

use crate::{GlobalGrid, Message, OccupancyGrid};
use aisle_geometry::{GridError, GridView};

/// What every grid message holds, whatever its capacity.
pub trait GridMessage: Message {
    /// `GridKind` code.
    fn kind(&self) -> u32;
    /// `width x height` in cells, as the message says (unchecked).
    fn shape(&self) -> (u32, u32);
    /// Origin corner (m) and resolution (m per cell), as the message says.
    fn placement(&self) -> ((f64, f64), f64);
    fn version(&self) -> u64;
    /// Every cell the message can hold.
    fn capacity_cells(&self) -> &[u8];
    /// Writes `map` with its `kind` and `version` (the cells beyond it untouched); a map
    /// of more cells than the message holds is an error, the message left as it was.
    fn write(&mut self, kind: u32, version: u64, map: &GridView<'_>) -> Result<(), GridTooLarge>;

    /// The first `width x height` cells (fewer if the message holds fewer).
    fn cells_in_use(&self) -> &[u8] {
        let (w, h) = self.shape();
        let all = self.capacity_cells();
        &all[..(w as usize).saturating_mul(h as usize).min(all.len())]
    }

    /// The grid as a view into the message: an error when its resolution is not
    /// positive, it is empty, or `width x height` exceeds the cells it can hold.
    fn view(&self) -> Result<GridView<'_>, GridError> {
        let ((x, y), res) = self.placement();
        let (w, h) = self.shape();
        GridView::new(x, y, res, w as usize, h as usize, self.cells_in_use())
    }
}

/// A map [`GridMessage::write`] cannot hold.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("a {width} x {height} map does not fit {type_name}, which holds {capacity} cells")]
pub struct GridTooLarge {
    pub width: usize,
    pub height: usize,
    pub type_name: &'static str,
    pub capacity: usize,
}

/// The same fields in both messages, so one implementation.
macro_rules! grid_message {
    ($($t:ty),*) => {$(
        impl GridMessage for $t {
            fn kind(&self) -> u32 {
                self.kind
            }
            fn shape(&self) -> (u32, u32) {
                (self.width, self.height)
            }
            fn placement(&self) -> ((f64, f64), f64) {
                ((self.origin_x, self.origin_y), self.resolution)
            }
            fn version(&self) -> u64 {
                self.version
            }
            fn capacity_cells(&self) -> &[u8] {
                &self.cells
            }
            fn write(
                &mut self,
                kind: u32,
                version: u64,
                map: &GridView<'_>,
            ) -> Result<(), GridTooLarge> {
                let Some(cells) = self.cells.get_mut(..map.cells.len()) else {
                    return Err(GridTooLarge {
                        width: map.width,
                        height: map.height,
                        type_name: <$t>::TYPE_NAME,
                        capacity: self.cells.len(),
                    });
                };
                cells.copy_from_slice(map.cells);
                self.kind = kind;
                self.width = map.width as u32;
                self.height = map.height as u32;
                self.origin_x = map.origin_x;
                self.origin_y = map.origin_y;
                self.resolution = map.resolution;
                self.version = version;
                Ok(())
            }
        }
    )*};
}
grid_message!(OccupancyGrid, GlobalGrid);

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
    pub fn copy_from(&mut self, m: &impl GridMessage) {
        (self.origin, self.resolution) = m.placement();
        let (w, h) = m.shape();
        (self.width, self.height) = (w as usize, h as usize);
        self.cells.clear();
        self.cells.extend_from_slice(m.cells_in_use());
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

    /// The copy as a view, checked as [`GridMessage::view`] checks the message.
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
        c.copy_from(&*m);
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
        c.copy_from(&*huge);
        assert!(c.view().is_err());
    }

    #[test]
    fn a_map_written_into_either_message_reads_back_the_same() {
        let local = grid(3, 2);
        let map = local.view().unwrap();
        let mut global = crate::zeroed_box::<GlobalGrid>();
        global.write(0, 9, &map).unwrap();
        assert_eq!((global.kind(), global.version()), (0, 9));
        let back = global.view().unwrap();
        assert_eq!((back.width, back.height, back.cells), (3, 2, map.cells));
        assert_eq!(
            (back.origin_x, back.origin_y, back.resolution),
            (-5.0, -10.0, 0.1)
        );
        // What the local map cannot hold, the global one can.
        let (w, h) = (4000u32, 2000u32);
        let cells = vec![1u8; (w * h) as usize];
        let wide = GridView::new(0.0, 0.0, 0.05, w as usize, h as usize, &cells).unwrap();
        assert!(wide.cells.len() > crate::MAX_GRID_CELLS);
        global.write(0, 10, &wide).unwrap();
        let mut local = crate::zeroed_box::<OccupancyGrid>();
        let e = local.write(1, 3, &wide).unwrap_err();
        assert_eq!((e.width, e.capacity), (4000, crate::MAX_GRID_CELLS));
        assert_eq!((local.width, local.version), (0, 0), "left as it was");
        assert_eq!(global.view().unwrap().cells.len(), (w * h) as usize);
        assert_eq!(global.used_len(), 96 + (w * h) as usize);
        (global.width, global.height) = (8192, 4096);
        assert!(global.view().is_err(), "more cells than it holds");
    }
}
