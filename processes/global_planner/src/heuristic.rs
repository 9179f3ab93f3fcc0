//! The obstacle-aware part of the search heuristic: the 8-connected grid distance from
//! the goal to every cell, on a grid that may be coarser than the map.
//!
//! A coarse cell is blocked only when every map cell in it is certainly blocked for the
//! robot's centre (an occupied cell's square reaches into the inscribed circle of any
//! pose there), so a free continuous path always maps to a connected chain of unblocked cells:
//! "unreached from the goal" proves that no path exists. Distances use a bucket queue
//! (Dial's algorithm) with integer steps 5 (side) and 7 (diagonal), which slightly
//! underestimates the diagonal. Knows nothing of headings or motions.

use crate::distance_map::DistanceMap;

const SIDE: u32 = 5;
const DIAG: u32 = 7;
const UNREACHED: u32 = u32::MAX;

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
    blocked: Vec<bool>,
    /// Start values of `dist`: unreached, or 0 for blocked cells so that the search's
    /// "shorter than known" test rejects them without a second lookup.
    dist_init: Vec<u32>,
    /// (distance map generation, inscribed radius bits, factor) that `blocked` is for:
    /// it depends on the map and the body only, not on the goal.
    blocked_key: Option<(u64, u64, usize)>,
    dist: Vec<u32>,
    buckets: [Vec<u32>; (DIAG + 1) as usize],
    /// Cells settled by the last computation.
    pub settled: u32,
}

impl GridHeuristic {
    /// Computes distances from `goal` for a robot whose inscribed radius (margin
    /// included) is `r_in`, on cells of about `cell_size` metres (a whole multiple of the
    /// map resolution). Returns false when the goal's own cell is blocked.
    pub fn compute(
        &mut self,
        dm: &DistanceMap,
        r_in: f64,
        cell_size: f64,
        goal: (f64, f64),
    ) -> bool {
        let f = ((cell_size / dm.resolution).round() as usize).max(1);
        let key = (dm.generation, r_in.to_bits(), f);
        if self.blocked_key != Some(key) {
            self.build_blocked(dm, r_in, f);
            self.blocked_key = Some(key);
        }
        self.dist.clear();
        self.dist.extend_from_slice(&self.dist_init);
        self.settled = 0;
        let Some(g) = self.index_of(goal.0, goal.1) else {
            return false;
        };
        if self.blocked[g] {
            return false;
        }
        for b in &mut self.buckets {
            b.clear();
        }
        self.dist[g] = 0;
        self.buckets[0].push(g as u32);
        let mut pending = 1usize;
        let mut level = 0u32;
        let st = self.stride as isize;
        let steps: [(isize, u32); 8] = [
            (1, SIDE),
            (-1, SIDE),
            (st, SIDE),
            (-st, SIDE),
            (st + 1, DIAG),
            (st - 1, DIAG),
            (-st + 1, DIAG),
            (-st - 1, DIAG),
        ];
        let dist = &mut self.dist;
        let buckets = &mut self.buckets;
        let mut settled = 0u32;
        while pending > 0 {
            let slot = (level % (DIAG + 1)) as usize;
            while let Some(c) = buckets[slot].pop() {
                pending -= 1;
                if dist[c as usize] != level {
                    continue;
                }
                settled += 1;
                for (off, cost) in steps {
                    // Settled cells are never on the border, so every neighbour exists;
                    // blocked ones hold 0 and are never improved.
                    let ni = (c as isize + off) as usize;
                    let nd = level + cost;
                    if nd < dist[ni] {
                        dist[ni] = nd;
                        buckets[(nd % (DIAG + 1)) as usize].push(ni as u32);
                        pending += 1;
                    }
                }
            }
            level += 1;
        }
        self.settled = settled;
        true
    }

    fn build_blocked(&mut self, dm: &DistanceMap, r_in: f64, f: usize) {
        self.width = dm.width.div_ceil(f);
        self.height = dm.height.div_ceil(f);
        self.stride = self.width + 2;
        self.origin_x = dm.origin_x;
        self.origin_y = dm.origin_y;
        self.cell = dm.resolution * f as f64;
        self.blocked.clear();
        self.blocked.resize(self.stride * (self.height + 2), true);
        // For any robot centre q in a map cell c and an occupied cell o (equal squares),
        // the farthest q is from o's square is exactly |c - o|: the far corner of c is
        // half a cell farther, o's near edge half a cell nearer, on each axis. So a centre
        // distance under r_in puts o's square inside the inscribed circle of every pose
        // in c: c is blocked for sure. (Subtracting half a diagonal here, as before,
        // left narrow holes in a detected wall open to the heuristic that the body
        // cannot pass, and the search flooded the space before them.) The 1e-6 absorbs
        // the f32 rounding of the stored distances.
        let limit = r_in - 1e-6;
        for y in 0..dm.height {
            let row = &dm.dist[y * dm.width..(y + 1) * dm.width];
            let base = (y / f + 1) * self.stride + 1;
            for (x, &d) in row.iter().enumerate() {
                if f64::from(d) >= limit {
                    self.blocked[base + x / f] = false;
                }
            }
        }
        self.dist_init.clear();
        self.dist_init
            .extend(self.blocked.iter().map(|&b| if b { 0 } else { UNREACHED }));
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

    /// Grid distance in metres from the goal, or `None` when the goal cannot be reached.
    #[inline]
    pub fn metres(&self, x: f64, y: f64) -> Option<f64> {
        let i = self.index_of(x, y)?;
        let d = self.dist[i];
        (d != UNREACHED && !self.blocked[i]).then(|| f64::from(d) * self.cell / f64::from(SIDE))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use aisle_geometry::{CellIndex, GridMap, OCCUPIED_STATIC};

    #[test]
    fn goes_around_a_wall_and_proves_enclosure() {
        let mut g = GridMap::new_free(0.0, 0.0, 0.1, 6.0, 4.0).unwrap();
        // A wall at x = 3.0 from y = 0 up to y = 3.0, leaving a gap above.
        for iy in 0..30 {
            g.set(CellIndex { ix: 30, iy }, OCCUPIED_STATIC);
        }
        let mut dm = DistanceMap::default();
        dm.ensure(&g.view());
        let mut h = GridHeuristic::default();
        assert!(h.compute(&dm, 0.2, 0.1, (4.5, 1.0)));
        let straight = 3.0;
        let around = h.metres(1.5, 1.0).unwrap();
        assert!(around > straight + 2.0, "{around}");
        assert!(h.metres(4.6, 1.0).unwrap() < 0.2);
        // Close the gap: the left side is unreachable.
        for iy in 30..40 {
            g.set(CellIndex { ix: 30, iy }, OCCUPIED_STATIC);
        }
        dm.ensure(&g.view());
        assert!(h.compute(&dm, 0.2, 0.2, (4.5, 1.0)));
        assert_eq!(h.metres(1.5, 1.0), None);
        assert!(h.metres(5.0, 2.0).is_some());
    }
}
