//! The results of motion checks (free or not, and the probes the check took), kept with
//! the distance map from request to request, keyed by the checker (footprint and cover),
//! the start pose's bits and the motion's bits.
//!
//! A motion check is a pure function of those keys and of the map (the probe order
//! inside it changes no answer, `collision.rs`), so a repeated request checks no motion
//! again while the map stands. When cells change, an entry is dropped only if a changed
//! cell can reach what its check read: the probes read distances at points within the
//! body's circumscribed radius of a sample centre, and the occupancy inside the footprint
//! grown by the cover; a capped distance `d` at a cell changes only if a changed cell
//! lies within `d` of it (an added cell nearer than `d` lowers it, a removed one farther
//! than `d` was not its nearest). So each entry keeps the box of its sample centres grown
//! by the body's reach and the largest distance it read; a change outside that box cannot
//! alter its answer or its probe count. The exact footprint check of a single pose (the
//! output's traced poses) is kept the same way: it reads only the occupancy under the
//! footprint. Knows nothing of search.

use crate::distance_map::Window;
use crate::motion::{Motion, pose_bits};
use aisle_geometry::Pose2;
use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hash, Hasher};

/// Entries kept at most. A request that fills the table keeps the rest of its checks
/// out of it (neither looked up nor kept: a long search rarely repeats, and keeping
/// every one of the 450k checks of a long `config/large` carry cost it more than a
/// quarter of its time, 64k of them still a tenth), and the next request starts it
/// again; memory stays bounded (about 2 MB).
const MAX_ENTRIES: usize = 1 << 14;

/// Most entries a change scans to keep those it cannot reach.
const SCANNED: usize = 1 << 13;

/// Entries a table holds room for from the start (the crossing of `config/large` keeps
/// 3,870 motions and poses).
const RESERVED: usize = 1 << 13;

/// Checker (footprint length, width and cover bits), start pose bits, motion tag and
/// fields' bits.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Key([u64; 10]);

impl Hash for Key {
    #[inline]
    fn hash<H: Hasher>(&self, state: &mut H) {
        for w in self.0 {
            state.write_u64(w);
        }
    }
}

/// One motion check's answer, and the cells whose change could alter it.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Entry {
    pub free: bool,
    pub probes: u32,
    /// Cells `x0..=x1`, `y0..=y1` (may reach beyond the grid).
    pub region: [i64; 4],
}

/// The memo (see the module).
#[derive(Debug, Default)]
pub(crate) struct MotionCache {
    map: HashMap<Key, Entry, BuildHasherDefault<WordHasher>>,
    /// This request filled the table: it is left alone until the next one.
    full: bool,
}

impl MotionCache {
    #[inline]
    pub fn get(&self, key: &Key) -> Option<Entry> {
        if self.full {
            return None;
        }
        self.map.get(key).copied()
    }

    pub fn insert(&mut self, key: Key, entry: Entry) {
        if self.map.len() >= MAX_ENTRIES {
            self.full = true;
            return;
        }
        self.map.insert(key, entry);
    }

    /// A new request: the table starts again if the last one filled it.
    pub fn begin_request(&mut self) {
        if self.map.len() >= MAX_ENTRIES {
            self.map.clear();
        }
        self.full = false;
    }

    /// Forgets everything (a new grid), keeping room for a request's checks: growing
    /// the table entry by entry rehashed it several times in a cold request.
    pub fn clear(&mut self) {
        self.map.clear();
        self.map.reserve(RESERVED);
    }

    /// Drops the entries whose region meets the changed cells `win`; a large table is
    /// emptied instead (a scan of all its entries cost a request more than checking its
    /// motions again: the docked plans change the map once per side).
    pub fn invalidate(&mut self, win: Window) {
        if self.map.len() > SCANNED {
            self.map.clear();
            return;
        }
        let (x0, y0) = (win.x0 as i64, win.y0 as i64);
        let (x1, y1) = (win.x1 as i64 - 1, win.y1 as i64 - 1);
        self.map.retain(|_, e| {
            let r = e.region;
            r[0] > x1 || r[2] < x0 || r[1] > y1 || r[3] < y0
        });
    }

    #[cfg(test)]
    pub fn len(&self) -> usize {
        self.map.len()
    }
}

/// The key of `motion` from `from` for the checker with footprint `(length, width)` and
/// `cover`.
#[inline]
pub(crate) fn key(checker: [f64; 3], from: &Pose2, motion: &Motion) -> Key {
    let [a, b, c] = pose_bits(from);
    let m = match *motion {
        Motion::Drive { length, curvature } => [0, length.to_bits(), curvature.to_bits(), 0],
        Motion::Rotate { angle } => [1, angle.to_bits(), 0, 0],
        Motion::Lerp { to } => [2, to.x.to_bits(), to.y.to_bits(), to.theta.to_bits()],
    };
    Key([
        checker[0].to_bits(),
        checker[1].to_bits(),
        checker[2].to_bits(),
        a,
        b,
        c,
        m[0],
        m[1],
        m[2],
        m[3],
    ])
}

/// The key of the exact check of footprint `(length, width)` at `at` (no motion, no
/// cover): a tag no motion has.
#[inline]
pub(crate) fn pose_key(footprint: [f64; 2], at: &Pose2) -> Key {
    let [a, b, c] = pose_bits(at);
    let [l, w] = footprint.map(f64::to_bits);
    Key([l, w, 0, a, b, c, 3, 0, 0, 0])
}

/// A multiply-rotate hash over whole words (keys are bit patterns, not attacker input):
/// SipHash cost more than the lookups save.
#[derive(Default)]
pub(crate) struct WordHasher(u64);

impl Hasher for WordHasher {
    #[inline]
    fn finish(&self) -> u64 {
        self.0
    }

    #[inline]
    fn write(&mut self, bytes: &[u8]) {
        for chunk in bytes.chunks(8) {
            let mut w = [0u8; 8];
            w[..chunk.len()].copy_from_slice(chunk);
            self.write_u64(u64::from_le_bytes(w));
        }
    }

    #[inline]
    fn write_u64(&mut self, v: u64) {
        self.0 = (self.0.rotate_left(5) ^ v).wrapping_mul(0x51_7c_c1_b7_27_22_0a_95);
    }

    #[inline]
    fn write_usize(&mut self, v: usize) {
        self.write_u64(v as u64);
    }
}

#[cfg(test)]
mod tests {
    use crate::collision::FootprintChecker;
    use crate::distance_map::DistanceMap;
    use crate::motion::Motion;
    use aisle_geometry::{CellIndex, FREE, Footprint, GridMap, OCCUPIED_STATIC, Pose2};

    /// Through a run of map changes (detections added and taken away, beside the checked
    /// motions and far from them), every motion and pose check answered from the memo
    /// equals a fresh check on a new distance map, probe counts included; and the memo
    /// keeps the entries the changes cannot reach.
    #[test]
    fn kept_checks_equal_fresh_ones_through_map_changes() {
        let mut g = GridMap::new_free(0.0, 0.0, 0.05, 24.0, 16.0).unwrap();
        let (w, h) = (g.view().width as i64, g.view().height as i64);
        let mut next = crate::tests::stream(0x3c6e_f372_fe94_f82b);
        for _ in 0..40 {
            let (x0, y0, len, vertical) = (next(w), next(h), 10 + next(100), next(2) == 0);
            for k in 0..len {
                let (ix, iy) = if vertical { (x0, y0 + k) } else { (x0 + k, y0) };
                g.set(CellIndex { ix, iy }, OCCUPIED_STATIC);
            }
        }
        let unit = |k: i64| k as f64 / 1000.0;
        let queries: Vec<(Pose2, Motion)> = (0..600)
            .map(|k| {
                let p = Pose2::new(
                    0.5 + 23.0 * unit(next(1000)),
                    0.5 + 15.0 * unit(next(1000)),
                    6.0 * unit(next(1000)) - 3.0,
                );
                let m = match k % 3 {
                    0 => Motion::Drive {
                        length: 2.0 * unit(next(1000)) - 1.0,
                        curvature: 4.0 * unit(next(1000)) - 2.0,
                    },
                    1 => Motion::Rotate {
                        angle: 3.0 * unit(next(1000)) - 1.5,
                    },
                    _ => Motion::Lerp {
                        to: Pose2::new(p.x + 0.3, p.y - 0.2, p.theta + 0.4),
                    },
                };
                (p, m)
            })
            .collect();
        let fp = Footprint::new(0.6, 0.45);
        let mut dm = DistanceMap::default();
        dm.force_lazy = true;
        let (mut boxes, mut kept, mut blocked) = (Vec::new(), 0, 0);
        for round in 0..40 {
            if round > 0 {
                // A 0.3 m box beside a checked pose (within reach of its clearance, not
                // of its body), or the oldest one taken away.
                let (cell, v) = if round % 3 == 0 && !boxes.is_empty() {
                    (boxes.remove(0), FREE)
                } else {
                    let p = queries[next(queries.len() as i64) as usize].0;
                    let c = g.view().cell_of(p.x + 0.5 + unit(next(1000)), p.y);
                    boxes.push(c);
                    (c, OCCUPIED_STATIC)
                };
                for k in 0..36 {
                    let c = CellIndex {
                        ix: cell.ix + k % 6,
                        iy: cell.iy + k / 6,
                    };
                    g.set(c, v);
                }
            }
            dm.ensure(&g.view());
            kept += usize::from(round > 0 && dm.motions.borrow().len() > 0);
            let mut fresh = DistanceMap::default();
            fresh.force_lazy = true;
            fresh.ensure(&g.view());
            let (a, b) = (
                FootprintChecker::new(&dm, fp, 0.02),
                FootprintChecker::new(&fresh, fp, 0.02),
            );
            for (p, m) in &queries {
                let (mut pa, mut pb) = (0, 0);
                let free = b.motion_free(p, m, &mut pb);
                assert_eq!(a.motion_free(p, m, &mut pa), free, "round {round} {p:?}");
                assert_eq!(pa, pb, "round {round} {p:?} {m:?}");
                assert_eq!(a.pose_free(p), b.pose_free(p), "round {round} {p:?}");
                blocked += usize::from(!free);
            }
        }
        assert!(kept == 39 && blocked > 1000, "{kept} {blocked}");
    }

    /// The claim the regions rest on: a capped distance changes only where a changed cell
    /// lies within the old distance of it (plus a cell of round-off), whichever way the
    /// cells changed.
    #[test]
    fn a_distance_changes_only_within_its_own_reach_of_a_change() {
        let mut g = GridMap::new_free(0.0, 0.0, 0.05, 12.0, 9.0).unwrap();
        let (w, h) = (g.view().width as i64, g.view().height as i64);
        let mut next = crate::tests::stream(0xa54f_f53a_5f1d_36f1);
        for _ in 0..25 {
            let (x0, y0, len) = (next(w), next(h), 10 + next(80));
            for k in 0..len {
                g.set(CellIndex { ix: x0 + k, iy: y0 }, OCCUPIED_STATIC);
            }
        }
        let mut before = DistanceMap::default();
        before.ensure(&g.view());
        let mut changed_cells = 0;
        for round in 0..12 {
            let (x0, y0) = (next(w - 6), next(h - 6));
            let v = if round % 2 == 0 {
                OCCUPIED_STATIC
            } else {
                FREE
            };
            let mut changed = Vec::new();
            for k in 0..36 {
                let c = CellIndex {
                    ix: x0 + k % 6,
                    iy: y0 + k / 6,
                };
                if g.view().cells[(c.iy * w + c.ix) as usize] != v {
                    changed.push(c);
                }
                g.set(c, v);
            }
            let mut after = DistanceMap::default();
            after.ensure(&g.view());
            for y in 0..h as usize {
                for x in 0..w as usize {
                    let (old, new) = (before.dist_at(x, y), after.dist_at(x, y));
                    if old.to_bits() == new.to_bits() {
                        continue;
                    }
                    changed_cells += 1;
                    let reach = f64::from(old) / 0.05 + 1.0;
                    let near = changed.iter().any(|c| {
                        let (dx, dy) = (c.ix as f64 - x as f64, c.iy as f64 - y as f64);
                        dx.hypot(dy) <= reach
                    });
                    assert!(near, "round {round} ({x}, {y}) {old} -> {new}");
                }
            }
            before = after;
        }
        assert!(changed_cells > 1000, "{changed_cells}");
    }
}
