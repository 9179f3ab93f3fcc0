//! Repairing the lazy backward search in place after a map change that only blocked
//! cells or only freed them (a detection appearing or going away): only the cells whose
//! distance the change alters are touched, instead of every cell beyond the nearest flip
//! (`repair.rs`, which still handles a change that does both).
//!
//! Blocked cells can only lengthen distances. A closed cell keeps its distance exactly
//! when a closed neighbour that keeps its own precedes it tightly (its distance plus the
//! step is this one's): that chain still reaches the goal. Deciding that in order of
//! distance from the flipped cells outwards finds every cell that lost its support; those
//! are taken back (closed ones reopened), queued again from their supported neighbours,
//! and the open list is queued by f from the lowest level again. The A* then closes them
//! at their new exact distances (its state is that of a search on the changed map: every
//! closed cell exact, every open one at its best through closed neighbours).
//!
//! Freed cells can only shorten distances, and a shortened path runs through them. A
//! Dijkstra from the freed cells (seeded through their closed neighbours) carries every
//! shortening, in order: into closed cells, and into cells not closed whose f through
//! the freed cells is below the search's level (the search would have closed them
//! already on the changed map: they are closed here, at the distance the Dijkstra
//! gives, which is exact because every shorter path's cells come before them). Other
//! cells it reaches are opened at the shorter distance. Exact by the usual argument:
//! a cell whose distance shrank has a predecessor whose distance shrank too, or a
//! closed one next to a freed cell. Either way the open list is then queued again by f
//! towards the new request's start (the closed distances are exact whatever consistent
//! estimate ordered them). Knows nothing of the planner.

use super::{BLOCKED, FORGOTTEN, GridHeuristic, UNKNOWN, UNREACHED, neighbour_steps, octile};
use crate::distance_map::DistanceMap;
use std::cmp::Reverse;

/// A cell the search gave a distance (closed or open).
#[inline]
fn reached(g: u32) -> bool {
    g != BLOCKED && g < FORGOTTEN
}

impl GridHeuristic {
    /// Repairs the search after `redecide` when its flips all went one way, and aims it
    /// at `start`; false (and nothing done) when they went both ways.
    pub(super) fn repair_in_place(&mut self, dm: &DistanceMap, start: (f64, f64)) -> bool {
        let (mut blocked, mut freed) = (false, false);
        for &(i, old) in &self.redecided {
            let now = self.g[i] == BLOCKED;
            blocked |= old != BLOCKED && now;
            freed |= old == BLOCKED && !now;
        }
        match (blocked, freed) {
            (true, true) => return false,
            (true, false) => self.lengthen(),
            (false, true) => self.shorten(dm),
            (false, false) => {}
        }
        // Aimed at the old start, the search would close its way there before reaching
        // the new one; any consistent estimate keeps the closed distances exact.
        self.target = Some(self.target_of(start));
        self.requeue_open();
        #[cfg(test)]
        {
            self.in_place += 1;
        }
        true
    }

    /// The repair for newly blocked cells (see the module).
    fn lengthen(&mut self) {
        let steps = neighbour_steps(self.stride);
        self.repair_heap.clear();
        self.affected.clear();
        for k in 0..self.redecided.len() {
            let (b, old) = self.redecided[k];
            if old == BLOCKED || self.g[b] != BLOCKED {
                continue;
            }
            for &(d, _) in &steps {
                let n = b.wrapping_add(d);
                if reached(self.g[n]) {
                    self.repair_heap.push(Reverse((self.g[n], n as u32)));
                }
            }
        }
        let mut last = None;
        while let Some(Reverse(entry)) = self.repair_heap.pop() {
            // Equal entries come off together: a cell is decided once, after every
            // cell nearer than it.
            if last == Some(entry) {
                continue;
            }
            last = Some(entry);
            let (gn, n) = (entry.0, entry.1 as usize);
            let supported = steps.iter().any(|&(d, w)| {
                let u = n.wrapping_add(d);
                self.closed[u] && self.g[u] + w == gn
            });
            if supported {
                continue;
            }
            self.affected.push(n as u32);
            // An open cell supports nothing.
            if !self.closed[n] {
                continue;
            }
            self.closed[n] = false;
            self.settled -= 1;
            for &(d, _) in &steps {
                let m = n.wrapping_add(d);
                let gm = self.g[m];
                if reached(gm) && gm > gn {
                    self.repair_heap.push(Reverse((gm, m as u32)));
                }
            }
        }
        for &a in &self.affected {
            self.g[a as usize] = FORGOTTEN;
        }
        for k in 0..self.affected.len() {
            let a = self.affected[k] as usize;
            if let Some(best) = self.through_closed(a, &steps) {
                self.g[a] = best;
                let f = best + octile(self.target, self.stride, a);
                self.deferred
                    .push(Reverse((f, ((a as u64) << 32) | u64::from(best))));
            }
        }
    }

    /// Queues every open entry in the heap by its f towards the current target and
    /// starts the levels again from the lowest (a repair may have queued cells below the
    /// level reached); stale entries are dropped.
    fn requeue_open(&mut self) {
        let mut all = std::mem::take(&mut self.deferred).into_vec();
        for b in &mut self.buckets {
            all.extend(b.drain(..).map(|e| Reverse((0, e))));
        }
        let (g, target, stride) = (&self.g, self.target, self.stride);
        all.retain_mut(|Reverse((f, e))| {
            let (c, gc) = ((*e >> 32) as usize, *e as u32);
            *f = gc + octile(target, stride, c);
            g[c] == gc
        });
        self.deferred = all.into();
        self.pending = 0;
        self.level = self.deferred.peek().map_or(self.level, |e| e.0.0);
    }

    /// The repair for newly freed cells (see the module).
    fn shorten(&mut self, dm: &DistanceMap) {
        let steps = neighbour_steps(self.stride);
        let level = self.level;
        self.repair_heap.clear();
        for k in 0..self.redecided.len() {
            let (u, old) = self.redecided[k];
            if old != BLOCKED || self.g[u] == BLOCKED {
                continue;
            }
            for &(d, w) in &steps {
                let n = u.wrapping_add(d);
                if self.closed[n] {
                    self.repair_heap.push(Reverse((self.g[n] + w, u as u32)));
                }
            }
        }
        while let Some(Reverse((c, v))) = self.repair_heap.pop() {
            let v = v as usize;
            if self.g[v] == UNKNOWN && self.decide(dm, v) {
                continue;
            }
            let old = self.g[v];
            // Blocked (0), or no shorter: nothing to carry.
            if c >= old {
                continue;
            }
            if old >= UNREACHED {
                self.touched.push(v as u32);
            }
            self.g[v] = c;
            let f = c + octile(self.target, self.stride, v);
            if !self.closed[v] && f >= level {
                self.deferred
                    .push(Reverse((f, ((v as u64) << 32) | u64::from(c))));
                continue;
            }
            if !self.closed[v] {
                self.closed[v] = true;
                self.settled += 1;
            }
            for &(d, w) in &steps {
                let m = v.wrapping_add(d);
                let gm = self.g[m];
                if gm != BLOCKED && c + w < gm {
                    self.repair_heap.push(Reverse((c + w, m as u32)));
                }
            }
        }
    }
}
