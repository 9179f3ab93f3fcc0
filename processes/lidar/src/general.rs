//! The general path: a scan from a sensor with any orientation (rolled or pitched).
//!
//! Boxes become oriented boxes in the sensor frame, so each ray runs a 3D slab test.
//! Per scan the boxes near the sensor (the grid's superset of those within range) are
//! moved to the sensor frame once, culled by range and by the elevations they span,
//! and given the columns (their azimuths about the sensor z axis) they can occupy, from
//! the box's sensor-frame bounding box. A sweep over columns (`column.rs`) visits the
//! boxes whose span covers the column nearest first and stops at the first one beyond
//! every row's best hit; per column, where the column's vertical half-plane crosses a
//! box's bounding box gives a lower bound on the distance of a hit and the elevations
//! that can hit it, so only those rows run the slab test. Which boxes are tested does
//! not change the result (the nearest entry of every box that can be hit), so the
//! points equal those of a test against every box. Knows nothing of noise.

use crate::SensorPose;
use crate::column::{AZIMUTH_ERR, Column, NEAR_SLACK, RowTable, Span, Sweep, azimuth, box_rows};
use crate::grid::Near;
use crate::pattern::ScanPattern;
use crate::planar::slab;
use crate::world::World;

/// An oriented box in the sensor frame.
#[derive(Debug, Clone, Copy, Default)]
struct SensorObb {
    /// Box axes in the sensor frame (rows).
    axes: [[f32; 3]; 3],
    /// Sensor origin in the box frame.
    origin: [f32; 3],
    half: [f32; 3],
    /// Lower bound on the distance of any hit: |center| - radius.
    near: f32,
    /// Centre and half extents (padded) of its bounding box in the sensor xy plane.
    xy: [f32; 2],
    ext: [f32; 2],
    /// Its z interval in the sensor frame (padded).
    z: [f32; 2],
}

/// Pads the sensor-frame bounding box in which a column's rays must meet a box, so
/// rounding in f32 never drops a box the ray test would hit (metres).
const PAD: f64 = 1e-3;

/// A box as seen by one column: ray direction in the box frame is
/// `cos e * a + sin e * b`.
#[derive(Debug, Clone, Copy)]
struct Candidate {
    a: [f32; 3],
    b: [f32; 3],
    origin: [f32; 3],
    half: [f32; 3],
}

#[derive(Debug, Clone)]
pub(crate) struct GeneralCaster {
    obbs: Vec<SensorObb>,
    sweep: Sweep,
    column: Column,
    table: RowTable,
    near: Near,
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

impl GeneralCaster {
    pub(crate) fn new(box_count: usize, pattern: &ScanPattern) -> GeneralCaster {
        GeneralCaster {
            obbs: Vec::with_capacity(box_count),
            // A box can straddle the +-pi seam of a 360 deg scan: up to three spans.
            sweep: Sweep::with_capacity(3 * box_count),
            column: Column::new(pattern.rows()),
            table: RowTable::new(&pattern.tan_el),
            near: Near::new(box_count),
        }
    }

    pub(crate) fn scan(
        &mut self,
        pattern: &ScanPattern,
        world: &World,
        sensor: &SensorPose,
        hit_floor: bool,
        out: &mut [[f32; 3]],
    ) -> usize {
        let grid = Grid::new(pattern);
        self.place_boxes(world, sensor, &grid);
        self.sweep.start();
        let rows = pattern.rows();
        let cols = pattern.columns();
        let mut hits = 0;
        for col in 0..cols {
            self.sweep.advance(col);
            let (ca, sa) = (pattern.cos_az[col], pattern.sin_az[col]);
            self.begin_column(pattern, sensor, hit_floor, ca, sa);
            for a in self.sweep.active() {
                if self.column.beyond(a.near()) {
                    break;
                }
                let o = &self.obbs[a.item()];
                cast_obb(o, ca, sa, pattern, &self.table, &mut self.column);
            }
            for row in 0..rows {
                out[row * cols + col] = if self.column.hit[row] {
                    hits += 1;
                    let best = self.column.best[row];
                    let d = pattern.direction(row, col);
                    [best * d[0], best * d[1], best * d[2]]
                } else {
                    [f32::NAN; 3]
                };
            }
        }
        hits
    }

    /// Starts the column of azimuth (cos `ca`, sin `sa`): each row at max range (no
    /// return), or where it meets the floor if it is hit.
    #[inline]
    fn begin_column(
        &mut self,
        pattern: &ScanPattern,
        sensor: &SensorPose,
        hit_floor: bool,
        ca: f32,
        sa: f32,
    ) {
        let r = &sensor.rotation;
        let height = sensor.position[2];
        // World z of the column's horizontal direction, for the floor.
        let gz_h = (r[2][0] * f64::from(ca) + r[2][1] * f64::from(sa)) as f32;
        for row in 0..pattern.rows() {
            let mut best = pattern.max_range;
            let mut hit = false;
            let dz = pattern.cos_el[row] * gz_h + pattern.sin_el[row] * r[2][2] as f32;
            if hit_floor && dz < 0.0 && height > 0.0 {
                let t = (height / f64::from(-dz)) as f32;
                if t <= best {
                    best = t;
                    hit = true;
                }
            }
            self.column.best[row] = best;
            self.column.hit[row] = hit;
        }
        self.column.refresh();
    }

    /// Moves every enabled box near the sensor into the sensor frame, drops those that
    /// hold the sensor, lie beyond range or outside every row, and lists the columns
    /// each may cover.
    fn place_boxes(&mut self, world: &World, sensor: &SensorPose, grid: &Grid) {
        self.obbs.clear();
        self.sweep.clear();
        let centre = [sensor.position[0], sensor.position[1]];
        world.gather_near(centre, grid.range, &mut self.near);
        for k in 0..self.near.list.len() {
            let Some(b) = world.enabled_box(self.near.list[k]) else {
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
            self.push_spans(grid, c, ext, &axes, &half, span);
        }
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
            self.sweep.spans.push(Span {
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
                self.sweep.spans.push(Span { c_lo, c_hi, ..span });
            }
        }
    }
}

/// Lowers the best hits of the current column (cos `ca`, sin `sa`) to where its rays
/// enter box `o`, in the rows whose elevations can meet it. A ray of this column at
/// distance t is t cos e along (ca, sa) in the xy plane, so it can meet the box only
/// where that 2D ray crosses the box's xy bounding box, at s_in <= t cos e <= t.
#[inline]
fn cast_obb(
    o: &SensorObb,
    ca: f32,
    sa: f32,
    pattern: &ScanPattern,
    table: &RowTable,
    column: &mut Column,
) {
    let Some((sx0, sx1)) = slab(-o.xy[0], ca, o.ext[0]) else {
        return;
    };
    let Some((sy0, sy1)) = slab(-o.xy[1], sa, o.ext[1]) else {
        return;
    };
    let s_in = sx0.max(sy0).max(0.0);
    let s_out = sx1.min(sy1);
    if s_in > s_out {
        return;
    }
    // + 0.0 turns a -0.0 into 0.0.
    let near = o.near.max(s_in) + 0.0;
    if column.beyond(near) {
        return;
    }
    let (tan_lo, tan_hi) = tan_bounds(s_in, s_out, o.z);
    let Some((first, last)) = table.rows(tan_lo, tan_hi) else {
        return;
    };
    let cand = Candidate {
        a: o.axes.map(|ax| ax[0] * ca + ax[1] * sa),
        b: o.axes.map(|ax| ax[2]),
        origin: o.origin,
        half: o.half,
    };
    for row in first..=last {
        let best = column.best[row];
        let tan_e = pattern.tan_el[row];
        if near > best || tan_e < tan_lo || tan_e > tan_hi {
            continue;
        }
        if let Some(t) = entry(&cand, pattern.cos_el[row], pattern.sin_el[row], best) {
            column.set(row, t);
        }
    }
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// The tangents of the elevations of the points at horizontal distance in [`s_in`,
/// `s_out`] and height in `z` (sensor frame): where a ray of the column can meet a box
/// whose bounding box gives those.
#[inline]
pub(crate) fn tan_bounds(s_in: f32, s_out: f32, z: [f32; 2]) -> (f32, f32) {
    if s_out.is_nan() || s_out <= 0.0 {
        return (f32::NEG_INFINITY, f32::INFINITY);
    }
    let over = |v: f32| {
        if s_in > 0.0 {
            v / s_in
        } else {
            v.signum() * f32::INFINITY
        }
    };
    let hi = if z[1] > 0.0 { over(z[1]) } else { z[1] / s_out };
    let lo = if z[0] < 0.0 { over(z[0]) } else { z[0] / s_out };
    (lo, hi)
}

/// Entry distance of the ray into the box, if it enters at t >= 0 and no farther than
/// `best`. The entry only grows and the exit only shrinks from axis to axis, so a ray
/// that has left the box, or entered it beyond `best`, is dropped at once.
#[inline]
fn entry(c: &Candidate, ce: f32, se: f32, best: f32) -> Option<f32> {
    let mut t0 = 0.0f32;
    let mut t1 = f32::INFINITY;
    for i in 0..3 {
        let d = ce * c.a[i] + se * c.b[i];
        let o = c.origin[i];
        let h = c.half[i];
        if d != 0.0 {
            let inv = 1.0 / d;
            let ta = (-h - o) * inv;
            let tb = (h - o) * inv;
            t0 = t0.max(ta.min(tb));
            t1 = t1.min(ta.max(tb));
            if t0 > t1 || t0 > best {
                return None;
            }
        } else if o.abs() > h {
            return None;
        }
    }
    Some(t0)
}
