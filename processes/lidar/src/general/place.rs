//! One tilted scan's boxes in the sensor frame: each enabled box near the sensor as an
//! oriented box, culled by range and by the elevations it spans, and the columns and
//! rows it may cover (its azimuths about the sensor z axis and its elevations, from the
//! sensor-frame bounding box of the part of it the pattern's elevations reach: a tilted
//! rack upright's whole bounding box leans over many more columns than its foot).
//! Built once per scan on the calling thread and then only read by the column sweeps
//! (`sweep.rs`), on one thread or two. Knows nothing of rays' tests or of threads.

use super::sweep::TINY;
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
    /// No slab bound (+-half - origin) is near zero: its ray tests take the fast path
    /// (`sweep::entries`).
    pub plain: bool,
    /// Lower bound on the distance of any hit: |center| - radius.
    pub near: f32,
    /// Centre and half extents (padded) of its bounding box in the sensor xy plane.
    pub xy: [f32; 2],
    pub ext: [f32; 2],
    /// Its z interval in the sensor frame (padded).
    pub z: [f32; 2],
    /// The rows that may see it in any column.
    pub rows: [u32; 2],
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
    /// Tangents of the lowest and the highest elevation.
    tan: [f64; 2],
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
            tan: [
                pattern.elevations()[0].tan(),
                pattern.elevations()[pattern.rows() - 1].tan(),
            ],
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
            // The rays meet only the part of the box their elevations reach: its
            // bounds, not the whole box's, give the columns, rows and distances.
            let full = [c[0], c[1]];
            let Some((m, h2)) =
                self.visible(grid.range, full, ext_of(&axes, &half), c, &axes, &half)
            else {
                continue;
            };
            let c: [f64; 3] = std::array::from_fn(|j| c[j] + m * axes[2][j]);
            let cut = [half[0], half[1], h2];
            let radius = (cut[0] * cut[0] + cut[1] * cut[1] + cut[2] * cut[2]).sqrt();
            let near = dot(c, c).sqrt() - radius;
            if near > grid.range {
                continue;
            }
            // Half extents of the part's bounding box in the sensor frame.
            let ext = ext_of(&axes, &cut);
            let z = [c[2] - ext[2], c[2] + ext[2]];
            // The rows from the padded bounds, as the column sweep's own tests use.
            let Some((row_lo, row_hi, dmin)) = box_rows(
                &self.table,
                grid.range,
                [c[0], c[1]],
                [ext[0] + PAD, ext[1] + PAD],
                [z[0] - PAD, z[1] + PAD],
            ) else {
                continue;
            };
            let index = self.obbs.len() as u32;
            let (origin, half) = (origin.map(|v| v as f32), half.map(|v| v as f32));
            self.obbs.push(SensorObb {
                axes: axes.map(|a| a.map(|v| v as f32)),
                origin,
                half,
                plain: (0..3).all(|i| {
                    (half[i] - origin[i]).abs() >= TINY && (-half[i] - origin[i]).abs() >= TINY
                }),
                near: near as f32,
                xy: [c[0] as f32, c[1] as f32],
                ext: [(ext[0] + PAD) as f32, (ext[1] + PAD) as f32],
                z: [(c[2] - ext[2] - PAD) as f32, (c[2] + ext[2] + PAD) as f32],
                rows: [row_lo as u32, row_hi as u32],
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
            self.push_spans(&grid, c, ext, &axes, &cut, span);
        }
        sort_spans(&mut self.spans);
    }

    /// The part of a box (centre `c`, `axes` and `half` extents in the sensor frame, its
    /// bounding box's half extents `ext`) that the pattern's elevations reach, as the
    /// offset of its centre along the box's vertical axis and its half height there;
    /// `None` when they reach none of it. A ray's point at horizontal distance r has
    /// a height between r tan of the lowest and the highest elevation, and r lies
    /// within the distances of the bounding box; a box whose vertical axis the tilt
    /// has laid down (or nearly) is kept whole.
    fn visible(
        &self,
        range: f64,
        xy: [f64; 2],
        ext: [f64; 3],
        c: [f64; 3],
        axes: &[[f64; 3]; 3],
        half: &[f64; 3],
    ) -> Option<(f64, f64)> {
        let up = axes[2][2];
        if up.abs() < 0.5 || !self.tan[0].is_finite() || !self.tan[1].is_finite() {
            return Some((0.0, half[2]));
        }
        let ex = (xy[0].abs() - ext[0]).max(0.0);
        let ey = (xy[1].abs() - ext[1]).max(0.0);
        let fx = xy[0].abs() + ext[0];
        let fy = xy[1].abs() + ext[1];
        let r = [
            (ex * ex + ey * ey).sqrt(),
            (fx * fx + fy * fy).sqrt().min(range),
        ];
        // Far above the f32 rays' rounding (about 1e-6 of their length).
        let pad = PAD + 1e-4 * r[1];
        let z_lo = (self.tan[0] * r[0]).min(self.tan[0] * r[1]) - pad;
        let z_hi = (self.tan[1] * r[0]).max(self.tan[1] * r[1]) + pad;
        // A point's height is c[2] + u0 axes[0][2] + u1 axes[1][2] + u2 up, the first
        // two within +-rest.
        let rest = half[0] * axes[0][2].abs() + half[1] * axes[1][2].abs();
        let a = (z_lo - c[2] - rest) / up;
        let b = (z_hi - c[2] + rest) / up;
        let (lo, hi) = (a.min(b).max(-half[2]), a.max(b).min(half[2]));
        (lo <= hi).then_some((0.5 * (lo + hi), 0.5 * (hi - lo)))
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

/// Half extents in the sensor frame of the bounding box of a box with `axes` (rows,
/// sensor frame) and `half` extents.
fn ext_of(axes: &[[f64; 3]; 3], half: &[f64; 3]) -> [f64; 3] {
    std::array::from_fn(|j| (0..3).map(|i| axes[i][j].abs() * half[i]).sum::<f64>())
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A deterministic stream in [0, 1).
    fn stream(mut s: u64) -> impl FnMut() -> f64 {
        move || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 11) as f64 / (1u64 << 53) as f64
        }
    }

    #[test]
    fn the_visible_part_holds_every_point_of_the_box_the_elevations_reach() {
        let cfg = crate::LidarConfig {
            elevation_min_deg: -15.0,
            elevation_max_deg: 30.0,
            ..Default::default()
        };
        let pattern = ScanPattern::new(&cfg).unwrap();
        let p = Placement::new(1, &pattern);
        let (lo, hi) = (p.tan[0], p.tan[1]);
        let mut next = stream(0xC07E);
        let (mut reached, mut cut) = (0, 0);
        for _ in 0..3000 {
            let rpy = [0.4 * next() - 0.2, 0.6 * next() - 0.3, 6.3 * next()];
            let rot = SensorPose::from_xyz_rpy([0.0; 3], rpy);
            let axes: [[f64; 3]; 3] = std::array::from_fn(|i| {
                let mut e = [0.0; 3];
                e[i] = 1.0;
                rot.vector_to_sensor(e)
            });
            let half = [0.02 + next(), 0.02 + next(), 0.05 + 3.0 * next()];
            let c = [16.0 * next() - 8.0, 16.0 * next() - 8.0, 6.0 * next() - 2.0];
            let ext = ext_of(&axes, &half);
            let part = p.visible(12.0, [c[0], c[1]], ext, c, &axes, &half);
            if part.is_some_and(|(_, h)| h < half[2]) {
                cut += 1;
            }
            for _ in 0..200 {
                let u: [f64; 3] = std::array::from_fn(|i| half[i] * (2.0 * next() - 1.0));
                let q: [f64; 3] =
                    std::array::from_fn(|j| c[j] + (0..3).map(|i| u[i] * axes[i][j]).sum::<f64>());
                let r = (q[0] * q[0] + q[1] * q[1]).sqrt();
                if r > 12.0 || q[2] < lo * r || q[2] > hi * r {
                    continue;
                }
                reached += 1;
                let (m, h) = part.expect("a point the rays reach");
                assert!((u[2] - m).abs() <= h, "{u:?} outside {m} +- {h}");
            }
        }
        assert!(reached > 50_000 && cut > 1000, "{reached} {cut}");
    }
}
