//! The lidar obstacle layer: marks lidar returns as `OCCUPIED_DETECTED` cells of the
//! global grid and clears detections that later rays see through.
//!
//! One scan, in this order (clearing first, so that whatever this scan sees is marked
//! again after any clearing, and a ray never erases an obstacle another ray of the same
//! scan hits):
//!
//! 1. **Clear.** In every azimuth column only the *lowest* ray in the world (the row
//!    whose world direction has the smallest vertical component; row 0 = 0 deg for the
//!    seed's level lidar) clears. Its 2D projection clears from the sensor to just
//!    before its return, or to `max_range` along the ray when it has none, and only over
//!    the part of the ray that lies inside the obstacle height band. A detection on the
//!    way becomes free when the ray passes through the middle of its cell (within
//!    `clear_radius` of the centre) and crosses the surface the cell is part of, rather
//!    than running along it (the private `clearing` module says why); static cells are
//!    never touched. Only detected cells are visited, not every cell of every ray.
//!    *Why the lowest ray only:* a ray proves a column empty only at its own height. A
//!    higher ray passing over a low obstacle (a 0.9 m pallet stack seen by the rows below)
//!    would erase it, and would erase anything hidden behind it. The lowest ray passes
//!    over nothing the lidar can detect (with elevations >= 0 nothing lower than the
//!    sensor is ever seen), so what it crosses is really gone. Limitation: an overhang
//!    (a rack deck) that only higher rows hit is cleared by the lowest ray passing under
//!    it when those rows no longer see it in the same scan.
//! 2. **Forget the ignored rectangles.** Detected cells whose centre lies in the robot's
//!    footprint, the carried rack's footprint or a supervisor-given rectangle (the rack
//!    being approached, grown by the ignore margin) are cleared, so they never stay
//!    obstacles from earlier scans. The robot's and the carried rack's margin ring is
//!    not cleared: a pallet seen beside the carried rack stays on the map when the rack
//!    comes within the ring of it (the controller must see it to keep off it; clearing
//!    it there let a backed-off band swing the rack into it).
//! 3. **Mark.** Every return whose world height is within the band and which is in none of
//!    those rectangles marks its cell `OCCUPIED_DETECTED` (static cells stay static).
//! 4. **Settle.** Steps 1 and 2 only *flag* cells (an internal value that never leaves
//!    `update`); step 3 turns a flagged cell it hits back into a detection, and only the
//!    flagged cells left over become free. So a cell cleared and re-marked in the same
//!    scan is no change, and [`ScanStats::changed`] means the grid really differs.
//!
//! Detections are kept in the global grid, so they persist when out of view until a
//! lowest ray crosses them. The update allocates nothing: the beam and ray tables are built once.
//! Knows nothing of the bus, the scene or how the map is published.

use crate::clearing::{Flagged, PENDING_CLEAR, RayClearing};
use crate::cloud::{BeamGeometry, OrganizedCloud, SensorPose};
use crate::config::ObstacleConfig;
use crate::error::MapError;
use aisle_geometry::{FREE, Footprint, GridMap, OCCUPIED_DETECTED, Pose2};

/// Rectangles beyond the robot and its carried rack one scan may ignore.
pub const MAX_IGNORE_ZONES: usize = 6;
const MAX_ZONES: usize = MAX_IGNORE_ZONES + 2;

/// A rectangle whose points are not obstacles.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IgnoreZone {
    pub pose: Pose2,
    pub footprint: Footprint,
}

/// One lidar scan and where everything was when it was taken.
#[derive(Debug, Clone, Copy)]
pub struct Scan<'a> {
    pub cloud: OrganizedCloud<'a>,
    /// Sensor pose in the map frame.
    pub sensor: SensorPose,
    /// Robot base pose in the map frame.
    pub robot: Pose2,
    /// The robot's own footprint, centred on `robot`.
    pub robot_footprint: Footprint,
    /// The carried rack; its pose is relative to the robot base.
    pub carried: Option<IgnoreZone>,
    /// Map-frame rectangles to ignore, e.g. the rack being approached for a pick.
    pub ignore: &'a [IgnoreZone],
}

/// What one update did (for logs and metrics).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ScanStats {
    /// Points with a return.
    pub returns: u32,
    /// Returns outside the obstacle height band.
    pub out_of_band: u32,
    /// Returns inside an ignored rectangle.
    pub ignored: u32,
    /// Returns that marked a cell (or hit a cell already occupied).
    pub marked: u32,
    /// Cells that went from free to detected.
    pub newly_detected: u32,
    /// Detected cells made free again (net: a cell cleared and re-marked by the same
    /// scan is not counted).
    pub cleared: u32,
    /// Row-major indices of the first and last cell the update may have changed
    /// (`None`: it changed none): where to look for what changed.
    pub written: Option<(usize, usize)>,
}

impl ScanStats {
    /// Whether the grid changed.
    pub fn changed(&self) -> bool {
        self.newly_detected > 0 || self.cleared > 0
    }
}

/// A rectangle in grid units (cells), ready for point tests.
#[derive(Debug, Clone, Copy, Default)]
struct Zone {
    cx: f32,
    cy: f32,
    c: f32,
    s: f32,
    /// Half extents grown by the ignore margin: no return inside marks a cell.
    hl: f32,
    hw: f32,
    /// Half extents within which earlier detections are forgotten: the body itself for
    /// the robot and its carried rack, whose margin ring must keep what was seen there
    /// (an obstacle next to the body is exactly what must not vanish); the grown
    /// rectangle for a body the supervisor ignores (the rack being approached).
    clear_hl: f32,
    clear_hw: f32,
}

impl Zone {
    #[inline(always)]
    fn contains(&self, gx: f32, gy: f32) -> bool {
        self.within(gx, gy, self.hl, self.hw)
    }

    #[inline(always)]
    fn clears(&self, gx: f32, gy: f32) -> bool {
        self.within(gx, gy, self.clear_hl, self.clear_hw)
    }

    #[inline(always)]
    fn within(&self, gx: f32, gy: f32, hl: f32, hw: f32) -> bool {
        let dx = gx - self.cx;
        let dy = gy - self.cy;
        (self.c * dx + self.s * dy).abs() <= hl && (self.c * dy - self.s * dx).abs() <= hw
    }
}

/// The layer's fixed tables; the grid it writes to is passed to [`ObstacleLayer::update`].
#[derive(Debug, Clone)]
pub struct ObstacleLayer {
    cfg: ObstacleConfig,
    beams: BeamGeometry,
    cos_el: Vec<f32>,
    sin_el: Vec<f32>,
    cos_az: Vec<f32>,
    sin_az: Vec<f32>,
    /// Per-scan ray tables, reused so an update allocates nothing.
    clearing: RayClearing,
}

impl ObstacleLayer {
    pub fn new(cfg: &ObstacleConfig, beams: BeamGeometry) -> Result<Self, MapError> {
        crate::cloud::check_beams(&beams)?;
        let el: Vec<f64> = (0..beams.rows).map(|r| beams.elevation(r)).collect();
        let az: Vec<f64> = (0..beams.cols).map(|c| beams.azimuth(c)).collect();
        Ok(Self {
            cfg: cfg.clone(),
            beams,
            cos_el: el.iter().map(|e| e.cos() as f32).collect(),
            sin_el: el.iter().map(|e| e.sin() as f32).collect(),
            cos_az: az.iter().map(|a| a.cos() as f32).collect(),
            sin_az: az.iter().map(|a| a.sin() as f32).collect(),
            clearing: RayClearing::new(beams.cols),
        })
    }

    pub fn beams(&self) -> &BeamGeometry {
        &self.beams
    }

    /// Integrates one scan into `grid` (cells `FREE`, `OCCUPIED_STATIC` or
    /// `OCCUPIED_DETECTED`). Refuses a cloud of the wrong shape, non-finite poses and
    /// too many ignore zones; NaN points are "no return". Allocation-free.
    pub fn update(&mut self, grid: &mut GridMap, scan: &Scan<'_>) -> Result<ScanStats, MapError> {
        let (rows, cols) = (self.beams.rows, self.beams.cols);
        let cloud = &scan.cloud;
        if cloud.rows != rows || cloud.cols != cols || cloud.points.len() != rows * cols {
            return Err(MapError::CloudShape {
                rows: cloud.rows,
                cols: cloud.cols,
                len: cloud.points.len(),
                exp_rows: rows,
                exp_cols: cols,
            });
        }
        if !scan.sensor.is_finite() {
            return Err(MapError::NotFinite {
                what: "sensor pose",
            });
        }
        if !scan.robot.is_finite() {
            return Err(MapError::NotFinite { what: "robot pose" });
        }
        if scan.ignore.len() > MAX_IGNORE_ZONES {
            return Err(MapError::TooMany {
                what: "ignore zones",
                got: scan.ignore.len(),
                max: MAX_IGNORE_ZONES,
            });
        }
        let frame = GridFrame::new(grid, &scan.sensor);
        let mut zones = [Zone::default(); MAX_ZONES];
        let n_zones = self.zones(scan, &frame, &mut zones)?;
        let zones = &zones[..n_zones];

        let mut stats = ScanStats::default();
        let mut flagged = Flagged::NONE;
        self.clear_along_lowest_rays(grid, scan, &frame, &mut flagged);
        clear_zones(grid, zones, &mut flagged);
        let marked = self.mark(grid, cloud, &frame, zones, &mut stats);
        // Marks turn free or flagged cells into detections; flagged cells are resolved
        // below, within their span: what changed lies within the two spans.
        let lo = flagged.lo.min(marked.lo);
        let hi = flagged.hi.max(marked.hi);
        stats.written = (lo <= hi).then_some((lo, hi));
        if flagged.lo <= flagged.hi {
            // Branch-free so it vectorises: the range can span most of the grid.
            let mut cleared = 0u32;
            for c in &mut grid.cells[flagged.lo..=flagged.hi] {
                let pending = *c == PENDING_CLEAR;
                cleared += u32::from(pending);
                *c = if pending { FREE } else { *c };
            }
            stats.cleared = cleared;
        }
        Ok(stats)
    }

    /// The ignored rectangles of this scan in grid units, grown by the margin.
    fn zones(
        &self,
        scan: &Scan<'_>,
        f: &GridFrame,
        out: &mut [Zone; MAX_ZONES],
    ) -> Result<usize, MapError> {
        let margin = self.cfg.ignore_margin;
        let mut n = 0;
        let mut push = |pose: Pose2, fp: Footprint, body: bool| -> Result<(), MapError> {
            if !(pose.is_finite() && fp.length.is_finite() && fp.width.is_finite()) {
                return Err(MapError::NotFinite {
                    what: "ignore zone",
                });
            }
            let (s, c) = pose.theta.sin_cos();
            let clear = if body { 0.0 } else { margin };
            out[n] = Zone {
                cx: ((pose.x - f.origin_x) * f.inv_res) as f32,
                cy: ((pose.y - f.origin_y) * f.inv_res) as f32,
                c: c as f32,
                s: s as f32,
                hl: ((0.5 * fp.length.max(0.0) + margin) * f.inv_res) as f32,
                hw: ((0.5 * fp.width.max(0.0) + margin) * f.inv_res) as f32,
                clear_hl: ((0.5 * fp.length.max(0.0) + clear) * f.inv_res) as f32,
                clear_hw: ((0.5 * fp.width.max(0.0) + clear) * f.inv_res) as f32,
            };
            n += 1;
            Ok(())
        };
        push(scan.robot, scan.robot_footprint, true)?;
        if let Some(z) = scan.carried {
            push(scan.robot.compose(&z.pose), z.footprint, true)?;
        }
        for z in scan.ignore {
            push(z.pose, z.footprint, false)?;
        }
        Ok(n)
    }

    fn clear_along_lowest_rays(
        &mut self,
        grid: &mut GridMap,
        scan: &Scan<'_>,
        f: &GridFrame,
        flagged: &mut Flagged,
    ) {
        let [lo, hi] = self.cfg.height_band;
        let (lo, hi) = (lo as f32, hi as f32);
        let max_range = self.cfg.max_range as f32;
        let (w, h) = (grid.width, grid.height);
        let cols = self.beams.cols;
        let r = f.rot;
        let radius = (self.cfg.clear_radius * f.inv_res) as f32;
        self.clearing.begin((f.sensor[0], f.sensor[1]), radius);
        for c in 0..cols {
            let (ca, sa) = (self.cos_az[c], self.sin_az[c]);
            // World z of beam (row, c) is cos_el * k + r[2][2] * sin_el.
            let k = r[2][0] * ca + r[2][1] * sa;
            let mut best = 0;
            let mut best_z = f32::INFINITY;
            for (row, (&ce, &se)) in self.cos_el.iter().zip(self.sin_el.iter()).enumerate() {
                let z = ce * k + r[2][2] * se;
                if z < best_z {
                    best_z = z;
                    best = row;
                }
            }
            let p = scan.cloud.points[best * cols + c];
            let hit = p.iter().all(|v| v.is_finite());
            let p = if hit {
                p
            } else {
                let (ce, se) = (self.cos_el[best], self.sin_el[best]);
                [max_range * ce * ca, max_range * ce * sa, max_range * se]
            };
            let end = f.to_grid(p);
            // Part of the segment (fraction t of sensor -> end) inside the height band.
            let (z0, z1) = (f.sensor[2], end[2]);
            let dz = z1 - z0;
            let (ta, tb) = if dz.abs() < 1e-6 {
                if z0 < lo || z0 > hi {
                    continue;
                }
                (0.0, 1.0)
            } else {
                let a = (lo - z0) / dz;
                let b = (hi - z0) / dz;
                (a.min(b).max(0.0), a.max(b).min(1.0))
            };
            if ta >= tb {
                continue;
            }
            self.clearing.set(c, (end[0], end[1]), ta, tb, hit);
        }
        self.clearing.apply(&mut grid.cells, w, h, flagged);
    }

    fn mark(
        &self,
        grid: &mut GridMap,
        cloud: &OrganizedCloud<'_>,
        f: &GridFrame,
        zones: &[Zone],
        stats: &mut ScanStats,
    ) -> Flagged {
        let mut newly = Flagged::NONE;
        let [lo, hi] = self.cfg.height_band;
        let (lo, hi) = (lo as f32, hi as f32);
        let (w, h) = (grid.width, grid.height);
        let (wf, hf) = (w as f32, h as f32);
        let cells = &mut grid.cells[..];
        for p in cloud.points {
            if !(p[0].is_finite() && p[1].is_finite() && p[2].is_finite()) {
                continue;
            }
            stats.returns += 1;
            let [gx, gy, z] = f.to_grid(*p);
            if z < lo || z > hi {
                stats.out_of_band += 1;
                continue;
            }
            if zones.iter().any(|zn| zn.contains(gx, gy)) {
                stats.ignored += 1;
                continue;
            }
            if !(gx >= 0.0 && gy >= 0.0 && gx < wf && gy < hf) {
                continue;
            }
            let i = gy as usize * w + gx as usize;
            stats.marked += 1;
            match cells[i] {
                FREE => {
                    cells[i] = OCCUPIED_DETECTED;
                    stats.newly_detected += 1;
                    newly.lo = newly.lo.min(i);
                    newly.hi = newly.hi.max(i);
                }
                PENDING_CLEAR => cells[i] = OCCUPIED_DETECTED,
                _ => {}
            }
        }
        newly
    }
}

/// Flags detected cells whose centre lies in any zone's clearing extents.
fn clear_zones(grid: &mut GridMap, zones: &[Zone], flagged: &mut Flagged) {
    let (w, h) = (grid.width, grid.height);
    for z in zones {
        // Half extents of the zone's bounding box, grid units.
        let ex = z.c.abs() * z.hl + z.s.abs() * z.hw;
        let ey = z.s.abs() * z.hl + z.c.abs() * z.hw;
        let x0 = (z.cx - ex).floor().max(0.0);
        let y0 = (z.cy - ey).floor().max(0.0);
        let x1 = (z.cx + ex).ceil().min(w as f32);
        let y1 = (z.cy + ey).ceil().min(h as f32);
        if !(x0 < x1 && y0 < y1) {
            continue;
        }
        for iy in y0 as usize..y1 as usize {
            for ix in x0 as usize..x1 as usize {
                let i = iy * w + ix;
                if z.clears(ix as f32 + 0.5, iy as f32 + 0.5) {
                    flagged.flag(&mut grid.cells, i);
                }
            }
        }
    }
}

/// The sensor-to-grid transform of one scan: x and y come out in cell units relative to
/// the grid's origin corner, z in metres. f32 keeps the hot loop narrow; at 1/10 m cells
/// over a few hundred cells its rounding is far below a cell.
struct GridFrame {
    origin_x: f64,
    origin_y: f64,
    inv_res: f64,
    /// Rows x and y scaled to cells, row z in metres.
    rot: [[f32; 3]; 3],
    /// The sensor origin in the same units.
    sensor: [f32; 3],
}

impl GridFrame {
    fn new(grid: &GridMap, pose: &SensorPose) -> Self {
        let inv_res = 1.0 / grid.resolution;
        let scale = [inv_res, inv_res, 1.0];
        let shift = [grid.origin_x, grid.origin_y, 0.0];
        let mut rot = [[0.0f32; 3]; 3];
        let mut sensor = [0.0f32; 3];
        // The rotation's z row stays unscaled (metres) for beam heights.
        for (i, row) in rot.iter_mut().enumerate() {
            for (out, &v) in row.iter_mut().zip(&pose.rotation[i]) {
                *out = (v * scale[i]) as f32;
            }
            sensor[i] = ((pose.position[i] - shift[i]) * scale[i]) as f32;
        }
        Self {
            origin_x: grid.origin_x,
            origin_y: grid.origin_y,
            inv_res,
            rot,
            sensor,
        }
    }

    #[inline(always)]
    fn to_grid(&self, p: [f32; 3]) -> [f32; 3] {
        let r = &self.rot;
        let t = &self.sensor;
        [
            r[0][0] * p[0] + r[0][1] * p[1] + r[0][2] * p[2] + t[0],
            r[1][0] * p[0] + r[1][1] * p[1] + r[1][2] * p[2] + t[1],
            r[2][0] * p[0] + r[2][1] * p[1] + r[2][2] * p[2] + t[2],
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::MapConfig;
    use crate::static_map::empty_grid;
    use crate::synthetic::{WorldBox, cast_cloud};
    use aisle_geometry::OCCUPIED_STATIC;
    use std::f64::consts::FRAC_PI_2;

    const JACKAL: Footprint = Footprint::new(0.508, 0.43);
    const RACK: Footprint = Footprint::new(0.88, 0.8);
    const SENSOR_Z: f64 = 0.3;

    fn layer() -> ObstacleLayer {
        ObstacleLayer::new(&MapConfig::default().obstacles, BeamGeometry::default()).unwrap()
    }

    fn grid() -> GridMap {
        empty_grid(&MapConfig::default()).unwrap()
    }

    /// The robot at `robot`, its lidar 0.25 m ahead of the base at `SENSOR_Z`.
    fn sensor_on(robot: Pose2) -> SensorPose {
        let (x, y) = robot.transform_point(0.25, 0.0);
        SensorPose::level(x, y, SENSOR_Z, robot.theta)
    }

    fn scan_of<'a>(points: &'a [[f32; 3]], robot: Pose2, ignore: &'a [IgnoreZone]) -> Scan<'a> {
        let b = BeamGeometry::default();
        Scan {
            cloud: OrganizedCloud::new(b.rows, b.cols, points).unwrap(),
            sensor: sensor_on(robot),
            robot,
            robot_footprint: JACKAL,
            carried: None,
            ignore,
        }
    }

    fn cast(boxes: &[WorldBox], robot: Pose2) -> Vec<[f32; 3]> {
        let mut out = Vec::new();
        cast_cloud(
            boxes,
            &sensor_on(robot),
            &BeamGeometry::default(),
            12.0,
            &mut out,
        );
        out
    }

    /// Detected cells whose centre lies within `margin` of the box's footprint.
    fn detected_near(g: &GridMap, b: &WorldBox, margin: f64) -> usize {
        let fp = Footprint::new(2.0 * b.half_x, 2.0 * b.half_y).inflated(margin);
        let v = g.view();
        (0..g.cells.len())
            .filter(|&i| g.cells[i] == OCCUPIED_DETECTED)
            .filter(|&i| {
                let c = aisle_geometry::CellIndex {
                    ix: (i % g.width) as i64,
                    iy: (i / g.width) as i64,
                };
                let (x, y) = v.cell_center(c);
                fp.contains(&b.pose, x, y)
            })
            .count()
    }

    fn detected(g: &GridMap) -> usize {
        g.cells.iter().filter(|&&c| c == OCCUPIED_DETECTED).count()
    }

    #[test]
    fn an_obstacle_that_leaves_is_forgotten() {
        let mut l = layer();
        let mut g = grid();
        let stack = WorldBox::standing(3.0, 0.0, 0.0, [1.0, 0.7, 0.944]);
        let robot = Pose2::default();
        let with = cast(&[stack], robot);
        let s = l.update(&mut g, &scan_of(&with, robot, &[])).unwrap();
        let seen = detected_near(&g, &stack, 0.1);
        assert!(seen >= 7, "the stack's face spans 7 cells, {seen} detected");
        assert_eq!(detected(&g), seen, "nothing else is detected");
        assert!(s.newly_detected as usize == seen && s.cleared == 0, "{s:?}");
        // The stack is taken away: the next scan sees through its cells.
        let without = cast(&[], robot);
        let s = l.update(&mut g, &scan_of(&without, robot, &[])).unwrap();
        assert_eq!(detected(&g), 0);
        assert_eq!(s.cleared as usize, seen);
        assert_eq!(s.returns, 0);
    }

    /// A barrier seen head-on, then passed close along its face: the rays that graze the
    /// face cross the cells holding it without a hit, and must not erase it (a sweep's
    /// robot backed into a barrier lost that way).
    #[test]
    fn a_face_passed_close_along_stays_detected() {
        let mut l = layer();
        let mut g = grid();
        let barrier = WorldBox::standing(6.783, 8.0, 0.0, [0.3, 1.866, 0.92]);
        let head_on = Pose2::new(9.0, 8.0, std::f64::consts::PI);
        l.update(&mut g, &scan_of(&cast(&[barrier], head_on), head_on, &[]))
            .unwrap();
        let face: Vec<usize> = (0..g.cells.len())
            .filter(|&i| g.cells[i] == OCCUPIED_DETECTED)
            .collect();
        assert!(
            face.len() >= 18,
            "the face spans 19 cells, {} seen",
            face.len()
        );
        // North of it, the sensor 0.05-0.25 m out from the face's line, looking back
        // along it (as the robot that lost one did).
        for k in 0..6 {
            let y = 10.5 - 0.25 * k as f64;
            for x in [7.1, 7.2, 7.3, 7.4] {
                for heading in [2.64, 2.3] {
                    let pose = Pose2::new(x, y, heading);
                    let cloud = cast(&[barrier], pose);
                    l.update(&mut g, &scan_of(&cloud, pose, &[])).unwrap();
                }
            }
        }
        let kept = face
            .iter()
            .filter(|&&i| g.cells[i] == OCCUPIED_DETECTED)
            .count();
        assert_eq!(kept, face.len(), "face cells lost");
    }

    #[test]
    fn detections_persist_out_of_view() {
        let mut l = layer();
        let mut g = grid();
        let stack = WorldBox::standing(3.0, 0.0, 0.0, [1.0, 0.7, 0.944]);
        let cloud = cast(&[stack], Pose2::default());
        l.update(&mut g, &scan_of(&cloud, Pose2::default(), &[]))
            .unwrap();
        let seen = detected(&g);
        // Turned away: the stack is behind the 240 deg field of view.
        let away = Pose2::new(0.0, 0.0, std::f64::consts::PI);
        let cloud = cast(&[stack], away);
        l.update(&mut g, &scan_of(&cloud, away, &[])).unwrap();
        assert_eq!(detected_near(&g, &stack, 0.1), seen);
    }

    #[test]
    fn a_ray_over_a_low_obstacle_does_not_erase_what_it_hides() {
        let mut l = layer();
        let mut g = grid();
        let near = WorldBox::standing(3.0, 0.0, 0.0, [0.4, 0.4, 0.5]);
        let far = WorldBox::standing(5.0, 0.0, 0.0, [0.4, 0.4, 0.5]);
        let boxes = [near, far];
        // Seen from the side first: both are detected.
        let side = Pose2::new(5.0, -3.0, FRAC_PI_2);
        let cloud = cast(&boxes, side);
        l.update(&mut g, &scan_of(&cloud, side, &[])).unwrap();
        let far_cells = detected_near(&g, &far, 0.1);
        assert!(far_cells > 0 && detected_near(&g, &near, 0.1) > 0);
        // From behind the near box, the far one is hidden from the lowest rays while the
        // rays above 4 deg pass over both inside the height band.
        let behind = Pose2::default();
        let cloud = cast(&boxes, behind);
        l.update(&mut g, &scan_of(&cloud, behind, &[])).unwrap();
        assert_eq!(detected_near(&g, &far, 0.1), far_cells);
        assert!(detected_near(&g, &near, 0.1) > 0);
    }

    #[test]
    fn the_robot_and_the_carried_rack_are_never_obstacles() {
        let mut l = layer();
        let mut g = grid();
        let robot = Pose2::new(2.0, 5.0, 0.7);
        let rack_parts = [
            ([0.415, 0.375, 0.15], [0.05, 0.05, 0.30]),
            ([-0.415, 0.375, 0.15], [0.05, 0.05, 0.30]),
            ([-0.415, -0.375, 0.15], [0.05, 0.05, 0.30]),
            ([0.415, -0.375, 0.15], [0.05, 0.05, 0.30]),
            ([0.0, 0.0, 0.325], [0.88, 0.80, 0.05]),
            ([0.2, 0.0, 0.675], [0.38, 0.60, 0.65]),
        ];
        let boxes: Vec<WorldBox> = rack_parts
            .iter()
            .map(|(c, s)| {
                let (x, y) = robot.transform_point(c[0], c[1]);
                WorldBox {
                    pose: Pose2::new(x, y, robot.theta),
                    z_min: c[2] - 0.5 * s[2],
                    z_max: c[2] + 0.5 * s[2],
                    half_x: 0.5 * s[0],
                    half_y: 0.5 * s[1],
                }
            })
            .collect();
        let mut cloud = cast(&boxes, robot);
        // Points on the robot's own body (sensor frame: behind and below the lidar).
        let own = [
            [-0.2f32, -0.1, -0.1],
            [-0.45, 0.1, -0.2],
            [-0.05, 0.05, -0.05],
        ];
        for (k, p) in own.iter().enumerate() {
            cloud[k * 97] = *p;
        }
        let carried = IgnoreZone {
            pose: Pose2::default(),
            footprint: RACK,
        };
        let mut scan = scan_of(&cloud, robot, &[]);
        // Without the carried rack the test would see it: the cloud really hits the rack.
        let mut probe = g.clone();
        l.update(&mut probe, &scan).unwrap();
        assert!(detected(&probe) > 0);
        scan.carried = Some(carried);
        let s = l.update(&mut g, &scan).unwrap();
        assert_eq!(detected(&g), 0, "{s:?}");
        assert!(s.ignored > 100, "{s:?}");
        // A stale detection under the rack (from before the pick) is forgotten too.
        g.set(g.view().cell_of(robot.x + 0.3, robot.y), OCCUPIED_DETECTED);
        l.update(&mut g, &scan).unwrap();
        assert_eq!(detected(&g), 0);
    }

    /// What a scan forgets without seeing through it: the cells under the robot and its
    /// rack, and the grown rectangle of a rack being approached; not the margin ring of
    /// the robot and its rack, where an obstacle just seen beside them stays.
    #[test]
    fn the_ring_beside_the_carried_rack_keeps_its_detections() {
        let l = layer();
        let mut g = grid();
        let robot = Pose2::new(2.0, 5.0, 0.0);
        // The rack's edge at x = 2.44: cell [2.4, 2.5) has its centre 0.01 m beyond it,
        // within the ignore margin; [2.3, 2.4) lies under the rack. The same for a rack
        // being approached at x = 8.
        let at = |x: f64| g.view().cell_of(x, robot.y);
        let (ring, under, approached) = (at(2.47), at(2.37), at(8.47));
        for c in [ring, under, approached] {
            g.set(c, OCCUPIED_DETECTED);
        }
        let cloud = vec![[f32::NAN; 3]; 31 * 1201];
        let zone = [IgnoreZone {
            pose: Pose2::new(8.0, 5.0, 0.0),
            footprint: RACK,
        }];
        let mut scan = scan_of(&cloud, robot, &zone);
        scan.carried = Some(IgnoreZone {
            pose: Pose2::default(),
            footprint: RACK,
        });
        let frame = GridFrame::new(&g, &scan.sensor);
        let mut zones = [Zone::default(); MAX_ZONES];
        let n = l.zones(&scan, &frame, &mut zones).unwrap();
        let mut flagged = Flagged::NONE;
        clear_zones(&mut g, &zones[..n], &mut flagged);
        assert_eq!(g.view().get(ring), Some(OCCUPIED_DETECTED));
        assert_eq!(g.view().get(under), Some(PENDING_CLEAR));
        assert_eq!(g.view().get(approached), Some(PENDING_CLEAR));
        // And a return in the ring still marks nothing (range noise on the rack's edges).
        let grid_units = |v: f64, o: f64| ((v - o) * frame.inv_res) as f32;
        let (gx, gy) = (
            grid_units(2.47, frame.origin_x),
            grid_units(robot.y, frame.origin_y),
        );
        assert!(zones[1].contains(gx, gy) && !zones[1].clears(gx, gy));
    }

    #[test]
    fn the_rack_being_approached_is_ignored() {
        let mut l = layer();
        let mut g = grid();
        let rack = WorldBox::standing(2.0, 13.0, FRAC_PI_2, [0.88, 0.8, 1.0]);
        let robot = Pose2::new(2.0, 11.0, FRAC_PI_2);
        let cloud = cast(&[rack], robot);
        l.update(&mut g, &scan_of(&cloud, robot, &[])).unwrap();
        assert!(detected_near(&g, &rack, 0.1) > 0);
        let zone = [IgnoreZone {
            pose: rack.pose,
            footprint: RACK,
        }];
        l.update(&mut g, &scan_of(&cloud, robot, &zone)).unwrap();
        assert_eq!(detected(&g), 0);
    }

    #[test]
    fn static_cells_are_never_cleared_or_relabelled() {
        let mut l = layer();
        let mut g = grid();
        // A static strip across the view that is not in the world (map error or a door).
        for k in 0..20 {
            g.set(
                g.view().cell_of(2.05, -1.0 + 0.1 * k as f64),
                OCCUPIED_STATIC,
            );
        }
        // And a real box standing on a static cell.
        let b = WorldBox::standing(4.0, 1.0, 0.0, [0.3, 0.3, 0.6]);
        let c = g.view().cell_of(3.9, 1.0);
        g.set(c, OCCUPIED_STATIC);
        let before = g.clone();
        let cloud = cast(&[b], Pose2::default());
        l.update(&mut g, &scan_of(&cloud, Pose2::default(), &[]))
            .unwrap();
        for (i, (&a, &now)) in before.cells.iter().zip(&g.cells).enumerate() {
            if a == OCCUPIED_STATIC {
                assert_eq!(now, OCCUPIED_STATIC, "cell {i}");
            }
        }
        assert_eq!(g.view().get(c), Some(OCCUPIED_STATIC));
    }

    #[test]
    fn no_return_clears_up_to_max_range() {
        let mut l = layer();
        let mut g = grid();
        let near = g.view().cell_of(11.55, 0.05);
        let far = g.view().cell_of(12.55, 0.05);
        g.set(near, OCCUPIED_DETECTED);
        g.set(far, OCCUPIED_DETECTED);
        let cloud = vec![[f32::NAN; 3]; 31 * 1201];
        l.update(&mut g, &scan_of(&cloud, Pose2::new(-0.25, 0.0, 0.0), &[]))
            .unwrap();
        assert_eq!(g.view().get(near), Some(FREE));
        assert_eq!(g.view().get(far), Some(OCCUPIED_DETECTED));
    }

    #[test]
    fn a_pitched_sensor_clears_only_inside_the_band() {
        let mut l = layer();
        let mut g = grid();
        let floor = WorldBox {
            pose: Pose2::default(),
            z_min: -0.1,
            z_max: 0.0,
            half_x: 50.0,
            half_y: 50.0,
        };
        // Pitched 5 deg down: row 0 meets the floor 3.43 m ahead and leaves the height
        // band (0.05 m) at 2.86 m.
        let sensor = SensorPose::from_rpy([0.0, 0.0, SENSOR_Z], 0.0, 5f64.to_radians(), 0.0);
        let mut cloud = Vec::new();
        cast_cloud(
            &[floor],
            &sensor,
            &BeamGeometry::default(),
            12.0,
            &mut cloud,
        );
        let inside = g.view().cell_of(2.55, 0.05);
        let beyond = g.view().cell_of(3.15, 0.05);
        g.set(inside, OCCUPIED_DETECTED);
        g.set(beyond, OCCUPIED_DETECTED);
        let mut scan = scan_of(&cloud, Pose2::new(-0.25, 0.0, 0.0), &[]);
        scan.sensor = sensor;
        let s = l.update(&mut g, &scan).unwrap();
        assert!(
            s.out_of_band > 1000,
            "floor returns are not obstacles: {s:?}"
        );
        assert_eq!(s.newly_detected, 0);
        assert_eq!(g.view().get(inside), Some(FREE));
        assert_eq!(g.view().get(beyond), Some(OCCUPIED_DETECTED));
    }

    #[test]
    fn same_scans_give_the_same_grid() {
        let boxes = [
            WorldBox::standing(3.0, 1.0, 0.3, [1.0, 0.7, 0.944]),
            WorldBox::standing(6.0, -2.0, 0.0, [0.5, 0.5, 0.5]),
        ];
        let run = || {
            let mut l = layer();
            let mut g = grid();
            let mut stats = Vec::new();
            for k in 0..5 {
                let robot = Pose2::new(0.3 * k as f64, 0.1 * k as f64, 0.05 * k as f64);
                let cloud = cast(&boxes, robot);
                stats.push(l.update(&mut g, &scan_of(&cloud, robot, &[])).unwrap());
            }
            (g, stats)
        };
        let (a, sa) = run();
        let (b, sb) = run();
        assert_eq!(a.cells, b.cells);
        assert_eq!(sa, sb);
        assert!(detected(&a) > 0);
    }

    #[test]
    fn bad_input_is_an_error_not_a_panic() {
        let mut l = layer();
        let mut g = grid();
        let cloud = vec![[f32::NAN; 3]; 31 * 1201];
        let mut scan = scan_of(&cloud, Pose2::default(), &[]);
        let short = vec![[0.0f32; 3]; 10];
        scan.cloud = OrganizedCloud::new(2, 5, &short).unwrap();
        assert!(matches!(
            l.update(&mut g, &scan),
            Err(MapError::CloudShape { .. })
        ));
        let mut scan = scan_of(&cloud, Pose2::default(), &[]);
        scan.sensor.position[2] = f64::NAN;
        assert!(matches!(
            l.update(&mut g, &scan),
            Err(MapError::NotFinite { .. })
        ));
        let mut scan = scan_of(&cloud, Pose2::default(), &[]);
        scan.robot.theta = f64::INFINITY;
        assert!(l.update(&mut g, &scan).is_err());
        let zones = [IgnoreZone {
            pose: Pose2::default(),
            footprint: RACK,
        }; MAX_IGNORE_ZONES + 1];
        let scan = scan_of(&cloud, Pose2::default(), &zones);
        assert!(matches!(
            l.update(&mut g, &scan),
            Err(MapError::TooMany { .. })
        ));
        let bad_zone = [IgnoreZone {
            pose: Pose2::new(f64::NAN, 0.0, 0.0),
            footprint: RACK,
        }];
        let scan = scan_of(&cloud, Pose2::default(), &bad_zone);
        assert!(l.update(&mut g, &scan).is_err());
        // Garbage points (infinite, huge) are skipped or land outside the grid.
        let mut junk = vec![[1e30f32, -1e30, 0.5]; 31 * 1201];
        junk[5] = [f32::INFINITY, 0.0, 0.5];
        let s = l
            .update(&mut g, &scan_of(&junk, Pose2::default(), &[]))
            .unwrap();
        assert_eq!(s.newly_detected, 0);
    }
}
