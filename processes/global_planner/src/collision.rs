//! Collision checks of the real rectangular footprint against an occupancy grid.
//!
//! A pose collides when its rectangle touches an occupied cell's square or any space
//! outside the grid. The fast checker first asks the distance map: clearance above the
//! circumscribed radius means free, an occupied cell centre inside the inscribed circle
//! means blocked; only in between does it rasterise the rectangle row by row (exact, with
//! per-row prefix counts). Motions are checked continuously: every accepted sample covers
//! a neighbourhood of poses, and the next sample is placed so that neighbourhoods overlap.
//! Knows nothing of costs or search.

use crate::distance_map::DistanceMap;
use crate::motion::Motion;
use crate::motion_cache;
use aisle_geometry::{FREE, Footprint, GridView, Pose2};
use std::cell::Cell;
use std::f64::consts::FRAC_1_SQRT_2;

/// Calls `hit(row, first_col, last_col)` for every grid row the rectangle with `corners`
/// touches (closed sets), with the columns it touches in that row. Rows and columns are
/// relative to a grid with origin `(ox, oy)` and cell size `res`, and may be negative or
/// beyond the grid. Stops and returns true as soon as `hit` returns true.
pub(crate) fn rect_row_spans(
    corners: &[(f64, f64); 4],
    ox: f64,
    oy: f64,
    res: f64,
    mut hit: impl FnMut(i64, i64, i64) -> bool,
) -> bool {
    let ymin = corners.iter().map(|c| c.1).fold(f64::INFINITY, f64::min);
    let ymax = corners
        .iter()
        .map(|c| c.1)
        .fold(f64::NEG_INFINITY, f64::max);
    let r0 = floor_i64((ymin - oy) / res);
    let r1 = floor_i64((ymax - oy) / res);
    for row in r0..=r1 {
        let y0 = oy + row as f64 * res;
        let y1 = y0 + res;
        let mut xmin = f64::INFINITY;
        let mut xmax = f64::NEG_INFINITY;
        for k in 0..4 {
            let (px, py) = corners[k];
            let (qx, qy) = corners[(k + 1) % 4];
            let dy = qy - py;
            let (t0, t1) = if dy.abs() < 1e-15 {
                if py < y0 || py > y1 {
                    continue;
                }
                (0.0, 1.0)
            } else {
                let ta = (y0 - py) / dy;
                let tb = (y1 - py) / dy;
                (ta.min(tb).max(0.0), ta.max(tb).min(1.0))
            };
            if t0 > t1 {
                continue;
            }
            for t in [t0, t1] {
                let x = px + (qx - px) * t;
                xmin = xmin.min(x);
                xmax = xmax.max(x);
            }
        }
        if xmin > xmax {
            continue;
        }
        let c0 = floor_i64((xmin - ox) / res);
        let c1 = floor_i64((xmax - ox) / res);
        if hit(row, c0, c1) {
            return true;
        }
    }
    false
}

/// Same contract as [`rect_row_spans`] for a rectangle's corners in counter-clockwise
/// order, but with the span of each row from the rectangle's two monotone chains (a few
/// multiply-adds per row instead of clipping all four edges): the search calls this
/// thousands of times per request. Nearly axis-aligned rectangles use their bounding box,
/// which can only report more cells, never fewer.
pub(crate) fn rect_row_spans_fast(
    corners: &[(f64, f64); 4],
    ox: f64,
    oy: f64,
    res: f64,
    mut hit: impl FnMut(i64, i64, i64) -> bool,
) -> bool {
    let mut b = 0;
    for k in 1..4 {
        if corners[k].1 < corners[b].1 {
            b = k;
        }
    }
    let v0 = corners[b];
    let vr = corners[(b + 1) % 4];
    let vt = corners[(b + 2) % 4];
    let vl = corners[(b + 3) % 4];
    let (ymin, ymax) = (v0.1, vt.1);
    let r0 = floor_i64((ymin - oy) / res);
    let r1 = floor_i64((ymax - oy) / res);
    let scale = (vt.0 - v0.0).abs() + (ymax - ymin);
    let flat = (vr.1 - v0.1).abs() <= 1e-9 * scale || (vl.1 - v0.1).abs() <= 1e-9 * scale;
    if flat {
        let xmin = corners.iter().map(|c| c.0).fold(f64::INFINITY, f64::min);
        let xmax = corners
            .iter()
            .map(|c| c.0)
            .fold(f64::NEG_INFINITY, f64::max);
        let (c0, c1) = (floor_i64((xmin - ox) / res), floor_i64((xmax - ox) / res));
        return (r0..=r1).any(|row| hit(row, c0, c1));
    }
    let slope = |p: (f64, f64), q: (f64, f64)| (q.0 - p.0) / (q.1 - p.1);
    let (s_br, s_rt) = (slope(v0, vr), slope(vr, vt));
    let (s_bl, s_lt) = (slope(v0, vl), slope(vl, vt));
    let right = |y: f64| {
        if y <= vr.1 {
            v0.0 + (y - v0.1) * s_br
        } else {
            vr.0 + (y - vr.1) * s_rt
        }
    };
    let left = |y: f64| {
        if y <= vl.1 {
            v0.0 + (y - v0.1) * s_bl
        } else {
            vl.0 + (y - vl.1) * s_lt
        }
    };
    for row in r0..=r1 {
        let y0 = oy + row as f64 * res;
        let ya = y0.max(ymin);
        let yb = (y0 + res).min(ymax);
        if ya > yb {
            continue;
        }
        let mut xmin = left(ya).min(left(yb));
        if (ya..=yb).contains(&vl.1) {
            xmin = xmin.min(vl.0);
        }
        let mut xmax = right(ya).max(right(yb));
        if (ya..=yb).contains(&vr.1) {
            xmax = xmax.max(vr.0);
        }
        if hit(
            row,
            floor_i64((xmin - ox) / res),
            floor_i64((xmax - ox) / res),
        ) {
            return true;
        }
    }
    false
}

/// Whether a rectangle placed at `at` touches an occupied cell or leaves the grid.
/// Plain scan of the grid, no tables: for validators, not for the search.
pub(crate) fn footprint_hits(map: &GridView, fp: &Footprint, at: &Pose2) -> bool {
    let corners = fp.corners(at);
    let (w, h) = (map.width as i64, map.height as i64);
    rect_row_spans(
        &corners,
        map.origin_x,
        map.origin_y,
        map.resolution,
        |row, c0, c1| {
            if row < 0 || row >= h || c0 < 0 || c1 >= w {
                return true;
            }
            let base = row as usize * map.width;
            map.cells[base + c0 as usize..=base + c1 as usize]
                .iter()
                .any(|&c| c != FREE)
        },
    )
}

/// `v.floor() as i64` without a libm call (the baseline target has no rounding
/// instruction, and this sits on the hottest path). Exact for |v| < 2^52.
#[inline]
fn floor_i64(v: f64) -> i64 {
    let t = v as i64;
    if (t as f64) > v { t - 1 } else { t }
}

/// The corners of `fp` at `p`, in the order of [`Footprint::corners`], from the sine and
/// cosine of `p.theta` (the library version pays one evaluation per corner; the probe has
/// them already).
#[inline]
fn corners_fast(fp: &Footprint, p: &Pose2, (s, c): (f64, f64)) -> [(f64, f64); 4] {
    let (hl, hw) = (0.5 * fp.length, 0.5 * fp.width);
    [(hl, hw), (-hl, hw), (-hl, -hw), (hl, -hw)]
        .map(|(bx, by)| (p.x + c * bx - s * by, p.y + s * bx + c * by))
}

/// Most disks a footprint is covered with (per side).
const MAX_DISKS_PER_SIDE: usize = 4;

/// Result of probing one pose.
#[derive(Clone, Copy)]
enum Probe {
    Blocked,
    /// Free, and so is every pose whose body points move at most this far from it.
    Free(f64),
}

/// Checks one footprint (already grown by the safety margin) against a distance map.
pub(crate) struct FootprintChecker<'a> {
    dm: &'a DistanceMap,
    base: Footprint,
    /// The exact check uses `base` grown by `cover` and so vouches for all poses within
    /// `cover` of the checked one.
    exact: Footprint,
    cover: f64,
    r_circ: f64,
    r_in: f64,
    /// Centres (body frame) of equal sub-rectangles tiling `base`, and the radius of the
    /// disk that covers each: a cheaper middle test between the circumscribed circle and
    /// the exact scan, for poses near obstacles but not touching them.
    disks: [(f64, f64); MAX_DISKS_PER_SIDE * MAX_DISKS_PER_SIDE],
    n_disks: usize,
    r_disk: f64,
    /// The pose (bits) the last motion started from and its probe: an expansion checks
    /// every primitive from the same pose, so its first sample is probed once, not once
    /// per primitive (a probe is a pure function of the pose).
    first: Cell<Option<([u64; 3], Probe)>>,
    /// The disk whose clearance failed last, tried first.
    failed_disk: Cell<usize>,
    /// The largest distance read since it was last reset: how far a map change can be
    /// and still alter what a motion check read (`motion_cache.rs`).
    read_max: Cell<f64>,
}

impl<'a> FootprintChecker<'a> {
    /// `base` is the footprint that must stay free everywhere along checked motions;
    /// `cover` (> 0) is how far one exact check reaches.
    pub fn new(dm: &'a DistanceMap, base: Footprint, cover: f64) -> Self {
        // Near-square tiles of a third of the short side keep the disks' overshoot
        // beyond the rectangle's edges small.
        let side = base.length.min(base.width) / 3.0;
        let tiles = |extent: f64| ((extent / side).ceil() as usize).clamp(1, MAX_DISKS_PER_SIDE);
        let (nl, nw) = (tiles(base.length), tiles(base.width));
        let (tl, tw) = (base.length / nl as f64, base.width / nw as f64);
        let mut disks = [(0.0, 0.0); MAX_DISKS_PER_SIDE * MAX_DISKS_PER_SIDE];
        for i in 0..nl {
            for j in 0..nw {
                disks[i * nw + j] = (
                    -0.5 * base.length + (i as f64 + 0.5) * tl,
                    -0.5 * base.width + (j as f64 + 0.5) * tw,
                );
            }
        }
        Self {
            dm,
            base,
            exact: base.inflated(cover),
            cover,
            r_circ: base.circumscribed_radius(),
            r_in: base.inscribed_radius(),
            disks,
            n_disks: nl * nw,
            r_disk: 0.5 * tl.hypot(tw),
            first: Cell::new(None),
            failed_disk: Cell::new(0),
            read_max: Cell::new(0.0),
        }
    }

    /// Lower bound on the distance from (x, y) to any occupied cell's square (or the
    /// outside of the grid), and that cell's centre distance; None outside the grid.
    #[inline]
    fn clearance(&self, x: f64, y: f64) -> Option<(f64, f64)> {
        let dm = self.dm;
        let (cx, cy) = dm.cell(x, y)?;
        let d = f64::from(dm.dist_at(cx, cy));
        self.read_max.set(self.read_max.get().max(d));
        let ccx = dm.origin_x + (cx as f64 + 0.5) * dm.resolution;
        let ccy = dm.origin_y + (cy as f64 + 0.5) * dm.resolution;
        let (ex, ey) = (x - ccx, y - ccy);
        let off = (ex * ex + ey * ey).sqrt();
        Some((d - off - dm.resolution * FRAC_1_SQRT_2, d + off))
    }

    pub fn circumscribed_radius(&self) -> f64 {
        self.r_circ
    }

    /// Whether `base` at `p` is free (exact, no cover). Answered from the distance map's
    /// memo when checked on the same cells before.
    pub fn pose_free(&self, p: &Pose2) -> bool {
        let key = motion_cache::pose_key([self.base.length, self.base.width], p);
        if let Some(e) = self.dm.motions.borrow().get(&key) {
            return e.free;
        }
        let free = !self.rect_hits(&self.base, p, p.theta.sin_cos());
        // The scan reads the cells the rectangle touches: within its circumscribed
        // radius of the centre, plus a cell either side for round-off.
        let (dm, grow) = (self.dm, self.r_circ + 2.0 * self.dm.resolution);
        let cell = |v: f64, o: f64| floor_i64((v - o) / dm.resolution);
        let region = [
            cell(p.x - grow, dm.origin_x),
            cell(p.y - grow, dm.origin_y),
            cell(p.x + grow, dm.origin_x),
            cell(p.y + grow, dm.origin_y),
        ];
        let entry = motion_cache::Entry {
            free,
            probes: 0,
            region,
        };
        dm.motions.borrow_mut().insert(key, entry);
        free
    }

    #[inline]
    fn probe(&self, p: &Pose2) -> Probe {
        let Some((clearance, reach_centre)) = self.clearance(p.x, p.y) else {
            return Probe::Blocked;
        };
        let slack = clearance - self.r_circ;
        if slack >= self.cover {
            return Probe::Free(slack);
        }
        // An occupied cell centre strictly inside the inscribed circle is inside the body.
        if reach_centre < self.r_in {
            return Probe::Blocked;
        }
        // Every body point lies in one of the disks; if each disk keeps `cover` of
        // clearance, any pose whose body points move less than the smallest slack is free.
        let turn = p.theta.sin_cos();
        let (sin, cos) = turn;
        let mut disk_slack = f64::INFINITY;
        // From the disk that failed last: nearby poses fail on the same side, and then
        // the exact check decides whichever disk failed (when none fails, the least
        // slack is the same in any order).
        let (n, first) = (self.n_disks, self.failed_disk.get());
        for i in (first..n).chain(0..first) {
            let (bx, by) = self.disks[i];
            let x = p.x + cos * bx - sin * by;
            let y = p.y + sin * bx + cos * by;
            let Some((c, _)) = self.clearance(x, y) else {
                disk_slack = f64::NEG_INFINITY;
                self.failed_disk.set(i);
                break;
            };
            disk_slack = disk_slack.min(c - self.r_disk);
            if disk_slack < self.cover {
                self.failed_disk.set(i);
                break;
            }
        }
        if disk_slack >= self.cover {
            return Probe::Free(disk_slack);
        }
        if self.rect_hits(&self.exact, p, turn) {
            Probe::Blocked
        } else {
            Probe::Free(self.cover)
        }
    }

    /// Whether `fp` at `p` (whose heading has the sine and cosine `turn`) touches an
    /// occupied cell or leaves the grid.
    fn rect_hits(&self, fp: &Footprint, p: &Pose2, turn: (f64, f64)) -> bool {
        let dm = self.dm;
        let corners = corners_fast(fp, p, turn);
        let (w, h) = (dm.width as i64, dm.height as i64);
        rect_row_spans_fast(
            &corners,
            dm.origin_x,
            dm.origin_y,
            dm.resolution,
            |row, c0, c1| {
                row < 0
                    || row >= h
                    || c0 < 0
                    || c1 >= w
                    || dm.occupied_in_row(row as usize, c0 as usize, c1 as usize)
            },
        )
    }

    /// [`FootprintChecker::probe`] of the first sample of a motion, kept for the next
    /// motion that starts at the same pose (bit for bit).
    #[inline]
    fn first_probe(&self, p: &Pose2) -> Probe {
        let key = crate::motion::pose_bits(p);
        if let Some((k, probe)) = self.first.get()
            && k == key
        {
            return probe;
        }
        let probe = self.probe(p);
        self.first.set(Some((key, probe)));
        probe
    }

    /// Whether `base` stays free at every pose of `motion` from `from` (continuously, not
    /// only at samples). Returns the number of probes through `probes`. Answered from the
    /// distance map's memo when this check was made on the same cells before.
    pub fn motion_free(&self, from: &Pose2, motion: &Motion, probes: &mut u64) -> bool {
        let checker = [self.base.length, self.base.width, self.cover];
        let key = motion_cache::key(checker, from, motion);
        if let Some(e) = self.dm.motions.borrow().get(&key) {
            *probes += u64::from(e.probes);
            return e.free;
        }
        self.read_max.set(0.0);
        let mut n = 0;
        let free = self.sweep(from, motion, &mut n);
        *probes += n;
        // Sample centres stay within `total` of the start; a probe reads distances within
        // the circumscribed radius of its centre and occupancy within the footprint grown
        // by the cover; a read distance d changes only by a cell within d of it (plus
        // cells of round-off).
        let total = motion.sweep_bound(from, self.r_circ);
        let res = self.dm.resolution;
        let grow = total + self.r_circ + 2.0 * self.cover + self.read_max.get() + 3.0 * res;
        let cell = |v: f64, o: f64| floor_i64((v - o) / res);
        let (ox, oy) = (self.dm.origin_x, self.dm.origin_y);
        let region = [
            cell(from.x - grow, ox),
            cell(from.y - grow, oy),
            cell(from.x + grow, ox),
            cell(from.y + grow, oy),
        ];
        let probes = u32::try_from(n).unwrap_or(u32::MAX);
        if probes < u32::MAX {
            let entry = motion_cache::Entry {
                free,
                probes,
                region,
            };
            self.dm.motions.borrow_mut().insert(key, entry);
        }
        free
    }

    /// [`FootprintChecker::motion_free`] computed.
    fn sweep(&self, from: &Pose2, motion: &Motion, probes: &mut u64) -> bool {
        let total = motion.sweep_bound(from, self.r_circ);
        // Every sample turns from the same heading.
        let turn = from.theta.sin_cos();
        let mut s = 0.0;
        loop {
            let p = if s >= 1.0 {
                motion.end_turned(from, turn)
            } else {
                motion.at_turned(from, s, turn)
            };
            *probes += 1;
            let probe = if s == 0.0 {
                self.first_probe(&p)
            } else {
                self.probe(&p)
            };
            let reach = match probe {
                Probe::Blocked => return false,
                Probe::Free(r) => r,
            };
            if s >= 1.0 || total <= 0.0 {
                return true;
            }
            // The next sample vouches for at least `cover` around itself, so its
            // neighbourhood meets this one's.
            s = (s + (reach + self.cover) / total).min(1.0);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use aisle_geometry::{CellIndex, GridMap, OCCUPIED_STATIC};

    fn map_with(cells: &[(i64, i64)]) -> GridMap {
        let mut g = GridMap::new_free(0.0, 0.0, 0.1, 4.0, 3.0).unwrap();
        for &(ix, iy) in cells {
            g.set(CellIndex { ix, iy }, OCCUPIED_STATIC);
        }
        g
    }

    #[test]
    fn exact_rectangle_touch_rules() {
        // One occupied cell: [2.0, 2.1] x [1.5, 1.6].
        let g = map_with(&[(20, 15)]);
        let v = g.view();
        let fp = Footprint::new(0.4, 0.2);
        // Front edge at x = 1.99: free; at 2.01: touches the cell.
        assert!(!footprint_hits(&v, &fp, &Pose2::new(1.79, 1.55, 0.0)));
        assert!(footprint_hits(&v, &fp, &Pose2::new(1.81, 1.55, 0.0)));
        // Rotated by 45 degrees, its corner reaches farther than its edge midpoints.
        let diag = Pose2::new(1.85, 1.40, std::f64::consts::FRAC_PI_4);
        let mut dm = DistanceMap::default();
        dm.ensure(&v);
        let ch = FootprintChecker::new(&dm, fp, 0.01);
        assert_eq!(footprint_hits(&v, &fp, &diag), !ch.pose_free(&diag));
        // Leaving the grid is a collision.
        assert!(footprint_hits(&v, &fp, &Pose2::new(0.1, 1.0, 0.0)));
        assert!(!ch.pose_free(&Pose2::new(0.1, 1.0, 0.0)));
    }

    #[test]
    fn fast_checker_agrees_with_plain_scan() {
        let g = map_with(&[(20, 15), (21, 15), (5, 5), (30, 25), (10, 20)]);
        let v = g.view();
        let mut dm = DistanceMap::default();
        dm.ensure(&v);
        let fp = Footprint::new(0.7, 0.5);
        let ch = FootprintChecker::new(&dm, fp, 0.02);
        let mut n_blocked = 0;
        for i in 0..40 {
            for j in 0..30 {
                for k in 0..8 {
                    let p =
                        Pose2::new(0.05 + i as f64 * 0.1, 0.03 + j as f64 * 0.1, k as f64 * 0.4);
                    let slow = footprint_hits(&v, &fp, &p);
                    assert_eq!(slow, !ch.pose_free(&p), "{p:?}");
                    // The probe may only be stricter (it checks a grown rectangle).
                    if slow {
                        n_blocked += 1;
                        assert!(matches!(ch.probe(&p), Probe::Blocked));
                    } else if let Probe::Free(reach) = ch.probe(&p) {
                        // Moves whose body points travel less than `reach` stay free.
                        let r = 0.99 * reach.min(0.5);
                        for (dx, dy) in [(r, 0.0), (0.0, -r), (-0.7 * r, 0.7 * r)] {
                            let q = Pose2::new(p.x + dx, p.y + dy, p.theta);
                            assert!(!footprint_hits(&v, &fp, &q), "{p:?} reach {reach}");
                        }
                    }
                }
            }
        }
        assert!(n_blocked > 100);
    }

    #[test]
    fn fast_row_spans_match_the_plain_ones() {
        let fp = Footprint::new(1.7, 1.6);
        let (ox, oy, res) = (-0.3, 0.2, 0.05);
        let mut plain = Vec::new();
        let mut fast = Vec::new();
        for k in 0..400 {
            let t = f64::from(k);
            let p = Pose2::new(0.37 * t % 3.0, 0.53 * t % 2.0, 0.0917 * t);
            let corners = corners_fast(&fp, &p, p.theta.sin_cos());
            plain.clear();
            fast.clear();
            rect_row_spans(&corners, ox, oy, res, |r, a, b| {
                plain.push((r, a, b));
                false
            });
            rect_row_spans_fast(&corners, ox, oy, res, |r, a, b| {
                fast.push((r, a, b));
                false
            });
            assert_eq!(plain.len(), fast.len(), "{p:?}");
            for (a, b) in plain.iter().zip(&fast) {
                // Equal, or the fast one wider by round-off at a cell boundary.
                assert_eq!(a.0, b.0);
                assert!(
                    b.1 <= a.1 && a.1 - b.1 <= 1 && b.2 >= a.2 && b.2 - a.2 <= 1,
                    "{p:?}"
                );
            }
            let exact = plain.iter().zip(&fast).filter(|(a, b)| a == b).count();
            assert!(exact + 1 >= plain.len(), "{p:?}");
        }
    }

    #[test]
    fn motion_check_catches_a_thin_wall_between_samples() {
        // A wall one cell thick across the corridor at x = 2.0 .. 2.1.
        let wall: Vec<(i64, i64)> = (0..30).map(|iy| (20, iy)).collect();
        let g = map_with(&wall);
        let mut dm = DistanceMap::default();
        dm.ensure(&g.view());
        let ch = FootprintChecker::new(&dm, Footprint::new(0.3, 0.3), 0.02);
        let mut probes = 0;
        let through = Motion::Drive {
            length: 1.0,
            curvature: 0.0,
        };
        assert!(!ch.motion_free(&Pose2::new(1.5, 1.5, 0.0), &through, &mut probes));
        let short = Motion::Drive {
            length: 0.2,
            curvature: 0.0,
        };
        assert!(ch.motion_free(&Pose2::new(1.5, 1.5, 0.0), &short, &mut probes));
    }
}
