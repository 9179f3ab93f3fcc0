//! The search's state table: which node holds each (search cell, heading bin) state,
//! stored in tiles of 8 x 8 cells (all their bins) allocated when the search first
//! touches them, so that its memory and its clearing cost follow the search, not the
//! map (100 x 200 m at 0.1 m and 72 bins would be 144 M states, 576 MB dense).
//!
//! A state number holds its tile in the high bits and its place in the tile in the low
//! ones, so a lookup is two array reads. Knows nothing of poses or costs.

use aisle_geometry::{GridView, Pose2};

/// No node (an empty slot).
pub(crate) const NONE: u32 = u32::MAX;
const TILE_SHIFT: usize = 3;
const TILE_MASK: usize = (1 << TILE_SHIFT) - 1;

/// Geometry of the search cells over the map's extent, and the numbering of states.
pub(crate) struct SearchGrid {
    origin_x: f64,
    origin_y: f64,
    cell: f64,
    nx: usize,
    ny: usize,
    bins: usize,
    tiles_x: usize,
    /// Bits of a state that number it within its tile.
    local_bits: u32,
}

impl SearchGrid {
    /// `None` when the states of this map do not fit in 32-bit numbers.
    pub(crate) fn new(map: &GridView, cell: f64, bins: u32) -> Option<Self> {
        let (x0, y0, x1, y1) = map.bounds();
        let nx = ((x1 - x0) / cell).ceil() as usize;
        let ny = ((y1 - y0) / cell).ceil() as usize;
        let tiles_x = nx.div_ceil(1 << TILE_SHIFT);
        let tiles = tiles_x as u64 * ny.div_ceil(1 << TILE_SHIFT) as u64;
        let per_tile = (1u64 << (2 * TILE_SHIFT)) * u64::from(bins);
        let local_bits = 64 - (per_tile - 1).leading_zeros();
        (tiles.checked_shl(local_bits)? <= 1 << 32).then_some(Self {
            origin_x: x0,
            origin_y: y0,
            cell,
            nx,
            ny,
            bins: bins as usize,
            tiles_x,
            local_bits,
        })
    }

    /// The state of pose `p` in heading bin `bin`, if its cell is on the grid.
    #[inline]
    pub(crate) fn state(&self, p: &Pose2, bin: u32) -> Option<u32> {
        let fx = ((p.x - self.origin_x) / self.cell).floor();
        let fy = ((p.y - self.origin_y) / self.cell).floor();
        if fx < 0.0 || fy < 0.0 || fx >= self.nx as f64 || fy >= self.ny as f64 {
            return None;
        }
        let (ix, iy) = (fx as usize, fy as usize);
        let tile = (iy >> TILE_SHIFT) * self.tiles_x + (ix >> TILE_SHIFT);
        let local = (((iy & TILE_MASK) << TILE_SHIFT) | (ix & TILE_MASK)) * self.bins;
        Some(((tile << self.local_bits) | (local + bin as usize)) as u32)
    }
}

/// State number to node index, tile by tile.
#[derive(Debug, Default)]
pub(crate) struct StateTable {
    local_bits: u32,
    /// Per tile: its slot in `slots`, or [`NONE`].
    index: Vec<u32>,
    /// Tile storage, kept between requests; `slots[..used]` are in use.
    slots: Vec<Box<[u32]>>,
    used: usize,
    /// Tiles given a slot in this request.
    touched: Vec<u32>,
}

impl StateTable {
    /// Empties the table for `grid`. Every state set since the last reset must have been
    /// set back to [`NONE`] (the caller does it for its nodes): the slots are then
    /// empty and only handed back.
    pub(crate) fn reset(&mut self, grid: &SearchGrid) {
        for &t in &self.touched {
            self.index[t as usize] = NONE;
        }
        self.touched.clear();
        self.used = 0;
        let tiles = (grid.nx.div_ceil(1 << TILE_SHIFT)) * grid.ny.div_ceil(1 << TILE_SHIFT);
        if self.index.len() < tiles {
            self.index.resize(tiles, NONE);
        }
        if self.local_bits != grid.local_bits {
            self.slots.clear();
            self.local_bits = grid.local_bits;
        }
    }

    /// Makes `tiles` tile slots for `grid` ahead of any search (touched, so resident):
    /// the slots a search takes are then ones already made. Right after a reset only.
    pub(crate) fn warm(&mut self, grid: &SearchGrid, tiles: usize) {
        self.reset(grid);
        while self.slots.len() < tiles {
            self.slots
                .push(vec![NONE; 1 << self.local_bits].into_boxed_slice());
        }
    }

    #[inline]
    pub(crate) fn get(&self, state: u32) -> u32 {
        let slot = self.index[(state >> self.local_bits) as usize];
        if slot == NONE {
            return NONE;
        }
        self.slots[slot as usize][(state & ((1 << self.local_bits) - 1)) as usize]
    }

    #[inline]
    pub(crate) fn set(&mut self, state: u32, node: u32) {
        let t = (state >> self.local_bits) as usize;
        let mut slot = self.index[t];
        if slot == NONE {
            slot = self.take_slot(t);
        }
        self.slots[slot as usize][(state & ((1 << self.local_bits) - 1)) as usize] = node;
    }

    #[cold]
    fn take_slot(&mut self, t: usize) -> u32 {
        if self.used == self.slots.len() {
            self.slots
                .push(vec![NONE; 1 << self.local_bits].into_boxed_slice());
        }
        let slot = self.used as u32;
        self.used += 1;
        self.index[t] = slot;
        self.touched.push(t as u32);
        slot
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use aisle_geometry::GridMap;
    use std::collections::HashMap;

    /// The table against a hash map over random poses, across resets, and its tiles
    /// follow what was touched, not the map.
    #[test]
    fn table_matches_a_map_and_stays_sparse() {
        let map = GridMap::new_free(-3.0, 1.0, 0.05, 100.0, 200.0).unwrap();
        let grid = SearchGrid::new(&map.view(), 0.1, 72).unwrap();
        let mut table = StateTable::default();
        let mut seed = 0x2545_f491_4f6c_dd1d_u64;
        let mut next = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        for round in 0..3 {
            table.reset(&grid);
            let mut reference: HashMap<u32, u32> = HashMap::new();
            // Poses in a 10 x 10 m patch somewhere on the map.
            let (cx, cy) = (-3.0 + 90.0 * next(), 1.0 + 190.0 * next());
            for i in 0..20_000u32 {
                let p = Pose2::new(cx + 10.0 * next(), cy + 10.0 * next(), 0.0);
                let bin = (72.0 * next()) as u32;
                let Some(s) = grid.state(&p, bin) else {
                    continue;
                };
                assert_eq!(table.get(s), reference.get(&s).copied().unwrap_or(NONE));
                if i % 3 != 0 {
                    table.set(s, i);
                    reference.insert(s, i);
                }
            }
            // 10 x 10 m: at most 14 x 14 tiles of 0.8 m, of 31,250 on the map.
            assert!(table.used <= 196, "round {round}: {}", table.used);
            for &s in reference.keys() {
                table.set(s, NONE);
            }
        }
        assert!(
            SearchGrid::new(&map.view(), 0.001, 720).is_none(),
            "too many states"
        );
    }
}
