//! The fast path: a scan from a level sensor (its z axis is world z; any yaw).
//!
//! Every box is axis-aligned in its body frame and bodies only yaw, so for a level sensor
//! each box is a rotated rectangle times a z interval in the sensor frame. All rays of one
//! azimuth column share a horizontal direction, so the 2D slab test of a box against the
//! column gives an interval [s_in, s_out] of horizontal distance that holds for every
//! elevation; a ray at elevation e (z = s tan e) then hits where that interval meets
//! z0 <= s tan e <= z1, which is two multiplications. Per scan each box is moved to the
//! sensor frame once, culled by range, and given the column and row span it can occupy;
//! a sweep over columns keeps the boxes whose span covers the column, sorted by s_in,
//! so each ray stops at the first box that starts beyond its best hit.
//!
//! Knows nothing of noise or of the general (tilted) case.

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

/// Columns `c_lo..=c_hi` may see box `sbox`.
#[derive(Debug, Clone, Copy)]
struct Span {
    c_lo: u32,
    c_hi: u32,
    sbox: u32,
}

/// A box that the current column's vertical plane crosses within range.
#[derive(Debug, Clone, Copy)]
struct Candidate {
    s_in: f32,
    s_out: f32,
    z0: f32,
    z1: f32,
    row_lo: u32,
    row_hi: u32,
}

/// Reusable buffers; sized for the scene once, so a scan allocates nothing.
#[derive(Debug, Clone)]
pub(crate) struct PlanarCaster {
    sboxes: Vec<SensorBox>,
    spans: Vec<Span>,
    active: Vec<u32>,
    cands: Vec<Candidate>,
    /// The candidates in order of `s_in`: its bits (never negative, so they sort as
    /// integers) above the candidate's index.
    order: Vec<u64>,
    floor_s: Vec<f32>,
    near: Near,
}

/// Origins this close to a box's outline count as inside it for the azimuth span, where
/// the corner angles would otherwise wrap unpredictably.
const ON_OUTLINE: f64 = 1e-9;

impl PlanarCaster {
    pub(crate) fn new(box_count: usize, rows: usize) -> PlanarCaster {
        PlanarCaster {
            sboxes: Vec::with_capacity(box_count),
            // A box can straddle the +-pi seam of a 360 deg scan: up to three spans.
            spans: Vec::with_capacity(3 * box_count),
            active: Vec::with_capacity(3 * box_count),
            cands: Vec::with_capacity(3 * box_count),
            order: Vec::with_capacity(3 * box_count),
            floor_s: vec![f32::INFINITY; rows],
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
        self.spans.clear();
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
            let Some((row_lo, row_hi)) = frame.rows(&p) else {
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
                row_lo,
                row_hi,
            });
            self.push_spans(&frame, &p, index);
        }
        self.spans.sort_unstable_by_key(|s| (s.c_lo, s.sbox));
    }

    /// Horizontal distance at which each row's ray meets the floor (infinite for rays
    /// that do not point down, or when the floor is not hit).
    fn floor_distances(&mut self, pattern: &ScanPattern, origin: [f64; 3], hit_floor: bool) {
        for (r, f) in self.floor_s.iter_mut().enumerate() {
            let k = pattern.tan_el[r];
            *f = if hit_floor && k < 0.0 && origin[2] > 0.0 {
                (origin[2] / -f64::from(k)) as f32
            } else {
                f32::INFINITY
            };
        }
    }

    /// The columns that may see box `index`: every column if the sensor is within its
    /// outline, else the azimuths between its extreme corners (one spare column either
    /// way), once per copy of that interval shifted by a turn that meets the pattern.
    #[inline]
    fn push_spans(&mut self, frame: &Frame, p: &Placed, index: u32) {
        let cols = frame.cols;
        if p.inside_2d {
            self.spans.push(Span {
                c_lo: 0,
                c_hi: (cols - 1) as u32,
                sbox: index,
            });
            return;
        }
        let (cx, cyy, ct, st, hx, hy) = (p.cx, p.cyy, p.ct, p.st, p.hx, p.hy);
        let ac = cyy.atan2(cx);
        let (mut dlo, mut dhi) = (f64::INFINITY, f64::NEG_INFINITY);
        for (su, sv) in [(1.0, 1.0), (1.0, -1.0), (-1.0, 1.0), (-1.0, -1.0)] {
            // Corner = centre + su*hx*u + sv*hy*v, with u = (ct, st), v = (-st, ct).
            let px = cx + su * hx * ct - sv * hy * st;
            let py = cyy + su * hx * st + sv * hy * ct;
            let d = aisle_geometry::wrap_angle(py.atan2(px) - ac);
            dlo = dlo.min(d);
            dhi = dhi.max(d);
        }
        for shift in [-std::f64::consts::TAU, 0.0, std::f64::consts::TAU] {
            let lo = ((ac + dlo + shift - frame.az0) / frame.az_step).ceil() - 1.0;
            let hi = ((ac + dhi + shift - frame.az0) / frame.az_step).floor() + 1.0;
            if hi < 0.0 || lo > (cols - 1) as f64 {
                continue;
            }
            self.spans.push(Span {
                c_lo: lo.max(0.0) as u32,
                c_hi: hi.min((cols - 1) as f64) as u32,
                sbox: index,
            });
        }
    }

    fn sweep(&mut self, pattern: &ScanPattern, out: &mut [[f32; 3]]) -> usize {
        let rows = pattern.rows();
        let cols = pattern.columns();
        let range = pattern.max_range;
        let nan = [f32::NAN; 3];
        let mut next = 0;
        let mut hits = 0;
        self.active.clear();
        for c in 0..cols {
            while next < self.spans.len() && self.spans[next].c_lo as usize <= c {
                self.active.push(next as u32);
                next += 1;
            }
            let mut i = 0;
            while i < self.active.len() {
                if (self.spans[self.active[i] as usize].c_hi as usize) < c {
                    self.active.swap_remove(i);
                } else {
                    i += 1;
                }
            }
            let ca = pattern.cos_az[c];
            let sa = pattern.sin_az[c];
            self.cands.clear();
            self.order.clear();
            for &si in &self.active {
                let b = &self.sboxes[self.spans[si as usize].sbox as usize];
                let du = ca * b.ux + sa * b.uy;
                let dv = sa * b.ux - ca * b.uy;
                let Some((u0, u1)) = slab(b.ou, du, b.hx) else {
                    continue;
                };
                let Some((v0, v1)) = slab(b.ov, dv, b.hy) else {
                    continue;
                };
                // + 0.0 turns a -0.0 into 0.0, whose bits sort first.
                let s_in = u0.max(v0).max(0.0) + 0.0;
                let s_out = u1.min(v1);
                if s_in <= s_out && s_in <= range {
                    let key = (u64::from(s_in.to_bits()) << 32) | self.cands.len() as u64;
                    self.order.push(key);
                    self.cands.push(Candidate {
                        s_in,
                        s_out,
                        z0: b.z0,
                        z1: b.z1,
                        row_lo: b.row_lo,
                        row_hi: b.row_hi,
                    });
                }
            }
            self.order.sort_unstable();

            for r in 0..rows {
                let k = pattern.tan_el[r];
                let mut best = range * pattern.cos_el[r];
                let mut hit = false;
                if self.floor_s[r] <= best {
                    best = self.floor_s[r];
                    hit = true;
                }
                for &key in &self.order {
                    let cand = &self.cands[(key & 0xffff_ffff) as usize];
                    if cand.s_in > best {
                        break;
                    }
                    let row = r as u32;
                    if row < cand.row_lo || row > cand.row_hi {
                        continue;
                    }
                    // Horizontal distances where the ray's height lies in [z0, z1].
                    let (lo, hi) = if k > 0.0 {
                        (cand.z0 / k, cand.z1 / k)
                    } else if k < 0.0 {
                        (cand.z1 / k, cand.z0 / k)
                    } else if cand.z0 <= 0.0 && cand.z1 >= 0.0 {
                        (f32::NEG_INFINITY, f32::INFINITY)
                    } else {
                        continue;
                    };
                    let s = cand.s_in.max(lo);
                    if s <= cand.s_out.min(hi) && s <= best {
                        best = s;
                        hit = true;
                    }
                }
                out[r * cols + c] = if hit {
                    hits += 1;
                    [best * ca, best * sa, best * k]
                } else {
                    nan
                };
            }
        }
        hits
    }
}

/// What placing boxes in one scan needs: the sensor's position and yaw, the range and
/// the pattern's first angles and steps.
#[derive(Debug, Clone, Copy)]
struct Frame {
    origin: [f64; 3],
    yaw: f64,
    sy: f64,
    cy: f64,
    range: f64,
    rows: usize,
    cols: usize,
    el0: f64,
    el_step: f64,
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
        let rows = pattern.rows();
        let cols = pattern.columns();
        let el = pattern.elevations();
        let az = pattern.azimuths();
        let (sy, cy) = yaw.sin_cos();
        Frame {
            origin,
            yaw,
            sy,
            cy,
            range: pattern.max_range(),
            rows,
            cols,
            el0: el[0],
            el_step: if rows > 1 { el[1] - el[0] } else { 1.0 },
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

    /// The rows that may see `p` (one spare channel either way: a spare candidate
    /// costs a test, a missing one would lose a return), or `None` when it is beyond
    /// range or outside every row.
    #[inline]
    fn rows(&self, p: &Placed) -> Option<(u32, u32)> {
        let (ou, ov, hx, hy, z0, z1) = (p.ou, p.ov, p.hx, p.hy, p.z0, p.z1);
        let ex = (ou.abs() - hx).max(0.0);
        let ey = (ov.abs() - hy).max(0.0);
        let dmin = ex.hypot(ey);
        if dmin > self.range {
            return None;
        }
        let dmax = (ou.abs() + hx).hypot(ov.abs() + hy).min(self.range);
        // Elevations of the box's points: (d, z) ranges over [dmin, dmax] x [z0, z1].
        let e_hi = z1.atan2(if z1 > 0.0 { dmin } else { dmax });
        let e_lo = z0.atan2(if z0 > 0.0 { dmax } else { dmin });
        let lo = ((e_lo - self.el0) / self.el_step).ceil() - 1.0;
        let hi = ((e_hi - self.el0) / self.el_step).floor() + 1.0;
        let last = (self.rows - 1) as f64;
        if hi < 0.0 || lo > last {
            return None;
        }
        Some((lo.max(0.0) as u32, hi.min(last) as u32))
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
