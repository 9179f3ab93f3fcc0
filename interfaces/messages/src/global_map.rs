//! The global map a subscriber holds, assembled from the two topics it crosses the bus
//! on: the newest full map (`aisle/map/global`, a [`GlobalGrid`]) and the newest
//! changes since it (`aisle/map/global_changes`, a [`MapChanges`]).
//!
//! Both topics keep only their newest sample, and the changes are cumulative since the
//! full map they name, so a holder needs nothing older than the newest of each: a
//! subscriber that joined late, fell behind or restarted is exact again after one read
//! of each. Knows the messages only; nothing of who publishes them or of the bus.

use crate::{GlobalGrid, GridCopy, GridMessage, MapChanges};
use aisle_geometry::{GridError, GridView};

/// The held map: a copy of the newest full map with the newest applicable changes on it.
#[derive(Debug, Clone, Default)]
pub struct GlobalMapCopy {
    grid: GridCopy,
    /// `version` of the full map the copy started from; `None` before the first one.
    base: Option<u64>,
    version: u64,
}

/// What [`GlobalMapCopy::update`] did.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct MapUpdate {
    /// A new full map was copied.
    pub full: bool,
    /// Changes were applied (how many cells they list).
    pub changes: Option<usize>,
    /// The full map given was not a valid grid: left out, the held map kept.
    pub refused: Option<GridError>,
}

impl MapUpdate {
    /// Whether the held map may differ from before.
    pub fn changed(&self) -> bool {
        self.full || self.changes.is_some()
    }
}

/// Changes that name the held full map but cannot be applied to it.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum MapChangesError {
    #[error("changes for a {got_w} x {got_h} map, the full map of their version is {w} x {h}")]
    Shape {
        got_w: u32,
        got_h: u32,
        w: usize,
        h: usize,
    },
    #[error("{len} changes listed, a MapChanges holds at most {max}")]
    TooMany { len: u32, max: usize },
    #[error("change {entry} names cell {index} of a map of {cells} cells")]
    Cell {
        entry: usize,
        index: u64,
        cells: usize,
    },
}

impl GlobalMapCopy {
    /// An empty copy whose buffer already holds `cells` cells (no allocation later).
    pub fn with_capacity(cells: usize) -> GlobalMapCopy {
        GlobalMapCopy {
            grid: GridCopy::with_capacity(cells),
            ..GlobalMapCopy::default()
        }
    }

    /// Takes a full map and changes that newly arrived, either absent when none came
    /// (each message once: what `Io::latest` returns): a full map is copied, whatever
    /// its version (a mapper started afresh counts from 0 again), unless it is not a
    /// valid grid (then it is left out and reported); changes that name the
    /// held full map and are newer than the copy are applied. Changes that name another
    /// full map are left (the full map they need is on its way, or they are older than
    /// it). An error leaves the copy as the full map had it.
    pub fn update(
        &mut self,
        full: Option<&GlobalGrid>,
        changes: Option<&MapChanges>,
    ) -> Result<MapUpdate, MapChangesError> {
        let mut done = MapUpdate::default();
        if let Some(f) = full {
            match f.view() {
                Ok(_) => {
                    self.grid.copy_from(f);
                    self.base = Some(f.version);
                    self.version = f.version;
                    done.full = true;
                }
                Err(e) => done.refused = Some(e),
            }
        }
        if let Some(c) = changes
            && self.base == Some(c.base_version)
            && c.version > self.version
        {
            self.apply(c)?;
            done.changes = Some(c.len as usize);
        }
        Ok(done)
    }

    /// Writes every listed cell, after checking them all.
    fn apply(&mut self, c: &MapChanges) -> Result<(), MapChangesError> {
        let (w, h) = self.grid.shape();
        if (c.width as usize, c.height as usize) != (w, h) {
            return Err(MapChangesError::Shape {
                got_w: c.width,
                got_h: c.height,
                w,
                h,
            });
        }
        let list = c
            .changes
            .get(..c.len as usize)
            .ok_or(MapChangesError::TooMany {
                len: c.len,
                max: c.changes.len(),
            })?;
        let cells = self.grid.cells_mut();
        if let Some((entry, bad)) = list
            .iter()
            .enumerate()
            .find(|(_, e)| e.index >= cells.len() as u64)
        {
            return Err(MapChangesError::Cell {
                entry,
                index: bad.index,
                cells: cells.len(),
            });
        }
        for e in list {
            cells[e.index as usize] = e.value;
        }
        self.version = c.version;
        Ok(())
    }

    /// The held map, checked as [`GridMessage::view`] checks the message.
    pub fn view(&self) -> Result<GridView<'_>, GridError> {
        self.grid.view()
    }

    /// The held map as an owned grid.
    pub fn grid(&self) -> &GridCopy {
        &self.grid
    }

    /// The version of the held map (that of its full map, or of the changes applied).
    pub fn version(&self) -> u64 {
        self.version
    }

    /// The version of the full map the copy started from; `None` before the first.
    pub fn base_version(&self) -> Option<u64> {
        self.base
    }
}

#[cfg(test)]
mod tests;
