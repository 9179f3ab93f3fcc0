//! Per-map lookup tables for fast collision checks: the Euclidean distance from every
//! cell centre to the nearest occupied cell centre (space outside the grid counts as
//! occupied) and per-row prefix counts of occupied cells.
//!
//! Built once per distinct map and kept while the map stays the same (the planner keeps
//! a copy of the cells to notice a change). Knows nothing of footprints or search.

use aisle_geometry::{FREE, GridView};

#[derive(Debug, Default)]
pub(crate) struct DistanceMap {
    pub origin_x: f64,
    pub origin_y: f64,
    pub resolution: f64,
    pub width: usize,
    pub height: usize,
    cells: Vec<u8>,
    /// Metres from each cell centre to the nearest occupied (or outside) cell centre.
    pub dist: Vec<f32>,
    /// `width + 1` entries per row: occupied cells left of each column.
    pub row_prefix: Vec<u32>,
    /// Counts rebuilds, so that tables derived from this one know when to refresh.
    pub generation: u64,
    // Scratch for the transform.
    scratch_f: Vec<f64>,
    scratch_d: Vec<f64>,
    scratch_v: Vec<usize>,
    scratch_z: Vec<f64>,
    padded: Vec<f64>,
}

impl DistanceMap {
    /// Rebuilds the tables unless they already describe exactly this map.
    /// Returns true when it had to rebuild.
    pub fn ensure(&mut self, map: &GridView) -> bool {
        let same = self.width == map.width
            && self.height == map.height
            && self.origin_x.to_bits() == map.origin_x.to_bits()
            && self.origin_y.to_bits() == map.origin_y.to_bits()
            && self.resolution.to_bits() == map.resolution.to_bits()
            && self.cells == map.cells;
        if !same {
            self.rebuild(map);
        }
        !same
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
        self.row_prefix.reserve((w + 1) * h);
        for row in map.cells.chunks_exact(w) {
            let mut acc = 0u32;
            self.row_prefix.push(0);
            for &c in row {
                acc += u32::from(c != FREE);
                self.row_prefix.push(acc);
            }
        }

        // Exact squared EDT (Felzenszwalb and Huttenlocher) on a grid padded with one
        // ring of occupied cells, which stands for everything outside the map.
        let (pw, ph) = (w + 2, h + 2);
        // Larger than any real squared distance yet small enough to stay exact.
        let far = 4.0 * ((pw + ph) * (pw + ph)) as f64;
        self.padded.clear();
        self.padded.resize(pw * ph, 0.0);
        for py in 0..ph {
            for px in 0..pw {
                let border = px == 0 || py == 0 || px == pw - 1 || py == ph - 1;
                let occ = border || map.cells[(py - 1) * w + (px - 1)] != FREE;
                self.padded[py * pw + px] = if occ { 0.0 } else { far };
            }
        }
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
        self.dist.clear();
        self.dist.reserve(w * h);
        for y in 0..h {
            for x in 0..w {
                let d2 = self.padded[(y + 1) * pw + (x + 1)];
                self.dist.push((d2.sqrt() * map.resolution) as f32);
            }
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
                    (got - best * 0.1).abs() < 1e-5,
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
}
