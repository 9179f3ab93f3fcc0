//! The column sweep of a tilted scan over a range of columns: per column, the boxes
//! whose span covers it nearest first (a [`Cursor`] over the placed spans), stopping at
//! the first one beyond every row's best hit; per box, where the column's vertical
//! half-plane crosses the box's bounding box gives a lower bound on the distance of a
//! hit and the heights where it can be, so only the rows that reach those heights
//! there (two products a row) run the 3D slab test, four rays at a time.
//! A [`Lane`] is one thread's scratch; lanes over disjoint column ranges write disjoint
//! points, each the same as one sweep over every column would. Knows nothing of threads.

use super::place::{Placement, SensorObb};
use crate::column::{Column, Cursor};
use crate::pattern::ScanPattern;
use crate::planar::slab;
use std::ops::Range;

/// A box as seen by one column: ray direction in the box frame is
/// `cos e * a + sin e * b`.
#[derive(Debug, Clone, Copy)]
struct Candidate {
    a: [f32; 3],
    b: [f32; 3],
    origin: [f32; 3],
    half: [f32; 3],
}

/// One thread's sweep state: its cursor over the spans and the current column.
#[derive(Debug, Clone)]
pub(super) struct Lane {
    cursor: Cursor,
    column: Column,
}

impl Lane {
    pub fn new(rows: usize, spans: usize) -> Lane {
        Lane {
            cursor: Cursor::with_capacity(spans),
            column: Column::new(rows),
        }
    }

    /// Casts columns `cols` of `p` into `out`, point (row, col) at
    /// `row * stride + col - cols.start`; returns the returns.
    pub fn sweep(
        &mut self,
        p: &Placement,
        cols: Range<usize>,
        out: &mut [[f32; 3]],
        stride: usize,
    ) -> usize {
        let pattern = &p.pattern;
        let rows = pattern.rows();
        let first = cols.start;
        let mut hits = 0;
        self.cursor.restart();
        for col in cols {
            self.cursor.advance(&p.spans, col);
            let (ca, sa) = (pattern.cos_az[col], pattern.sin_az[col]);
            self.begin_column(p, ca, sa);
            for a in self.cursor.active() {
                if self.column.beyond(a.near()) {
                    break;
                }
                let o = &p.obbs[a.item()];
                cast_obb(o, ca, sa, pattern, &mut self.column);
            }
            for row in 0..rows {
                out[row * stride + col - first] = if self.column.hit[row] {
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
    fn begin_column(&mut self, p: &Placement, ca: f32, sa: f32) {
        let (pattern, sensor) = (&p.pattern, &p.sensor);
        let r = &sensor.rotation;
        let height = sensor.position[2];
        // World z of the column's horizontal direction, for the floor.
        let gz_h = (r[2][0] * f64::from(ca) + r[2][1] * f64::from(sa)) as f32;
        for row in 0..pattern.rows() {
            let mut best = pattern.max_range;
            let mut hit = false;
            let dz = pattern.cos_el[row] * gz_h + pattern.sin_el[row] * r[2][2] as f32;
            if p.hit_floor && dz < 0.0 && height > 0.0 {
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
}

/// Lowers the best hits of the current column (cos `ca`, sin `sa`) to where its rays
/// enter box `o`, in the rows whose elevations can meet it. A ray of this column at
/// distance t is t cos e along (ca, sa) in the xy plane, so it can meet the box only
/// where that 2D ray crosses the box's xy bounding box, at s_in <= t cos e <= t.
#[inline]
fn cast_obb(o: &SensorObb, ca: f32, sa: f32, pattern: &ScanPattern, column: &mut Column) {
    let Some((sx0, sx1)) = slab(-o.xy[0], ca, o.ext[0]) else {
        return;
    };
    let Some((sy0, sy1)) = slab(-o.xy[1], sa, o.ext[1]) else {
        return;
    };
    let s_in = sx0.max(sy0).max(0.0);
    // No hit lies beyond max range, so neither does its horizontal distance.
    let s_out = sx1.min(sy1).min(pattern.max_range);
    // + 0.0 turns a -0.0 into 0.0.
    let near = o.near.max(s_in) + 0.0;
    if s_in > s_out || column.beyond(near) {
        return;
    }
    let cand = Candidate {
        a: o.axes.map(|ax| ax[0] * ca + ax[1] * sa),
        b: o.axes.map(|ax| ax[2]),
        origin: o.origin,
        half: o.half,
    };
    let (first, last) = (o.rows[0] as usize, o.rows[1] as usize);
    let z = o.z;
    // Rows in groups of LANES: a group's three divisions per ray issue as three vector
    // divisions. A lane past `last` repeats `last` and is never set. A row may meet
    // the box where its height over [s_in, s_out] (tan e times those) crosses z: two
    // products, where the tangents of the box's elevations would take two divisions
    // and a table lookup in the chain of every box (its rows in any column come from
    // `place.rs`).
    for row in (first..=last).step_by(LANES) {
        let at = |k: usize| (row + k).min(last);
        let best: [f32; LANES] = std::array::from_fn(|k| column.best[at(k)]);
        let wanted: [bool; LANES] = std::array::from_fn(|k| {
            let tan_e = pattern.tan_el[at(k)];
            let (p, q) = (tan_e * s_in, tan_e * s_out);
            (row + k <= last) & (near <= best[k]) & (p.max(q) >= z[0]) & (p.min(q) <= z[1])
        });
        if !wanted.contains(&true) {
            continue;
        }
        let ce: [f32; LANES] = std::array::from_fn(|k| pattern.cos_el[at(k)]);
        let se: [f32; LANES] = std::array::from_fn(|k| pattern.sin_el[at(k)]);
        let (t, hit) = entries(&cand, &ce, &se, &best, o.plain);
        for k in 0..LANES {
            if wanted[k] && hit[k] {
                column.set(row + k, t[k]);
            }
        }
    }
}

/// Rays whose box tests run side by side: four f32 lanes, one SSE register.
const LANES: usize = 4;

/// Below this (in magnitude) a slab's bound or a direction component sends a group of
/// rays to [`entry`] one by one: above it, no quotient in the slab test is zero, NaN
/// or infinite, where `f32::min` and `max` would differ from a comparison.
pub(super) const TINY: f32 = 1e-30;

/// [`entry`] for LANES rays of one column (cos and sin of their elevations `ce`, `se`)
/// at once, and whether each is a hit. Each lane's entry is the same bits as
/// [`entry`]'s: the same operations in the same order, and where no operand is zero,
/// NaN or infinite (`plain`: the box's slab bounds; the directions are checked here),
/// a comparison picks what `f32::min` and `max` would, without their NaN handling.
#[inline]
fn entries(
    c: &Candidate,
    ce: &[f32; LANES],
    se: &[f32; LANES],
    best: &[f32; LANES],
    plain: bool,
) -> ([f32; LANES], [bool; LANES]) {
    let d: [[f32; LANES]; 3] =
        std::array::from_fn(|i| std::array::from_fn(|k| ce[k] * c.a[i] + se[k] * c.b[i]));
    if !plain || d.iter().flatten().any(|&v| v.abs() < TINY) {
        let each: [Option<f32>; LANES] = std::array::from_fn(|k| entry(c, ce[k], se[k], best[k]));
        return (each.map(|t| t.unwrap_or(0.0)), each.map(|t| t.is_some()));
    }
    let min = |a: f32, b: f32| if a < b { a } else { b };
    let max = |a: f32, b: f32| if a > b { a } else { b };
    let mut t0 = [0.0f32; LANES];
    let mut t1 = [f32::INFINITY; LANES];
    for (i, di) in d.iter().enumerate() {
        let lo = -c.half[i] - c.origin[i];
        let hi = c.half[i] - c.origin[i];
        for k in 0..LANES {
            let inv = 1.0 / di[k];
            let ta = lo * inv;
            let tb = hi * inv;
            t0[k] = max(t0[k], min(ta, tb));
            t1[k] = min(t1[k], max(ta, tb));
        }
    }
    let hit = std::array::from_fn(|k| t0[k] <= t1[k] && t0[k] <= best[k]);
    (t0, hit)
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
/// `best`. The three slabs are intersected without a test between them (the entry only
/// grows and the exit only shrinks, so testing once at the end decides the same): a
/// branch per axis cost more in mispredictions than the divisions it skipped.
#[inline]
fn entry(c: &Candidate, ce: f32, se: f32, best: f32) -> Option<f32> {
    let d: [f32; 3] = std::array::from_fn(|i| ce * c.a[i] + se * c.b[i]);
    if d.contains(&0.0) {
        return entry_parallel(c, d, best);
    }
    // The three slabs at once, without a branch between them: the divisions overlap.
    let mut t0 = 0.0f32;
    let mut t1 = f32::INFINITY;
    for (i, &di) in d.iter().enumerate() {
        let inv = 1.0 / di;
        let ta = (-c.half[i] - c.origin[i]) * inv;
        let tb = (c.half[i] - c.origin[i]) * inv;
        t0 = t0.max(ta.min(tb));
        t1 = t1.min(ta.max(tb));
    }
    (t0 <= t1 && t0 <= best).then_some(t0)
}

/// [`entry`] for a ray parallel to a face pair of the box (a zero direction component).
#[cold]
fn entry_parallel(c: &Candidate, d: [f32; 3], best: f32) -> Option<f32> {
    let mut t0 = 0.0f32;
    let mut t1 = f32::INFINITY;
    for (i, &di) in d.iter().enumerate() {
        let (o, h) = (c.origin[i], c.half[i]);
        if di != 0.0 {
            let inv = 1.0 / di;
            let ta = (-h - o) * inv;
            let tb = (h - o) * inv;
            t0 = t0.max(ta.min(tb));
            t1 = t1.min(ta.max(tb));
        } else if o.abs() > h {
            return None;
        }
    }
    (t0 <= t1 && t0 <= best).then_some(t0)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A deterministic stream in [0, 1).
    fn stream(mut s: u64) -> impl FnMut() -> f32 {
        move || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 40) as f32 / (1u64 << 24) as f32
        }
    }

    #[test]
    fn four_rays_at_once_give_the_bits_of_one_at_a_time() {
        let mut next = stream(0x4_1A2E);
        let mut hits = 0;
        for case in 0..20_000 {
            let mut c = Candidate {
                a: std::array::from_fn(|_| 2.0 * next() - 1.0),
                b: std::array::from_fn(|_| 2.0 * next() - 1.0),
                origin: std::array::from_fn(|_| 12.0 * next() - 6.0),
                half: std::array::from_fn(|_| 0.02 + 2.0 * next()),
            };
            // The cases the fast path must leave to `entry`: the sensor on a face's
            // plane, a ray parallel to a face pair.
            match case % 5 {
                0 => c.origin[case % 3] = c.half[case % 3],
                1 => c.origin[case % 3] = -c.half[case % 3],
                2 => (c.a[case % 3], c.b[case % 3]) = (0.0, 0.0),
                _ => {}
            }
            let plain = (0..3).all(|i| {
                (c.half[i] - c.origin[i]).abs() >= TINY && (-c.half[i] - c.origin[i]).abs() >= TINY
            });
            let e: [f32; LANES] = std::array::from_fn(|_| 1.5 * next() - 0.75);
            let (ce, se) = (e.map(f32::cos), e.map(f32::sin));
            let best: [f32; LANES] = std::array::from_fn(|_| 15.0 * next());
            let (t, hit) = entries(&c, &ce, &se, &best, plain);
            for k in 0..LANES {
                let one = entry(&c, ce[k], se[k], best[k]);
                assert_eq!(hit[k], one.is_some(), "case {case} lane {k}");
                if let Some(want) = one {
                    assert_eq!(t[k].to_bits(), want.to_bits(), "case {case} lane {k}");
                    hits += 1;
                }
            }
        }
        assert!(hits > 2_000, "{hits}");
    }
}
