//! Keeping the lazy backward search from one request to the next for the same goal cell,
//! body and grid: as it stands when the map has not changed, and repaired when it has.
//!
//! A repair re-decides the blocked flags the changed cells reach (within the inscribed
//! radius) and compares them with those the search used. No flip: the search stands.
//! Otherwise a distance stays exact below a bound: a cell newly blocked at distance d lies on no
//! shortest path to a cell nearer than d, and a newly free cell u gives no cell nearer
//! than its octile distance from the goal a shorter way. The closed cells below the
//! least such bound are kept, everything else the search reached is forgotten, and the
//! kept cells' neighbours become the open list again (queued by f in a heap, since their
//! f spans more levels than the ring holds). A* from that state closes every further cell
//! at its exact distance (the kept cells are exact and their neighbours relaxed), so
//! queries answer as a flood of the changed map would. A change whose flips all go one
//! way (a detection appearing or going away) is repaired in place instead, touching only
//! the cells whose distance it alters (`incremental.rs`); the cut is for changes that
//! block and free at once. Knows nothing of the planner.

use super::{
    BLOCKED, FORGOTTEN, GridHeuristic, UNKNOWN, UNREACHED, geometry_of, neighbour_steps, octile,
};
use crate::distance_map::DistanceMap;
use std::cmp::Reverse;

impl GridHeuristic {
    /// Whether the last request's lazy search can serve this one: the same goal cell,
    /// body and grid, and the map changes since it was last brought up to date known
    /// (none, or still in the distance map's log).
    pub(super) fn continuable(
        &self,
        dm: &DistanceMap,
        r_in: f64,
        f: usize,
        goal: (f64, f64),
    ) -> bool {
        let Some(gi) = self.lazy_goal else {
            return false;
        };
        self.key == Some((geometry_of(dm), r_in.to_bits(), f))
            && self.index_of(goal.0, goal.1) == Some(gi)
            && (self.seen_generation == dm.generation
                || dm.changes_since(self.seen_generation).is_some())
    }

    /// Continues the search for a request aimed at `start`, repaired to the changed map
    /// if the map changed (see the module); false when the goal's own cell is blocked
    /// now. Unchanged, every cell it closed holds its exact distance whichever start it
    /// was aimed at (the octile estimate is consistent towards any target), so it goes
    /// on as it stands; only the order of the cells it still closes follows the old
    /// start.
    pub(super) fn continue_search(&mut self, dm: &DistanceMap, start: (f64, f64)) -> bool {
        let Some(gi) = self.lazy_goal else {
            return false;
        };
        let cut = self.redecide(dm, gi);
        self.seen_generation = dm.generation;
        if self.g[gi] == BLOCKED {
            self.lazy_goal = None;
            return false;
        }
        if cut == u32::MAX || self.repair_in_place(dm, start) {
            return true;
        }
        self.forget_from(cut);
        self.target = Some(self.target_of(start));
        self.reopen_frontier(dm);
        true
    }

    /// Re-decides the decided cells in the change windows; returns the least bound below
    /// which distances still hold (`u32::MAX`: no flag flipped). Cells not decided yet
    /// stay so.
    fn redecide(&mut self, dm: &DistanceMap, gi: usize) -> u32 {
        let f = self.factor;
        self.redecided.clear();
        self.reopened.clear();
        // A cell's flag reads the occupancy within the inscribed radius of its map
        // cells: the changed cells' window grown by that much holds every flag that can
        // flip.
        let reach = (self.limit / dm.resolution).ceil() as usize + 1;
        let changed = (self.seen_generation != dm.generation)
            .then(|| dm.cell_changes_since(self.seen_generation))
            .flatten();
        if let Some(changes) = changed {
            for w in changes.map(|w| w.grown(reach, reach, dm.width, dm.height)) {
                for cy in w.y0 / f..w.y1.div_ceil(f).min(self.height) {
                    for cx in w.x0 / f..w.x1.div_ceil(f).min(self.width) {
                        let i = (cy + 1) * self.stride + cx + 1;
                        if self.g[i] != UNKNOWN {
                            self.redecided.push((i, self.g[i]));
                            self.g[i] = UNKNOWN;
                        }
                    }
                }
            }
        }
        let goal = Some((gi % self.stride - 1, gi / self.stride - 1));
        let mut cut = u32::MAX;
        for k in 0..self.redecided.len() {
            let (i, old) = self.redecided[k];
            if self.g[i] == UNKNOWN {
                self.decide(dm, i);
            }
            match (old == BLOCKED, self.g[i] == BLOCKED) {
                (false, false) => self.g[i] = old,
                (false, true) => {
                    if old < FORGOTTEN {
                        cut = cut.min(old);
                    }
                    if self.closed[i] {
                        self.closed[i] = false;
                        self.settled -= 1;
                    }
                }
                (true, false) => {
                    cut = cut.min(1 + octile(goal, self.stride, i));
                    self.reopened.push(i as u32);
                }
                (true, true) => {}
            }
        }
        cut
    }

    /// Forgets every cell the search reached at a distance of `cut` or more (stored as
    /// distance + 1, as `cut` is), and every open one; `touched` keeps the rest only.
    fn forget_from(&mut self, cut: u32) {
        let mut kept = 0;
        for k in 0..self.touched.len() {
            let c = self.touched[k] as usize;
            let v = self.g[c];
            if v == BLOCKED {
                // Blocked now: it stays so, and nothing is left to reset.
                continue;
            }
            if self.closed[c] && v < cut {
                self.touched[kept] = c as u32;
                kept += 1;
                continue;
            }
            if self.closed[c] {
                self.closed[c] = false;
                self.settled -= 1;
            }
            self.g[c] = UNREACHED;
            self.reopened.push(c as u32);
        }
        self.touched.truncate(kept);
        for b in &mut self.buckets {
            b.clear();
        }
        self.deferred.clear();
        self.pending = 0;
    }

    /// Queues by f every cell next to a kept closed cell, at its distance through them.
    /// Before the change each closed cell's neighbours were reached or blocked, so those
    /// cells are among the ones just forgotten or freed (`reopened`).
    fn reopen_frontier(&mut self, dm: &DistanceMap) {
        let steps = neighbour_steps(self.stride);
        for k in 0..self.reopened.len() {
            let r = self.reopened[k] as usize;
            if let Some(best) = self.through_closed(r, &steps) {
                self.seed(dm, r, best);
            }
        }
        self.level = self.deferred.peek().map_or(self.level, |e| e.0.0);
    }

    /// Opens (or shortens) cell `n` at distance `nd` into the heap.
    fn seed(&mut self, dm: &DistanceMap, n: usize, nd: u32) {
        let old = self.g[n];
        if nd >= old {
            return;
        }
        if old == UNKNOWN && self.decide(dm, n) {
            return;
        }
        if old >= UNREACHED {
            self.touched.push(n as u32);
        }
        self.g[n] = nd;
        let f = nd + octile(self.target, self.stride, n);
        self.deferred
            .push(Reverse((f, ((n as u64) << 32) | u64::from(nd))));
    }
}
