//! One tilted scan's boxes in the sensor frame: each enabled box near the sensor as an
//! oriented box, culled by range and by the elevations it spans, and the columns it may
//! cover (its azimuths about the sensor z axis, from its sensor-frame bounding box).
//! Built once per scan on the calling thread and then only read by the column sweeps
//! (`sweep.rs`), on one thread or two. Knows nothing of rays' tests or of threads.

use crate::SensorPose;
use crate::column::{AZIMUTH_ERR, NEAR_SLACK, RowTable, Span, azimuth, box_rows, sort_spans};
use crate::grid::Near;
use crate::pattern::ScanPattern;
use crate::world::World;

/// An oriented box in the sensor frame.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct SensorObb {
    /// Box axes in the sensor frame (rows).
    pub axes: [[f32; 3]; 3],
    /// Sensor origin in the box frame.
    pub origin: [f32; 3],
    pub half: [f32; 3],
    /// Lower bound on the distance of any hit: |center| - radius.
    pub near: f32,
    /// Centre and half extents (padded) of its bounding box in the sensor xy plane.
    pub xy: [f32; 2],
    pub ext: [f32; 2],
    /// Its z interval in the sensor frame (padded).
    pub z: [f32; 2],
}

/// Pads the sensor-frame bounding box in which a column's rays must meet a box, so
/// rounding in f32 never drops a box the ray test would hit (metres).
const PAD: f64 = 1e-3;

/// What the column sweeps of one scan read: the pattern, the sensor, the placed boxes
/// and their column spans (sorted for a [`crate::column::Cursor`]).
#[derive(Debug, Clone)]
pub(super) struct Placement {
    pub pattern: ScanPattern,
    pub table: RowTable,
    pub sensor: SensorPose,
    pub hit_floor: bool,
    pub obbs: Vec<SensorObb>,
    pub spans: Vec<Span>,
}

/// The pattern's azimuths and range, for spans.
#[derive(Debug, Clone, Copy)]
struct Grid {
    range: f64,
    cols: usize,
    az0: f64,
    az_step: f64,
}

impl Grid {
    fn new(pattern: &ScanPattern) -> Grid {
        let az = pattern.azimuths();
        let cols = pattern.columns();
        Grid {
            range: pattern.max_range(),
            cols,
            az0: az[0],
            az_step: if cols > 1 { az[1] - az[0] } else { 1.0 },
        }
    }

    /// Channels `lo..=hi` (one spare either way) for angles in [a_lo, a_hi] shifted by
    /// `shift`, or `None` when none is in the pattern.
    fn channels(a_lo: f64, a_hi: f64, a0: f64, step: f64, n: usize) -> Option<(u32, u32)> {
        let lo = ((a_lo - a0) / step).ceil() - 1.0;
        let hi = ((a_hi - a0) / step).floor() + 1.0;
        let last = (n - 1) as f64;
        (hi >= 0.0 && lo <= last).then(|| (lo.max(0.0) as u32, hi.min(last) as u32))
    }
}

impl Placement {
    pub fn new(box_count: usize, pattern: &ScanPattern) -> Placement {
        Placement {
            pattern: pattern.clone(),
            table: RowTable::new(&pattern.tan_el),
            sensor: SensorPose::from_xyz_rpy([0.0; 3], [0.0; 3]),
            hit_floor: false,
            obbs: Vec::with_capacity(box_count),
            // A box can straddle the +-pi seam of a 360 deg scan: up to three spans.
            spans: Vec::with_capacity(3 * box_count),
        }
    }

    /// Moves every enabled box near `sensor` into the sensor frame, drops those that
    /// hold the sensor, lie beyond range or outside every row, and lists the columns
    /// each may cover, sorted.
    pub fn place(&mut self, world: &World, sensor: &SensorPose, hit_floor: bool, near: &mut Near) {
        self.sensor = *sensor;
        self.hit_floor = hit_floor;
        self.obbs.clear();
        self.spans.clear();
        let grid = Grid::new(&self.pattern);
        let centre = [sensor.position[0], sensor.position[1]];
        world.gather_near(centre, grid.range, near);
        for k in 0..near.list.len() {
            let Some(b) = world.enabled_box(near.list[k]) else {
                continue;
            };
            let zc = 0.5 * (b.z_min + b.z_max);
            let rel = [
                b.center[0] - sensor.position[0],
                b.center[1] - sensor.position[1],
                zc - sensor.position[2],
            ];
            let c = sensor.vector_to_sensor(rel);
            let (sy, cy) = b.yaw.sin_cos();
            let axes = [
                sensor.vector_to_sensor([cy, sy, 0.0]),
                sensor.vector_to_sensor([-sy, cy, 0.0]),
                sensor.vector_to_sensor([0.0, 0.0, 1.0]),
            ];
            let half = [b.half[0], b.half[1], 0.5 * (b.z_max - b.z_min)];
            let origin: [f64; 3] = std::array::from_fn(|i| -dot(axes[i], c));
            if (0..3).all(|i| origin[i].abs() <= half[i]) {
                // The sensor is inside this box: it sees out of it, not its walls.
                continue;
            }
            let radius = (half[0] * half[0] + half[1] * half[1] + half[2] * half[2]).sqrt();
            let near = dot(c, c).sqrt() - radius;
            if near > grid.range {
                continue;
            }
            // Half extents of the box's bounding box in the sensor frame.
            let ext: [f64; 3] =
                std::array::from_fn(|j| (0..3).map(|i| axes[i][j].abs() * half[i]).sum::<f64>());
            let z = [c[2] - ext[2], c[2] + ext[2]];
            let Some((_, _, dmin)) =
                box_rows(&self.table, grid.range, [c[0], c[1]], [ext[0], ext[1]], z)
            else {
                continue;
            };
            let index = self.obbs.len() as u32;
            self.obbs.push(SensorObb {
                axes: axes.map(|a| a.map(|v| v as f32)),
                origin: origin.map(|v| v as f32),
                half: half.map(|v| v as f32),
                near: near as f32,
                xy: [c[0] as f32, c[1] as f32],
                ext: [(ext[0] + PAD) as f32, (ext[1] + PAD) as f32],
                z: [(c[2] - ext[2] - PAD) as f32, (c[2] + ext[2] + PAD) as f32],
            });
            // A ray's distance is at least its distance from the sensor z axis, so
            // the bounding box's least one bounds it too: tighter than the sphere's
            // for a tall or long box.
            let span = Span {
                c_lo: 0,
                c_hi: 0,
                item: index,
                near: near.max(dmin - NEAR_SLACK).max(0.0) as f32,
            };
            self.push_spans(&grid, c, ext, &axes, &half, span);
        }
        sort_spans(&mut self.spans);
    }

    /// The columns that may see a box centred at `c` with sensor-frame half extents
    /// `ext`: every column if the sensor z axis meets its bounding box, else the
    /// azimuths of its eight corners, once per copy shifted by a turn.
    fn push_spans(
        &mut self,
        grid: &Grid,
        c: [f64; 3],
        ext: [f64; 3],
        axes: &[[f64; 3]; 3],
        half: &[f64; 3],
        span: Span,
    ) {
        let last = (grid.cols - 1) as u32;
        if c[0].abs() <= ext[0] && c[1].abs() <= ext[1] {
            self.spans.push(Span {
                c_lo: 0,
                c_hi: last,
                ..span
            });
            return;
        }
        // The box's projection misses the z axis, so its azimuths lie within a half
        // turn of the centre's.
        let ac = azimuth(c[1], c[0]);
        let (mut dlo, mut dhi) = (f64::INFINITY, f64::NEG_INFINITY);
        for k in 0..8 {
            let sgn = |bit: usize| if k & bit == 0 { 1.0 } else { -1.0 };
            let s = [sgn(1) * half[0], sgn(2) * half[1], sgn(4) * half[2]];
            let px = c[0] + s[0] * axes[0][0] + s[1] * axes[1][0] + s[2] * axes[2][0];
            let py = c[1] + s[0] * axes[0][1] + s[1] * axes[1][1] + s[2] * axes[2][1];
            let d = aisle_geometry::wrap_angle(azimuth(py, px) - ac);
            dlo = dlo.min(d);
            dhi = dhi.max(d);
        }
        // Both angles may be off by the approximation's error.
        (dlo, dhi) = (dlo - 2.0 * AZIMUTH_ERR, dhi + 2.0 * AZIMUTH_ERR);
        for shift in [-std::f64::consts::TAU, 0.0, std::f64::consts::TAU] {
            let (lo, hi) = (ac + dlo + shift, ac + dhi + shift);
            if let Some((c_lo, c_hi)) = Grid::channels(lo, hi, grid.az0, grid.az_step, grid.cols) {
                self.spans.push(Span { c_lo, c_hi, ..span });
            }
        }
    }
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
