//! The obstacle-aware part of the search heuristic: the 8-connected grid distance from
//! the goal to a cell, on a grid that may be coarser than the map, found by a backward
//! search from the goal that runs only as far as the queries need.
//!
//! A coarse cell is blocked only when every map cell in it is certainly blocked for the
//! robot's centre (an occupied cell's square reaches into the inscribed circle of any
//! pose there), so a free continuous path always maps to a connected chain of unblocked
//! cells: "unreached from the goal" proves that no path exists. Steps cost 5 (side) and
//! 7 (diagonal). That underestimates a diagonal, but a direction between the axes and
//! the diagonals takes a staircase of both, up to [`GRID_OVERESTIMATE`] times the
//! straight line (7.7 % at atan 0.4 = 21.8 deg): an estimate the search orders nodes by,
//! not a lower bound. Plain A*'s cost bound (`search.rs`) allows for that factor.
//!
//! The backward search is an A* from the goal towards the request's start (octile
//! distance in the same units, consistent), in buckets of equal f (Nature of Dial's
//! algorithm: f grows by at most 14 per step). A consistent heuristic makes every closed
//! cell's distance exact, so a query returns the same value as a search over the whole
//! map: when its cell is not closed yet, the search resumes until it is (or until the
//! queue runs dry, which proves the cell unreachable). A request to the same goal cell
//! on the same map and body resumes the last request's search rather than starting
//! again (replans along a leg, repeated requests): its closed distances are as exact for
//! any start. The planner's eager reference searches a small map whole at once
//! (`eager`, plain Dijkstra), which also counts the cells the goal can be reached from. One array holds, per cell, blocked, not decided yet, or the distance of this
//! request (untouched: unreached), so that a neighbour costs one comparison; blocked
//! flags are kept between requests and dropped where the distance map changed, and only
//! the cells a request touched are reset. Knows nothing of headings or motions.

use crate::blocked::Disk;
use crate::distance_map::DistanceMap;
use coarse::Coarse;
use std::cmp::Reverse;
use std::collections::BinaryHeap;

const SIDE: u32 = 5;
const DIAG: u32 = 7;
/// The most by which the grid distance (sides of 5, diagonals of 7) exceeds the straight
/// line: sqrt(1 + (7/5 - 1)^2), where a path climbs 2 cells in 5.
pub(crate) const GRID_OVERESTIMATE: f64 = 1.077_032_961_426_900_8;
const RING: usize = 16;
/// Values of `g` besides a distance plus one: blocked (below any distance, so a
/// neighbour test skips it), free but not reached in this request, and not decided.
const BLOCKED: u32 = 0;
const UNREACHED: u32 = u32::MAX - 1;
const UNKNOWN: u32 = u32::MAX;
/// Reached before a repair, which took its distance away (`incremental.rs`): unreached,
/// but already listed in `touched`, so that reaching it again does not list it twice.
const FORGOTTEN: u32 = u32::MAX - 2;

#[derive(Debug, Default)]
pub(crate) struct GridHeuristic {
    /// Coarse grid size without the border.
    width: usize,
    height: usize,
    /// Row stride of the padded arrays: one blocked cell on every side, so that the
    /// search needs no bounds checks.
    stride: usize,
    origin_x: f64,
    origin_y: f64,
    cell: f64,
    /// Map cells per coarse cell side.
    factor: usize,
    limit: f64,
    /// (map geometry, inscribed radius bits, factor) that the blocked flags are for,
    /// and the distance map generation they have seen.
    key: Option<([u64; 5], u64, usize)>,
    /// The occupancy disk for `limit` on this map (`blocked.rs`).
    disk: Option<Disk>,
    seen_generation: u64,
    /// Per padded cell: [`BLOCKED`], [`UNREACHED`], [`UNKNOWN`] or distance + 1.
    g: Vec<u32>,
    closed: Vec<bool>,
    /// Cells given a distance in this request.
    touched: Vec<u32>,
    /// Open entries (cell << 32 | g) by f modulo the ring.
    buckets: [Vec<u64>; RING],
    /// Open entries by f whose f is too far ahead for the ring (only after a repair,
    /// whose frontier spans many levels); fed to the ring as the level nears them.
    deferred: BinaryHeap<Reverse<(u32, u64)>>,
    /// A repair's scratch: coarse cells re-decided, with their values before, and the
    /// cells it made unreached again (forgotten or freed).
    redecided: Vec<(usize, u32)>,
    reopened: Vec<u32>,
    /// An in-place repair's scratch (`incremental.rs`): cells by distance, and the cells
    /// whose distance it took away.
    repair_heap: BinaryHeap<Reverse<(u32, u32)>>,
    affected: Vec<u32>,
    /// Repairs done in place (tests: that the path under test ran).
    #[cfg(test)]
    in_place: usize,
    level: u32,
    pending: usize,
    /// Coarse cell of the start (the A* target); `None`: Dijkstra.
    target: Option<(usize, usize)>,
    /// Whether the last request searched everything reachable (its cells are reset by
    /// a pass over the grid, not from `touched`).
    eager_last: bool,
    /// The goal cell of the lazy search the tables hold (`None`: none to resume).
    lazy_goal: Option<usize>,
    /// Cells closed by the search the tables hold (a resumed search counts on).
    pub settled: u32,
}

impl GridHeuristic {
    /// Starts the search from `goal` for a robot whose inscribed radius (margin included)
    /// is `r_in`, on cells of about `cell_size` metres (a whole multiple of the map
    /// resolution), aimed at `start`; `eager` runs it over everything reachable at once.
    /// Returns false when the goal's own cell is blocked or off the grid.
    pub fn begin(
        &mut self,
        dm: &DistanceMap,
        r_in: f64,
        cell_size: f64,
        (goal, start): ((f64, f64), (f64, f64)),
        eager: bool,
    ) -> bool {
        let f = ((cell_size / dm.resolution).round() as usize).max(1);
        if !eager && self.continuable(dm, r_in, f, goal) {
            return self.continue_search(dm, start);
        }
        self.lazy_goal = None;
        if self.eager_last {
            // After a search over everything reachable, a pass is cheaper than a list
            // (and it closed nothing: `closed` is for lazy searches, whose closed cells
            // are all touched).
            for g in &mut self.g {
                let reached = (*g != BLOCKED) & (*g < UNREACHED);
                *g = if reached { UNREACHED } else { *g };
            }
        }
        for &c in &self.touched {
            // A repair may have blocked a cell it had reached.
            if self.g[c as usize] != BLOCKED {
                self.g[c as usize] = UNREACHED;
            }
            self.closed[c as usize] = false;
        }
        self.touched.clear();
        self.refresh_blocked(dm, r_in, f);
        for b in &mut self.buckets {
            b.clear();
        }
        self.deferred.clear();
        (self.settled, self.level, self.pending) = (0, 0, 0);
        self.eager_last = eager;
        self.target = (!eager).then(|| self.target_of(start));
        let Some(gi) = self.index_of(goal.0, goal.1) else {
            return false;
        };
        if self.is_blocked(dm, gi) {
            return false;
        }
        self.g[gi] = 1;
        if !eager {
            self.touched.push(gi as u32);
            self.lazy_goal = Some(gi);
        }
        self.level = 1 + self.h(gi);
        self.buckets[self.level as usize % RING].push(((gi as u64) << 32) | 1);
        self.pending = 1;
        if eager {
            self.run::<false>(dm, None);
        }
        true
    }

    /// Sizes and touches its tables for `dm` with cells of about `cell_size` metres before
    /// its first request (the body is not known yet: the first `begin` fills them).
    /// Nothing once it has served a request.
    pub fn warm(&mut self, dm: &DistanceMap, cell_size: f64) {
        if self.key.is_some() {
            return;
        }
        let f = ((cell_size / dm.resolution).round() as usize).max(1);
        let n = (dm.width.div_ceil(f) + 2) * (dm.height.div_ceil(f) + 2);
        self.g.resize(n, BLOCKED);
        self.g.clear();
        self.closed.resize(n, false);
        self.closed.clear();
        self.touched.reserve(n);
    }

    /// The most by which [`GridHeuristic::metres`] may exceed a real path's length: it
    /// measures between cell centres, and each end may lie half a diagonal away.
    pub fn quantisation(&self) -> f64 {
        self.cell * std::f64::consts::SQRT_2
    }

    /// Whether its blocked cells are for a body of inscribed radius `r_in`.
    pub fn serves(&self, r_in: f64) -> bool {
        self.key.is_some_and(|k| k.1 == r_in.to_bits())
    }

    /// Runs the search over everything reachable from the goal; `settled` then counts
    /// those cells.
    pub fn complete(&mut self, dm: &DistanceMap) {
        if !self.eager_last {
            self.run::<true>(dm, None);
        }
    }

    /// Grid distance in metres from the goal, or `None` when the goal cannot be reached.
    #[inline]
    pub fn metres(&mut self, dm: &DistanceMap, x: f64, y: f64) -> Option<f64> {
        let i = self.index_of(x, y)?;
        let g = self.g[i];
        // After a search over everything, every cell reached is closed.
        let closed = if self.eager_last {
            g != BLOCKED && g < UNREACHED
        } else {
            self.closed[i]
        };
        if !closed && (self.eager_last || self.is_blocked(dm, i) || !self.run::<true>(dm, Some(i)))
        {
            return None;
        }
        Some(f64::from(self.g[i] - 1) * self.cell / f64::from(SIDE))
    }

    /// Octile distance (in steps of 5 and 7) from padded cell `i` to the target.
    #[inline]
    fn h(&self, i: usize) -> u32 {
        octile(self.target, self.stride, i)
    }

    /// Expands cells in order of f until `until` is closed (true) or nothing is left
    /// (false). `LAZY`: towards the target, noting closed and touched cells (else a
    /// plain Dijkstra over everything, reset by a pass).
    fn run<const LAZY: bool>(&mut self, dm: &DistanceMap, until: Option<usize>) -> bool {
        let st = self.stride;
        let coarse = Coarse {
            stride: self.stride,
            width: self.width,
            factor: self.factor,
            limit: self.limit,
            disk: self.disk.as_ref(),
        };
        let target = self.target;
        let (g, closed) = (&mut self.g[..], &mut self.closed[..]);
        let (buckets, touched) = (&mut self.buckets, &mut self.touched);
        let deferred = &mut self.deferred;
        let (mut level, mut pending, mut settled) = (self.level, self.pending, self.settled);
        let mut found = false;
        let mut open = Open {
            g,
            buckets,
            touched,
            coarse,
            dm,
            target,
        };
        'levels: while pending > 0 || !deferred.is_empty() {
            if pending == 0
                && let Some(&Reverse((f, _))) = deferred.peek()
            {
                level = level.max(f);
            }
            while let Some(&Reverse((f, entry))) = deferred.peek() {
                if f >= level + RING as u32 {
                    break;
                }
                deferred.pop();
                open.buckets[f as usize % RING].push(entry);
                pending += 1;
            }
            let slot = level as usize % RING;
            while let Some(entry) = open.buckets[slot].pop() {
                pending -= 1;
                let (c, gc) = ((entry >> 32) as usize, entry as u32);
                // Superseded by a shorter distance: stale. (A closed cell is never
                // queued again: its distance is the shortest.)
                if open.g[c] != gc {
                    continue;
                }
                if LAZY {
                    closed[c] = true;
                }
                settled += 1;
                // Closed cells are never on the border, so every neighbour exists;
                // border cells are blocked.
                let (side, diag) = (gc + SIDE, gc + DIAG);
                pending += open.relax::<LAZY>(c + 1, side)
                    + open.relax::<LAZY>(c - 1, side)
                    + open.relax::<LAZY>(c + st, side)
                    + open.relax::<LAZY>(c - st, side)
                    + open.relax::<LAZY>(c + st + 1, diag)
                    + open.relax::<LAZY>(c + st - 1, diag)
                    + open.relax::<LAZY>(c - st + 1, diag)
                    + open.relax::<LAZY>(c - st - 1, diag);
                if LAZY && until == Some(c) {
                    found = true;
                    break 'levels;
                }
            }
            level += 1;
        }
        (self.level, self.pending, self.settled) = (level, pending, settled);
        found
    }

    /// Whether padded cell `i` is blocked, deciding it from the distance map if not known.
    #[inline]
    fn is_blocked(&mut self, dm: &DistanceMap, i: usize) -> bool {
        match self.g[i] {
            UNKNOWN => self.decide(dm, i),
            v => v == BLOCKED,
        }
    }

    /// Decides padded cell `i` (and the undecided cells of its row in the same 64 map
    /// columns) from the map; whether it is blocked.
    fn decide(&mut self, dm: &DistanceMap, i: usize) -> bool {
        let coarse = Coarse {
            stride: self.stride,
            width: self.width,
            factor: self.factor,
            limit: self.limit,
            disk: self.disk.as_ref(),
        };
        coarse.decide(&mut self.g, dm, i)
    }

    /// Keeps the blocked flags that still hold for this map, body and grid.
    fn refresh_blocked(&mut self, dm: &DistanceMap, r_in: f64, f: usize) {
        let key = (geometry_of(dm), r_in.to_bits(), f);
        if self.key == Some(key) {
            if self.seen_generation != dm.generation {
                self.drop_changed(dm);
            }
            self.seen_generation = dm.generation;
            return;
        }
        self.key = Some(key);
        self.seen_generation = dm.generation;
        self.factor = f;
        self.limit = r_in - 1e-6;
        // A small map's distances are all there already: reading them is cheaper than
        // spreading bits by a large body's disk.
        self.disk = (!dm.filled_whole)
            .then(|| Disk::new(dm.resolution, self.limit))
            .flatten();
        self.width = dm.width.div_ceil(f);
        self.height = dm.height.div_ceil(f);
        self.stride = self.width + 2;
        self.origin_x = dm.origin_x;
        self.origin_y = dm.origin_y;
        self.cell = dm.resolution * f as f64;
        let n = self.stride * (self.height + 2);
        self.g.clear();
        self.g.resize(n, BLOCKED);
        self.forget(0, self.width, 0, self.height);
        self.closed.clear();
        self.closed.resize(n, false);
    }

    /// Marks coarse columns `x0..x1`, rows `y0..y1` not decided.
    fn forget(&mut self, x0: usize, x1: usize, y0: usize, y1: usize) {
        for y in y0..y1 {
            let row = (y + 1) * self.stride + 1;
            self.g[row + x0..row + x1].fill(UNKNOWN);
        }
    }

    /// Forgets the blocked flags of the coarse cells whose map cells changed distance.
    fn drop_changed(&mut self, dm: &DistanceMap) {
        let f = self.factor;
        let Some(changes) = dm.changes_since(self.seen_generation) else {
            self.forget(0, self.width, 0, self.height);
            return;
        };
        let windows: Vec<_> = changes.collect();
        for w in windows {
            self.forget(w.x0 / f, w.x1.div_ceil(f), w.y0 / f, w.y1.div_ceil(f));
        }
    }

    /// The coarse cell (unpadded) nearest to `start`: the lazy search's A* target.
    fn target_of(&self, start: (f64, f64)) -> (usize, usize) {
        let clamp = |v: f64, n: usize| (v.max(0.0) as usize).min(n - 1);
        (
            clamp((start.0 - self.origin_x) / self.cell, self.width),
            clamp((start.1 - self.origin_y) / self.cell, self.height),
        )
    }

    /// Padded index of the coarse cell holding (x, y), if inside the grid.
    #[inline]
    fn index_of(&self, x: f64, y: f64) -> Option<usize> {
        // Truncation is the floor for the non-negative values accepted here.
        let fx = (x - self.origin_x) / self.cell;
        let fy = (y - self.origin_y) / self.cell;
        if fx >= 0.0 && fy >= 0.0 && fx < self.width as f64 && fy < self.height as f64 {
            Some((fy as usize + 1) * self.stride + fx as usize + 1)
        } else {
            None
        }
    }
}

/// The map geometry the blocked flags are keyed by.
fn geometry_of(dm: &DistanceMap) -> [u64; 5] {
    [
        dm.width as u64,
        dm.height as u64,
        dm.origin_x.to_bits(),
        dm.origin_y.to_bits(),
        dm.resolution.to_bits(),
    ]
}

/// The eight neighbour offsets (wrapping) and their step costs in a padded grid of row
/// stride `st` (the repairs walk them; the search unrolls them).
fn neighbour_steps(st: usize) -> [(usize, u32); 8] {
    [
        (1, SIDE),
        (usize::MAX, SIDE),
        (st, SIDE),
        (st.wrapping_neg(), SIDE),
        (st + 1, DIAG),
        (st - 1, DIAG),
        ((st - 1).wrapping_neg(), DIAG),
        ((st + 1).wrapping_neg(), DIAG),
    ]
}

impl GridHeuristic {
    /// The least distance of cell `i` through its closed neighbours, if it has any.
    fn through_closed(&self, i: usize, steps: &[(usize, u32); 8]) -> Option<u32> {
        steps
            .iter()
            .filter_map(|&(d, w)| {
                let n = i.wrapping_add(d);
                self.closed[n].then(|| self.g[n] + w)
            })
            .min()
    }
}

/// Octile distance (in steps of 5 and 7) from padded cell `i` (row stride `stride`) to
/// `target`; 0 without one.
#[inline]
fn octile(target: Option<(usize, usize)>, stride: usize, i: usize) -> u32 {
    let Some((tx, ty)) = target else {
        return 0;
    };
    let y = i / stride;
    let x = i - y * stride;
    let (dx, dy) = ((x - 1).abs_diff(tx) as u32, (y - 1).abs_diff(ty) as u32);
    SIDE * dx.max(dy) + (DIAG - SIDE) * dx.min(dy)
}

/// The search's open side while it runs: distances, buckets, the cells touched.
struct Open<'a> {
    g: &'a mut [u32],
    buckets: &'a mut [Vec<u64>; RING],
    touched: &'a mut Vec<u32>,
    coarse: Coarse<'a>,
    dm: &'a DistanceMap,
    target: Option<(usize, usize)>,
}

impl Open<'_> {
    /// Opens (or shortens) cell `n` at distance `nd`; 1 if it was queued.
    #[inline(always)]
    fn relax<const LAZY: bool>(&mut self, n: usize, nd: u32) -> usize {
        let old = self.g[n];
        // Blocked cells and cells already as near fail here.
        if nd >= old {
            return 0;
        }
        if old == UNKNOWN && self.coarse.decide(self.g, self.dm, n) {
            return 0;
        }
        if LAZY && old >= UNREACHED {
            self.touched.push(n as u32);
        }
        self.g[n] = nd;
        let f = if LAZY {
            nd + octile(self.target, self.coarse.stride, n)
        } else {
            nd
        };
        self.buckets[f as usize % RING].push(((n as u64) << 32) | u64::from(nd));
        1
    }
}

mod coarse;
mod incremental;
mod repair;
#[cfg(test)]
mod tests;
