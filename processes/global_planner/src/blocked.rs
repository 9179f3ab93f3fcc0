//! Which heuristic cells the robot's centre cannot be in, decided from the occupancy
//! bits alone, 64 map columns at a time, so that the 2D heuristic's search needs no
//! distance tiles (a large map's backward search covers far more ground than the
//! Hybrid A* probes).
//!
//! A map cell is blocked when its stored obstacle distance is under the limit. The
//! stored value is monotone in the squared distance in cells, so there is a least
//! squared distance `d` at which it reaches the limit: the cell is blocked exactly when
//! an occupied cell (or the outside of the grid) lies within the disk of squared radius
//! `d - 1` around it. That disk is a few rows of runs, and a row of 64 cells is one word:
//! the blocked cells of a word are the OR over the disk's rows of that row's bits spread
//! by the run's half width. Same answer as the distance table, bit for bit (tested), and
//! a coarse cell is free when any of its map cells is. Knows cells, bits and the
//! distance formula; nothing of the search.

use crate::distance_map::{DIST_CAP, DistanceMap};

/// The disk of map cells whose obstacles block a cell: `half[dy]` is the half width of
/// its row `dy` cells above or below.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Disk {
    half: Vec<usize>,
}

impl Disk {
    /// The disk for distances compared with `limit` (m) on a grid of `res`; `None` when
    /// no word-wide pass can hold it (a half width over 63 cells).
    pub(crate) fn new(res: f64, limit: f64) -> Option<Disk> {
        // As the distance table stores it (`dist_tiles`).
        let stored = |d2: u64| f64::from(((d2 as f64).sqrt() * res).min(DIST_CAP) as f32);
        let far = ((DIST_CAP / res).ceil() as u64 + 1).pow(2);
        let d = if stored(far) < limit {
            // Never free: every cell is within the disk of the outside.
            far + 1
        } else {
            let (mut lo, mut hi) = (0u64, far);
            // Least d2 with stored(d2) >= limit, in lo..=hi.
            while lo < hi {
                let mid = lo + (hi - lo) / 2;
                if stored(mid) >= limit {
                    hi = mid;
                } else {
                    lo = mid + 1;
                }
            }
            lo
        };
        let mut half = Vec::new();
        // Rows with dy² <= d - 1, each as wide as w² <= d - 1 - dy² allows.
        while d >= 1 && (half.len() as u64).pow(2) < d {
            let room = d - 1 - (half.len() as u64).pow(2);
            let mut w = (room as f64).sqrt() as u64;
            while w * w > room {
                w -= 1;
            }
            while (w + 1) * (w + 1) <= room {
                w += 1;
            }
            half.push(w as usize);
        }
        (half.len() <= 64 && half.iter().all(|&w| w < 64)).then_some(Disk { half })
    }

    /// Bit x set: map cell (64 t + x, y) is blocked (within the disk of an occupied or
    /// outside cell).
    pub(crate) fn blocked_word(&self, dm: &DistanceMap, y: isize, t: isize) -> u64 {
        let mut acc = 0u64;
        let r = self.half.len() as isize - 1;
        for dy in -r..=r {
            let w = self.half[dy.unsigned_abs()];
            let yy = y + dy;
            let c = dm.row_word(yy, t);
            let mut spread = c;
            if w > 0 {
                let (left, right) = (dm.row_word(yy, t - 1), dm.row_word(yy, t + 1));
                for k in 1..=w {
                    spread |= (c << k) | (left >> (64 - k)) | (c >> k) | (right << (64 - k));
                }
            }
            acc |= spread;
            if acc == u64::MAX {
                break;
            }
        }
        acc
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use aisle_geometry::{CellIndex, GridMap, OCCUPIED_STATIC};

    /// Every cell's bit is the distance table's answer, on random maps of sizes that are
    /// not whole words, for limits at and between cell distances.
    #[test]
    fn words_equal_the_distance_table() {
        let mut next = crate::tests::stream(0x9e37_79b9_7f4a_7c15);
        let mut compared = 0;
        for (res, wm, hm) in [(0.05, 9.7, 6.3), (0.1, 13.1, 7.9), (0.03, 4.1, 5.0)] {
            let mut g = GridMap::new_free(1.0, -2.0, res, wm, hm).unwrap();
            let (w, h) = (g.view().width, g.view().height);
            for _ in 0..w * h / 150 {
                let c = CellIndex {
                    ix: next(w as i64),
                    iy: next(h as i64),
                };
                g.set(c, OCCUPIED_STATIC);
            }
            let mut dm = DistanceMap::default();
            dm.ensure(&g.view());
            for limit in [0.0, 0.1, 0.25 - 1e-6, 0.315 - 1e-6, 0.5, 0.74, 1.2] {
                let Some(disk) = Disk::new(res, limit) else {
                    assert!(limit / res > 60.0, "{limit} at {res}");
                    continue;
                };
                for y in 0..h {
                    for t in 0..w.div_ceil(64) {
                        let word = disk.blocked_word(&dm, y as isize, t as isize);
                        for x in t * 64..(t * 64 + 64).min(w) {
                            let blocked = f64::from(dm.dist_at(x, y)) < limit;
                            assert_eq!(
                                word >> (x - t * 64) & 1 == 1,
                                blocked,
                                "({x}, {y}) {limit}"
                            );
                            compared += 1;
                        }
                    }
                }
            }
        }
        assert!(compared > 100_000);
    }
}
