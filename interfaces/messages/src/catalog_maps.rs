//! The catalogue's grid messages (DESIGN.md section 4): occupancy grids, and the global
//! map's changes between two full maps. Re-exported by `catalog.rs`.

use iceoryx2::prelude::ZeroCopySend;

use crate::common::Header;
use crate::message;

/// Occupancy grids (the local map) of up to 2^21 cells (2 MiB) in any shape, no side
/// longer than `MAX_GRID_SIDE`: a 15 m local map at 20 cells/m is 300 x 300.
pub const MAX_GRID_SIDE: usize = 4096;
pub const MAX_GRID_CELLS: usize = 1 << 21;
/// The global map, a [`GlobalGrid`]: up to 2^24 cells (16 MiB), no side longer than
/// `MAX_GLOBAL_GRID_SIDE`: a 100 x 200 m warehouse at 20 cells/m is 2000 x 4000 (8 M
/// cells), 200 x 200 m at 20 cells/m fits. A sample that large crosses the bus only at
/// start and when the map's changes outgrow a [`MapChanges`]; its pages are touched only
/// as far as the map it holds.
pub const MAX_GLOBAL_GRID_SIDE: usize = 8192;
pub const MAX_GLOBAL_GRID_CELLS: usize = 1 << 24;
/// Cells a [`MapChanges`] lists at most (256 KiB of changes).
pub const MAX_MAP_CHANGES: usize = 1 << 14;

message!(
    /// An occupancy grid: row-major from the origin corner, 0 free, 1 static, 2 detected.
    OccupancyGrid = "aisle.OccupancyGrid.v2" size 2097248 {
        header: Header,
        /// `GridKind` code.
        kind: u32,
        width: u32,
        height: u32,
        _pad: u32,
        origin_x: f64,
        origin_y: f64,
        resolution: f64,
        /// Incremented whenever the detections change (global map).
        version: u64,
        cells: [u8; MAX_GRID_CELLS],
    }
    used |m: &OccupancyGrid| core::mem::offset_of!(OccupancyGrid, cells)
        + (m.width as usize * m.height as usize).min(MAX_GRID_CELLS)
);

message!(
    /// The global map whole: an [`OccupancyGrid`] with room for a warehouse's map at a
    /// fine resolution (`MAX_GLOBAL_GRID_CELLS`). The same fields in the same places; only
    /// the capacity of `cells` differs, so the local map, sent every scan, stays small.
    GlobalGrid = "aisle.GlobalGrid.v1" size 16777312 {
        header: Header,
        /// `GridKind` code.
        kind: u32,
        width: u32,
        height: u32,
        _pad: u32,
        origin_x: f64,
        origin_y: f64,
        resolution: f64,
        /// Incremented whenever the detections change.
        version: u64,
        cells: [u8; MAX_GLOBAL_GRID_CELLS],
    }
    used |m: &GlobalGrid| core::mem::offset_of!(GlobalGrid, cells)
        + (m.width as usize * m.height as usize).min(MAX_GLOBAL_GRID_CELLS)
);

crate::layout_struct!(
    /// One cell of a grid and its value (`OccupancyGrid` codes).
    CellChangeMsg = "aisle.CellChangeMsg.v1" {
        /// Row-major index of the cell in its grid.
        index: u64,
        value: u8,
        _pad: [u8; 7],
    }
);

message!(
    /// The global map as it changed since the full map of `base_version` (the
    /// `aisle/map/global` [`GlobalGrid`] of that version): every cell that changed since then,
    /// once, with its value now (16 bytes a cell). Cumulative, so the newest message alone brings a holder
    /// of that full map to `version`, whatever it missed; when the cells no longer fit,
    /// the mapper publishes a full map again and the changes start from it. So a change of
    /// a few cells crosses the bus as a few cells, not as a copy of the whole map.
    MapChanges = "aisle.MapChanges.v1" size 262224 {
        header: Header,
        /// `version` of the full map these changes apply to.
        base_version: u64,
        /// The map's version with them.
        version: u64,
        /// The full map's shape (a holder checks it against its copy).
        width: u32,
        height: u32,
        /// Entries of `changes` in use.
        len: u32,
        _pad: u32,
        changes: [CellChangeMsg; MAX_MAP_CHANGES],
    }
    used |m: &MapChanges| core::mem::offset_of!(MapChanges, changes)
        + core::mem::size_of::<CellChangeMsg>() * (m.len as usize).min(MAX_MAP_CHANGES)
);
