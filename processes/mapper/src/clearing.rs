//! Clearing along rays, visiting only the cells that can change: the detected ones.
//!
//! A detection is forgotten when a ray of a later scan passes through the middle of its
//! cell (within a radius of the centre, `obstacles.clear_radius`), goes on beyond it, and
//! crosses the surface the cell is part of rather than running along it. Crossing the
//! cell is not enough: a wall's face fills only part of the cells that hold it, and the
//! lidar sees the face alone, so a ray grazing along the face crosses every one of those
//! cells without a hit; clearing on "crosses the cell" erased walls seen earlier (an
//! aisle sweep backed the robot into one it had lost that way). The rule needs no state
//! beyond the grid, so a restarted mapper that takes its grid back clears exactly as
//! the one before it.
//!
//! Walking every ray cell by cell costs ~1,200 rays x ~100 cells per scan, nearly all
//! of them free cells where there is nothing to clear. Detections are sparse, so instead
//! each detected cell asks the few rays whose bearing falls within the cell's angular
//! extent whether one passes through it. The rays' bearings are indexed in an angular
//! table built once per scan; a cell right next to the sensor is asked only of the rays
//! nearest its centre's bearing (`MAX_BINS_PER_SIDE`).
//!
//! Knows grids only as `&mut [u8]` with a width and height, in cell units; knows
//! nothing of lidars or of the map's other layers.

use aisle_geometry::OCCUPIED_DETECTED;
use std::f32::consts::{PI, TAU};

/// A detection this scan's clearing has flagged; marking restores it, settling frees it.
/// Never visible outside one obstacle-layer update.
pub(crate) const PENDING_CLEAR: u8 = 3;

/// Angular table size over a full turn: 0.088 deg bins, finer than the seed's 0.2 deg
/// column spacing so neighbouring columns rarely share a bin.
const BINS: usize = 4096;
const NONE: u32 = u32::MAX;
/// Cap on the bins looked at each side of a cell's bearing (bounds the work for cells
/// right next to the sensor).
const MAX_BINS_PER_SIDE: usize = 256;
/// sin of the angle under which a ray counts as running along a surface rather than
/// crossing it (30 deg).
const ALONG_SURFACE: f32 = 0.5;
/// Half the diagonal of a cell, in cells: the radius that bounds a cell's extent.
const HALF_DIAGONAL: f32 = std::f32::consts::SQRT_2 * 0.5;

/// Bounds of the flat cell indices flagged `PENDING_CLEAR` (empty when `lo > hi`).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Flagged {
    pub lo: usize,
    pub hi: usize,
}

impl Flagged {
    pub const NONE: Flagged = Flagged {
        lo: usize::MAX,
        hi: 0,
    };

    #[inline(always)]
    pub fn flag(&mut self, cells: &mut [u8], i: usize) {
        if cells[i] == OCCUPIED_DETECTED {
            cells[i] = PENDING_CLEAR;
            self.lo = self.lo.min(i);
            self.hi = self.hi.max(i);
        }
    }
}

/// One ray's clearing segment in the plane, cell units, from the sensor's 2D position.
#[derive(Debug, Clone, Copy, Default)]
struct Ray {
    ux: f32,
    uy: f32,
    /// Distances along the unit direction where the clearing starts and stops.
    ra: f32,
    rb: f32,
    /// Cell of the return, never cleared by its own ray (-1 when there is none).
    end: (i64, i64),
}

/// Per-scan tables, allocated once for a number of rays.
#[derive(Debug, Clone)]
pub(crate) struct RayClearing {
    rays: Vec<Ray>,
    table: Vec<u32>,
    sensor: (f32, f32),
    /// How close, cells, a ray passes to a return to clear it.
    radius: f32,
    /// Bounding box of all segments, cell units.
    bbox: [f32; 4],
}

#[inline(always)]
fn bin_of(angle: f32) -> usize {
    let t = (angle + PI) * (BINS as f32 / TAU);
    (t.floor() as i64).rem_euclid(BINS as i64) as usize
}

impl RayClearing {
    pub fn new(rays: usize) -> Self {
        Self {
            rays: vec![Ray::default(); rays],
            table: vec![NONE; BINS],
            sensor: (0.0, 0.0),
            radius: 0.0,
            bbox: [
                f32::INFINITY,
                f32::INFINITY,
                f32::NEG_INFINITY,
                f32::NEG_INFINITY,
            ],
        }
    }

    /// Starts a scan from the sensor's 2D position; a ray clears the returns it passes
    /// within `radius` of (both in cell units).
    pub fn begin(&mut self, sensor: (f32, f32), radius: f32) {
        self.table.fill(NONE);
        self.sensor = sensor;
        self.radius = radius;
        self.bbox = [sensor.0, sensor.1, sensor.0, sensor.1];
        for r in &mut self.rays {
            r.rb = 0.0;
        }
    }

    /// Ray `k` clears the part of the segment from the sensor to `end` (cell units)
    /// between fractions `ta` and `tb`; `hit` says whether `end` is a return whose cell
    /// it must not clear.
    pub fn set(&mut self, k: usize, end: (f32, f32), ta: f32, tb: f32, hit: bool) {
        let (dx, dy) = (end.0 - self.sensor.0, end.1 - self.sensor.1);
        let len = (dx * dx + dy * dy).sqrt();
        if !(len > 1e-6 && len.is_finite() && ta < tb) {
            return;
        }
        let (ux, uy) = (dx / len, dy / len);
        let ray = Ray {
            ux,
            uy,
            ra: ta * len,
            rb: tb * len,
            end: if hit {
                (end.0.floor() as i64, end.1.floor() as i64)
            } else {
                (-1, -1)
            },
        };
        self.rays[k] = ray;
        self.table[bin_of(uy.atan2(ux))] = k as u32;
        for (x, y) in [
            (self.sensor.0 + ux * ray.ra, self.sensor.1 + uy * ray.ra),
            (self.sensor.0 + ux * ray.rb, self.sensor.1 + uy * ray.rb),
        ] {
            self.bbox[0] = self.bbox[0].min(x);
            self.bbox[1] = self.bbox[1].min(y);
            self.bbox[2] = self.bbox[2].max(x);
            self.bbox[3] = self.bbox[3].max(y);
        }
    }

    /// Whether ray `r` clears the detection of cell (ix, iy) whose centre is `p` (cell
    /// units): the ray passes within the radius of `p` inside its clearing stretch and
    /// ends a radius beyond it, and the cell is not the ray's own return.
    #[inline]
    fn passes_through(&self, r: &Ray, ix: i64, iy: i64, p: (f32, f32)) -> bool {
        if r.rb <= r.ra || (ix, iy) == r.end {
            return false;
        }
        let (dx, dy) = (p.0 - self.sensor.0, p.1 - self.sensor.1);
        let along = dx * r.ux + dy * r.uy;
        let across = (dx * r.uy - dy * r.ux).abs();
        let beyond = if r.end.0 >= 0 { self.radius } else { 0.0 };
        across <= self.radius && along >= r.ra && along <= r.rb - beyond
    }

    /// Flags every detected cell of `cells` (`w` x `h`, row-major) that a ray clears,
    /// except the corners of surfaces that stay (`keep_corners`).
    pub fn apply(&self, cells: &mut [u8], w: usize, h: usize, flagged: &mut Flagged) {
        let mut mine = Flagged::NONE;
        self.flag_crossed(cells, w, h, &mut mine);
        if mine.lo <= mine.hi {
            keep_corners(cells, w, h, &mine);
            flagged.lo = flagged.lo.min(mine.lo);
            flagged.hi = flagged.hi.max(mine.hi);
        }
    }

    fn flag_crossed(&self, cells: &mut [u8], w: usize, h: usize, flagged: &mut Flagged) {
        if w == 0 || h == 0 || self.bbox[0] > self.bbox[2] {
            return;
        }
        let clamp = |v: f32, n: usize| (v.max(0.0) as usize).min(n);
        let x0 = clamp(self.bbox[0].floor(), w);
        let x1 = clamp(self.bbox[2].floor() + 1.0, w);
        let y0 = clamp(self.bbox[1].floor(), h);
        let y1 = clamp(self.bbox[3].floor() + 1.0, h);
        if x0 >= x1 || y0 >= y1 {
            return;
        }
        const CHUNK: usize = 32;
        for iy in y0..y1 {
            let row0 = iy * w;
            let mut x = x0;
            while x < x1 {
                let end = (x + CHUNK).min(x1);
                // Branch-free test of a whole chunk first: most chunks hold no detection.
                let any = cells[row0 + x..row0 + end]
                    .iter()
                    .fold(false, |a, &c| a | (c == OCCUPIED_DETECTED));
                if any {
                    for ix in x..end {
                        if cells[row0 + ix] == OCCUPIED_DETECTED
                            && self.clears(cells, (w, h), (ix, iy))
                        {
                            flagged.flag(cells, row0 + ix);
                        }
                    }
                }
                x = end;
            }
        }
    }

    /// Whether any ray whose bearing lies within the cell's angular extent (grown by the
    /// radius) passes through its centre, across the surface the cell is part of.
    fn clears(&self, cells: &[u8], (w, h): (usize, usize), (ix, iy): (usize, usize)) -> bool {
        let p = (ix as f32 + 0.5, iy as f32 + 0.5);
        let (cx, cy) = (
            ix as f32 + 0.5 - self.sensor.0,
            iy as f32 + 0.5 - self.sensor.1,
        );
        let dist = (cx * cx + cy * cy).sqrt();
        // A ray within the radius of a return anywhere in the cell.
        let reach = HALF_DIAGONAL + self.radius;
        let half = if dist > reach {
            (reach / dist).asin()
        } else {
            PI
        };
        let side = ((half * (BINS as f32 / TAU)).ceil() as usize + 1).min(MAX_BINS_PER_SIDE);
        let centre = bin_of(cy.atan2(cx));
        (0..=2 * side).any(|k| {
            let b = (centre + BINS + k - side) % BINS;
            let r = self.table[b];
            if r == NONE {
                return false;
            }
            let ray = &self.rays[r as usize];
            self.passes_through(ray, ix as i64, iy as i64, p)
                && !runs_along(cells, (w, h), (ix, iy), (ray.ux, ray.uy))
        })
    }
}

/// Turns flagged cells back into detections where they are the corner of a surface
/// that stays: a detected (or static) cell beside them in their row and one in their
/// column, neither cleared by this scan. A box's corner fills only part of its cell,
/// so a ray through the cell's middle can pass the corner without touching it; it says
/// nothing about the part the box fills. A box that has gone loses its faces to the
/// rays that cross them, and its corners with them or after them.
fn keep_corners(cells: &mut [u8], w: usize, h: usize, range: &Flagged) {
    let stays = |c: u8| c != aisle_geometry::FREE && c != PENDING_CLEAR;
    for i in range.lo..=range.hi {
        if cells[i] != PENDING_CLEAR {
            continue;
        }
        let (ix, iy) = (i % w, i / w);
        let beside_in_row = (ix > 0 && stays(cells[i - 1])) || (ix + 1 < w && stays(cells[i + 1]));
        let beside_in_column =
            (iy > 0 && stays(cells[i - w])) || (iy + 1 < h && stays(cells[i + w]));
        if beside_in_row && beside_in_column {
            cells[i] = OCCUPIED_DETECTED;
        }
    }
}

/// Whether a ray of direction `u` runs along the surface cell (ix, iy) is part of: an
/// occupied 8-neighbour lies within `ALONG_SURFACE` of the ray's direction, either way.
/// A ray that grazes a wall's face a few millimetres off it passes by the face's
/// returns as closely as one that went through where they were; only a ray crossing
/// the surface tells whether it is still there. An isolated detection has no surface
/// and any ray through its return clears it.
fn runs_along(
    cells: &[u8],
    (w, h): (usize, usize),
    (ix, iy): (usize, usize),
    u: (f32, f32),
) -> bool {
    const NEIGHBOURS: [(i64, i64, f32); 8] = [
        (1, 0, 1.0),
        (-1, 0, 1.0),
        (0, 1, 1.0),
        (0, -1, 1.0),
        (1, 1, std::f32::consts::FRAC_1_SQRT_2),
        (1, -1, std::f32::consts::FRAC_1_SQRT_2),
        (-1, 1, std::f32::consts::FRAC_1_SQRT_2),
        (-1, -1, std::f32::consts::FRAC_1_SQRT_2),
    ];
    NEIGHBOURS.iter().any(|&(dx, dy, norm)| {
        let (nx, ny) = (ix as i64 + dx, iy as i64 + dy);
        if nx < 0 || ny < 0 || nx >= w as i64 || ny >= h as i64 {
            return false;
        }
        let occupied = cells[ny as usize * w + nx as usize] != aisle_geometry::FREE;
        // |sin| of the angle between the ray and the direction to the neighbour.
        let sin = (u.0 * dy as f32 - u.1 * dx as f32).abs() * norm;
        occupied && sin < ALONG_SURFACE
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Small deterministic generator (no RNG crate needed for a test).
    struct Lcg(u64);
    impl Lcg {
        fn next(&mut self) -> f32 {
            self.0 = self
                .0
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((self.0 >> 40) as f32) / (1u64 << 24) as f32
        }
    }

    /// A ray for the brute-force check: unit direction, clearing stretch, return cell.
    type TestRay = ((f32, f32), f32, f32, Option<(i64, i64)>);

    /// Whether any of `rays` (sensor, unit direction, clearing stretch, end cell)
    /// passes within `radius` of `p` between the stretch's ends: the closest point of
    /// the ray's line to `p` lies on the stretch (a radius short of a return).
    fn brute_force(
        sensor: (f32, f32),
        rays: &[TestRay],
        radius: f32,
        cell: (i64, i64),
        p: (f32, f32),
    ) -> bool {
        rays.iter().any(|&((ux, uy), ra, rb, end)| {
            let stop = if end.is_some() { rb - radius } else { rb };
            let t = (p.0 - sensor.0) * ux + (p.1 - sensor.1) * uy;
            let closest = (sensor.0 + t * ux, sensor.1 + t * uy);
            let d = ((closest.0 - p.0).powi(2) + (closest.1 - p.1).powi(2)).sqrt();
            end != Some(cell) && t >= ra && t <= stop && d <= radius
        })
    }

    /// Away from the sensor, the angular table clears exactly what asking every ray does.
    #[test]
    fn matches_asking_every_ray_away_from_the_sensor() {
        let (w, h) = (120usize, 100usize);
        let mut rng = Lcg(7);
        let radius = 0.3;
        for round in 0..20 {
            let sensor = (40.0 + 40.0 * rng.next(), 30.0 + 40.0 * rng.next());
            let n = 600;
            let mut rc = RayClearing::new(n);
            rc.begin(sensor, radius);
            let mut rays = Vec::new();
            for k in 0..n {
                let a = -2.0 + 4.0 * k as f32 / (n - 1) as f32 + 0.3 * round as f32;
                let range = 5.0 + 60.0 * rng.next();
                let end = (sensor.0 + range * a.cos(), sensor.1 + range * a.sin());
                let hit = rng.next() < 0.7;
                let ta = 0.2 * rng.next();
                rc.set(k, end, ta, 1.0, hit);
                let endc = (end.0.floor() as i64, end.1.floor() as i64);
                rays.push(((a.cos(), a.sin()), ta * range, range, hit.then_some(endc)));
            }
            // Every other cell of every other row detected (isolated: no surface for a
            // ray to run along).
            let mut cells: Vec<u8> = (0..w * h)
                .map(|i| {
                    if (i % w) % 2 == 0 && (i / w) % 2 == 0 {
                        OCCUPIED_DETECTED
                    } else {
                        0
                    }
                })
                .collect();
            let mut f = Flagged::NONE;
            rc.apply(&mut cells, w, h, &mut f);
            let (mut differ, mut cleared) = (0, 0);
            for (i, &c) in cells.iter().enumerate() {
                let (ix, iy) = ((i % w) as i64, (i / w) as i64);
                if ix % 2 != 0 || iy % 2 != 0 {
                    continue;
                }
                let (x, y) = (ix as f32 + 0.5, iy as f32 + 0.5);
                if ((x - sensor.0).powi(2) + (y - sensor.1).powi(2)).sqrt() < 3.0 {
                    continue;
                }
                let p = (ix as f32 + 0.5, iy as f32 + 0.5);
                let want = brute_force(sensor, &rays, radius, (ix, iy), p);
                cleared += usize::from(want);
                if (c == PENDING_CLEAR) != want {
                    differ += 1;
                }
            }
            // f32 rounding right at the radius may flip a cell or two.
            assert!(differ <= 2, "round {round}: {differ} cells differ");
            assert!(cleared > 20, "round {round}: only {cleared} cleared");
        }
    }

    /// A ray along a wall's face, through the middle of the cells that hold the face,
    /// runs along the surface: they stay. A ray across the face clears what it crosses.
    #[test]
    fn a_ray_along_a_face_keeps_it() {
        // Cells of 0.1 m; a face in column 5.
        let (w, h) = (10usize, 30usize);
        let mut cells = vec![0u8; w * h];
        for iy in 5..25 {
            cells[iy * w + 5] = OCCUPIED_DETECTED;
        }
        let mut rc = RayClearing::new(1);
        // 0.01 m in cells of 0.1 m.
        rc.begin((5.5, 29.5), 0.1);
        // Straight down the column's middle: no hit until the floor.
        rc.set(0, (5.5, 0.5), 0.0, 1.0, false);
        let mut f = Flagged::NONE;
        rc.apply(&mut cells, w, h, &mut f);
        assert!(!cells.contains(&PENDING_CLEAR));
        // A ray across the face through the middle of one of its cells (gone) clears it.
        rc.begin((9.5, 10.5), 0.1);
        rc.set(0, (0.5, 10.5), 0.0, 1.0, false);
        rc.apply(&mut cells, w, h, &mut f);
        assert_eq!(cells[10 * w + 5], PENDING_CLEAR);
        assert_eq!(cells.iter().filter(|&&c| c == PENDING_CLEAR).count(), 1);
        // One a cell apart from the middle, a little off its centre, does not.
        rc.begin((9.5, 12.65), 0.1);
        rc.set(0, (0.5, 12.65), 0.0, 1.0, false);
        rc.apply(&mut cells, w, h, &mut f);
        assert_eq!(cells.iter().filter(|&&c| c == PENDING_CLEAR).count(), 1);
    }

    /// A ray through the middle of a box's corner cell, past the corner, leaves the
    /// corner while the box's faces stay; once the faces are crossed too, it goes.
    #[test]
    fn a_corner_stays_while_its_faces_do() {
        // A box's south-west corner in cell (5, 5): faces along row 5 and column 5.
        let (w, h) = (12usize, 12usize);
        let mut cells = vec![0u8; w * h];
        for k in 5..9 {
            cells[5 * w + k] = OCCUPIED_DETECTED;
            cells[k * w + 5] = OCCUPIED_DETECTED;
        }
        let corner = 5 * w + 5;
        // North-west to south-east through the corner cell's middle: 45 degrees off
        // both faces, so it runs along neither.
        let mut rc = RayClearing::new(1);
        rc.begin((0.5, 10.5), 0.1);
        rc.set(0, (10.5, 0.5), 0.0, 1.0, false);
        let mut f = Flagged::NONE;
        rc.apply(&mut cells, w, h, &mut f);
        assert_eq!(cells[corner], OCCUPIED_DETECTED);
        assert!(!cells.contains(&PENDING_CLEAR));
        // The box gone: from the south-west, rays through the corner's middle and
        // through the middles of its faces' first cells, (6, 5) and (5, 6), crossing
        // them. The corner goes with its faces.
        let mut rc = RayClearing::new(3);
        rc.begin((0.5, 0.5), 0.1);
        rc.set(0, (11.5, 11.5), 0.0, 1.0, false);
        rc.set(1, (12.5, 10.5), 0.0, 1.0, false);
        rc.set(2, (10.5, 12.5), 0.0, 1.0, false);
        let mut f = Flagged::NONE;
        rc.apply(&mut cells, w, h, &mut f);
        assert_eq!(cells[corner], PENDING_CLEAR);
        assert_eq!(cells[5 * w + 6], PENDING_CLEAR);
        assert_eq!(cells[6 * w + 5], PENDING_CLEAR);
    }

    #[test]
    fn static_and_free_cells_are_untouched() {
        let mut rc = RayClearing::new(1);
        rc.begin((0.5, 0.5), 0.1);
        rc.set(0, (9.5, 0.5), 0.0, 1.0, true);
        // Detections apart (no surface along the ray), one static cell, the return last.
        let mut cells = vec![0u8, 2, 0, 1, 0, 2, 0, 2, 0, 2];
        let mut f = Flagged::NONE;
        rc.apply(&mut cells, 10, 1, &mut f);
        assert_eq!(cells, vec![0, 3, 0, 1, 0, 3, 0, 3, 0, 2]);
        assert_eq!((f.lo, f.hi), (1, 7));
    }
}
