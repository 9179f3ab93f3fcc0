//! The column sweep of a tilted scan over a range of columns: per column, the boxes
//! whose span covers it nearest first (a [`Cursor`] over the placed spans), stopping at
//! the first one beyond every row's best hit; per box, where the column's vertical
//! half-plane crosses the box's bounding box gives a lower bound on the distance of a
//! hit and the elevations that can hit it, so only those rows run the 3D slab test.
//! A [`Lane`] is one thread's scratch; lanes over disjoint column ranges write disjoint
//! points, each the same as one sweep over every column would. Knows nothing of threads.

use super::place::{Placement, SensorObb};
use crate::column::{Column, Cursor, RowTable};
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
                cast_obb(o, ca, sa, pattern, &p.table, &mut self.column);
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
