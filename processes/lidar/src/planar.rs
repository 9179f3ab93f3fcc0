//! The fast path: a scan from a level sensor (its z axis is world z; any yaw).
//!
//! Every box is axis-aligned in its body frame and bodies only yaw, so for a level sensor
//! each box is a rotated rectangle times a z interval in the sensor frame. All rays of one
//! azimuth column share a horizontal direction, so the 2D slab test of a box against the
//! column gives an interval [s_in, s_out] of horizontal distance that holds for every
//! elevation; a ray at elevation e (z = s tan e) then hits where that interval meets
//! z0 <= s tan e <= z1, which is two multiplications. Per scan each box is moved to the
//! sensor frame once, culled by range, and given the column and row span it can occupy;
//! a sweep over columns (`column.rs`) visits the boxes whose span covers the column
//! nearest first, each box lowering the best hit of the rows that can see it, and
//! stops at the first box beyond every row's best hit: the boxes behind those hits
//! cost nothing.
//!
//! Knows nothing of noise or of the general (tilted) case.

use crate::column::{AZIMUTH_ERR, Column, NEAR_SLACK, RowTable, Span, Sweep, azimuth, box_rows};
use crate::general::tan_bounds;
use crate::grid::Near;
use crate::pattern::ScanPattern;
use crate::world::{World, WorldBox};

/// A box in the sensor frame, as the column sweep needs it.
#[derive(Debug, Clone, Copy, Default)]
struct SensorBox {
    /// Sensor origin in the box frame.
    ou: f32,
    ov: f32,
    /// Box x axis in the sensor frame; its y axis is (-uy, ux).
    ux: f32,
    uy: f32,
    hx: f32,
    hy: f32,
    /// z interval relative to the sensor.
    z0: f32,
    z1: f32,
    row_lo: u32,
    row_hi: u32,
}

/// Reusable buffers; sized for the scene once, so a scan allocates nothing.
#[derive(Debug, Clone)]
pub(crate) struct PlanarCaster {
    sboxes: Vec<SensorBox>,
    sweep: Sweep,
    /// Each row's distance and return flag before any box: max range or the floor.
    start: Column,
    column: Column,
    table: RowTable,
    near: Near,
}

/// Origins this close to a box's outline count as inside it for the azimuth span, where
/// the corner angles would otherwise wrap unpredictably.
const ON_OUTLINE: f64 = 1e-9;

impl PlanarCaster {
    pub(crate) fn new(box_count: usize, pattern: &ScanPattern) -> PlanarCaster {
        let rows = pattern.rows();
        PlanarCaster {
            sboxes: Vec::with_capacity(box_count),
            // A box can straddle the +-pi seam of a 360 deg scan: up to three spans.
            sweep: Sweep::with_capacity(3 * box_count),
            start: Column::new(rows),
            column: Column::new(rows),
            table: RowTable::new(&pattern.tan_el),
            near: Near::new(box_count),
        }
    }

    /// Casts the whole pattern from `origin` (world, metres) heading `yaw`; writes the
    /// sensor-frame points (NaN for no return) into `out` and returns the hit count.
    pub(crate) fn scan(
        &mut self,
        pattern: &ScanPattern,
        world: &World,
        origin: [f64; 3],
        yaw: f64,
        hit_floor: bool,
        out: &mut [[f32; 3]],
    ) -> usize {
        self.prepare(pattern, world, origin, yaw, hit_floor);
        self.sweep(pattern, out)
    }

    /// Moves every enabled box near the sensor (the grid's superset of those within
    /// range) into the sensor frame, culls it, and lists the columns
    /// and rows it may cover, sorted for the column sweep; fills the floor distances.
    fn prepare(
        &mut self,
        pattern: &ScanPattern,
        world: &World,
        origin: [f64; 3],
        yaw: f64,
        hit_floor: bool,
    ) {
        self.sboxes.clear();
        self.sweep.clear();
        let frame = Frame::new(pattern, origin, yaw);
        self.floor_distances(pattern, origin, hit_floor);
        world.gather_near([origin[0], origin[1]], frame.range, &mut self.near);
        for k in 0..self.near.list.len() {
            let Some(b) = world.enabled_box(self.near.list[k]) else {
                continue;
            };
            let Some(p) = frame.place(b) else {
                continue;
            };
            let Some((row_lo, row_hi, dmin)) = box_rows(
                &self.table,
                frame.range,
                [p.ou, p.ov],
                [p.hx, p.hy],
                [p.z0, p.z1],
            ) else {
                continue;
            };
            let index = self.sboxes.len() as u32;
            self.sboxes.push(SensorBox {
                ou: p.ou as f32,
                ov: p.ov as f32,
                ux: p.ct as f32,
                uy: p.st as f32,
                hx: p.hx as f32,
                hy: p.hy as f32,
                z0: p.z0 as f32,
                z1: p.z1 as f32,
                row_lo: row_lo as u32,
                row_hi: row_hi as u32,
            });
            let near = (dmin - NEAR_SLACK).max(0.0) as f32;
            self.push_spans(&frame, &p, index, near);
        }
        self.sweep.start();
    }

    /// Each row's horizontal distance before any box: where its ray meets the floor if
    /// it points down and the floor is hit (a return), else at max range (none).
    fn floor_distances(&mut self, pattern: &ScanPattern, origin: [f64; 3], hit_floor: bool) {
        let range = pattern.max_range;
        for r in 0..pattern.rows() {
            let k = pattern.tan_el[r];
            let floor = if hit_floor && k < 0.0 && origin[2] > 0.0 {
                (origin[2] / -f64::from(k)) as f32
            } else {
                f32::INFINITY
            };
            let best = range * pattern.cos_el[r];
            self.start.hit[r] = floor <= best;
            self.start.best[r] = if floor <= best { floor } else { best };
        }
        self.start.refresh();
    }

    /// The columns that may see box `index`: every column if the sensor is within its
    /// outline, else the azimuths between its extreme corners (one spare column either
    /// way), once per copy of that interval shifted by a turn that meets the pattern.
    #[inline]
    fn push_spans(&mut self, frame: &Frame, p: &Placed, item: u32, near: f32) {
        let cols = frame.cols;
        if p.inside_2d {
            self.sweep.spans.push(Span {
                c_lo: 0,
                c_hi: (cols - 1) as u32,
                item,
                near,
            });
            return;
        }
        let (cx, cyy, ct, st, hx, hy) = (p.cx, p.cyy, p.ct, p.st, p.hx, p.hy);
        let ac = azimuth(cyy, cx);
        let (mut dlo, mut dhi) = (f64::INFINITY, f64::NEG_INFINITY);
        for (su, sv) in [(1.0, 1.0), (1.0, -1.0), (-1.0, 1.0), (-1.0, -1.0)] {
            // Corner = centre + su*hx*u + sv*hy*v, with u = (ct, st), v = (-st, ct).
            let px = cx + su * hx * ct - sv * hy * st;
            let py = cyy + su * hx * st + sv * hy * ct;
            let d = aisle_geometry::wrap_angle(azimuth(py, px) - ac);
            dlo = dlo.min(d);
            dhi = dhi.max(d);
        }
        // Both angles may be off by the approximation's error.
        (dlo, dhi) = (dlo - 2.0 * AZIMUTH_ERR, dhi + 2.0 * AZIMUTH_ERR);
        for shift in [-std::f64::consts::TAU, 0.0, std::f64::consts::TAU] {
            let lo = ((ac + dlo + shift - frame.az0) / frame.az_step).ceil() - 1.0;
            let hi = ((ac + dhi + shift - frame.az0) / frame.az_step).floor() + 1.0;
            if hi < 0.0 || lo > (cols - 1) as f64 {
                continue;
            }
            self.sweep.spans.push(Span {
                c_lo: lo.max(0.0) as u32,
                c_hi: hi.min((cols - 1) as f64) as u32,
                item,
                near,
            });
        }
    }

    fn sweep(&mut self, pattern: &ScanPattern, out: &mut [[f32; 3]]) -> usize {
        let rows = pattern.rows();
        let cols = pattern.columns();
        let mut hits = 0;
        for c in 0..cols {
            self.sweep.advance(c);
            let (ca, sa) = (pattern.cos_az[c], pattern.sin_az[c]);
            self.column.begin(&self.start);
            for a in self.sweep.active() {
                if self.column.beyond(a.near()) {
                    break;
                }
                let b = &self.sboxes[a.item()];
                cast_box(b, ca, sa, pattern, &self.table, &mut self.column);
            }
            for r in 0..rows {
                let best = self.column.best[r];
                out[r * cols + c] = if self.column.hit[r] {
                    hits += 1;
                    [best * ca, best * sa, best * pattern.tan_el[r]]
                } else {
                    [f32::NAN; 3]
                };
            }
        }
        hits
    }
}

/// Lowers the best hits of the current column (cos `ca`, sin `sa`) to where its rays
/// enter box `b`, in the rows that can see it.
#[inline]
fn cast_box(
    b: &SensorBox,
    ca: f32,
    sa: f32,
    pattern: &ScanPattern,
    table: &RowTable,
    column: &mut Column,
) {
    let du = ca * b.ux + sa * b.uy;
    let dv = sa * b.ux - ca * b.uy;
    let Some((u0, u1)) = slab(b.ou, du, b.hx) else {
        return;
    };
    let Some((v0, v1)) = slab(b.ov, dv, b.hy) else {
        return;
    };
    // + 0.0 turns a -0.0 into 0.0.
    let s_in = u0.max(v0).max(0.0) + 0.0;
    let s_out = u1.min(v1);
    if !(s_in <= s_out && s_in <= pattern.max_range) || column.beyond(s_in) {
        return;
    }
    let (t_lo, t_hi) = tan_bounds(s_in, s_out, [b.z0, b.z1]);
    let Some((a, z)) = table.rows(t_lo, t_hi) else {
        return;
    };
    let (first, last) = (a.max(b.row_lo as usize), z.min(b.row_hi as usize));
    if first > last {
        return;
    }
    // A ray whose height at s_in lies clearly within the box's heights enters through
    // the side at s_in: no division needed. The margin dwarfs the rounding (about
    // 6e-8 of these magnitudes) of both that test and the exact one below, so the
    // ray gets the same bits either way; rays near a top or bottom edge take the
    // exact test.
    let k_max = pattern.tan_el[first].abs().max(pattern.tan_el[last].abs());
    let margin = SIDE_MARGIN * (b.z0.abs() + b.z1.abs() + k_max * s_in);
    let (side_lo, side_hi) = (b.z0 + margin, b.z1 - margin);
    for r in first..=last {
        let best = column.best[r];
        if s_in > best {
            continue;
        }
        let k = pattern.tan_el[r];
        let height = k * s_in;
        if height > side_lo && height < side_hi {
            column.set(r, s_in);
            continue;
        }
        // Horizontal distances where the ray's height lies in [z0, z1].
        let (lo, hi) = if k > 0.0 {
            (b.z0 / k, b.z1 / k)
        } else if k < 0.0 {
            (b.z1 / k, b.z0 / k)
        } else if b.z0 <= 0.0 && b.z1 >= 0.0 {
            (f32::NEG_INFINITY, f32::INFINITY)
        } else {
            continue;
        };
        let s = s_in.max(lo);
        if s <= s_out.min(hi) && s <= best {
            column.set(r, s);
        }
    }
}

/// Relative margin of `cast_box`'s test for rays entering a box through its side.
const SIDE_MARGIN: f32 = 1e-5;

/// What placing boxes in one scan needs: the sensor's position and yaw, the range and
/// the pattern's first azimuth and step.
#[derive(Debug, Clone, Copy)]
struct Frame {
    origin: [f64; 3],
    yaw: f64,
    sy: f64,
    cy: f64,
    range: f64,
    cols: usize,
    az0: f64,
    az_step: f64,
}

/// A box in the sensor's horizontal frame, in f64, before it is culled and packed.
#[derive(Debug, Clone, Copy)]
struct Placed {
    /// Box centre in the sensor frame.
    cx: f64,
    cyy: f64,
    /// Sensor origin in the box frame.
    ou: f64,
    ov: f64,
    /// Cosine and sine of the box's yaw relative to the sensor.
    ct: f64,
    st: f64,
    hx: f64,
    hy: f64,
    /// z interval relative to the sensor.
    z0: f64,
    z1: f64,
    /// The sensor is within the box's outline (seen from above).
    inside_2d: bool,
}

impl Frame {
    fn new(pattern: &ScanPattern, origin: [f64; 3], yaw: f64) -> Frame {
        let cols = pattern.columns();
        let az = pattern.azimuths();
        let (sy, cy) = yaw.sin_cos();
        Frame {
            origin,
            yaw,
            sy,
            cy,
            range: pattern.max_range(),
            cols,
            az0: az[0],
            az_step: if cols > 1 { az[1] - az[0] } else { 1.0 },
        }
    }

    /// `b` in the sensor frame, or `None` when the sensor is inside it (it sees out of
    /// the box, not its walls).
    #[inline]
    fn place(&self, b: &WorldBox) -> Option<Placed> {
        let (sy, cy) = (self.sy, self.cy);
        let dx = b.center[0] - self.origin[0];
        let dy = b.center[1] - self.origin[1];
        let cx = cy * dx + sy * dy;
        let cyy = -sy * dx + cy * dy;
        let (st, ct) = (b.yaw - self.yaw).sin_cos();
        let ou = -(cx * ct + cyy * st);
        let ov = cx * st - cyy * ct;
        let (hx, hy) = (b.half[0], b.half[1]);
        let z0 = b.z_min - self.origin[2];
        let z1 = b.z_max - self.origin[2];
        let inside_2d = ou.abs() <= hx + ON_OUTLINE && ov.abs() <= hy + ON_OUTLINE;
        if ou.abs() <= hx && ov.abs() <= hy && z0 <= 0.0 && z1 >= 0.0 {
            return None;
        }
        Some(Placed {
            cx,
            cyy,
            ou,
            ov,
            ct,
            st,
            hx,
            hy,
            z0,
            z1,
            inside_2d,
        })
    }
}

/// Ray parameter interval inside the slab |o + t d| <= h, or `None` if it misses
/// (the general path's column test uses it too).
#[inline]
pub(crate) fn slab(o: f32, d: f32, h: f32) -> Option<(f32, f32)> {
    if d != 0.0 {
        let inv = 1.0 / d;
        let ta = (-h - o) * inv;
        let tb = (h - o) * inv;
        Some((ta.min(tb), ta.max(tb)))
    } else if o.abs() <= h {
        Some((f32::NEG_INFINITY, f32::INFINITY))
    } else {
        None
    }
}
