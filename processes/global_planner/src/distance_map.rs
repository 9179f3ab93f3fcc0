//! Per-map lookup tables for fast collision checks: the Euclidean distance from every
//! cell centre to the nearest occupied cell centre (space outside the grid counts as
//! occupied), capped at [`DIST_CAP`], and per-row prefix counts of occupied cells.
//!
//! Built for a map and kept while the map stays the same (the planner keeps a copy of
//! the cells to notice a change). A map that differs in a few places (the mapper's
//! detections between two requests) is updated only around them: capped distances
//! change only within the cap of a changed cell, so the transform runs on that window
//! (with the obstacles up to the cap beyond it) and the rest is kept. The cap makes the
//! update exact: the tables after an update are bit for bit those of a rebuild.
//! Knows nothing of footprints or search.

use aisle_geometry::{FREE, GridView};

/// Distances are kept up to this many metres; farther is stored as this. Queries
/// compare them with a body's radius plus its margin (all far below), and the collision
/// checker skips along a motion by the clearance beyond the body: at 8 m that skip is
/// never the limit on the test and seed queries (their outputs and probe counts are those
/// of uncapped tables), while a 4 m cap made the warm seed benchmark up to 28 % slower.
pub(crate) const DIST_CAP: f64 = 8.0;

/// A window of the grid, in cells: columns `x0..x1`, rows `y0..y1`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Window {
    x0: usize,
    y0: usize,
    x1: usize,
    y1: usize,
}

impl Window {
    fn area(&self) -> usize {
        (self.x1 - self.x0) * (self.y1 - self.y0)
    }

    /// Grown by `by` cells on every side, clipped to a `w` x `h` grid.
    fn grown(&self, by: usize, w: usize, h: usize) -> Window {
        Window {
            x0: self.x0.saturating_sub(by),
            y0: self.y0.saturating_sub(by),
            x1: (self.x1 + by).min(w),
            y1: (self.y1 + by).min(h),
        }
    }
}

#[derive(Debug, Default)]
pub(crate) struct DistanceMap {
    pub origin_x: f64,
    pub origin_y: f64,
    pub resolution: f64,
    pub width: usize,
    pub height: usize,
    cells: Vec<u8>,
    /// Metres from each cell centre to the nearest occupied (or outside) cell centre,
    /// at most [`DIST_CAP`].
    pub dist: Vec<f32>,
    /// `width + 1` entries per row: occupied cells left of each column.
    pub row_prefix: Vec<u32>,
    /// Counts rebuilds and updates, so that tables derived from this one know when to
    /// refresh.
    pub generation: u64,
    /// Cells the last change recomputed (the whole grid on a rebuild), for diagnostics.
    pub last_recomputed: usize,
    // Scratch for the transform.
    scratch_f: Vec<f64>,
    scratch_d: Vec<f64>,
    scratch_v: Vec<usize>,
    scratch_z: Vec<f64>,
    padded: Vec<f64>,
}

impl DistanceMap {
    /// Brings the tables to this map: nothing when they already describe it, an update
    /// around the changed cells when only cells changed, else a rebuild. Returns true
    /// when anything changed.
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
        let cap = (DIST_CAP / map.resolution).ceil() as usize + 1;
        let (w, h) = (map.width, map.height);
        let inner = changed.grown(cap, w, h);
        let sources = inner.grown(cap, w, h);
        // A window that large costs about as much as the whole grid.
        if 2 * sources.area() > w * h {
            self.rebuild(map);
            return true;
        }
        self.generation += 1;
        for y in changed.y0..changed.y1 {
            let row = y * w..(y + 1) * w;
            self.cells[row.clone()].copy_from_slice(&map.cells[row]);
            self.prefix_row(y);
        }
        self.transform(inner, sources);
        self.last_recomputed = inner.area();
        true
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
        self.origin_x = map.origin_x;
        self.origin_y = map.origin_y;
        self.resolution = map.resolution;
        self.width = map.width;
        self.height = map.height;
        self.cells.clear();
        self.cells.extend_from_slice(map.cells);
        let (w, h) = (map.width, map.height);
        self.row_prefix.clear();
        self.row_prefix.resize((w + 1) * h, 0);
        for y in 0..h {
            self.prefix_row(y);
        }
        self.dist.clear();
        self.dist.resize(w * h, 0.0);
        let all = Window {
            x0: 0,
            y0: 0,
            x1: w,
            y1: h,
        };
        self.transform(all, all);
        self.last_recomputed = w * h;
    }

    fn prefix_row(&mut self, y: usize) {
        let w = self.width;
        let out = &mut self.row_prefix[y * (w + 1)..(y + 1) * (w + 1)];
        let mut acc = 0u32;
        out[0] = 0;
        for (x, &c) in self.cells[y * w..(y + 1) * w].iter().enumerate() {
            acc += u32::from(c != FREE);
            out[x + 1] = acc;
        }
    }

    /// Recomputes `dist` inside `inner` from the obstacles inside `sources` (which holds
    /// every cell within the cap of `inner`): the exact squared EDT (Felzenszwalb and
    /// Huttenlocher) of `sources` with one ring around it, the ring being the grid's own
    /// cells where there are any and occupied outside the grid.
    fn transform(&mut self, inner: Window, sources: Window) {
        let (w, h) = (self.width as isize, self.height as isize);
        let (pw, ph) = (sources.x1 - sources.x0 + 2, sources.y1 - sources.y0 + 2);
        // Larger than any real squared distance yet small enough to stay exact.
        let far = 4.0 * ((pw + ph) * (pw + ph)) as f64;
        self.padded.clear();
        self.padded.resize(pw * ph, 0.0);
        for py in 0..ph {
            let y = sources.y0 as isize + py as isize - 1;
            for px in 0..pw {
                let x = sources.x0 as isize + px as isize - 1;
                let inside = x >= 0 && y >= 0 && x < w && y < h;
                let occ = !inside || self.cells[(y * w + x) as usize] != FREE;
                self.padded[py * pw + px] = if occ { 0.0 } else { far };
            }
        }
        self.transform_padded(pw, ph);
        let res = self.resolution;
        for y in inner.y0..inner.y1 {
            let py = y - sources.y0 + 1;
            for x in inner.x0..inner.x1 {
                let d2 = self.padded[py * pw + (x - sources.x0 + 1)];
                self.dist[y * self.width + x] = (d2.sqrt() * res).min(DIST_CAP) as f32;
            }
        }
    }

    /// The squared EDT of `padded` (`pw` x `ph`), in place: columns, then rows.
    fn transform_padded(&mut self, pw: usize, ph: usize) {
        let n = pw.max(ph);
        self.scratch_f.resize(n, 0.0);
        self.scratch_d.resize(n, 0.0);
        self.scratch_v.resize(n, 0);
        self.scratch_z.resize(n + 1, 0.0);
        for px in 0..pw {
            for py in 0..ph {
                self.scratch_f[py] = self.padded[py * pw + px];
            }
            edt_1d(
                &self.scratch_f[..ph],
                &mut self.scratch_d[..ph],
                &mut self.scratch_v,
                &mut self.scratch_z,
            );
            for py in 0..ph {
                self.padded[py * pw + px] = self.scratch_d[py];
            }
        }
        for py in 0..ph {
            self.scratch_f[..pw].copy_from_slice(&self.padded[py * pw..(py + 1) * pw]);
            edt_1d(
                &self.scratch_f[..pw],
                &mut self.scratch_d[..pw],
                &mut self.scratch_v,
                &mut self.scratch_z,
            );
            self.padded[py * pw..(py + 1) * pw].copy_from_slice(&self.scratch_d[..pw]);
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

    /// Occupied cells in columns `c0..=c1` of `row` (both inside the grid).
    #[inline]
    pub fn occupied_in_row(&self, row: usize, c0: usize, c1: usize) -> u32 {
        let base = row * (self.width + 1);
        self.row_prefix[base + c1 + 1] - self.row_prefix[base + c0]
    }
}

/// 1D squared distance transform of sampled function `f` into `d`.
fn edt_1d(f: &[f64], d: &mut [f64], v: &mut [usize], z: &mut [f64]) {
    let n = f.len();
    let mut k = 0usize;
    v[0] = 0;
    z[0] = f64::NEG_INFINITY;
    z[1] = f64::INFINITY;
    let inter = |q: usize, p: usize| -> f64 {
        let (qf, pf) = (q as f64, p as f64);
        ((f[q] + qf * qf) - (f[p] + pf * pf)) / (2.0 * (qf - pf))
    };
    for q in 1..n {
        let mut s = inter(q, v[k]);
        while s <= z[k] {
            k -= 1;
            s = inter(q, v[k]);
        }
        k += 1;
        v[k] = q;
        z[k] = s;
        z[k + 1] = f64::INFINITY;
    }
    k = 0;
    for (q, dq) in d.iter_mut().enumerate().take(n) {
        while z[k + 1] < q as f64 {
            k += 1;
        }
        let dx = q as f64 - v[k] as f64;
        *dq = dx * dx + f[v[k]];
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use aisle_geometry::{CellIndex, GridMap, OCCUPIED_STATIC};

    #[test]
    fn matches_brute_force() {
        let mut g = GridMap::new_free(0.0, 0.0, 0.1, 2.3, 1.7).unwrap();
        for (ix, iy) in [(3, 4), (10, 2), (11, 2), (20, 15), (7, 9)] {
            g.set(CellIndex { ix, iy }, OCCUPIED_STATIC);
        }
        let v = g.view();
        let mut dm = DistanceMap::default();
        assert!(dm.ensure(&v));
        assert!(!dm.ensure(&v), "same map is not rebuilt");
        for iy in 0..v.height as i64 {
            for ix in 0..v.width as i64 {
                let mut best = f64::INFINITY;
                for oy in -1..=v.height as i64 {
                    for ox in -1..=v.width as i64 {
                        let c = CellIndex { ix: ox, iy: oy };
                        if v.occupied_or_outside(c) {
                            best = best.min(((ox - ix) as f64).hypot((oy - iy) as f64));
                        }
                    }
                }
                let got = dm.dist[iy as usize * v.width + ix as usize] as f64;
                assert!(
                    (got - (best * 0.1).min(DIST_CAP)).abs() < 1e-5,
                    "({ix},{iy}) {got} vs {best}"
                );
            }
        }
        assert_eq!(dm.occupied_in_row(2, 0, v.width - 1), 2);
        assert_eq!(dm.occupied_in_row(2, 11, 11), 1);
        assert_eq!(dm.occupied_in_row(2, 12, 22), 0);
        g.set(CellIndex { ix: 0, iy: 0 }, OCCUPIED_STATIC);
        assert!(dm.ensure(&g.view()), "a changed cell forces a rebuild");
    }

    /// Tables after a sequence of updates are bit for bit those of a fresh build.
    #[test]
    fn updates_equal_a_rebuild_bit_for_bit() {
        // 80 x 50 m at 10 cells/m: windows of the cap stay under half the grid.
        let mut g = GridMap::new_free(-3.0, 2.0, 0.1, 80.0, 50.0).unwrap();
        let (w, h) = (g.view().width as i64, g.view().height as i64);
        let mut seed = 0x2545_f491_4f6c_dd1d_u64;
        let mut next = move |n: i64| {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed % n as u64) as i64
        };
        for _ in 0..400 {
            let (ix, iy) = (next(w), next(h));
            g.set(CellIndex { ix, iy }, OCCUPIED_STATIC);
        }
        let mut kept = DistanceMap::default();
        kept.ensure(&g.view());
        let full_cells = kept.last_recomputed;
        let mut updates = 0;
        for round in 0..12 {
            // A small cluster appears (or goes) somewhere, corners and edges included.
            let (cx, cy) = match round {
                0 => (0, 0),
                1 => (w - 1, h - 1),
                2 => (0, h / 2),
                _ => (next(w), next(h)),
            };
            let value = if round % 3 == 2 {
                FREE
            } else {
                OCCUPIED_STATIC
            };
            for k in 0..6 {
                let c = CellIndex {
                    ix: (cx + k % 3).min(w - 1),
                    iy: (cy + k / 3).min(h - 1),
                };
                g.set(c, value);
            }
            let v = g.view();
            kept.ensure(&v);
            updates += usize::from(kept.last_recomputed < full_cells);
            let mut fresh = DistanceMap::default();
            fresh.ensure(&v);
            assert!(
                kept.dist
                    .iter()
                    .zip(&fresh.dist)
                    .all(|(a, b)| a.to_bits() == b.to_bits()),
                "round {round}: distances differ from a rebuild"
            );
            assert_eq!(kept.row_prefix, fresh.row_prefix, "round {round}");
        }
        assert!(updates >= 10, "only {updates} of 12 changes were updates");
    }
}
