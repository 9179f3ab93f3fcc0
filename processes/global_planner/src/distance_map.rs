//! Per-map lookup tables for fast collision checks: the Euclidean distance from every
//! cell centre to the nearest occupied cell centre (space outside the grid counts as
//! occupied), capped at [`DIST_CAP`], kept in square tiles of [`TILE`] cells that are
//! computed when first read (`dist_tiles.rs` has the arithmetic), and the planner's copy
//! of the cells (for exact footprint scans).
//!
//! Nothing here is proportional to the map per request: a tile costs its own cells and
//! those within the cap around it (read once per column strip, through the cached
//! vertical pass), and only the tiles a search reads are computed. Unless
//! `force_lazy` is set (the planner sets it), maps of at most [`EAGER_CELLS`] are filled
//! whole on a rebuild (one transform over the grid; the planner's tests' reference).
//! A map that differs in a few cells (the
//! mapper's detections between two requests) drops the tiles within the cap of them, to
//! be computed again when read; every value read is bit for bit that of a whole-grid
//! transform of the current cells. It also holds the memo of motion checks made on
//! these cells (`motion_cache.rs`), whose entries a change drops where it can reach
//! them. Knows nothing of footprints or search.

use crate::dist_tiles::{self, Cells, Envelope, FAR};
use crate::motion_cache::MotionCache;
use aisle_geometry::GridView;
use std::cell::{Cell, OnceCell, RefCell};

/// Distances are kept up to this many metres; farther is stored as this. Queries
/// compare them with a body's radius plus its margin (all far below), and the collision
/// checker skips along a motion by the clearance beyond the body: at 8 m that skip is
/// never the limit on the test and seed queries (their outputs and probe counts are those
/// of uncapped tables), while a 4 m cap made the warm seed benchmark up to 28 % slower.
pub(crate) const DIST_CAP: f64 = 8.0;

/// Cells per tile side, as a shift.
const TILE_SHIFT: usize = 6;
/// Cells per tile side.
pub(crate) const TILE: usize = 1 << TILE_SHIFT;
const MASK: usize = TILE - 1;
// A row of a tile's occupancy is one u64.
const _: () = assert!(TILE == 64);

/// Maps of at most this many cells are filled whole on a rebuild unless `force_lazy`.
pub(crate) const EAGER_CELLS: usize = 1 << 20;

/// Changes remembered for derived tables (`changes_since`).
const CHANGE_LOG: usize = 64;

/// A window of the grid, in cells: columns `x0..x1`, rows `y0..y1`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Window {
    pub x0: usize,
    pub y0: usize,
    pub x1: usize,
    pub y1: usize,
}

impl Window {
    fn area(&self) -> usize {
        (self.x1 - self.x0) * (self.y1 - self.y0)
    }

    /// Grown by `bx` cells left and right and `by` up and down, clipped to `w` x `h`.
    pub(crate) fn grown(&self, bx: usize, by: usize, w: usize, h: usize) -> Window {
        Window {
            x0: self.x0.saturating_sub(bx),
            y0: self.y0.saturating_sub(by),
            x1: (self.x1 + bx).min(w),
            y1: (self.y1 + by).min(h),
        }
    }
}

type Tiles<T> = Vec<OnceCell<Box<[T]>>>;

#[derive(Debug, Default)]
pub(crate) struct DistanceMap {
    pub origin_x: f64,
    pub origin_y: f64,
    pub resolution: f64,
    pub width: usize,
    pub height: usize,
    cells: Vec<u8>,
    tiles_x: usize,
    /// The cap in cells, plus one: the farthest cell that can bring a distance under it.
    reach: usize,
    /// Per tile: vertical distances of its cells (`dist_tiles::vertical`).
    vert: Tiles<u32>,
    /// Per tile: one word per row, a bit per occupied cell (column `x & 63`).
    bits: Tiles<u64>,
    /// Per tile: metres from each cell centre to the nearest occupied (or outside) cell
    /// centre, at most [`DIST_CAP`].
    dist: Tiles<f32>,
    envelope: RefCell<Envelope>,
    /// Counts rebuilds and updates, so that tables derived from this one know when to
    /// refresh.
    pub generation: u64,
    /// (generation, window whose distances it changed) of the last updates.
    /// Per change: its generation, the window whose distances changed, and the window
    /// of the cells that changed.
    changes: Vec<(u64, Window, Window)>,
    /// Cells the last change invalidated (the whole grid on a rebuild), for diagnostics.
    pub last_recomputed: usize,
    /// Distance tiles computed since the last rebuild, for diagnostics.
    pub tiles_computed: Cell<usize>,
    /// Never fill the whole grid at once, whatever its size (tests).
    pub force_lazy: bool,
    /// Whether the last rebuild filled every tile (a small map).
    pub filled_whole: bool,
    /// Motion checks made on these cells (`motion_cache.rs`).
    pub motions: RefCell<MotionCache>,
}

impl DistanceMap {
    /// Brings the tables to this map: nothing when they already describe it, the tiles
    /// near the changed cells dropped when only cells changed, else a rebuild. Returns
    /// true when anything changed.
    pub fn ensure(&mut self, map: &GridView) -> bool {
        let same_grid = self.width == map.width
            && self.height == map.height
            && self.origin_x.to_bits() == map.origin_x.to_bits()
            && self.origin_y.to_bits() == map.origin_y.to_bits()
            && self.resolution.to_bits() == map.resolution.to_bits()
            && self.cells.len() == map.cells.len();
        if !same_grid {
            self.rebuild(map);
            return true;
        }
        let Some(changed) = self.changed_cells(map) else {
            return false;
        };
        self.generation += 1;
        let (w, h, r) = (self.width, self.height, self.reach);
        for y in changed.y0..changed.y1 {
            let row = y * w..(y + 1) * w;
            self.cells[row.clone()].copy_from_slice(&map.cells[row]);
        }
        // A vertical distance reads its own column `reach` rows either way; a distance,
        // the cells within `reach` on both axes.
        drop_tiles(&mut self.vert, self.tiles_x, changed.grown(0, r, w, h));
        drop_tiles(&mut self.bits, self.tiles_x, changed);
        let dists = changed.grown(r, r, w, h);
        drop_tiles(&mut self.dist, self.tiles_x, dists);
        self.motions.get_mut().invalidate(changed);
        if self.changes.len() == CHANGE_LOG {
            self.changes.remove(0);
        }
        self.changes.push((self.generation, dists, changed));
        self.last_recomputed = dists.area();
        true
    }

    /// The windows whose distances changed after generation `seen`, oldest first;
    /// `None` when that is not known (a rebuild since, or too long ago).
    pub fn changes_since(&self, seen: u64) -> Option<impl Iterator<Item = Window> + '_> {
        Some(self.logged_since(seen)?.map(|c| c.1))
    }

    /// The windows of the cells that changed after generation `seen`, as
    /// [`DistanceMap::changes_since`].
    pub fn cell_changes_since(&self, seen: u64) -> Option<impl Iterator<Item = Window> + '_> {
        Some(self.logged_since(seen)?.map(|c| c.2))
    }

    fn logged_since(&self, seen: u64) -> Option<impl Iterator<Item = &(u64, Window, Window)>> {
        let first = self.changes.first()?.0;
        (seen + 1 >= first && seen <= self.generation)
            .then(|| self.changes.iter().filter(move |c| c.0 > seen))
    }

    /// The rows and columns where `map` differs from the kept cells, if anywhere.
    fn changed_cells(&self, map: &GridView) -> Option<Window> {
        let w = map.width;
        let mut win: Option<Window> = None;
        for (y, (old, new)) in self
            .cells
            .chunks_exact(w)
            .zip(map.cells.chunks_exact(w))
            .enumerate()
        {
            if old == new {
                continue;
            }
            let first = old.iter().zip(new).position(|(a, b)| a != b).unwrap_or(0);
            let last = w - old
                .iter()
                .zip(new)
                .rev()
                .position(|(a, b)| a != b)
                .unwrap_or(0);
            win = Some(match win {
                None => Window {
                    x0: first,
                    y0: y,
                    x1: last,
                    y1: y + 1,
                },
                Some(v) => Window {
                    x0: v.x0.min(first),
                    y0: v.y0,
                    x1: v.x1.max(last),
                    y1: y + 1,
                },
            });
        }
        win
    }

    fn rebuild(&mut self, map: &GridView) {
        self.generation += 1;
        self.changes.clear();
        self.origin_x = map.origin_x;
        self.origin_y = map.origin_y;
        self.resolution = map.resolution;
        self.width = map.width;
        self.height = map.height;
        self.reach = (DIST_CAP / map.resolution).ceil() as usize + 1;
        self.cells.clear();
        self.cells.extend_from_slice(map.cells);
        let (w, h) = (map.width, map.height);
        self.tiles_x = w.div_ceil(TILE);
        let n = self.tiles_x * h.div_ceil(TILE);
        self.vert.clear();
        self.vert.resize_with(n, OnceCell::new);
        self.bits.clear();
        self.bits.resize_with(n, OnceCell::new);
        self.dist.clear();
        self.dist.resize_with(n, OnceCell::new);
        self.tiles_computed.set(0);
        self.motions.get_mut().clear();
        self.last_recomputed = w * h;
        self.filled_whole = w * h <= EAGER_CELLS && !self.force_lazy;
        if self.filled_whole {
            let all = dist_tiles::whole_grid(self.grid(), self.resolution, DIST_CAP);
            for (t, slot) in self.dist.iter().enumerate() {
                let (x0, x1, y0, y1) = self.tile_bounds(t);
                let mut tile = vec![0.0f32; TILE * TILE].into_boxed_slice();
                for y in y0..y1 {
                    let o = (y - y0) * TILE;
                    tile[o..o + x1 - x0].copy_from_slice(&all[y * w + x0..y * w + x1]);
                }
                // Freshly emptied above: the cell takes the tile.
                let _ = slot.set(tile);
            }
        }
    }

    fn grid(&self) -> Cells<'_> {
        Cells {
            cells: &self.cells,
            w: self.width,
            h: self.height,
        }
    }

    /// Columns `x0..x1` and rows `y0..y1` of tile `t`.
    fn tile_bounds(&self, t: usize) -> (usize, usize, usize, usize) {
        let (tx, ty) = (t % self.tiles_x, t / self.tiles_x);
        let (x0, y0) = (tx * TILE, ty * TILE);
        (
            x0,
            (x0 + TILE).min(self.width),
            y0,
            (y0 + TILE).min(self.height),
        )
    }

    /// The capped distance (m) at cell (`cx`, `cy`), which must be inside the grid.
    #[inline]
    pub fn dist_at(&self, cx: usize, cy: usize) -> f32 {
        let t = (cy >> TILE_SHIFT) * self.tiles_x + (cx >> TILE_SHIFT);
        let tile = match self.dist[t].get() {
            Some(tile) => tile,
            None => self.fill_dist(t),
        };
        tile[((cy & MASK) << TILE_SHIFT) | (cx & MASK)]
    }

    #[cold]
    #[inline(never)]
    fn fill_dist(&self, t: usize) -> &[f32] {
        let (x0, x1, y0, y1) = self.tile_bounds(t);
        let r = self.reach;
        let (cx0, cx1) = (x0.saturating_sub(r), (x1 + r).min(self.width));
        let ty = t / self.tiles_x;
        let vert: Vec<&[u32]> = (cx0 >> TILE_SHIFT..=(cx1 - 1) >> TILE_SHIFT)
            .map(|tx| self.vert_tile(ty * self.tiles_x + tx))
            .collect();
        let first_tile = cx0 >> TILE_SHIFT;
        let mut tile = vec![0.0f32; TILE * TILE].into_boxed_slice();
        let mut env = self.envelope.borrow_mut();
        for y in y0..y1 {
            let row = (y - y0) << TILE_SHIFT;
            env.clear();
            if cx0 == 0 {
                env.push(-1, 0);
            }
            for x in cx0..cx1 {
                let v = vert[(x >> TILE_SHIFT) - first_tile];
                env.push(x as isize, v[row | (x & MASK)]);
            }
            if cx1 == self.width {
                env.push(self.width as isize, 0);
            }
            env.eval(x0, self.resolution, DIST_CAP, &mut tile[row..row + x1 - x0]);
        }
        self.tiles_computed.set(self.tiles_computed.get() + 1);
        self.dist[t].get_or_init(|| tile)
    }

    fn vert_tile(&self, t: usize) -> &[u32] {
        self.vert[t].get_or_init(|| {
            let mut tile = vec![FAR; TILE * TILE].into_boxed_slice();
            let tx = t % self.tiles_x;
            let word = |y: usize| self.bits_tile((y >> TILE_SHIFT) * self.tiles_x + tx)[y & MASK];
            dist_tiles::vertical(
                self.grid(),
                word,
                self.reach,
                self.tile_bounds(t),
                &mut tile,
                TILE,
            );
            tile
        })
    }

    #[inline]
    fn bits_tile(&self, t: usize) -> &[u64] {
        match self.bits[t].get() {
            Some(tile) => tile,
            None => self.fill_bits(t),
        }
    }

    /// The cell holding a world point, if inside the grid.
    #[inline]
    pub fn cell(&self, x: f64, y: f64) -> Option<(usize, usize)> {
        // Truncation is the floor for the non-negative values accepted here (and avoids a
        // libm call on the collision checker's hottest path); NaN fails the tests.
        let fx = (x - self.origin_x) / self.resolution;
        let fy = (y - self.origin_y) / self.resolution;
        if fx >= 0.0 && fy >= 0.0 && fx < self.width as f64 && fy < self.height as f64 {
            Some((fx as usize, fy as usize))
        } else {
            None
        }
    }

    /// Whether any cell in columns `c0..=c1` of `row` (both inside the grid) is occupied.
    #[inline]
    pub fn occupied_in_row(&self, row: usize, c0: usize, c1: usize) -> bool {
        let (r, first, last) = (row & MASK, c0 >> TILE_SHIFT, c1 >> TILE_SHIFT);
        let base = (row >> TILE_SHIFT) * self.tiles_x;
        (first..=last).any(|tx| {
            let tile = self.bits_tile(base + tx);
            let lo = if tx == first { c0 & MASK } else { 0 };
            let hi = if tx == last { c1 & MASK } else { MASK };
            tile[r] & (u64::MAX >> (MASK - hi)) & (u64::MAX << lo) != 0
        })
    }

    /// The occupancy bits of row `y`, columns `64 t..64 t + 64` (bit x: column
    /// `64 t + x`), with everything outside the grid occupied.
    #[inline]
    pub fn row_word(&self, y: isize, t: isize) -> u64 {
        if y < 0 || t < 0 || y as usize >= self.height || t as usize >= self.tiles_x {
            return u64::MAX;
        }
        let (y, t) = (y as usize, t as usize);
        let tile = (y >> TILE_SHIFT) * self.tiles_x + t;
        let bits = self.bits_tile(tile);
        let inside = self.width - t * TILE;
        let outside = if inside >= TILE {
            0
        } else {
            u64::MAX << inside
        };
        bits[y & MASK] | outside
    }

    #[cold]
    #[inline(never)]
    fn fill_bits(&self, t: usize) -> &[u64] {
        let (x0, x1, y0, y1) = self.tile_bounds(t);
        let mut tile = vec![0u64; TILE].into_boxed_slice();
        for (y, word) in (y0..y1).zip(tile.iter_mut()) {
            *word =
                dist_tiles::occupancy_word(&self.cells[y * self.width + x0..y * self.width + x1]);
        }
        self.bits[t].get_or_init(|| tile)
    }
}

/// Empties the tiles of `tiles` (`tiles_x` per row) that meet window `win`.
fn drop_tiles<T>(tiles: &mut Tiles<T>, tiles_x: usize, win: Window) {
    if win.area() == 0 {
        return;
    }
    for ty in win.y0 >> TILE_SHIFT..=(win.y1 - 1) >> TILE_SHIFT {
        for tx in win.x0 >> TILE_SHIFT..=(win.x1 - 1) >> TILE_SHIFT {
            tiles[ty * tiles_x + tx].take();
        }
    }
}

#[cfg(test)]
mod tests;
