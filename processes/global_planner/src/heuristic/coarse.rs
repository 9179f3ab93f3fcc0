//! Deciding a coarse cell of the heuristic's grid blocked or free for the robot's
//! centre, from the map's occupancy bits (through the disk of the body's inscribed
//! radius) or from the distance table. Knows nothing of the search.

use super::{BLOCKED, UNKNOWN, UNREACHED};
use crate::blocked::Disk;
use crate::distance_map::DistanceMap;

/// What deciding a coarse cell's blocked flag needs.
#[derive(Clone, Copy)]
pub(super) struct Coarse<'a> {
    pub stride: usize,
    /// Coarse cells per row (without the border).
    pub width: usize,
    pub factor: usize,
    pub limit: f64,
    /// The occupancy test equal to `limit` (`None`: the distance table's values).
    pub disk: Option<&'a Disk>,
}

impl Coarse<'_> {
    /// Decides whether padded cell `i` is blocked (and the other undecided cells of its
    /// row that start in the same 64 map columns), records it in `g` and returns it.
    #[cold]
    pub fn decide(self, g: &mut [u32], dm: &DistanceMap, i: usize) -> bool {
        let f = self.factor;
        let Some(disk) = self.disk.filter(|_| f <= 64) else {
            return self.decide_by_distance(g, dm, i);
        };
        let (cx, cy) = (i % self.stride - 1, i / self.stride - 1);
        let t = (cx * f) >> 6;
        let first = (t * 64).div_ceil(f);
        let last = ((t * 64 + 63) / f).min(self.width - 1);
        let two_words = (last + 1) * f > (t + 1) * 64;
        // Bit x: some map cell in column 64 t + x of these rows is free.
        let mut free = 0u128;
        for y in cy * f..(cy * f + f).min(dm.height) {
            let (y, t) = (y as isize, t as isize);
            free |= u128::from(!disk.blocked_word(dm, y, t));
            if two_words {
                free |= u128::from(!disk.blocked_word(dm, y, t + 1)) << 64;
            }
        }
        let row = (cy + 1) * self.stride + 1;
        for c in first..=last {
            if g[row + c] == UNKNOWN {
                let a = c * f - t * 64;
                let cells = ((1u128 << f) - 1) << a;
                g[row + c] = if free & cells != 0 {
                    UNREACHED
                } else {
                    BLOCKED
                };
            }
        }
        g[i] == BLOCKED
    }

    /// [`Coarse::decide`] for cell `i` alone, from the distance table.
    fn decide_by_distance(self, g: &mut [u32], dm: &DistanceMap, i: usize) -> bool {
        // For any robot centre q in a map cell c and an occupied cell o (equal squares),
        // the farthest q is from o's square is exactly |c - o|: the far corner of c is
        // half a cell farther, o's near edge half a cell nearer, on each axis. So a centre
        // distance under r_in puts o's square inside the inscribed circle of every pose
        // in c: c is blocked for sure. (Subtracting half a diagonal here, as before,
        // left narrow holes in a detected wall open to the heuristic that the body
        // cannot pass, and the search flooded the space before them.) The 1e-6 absorbs
        // the f32 rounding of the stored distances.
        let (cx, cy) = (i % self.stride - 1, i / self.stride - 1);
        let f = self.factor;
        let (x0, y0) = (cx * f, cy * f);
        let (x1, y1) = ((x0 + f).min(dm.width), (y0 + f).min(dm.height));
        let free = (y0..y1).any(|y| (x0..x1).any(|x| f64::from(dm.dist_at(x, y)) >= self.limit));
        g[i] = if free { UNREACHED } else { BLOCKED };
        !free
    }
}
