//! The arithmetic of the capped obstacle-distance table, apart from its storage
//! (`distance_map.rs`): one tile from the cells near it, and the whole grid at once.
//!
//! A tile is computed in two separable passes. The vertical pass gives, per column, the
//! distance in cells to the nearest occupied cell of that column (the rows just outside
//! the grid count as occupied) when it is at most `reach`, else [`FAR`]; it reads the
//! column `reach` rows above and below the tile and no farther. The row pass takes, per
//! row, the lower envelope of the parabolas `(x - x')² + V(x')²` of the columns within
//! `reach` on either side (the columns just outside the grid with V = 0) and evaluates it
//! at the tile's cells. An obstacle closer than `reach` cells is always among the
//! parabolas, so the squared distance is exact whenever it is under the cap, and at or
//! beyond the cap either way: the stored value, `(sqrt(d²) · res).min(cap)` in f32, is bit
//! for bit the one of the whole-grid transform (Felzenszwalb and Huttenlocher), which
//! small maps use to fill every tile at once. Knows cells and distances only.

use aisle_geometry::FREE;

/// A vertical distance beyond the reach: the column adds nothing within the cap.
pub(crate) const FAR: u32 = u32::MAX;

/// A grid of cells, `w` by `h`, row-major.
#[derive(Clone, Copy)]
pub(crate) struct Cells<'a> {
    pub cells: &'a [u8],
    pub w: usize,
    pub h: usize,
}

/// Vertical distances of columns `x0..x1`, rows `y0..y1` into `out` (row stride
/// `stride`): cells to the nearest occupied cell of the same column (the rows -1 and `h`
/// occupied) if at most `reach`, else [`FAR`].
pub(crate) fn vertical(
    g: Cells,
    reach: usize,
    (x0, x1, y0, y1): (usize, usize, usize, usize),
    out: &mut [u32],
    stride: usize,
) {
    let n = x1 - x0;
    // Rows as i32 (half the width of isize, for the vector units).
    let mut near = vec![-1i32; n];
    // Rows farther than `reach` from the tile cannot bring a column under it.
    for y in y0.saturating_sub(reach)..y1 {
        let row = &g.cells[y * g.w + x0..y * g.w + x1];
        for (last, &c) in near.iter_mut().zip(row) {
            if c != FREE {
                *last = y as i32;
            }
        }
        if y >= y0 {
            let o = &mut out[(y - y0) * stride..(y - y0) * stride + n];
            for (v, &last) in o.iter_mut().zip(&near) {
                *v = (y as i32 - last) as u32;
            }
        }
    }
    near.fill(g.h as i32);
    for y in (y0..(y1 + reach).min(g.h)).rev() {
        let row = &g.cells[y * g.w + x0..y * g.w + x1];
        for (next, &c) in near.iter_mut().zip(row) {
            if c != FREE {
                *next = y as i32;
            }
        }
        if y < y1 {
            let o = &mut out[(y - y0) * stride..(y - y0) * stride + n];
            for (v, &next) in o.iter_mut().zip(&near) {
                let d = (*v).min((next - y as i32) as u32);
                *v = if d as usize > reach { FAR } else { d };
            }
        }
    }
}

/// Scratch of the row pass: the parabolas of one row and their lower envelope.
#[derive(Debug, Default)]
pub(crate) struct Envelope {
    q: Vec<f64>,
    f: Vec<f64>,
    v: Vec<usize>,
    z: Vec<f64>,
}

impl Envelope {
    pub(crate) fn clear(&mut self) {
        self.q.clear();
        self.f.clear();
    }

    /// Adds the parabola of column `x` (positions strictly increasing) with vertical
    /// distance `vd`.
    #[inline]
    pub(crate) fn push(&mut self, x: isize, vd: u32) {
        if vd != FAR {
            self.q.push(x as f64);
            self.f.push(f64::from(vd) * f64::from(vd));
        }
    }

    /// Writes `(sqrt(d²) · res).min(cap)` for columns `x0..x0 + out.len()`.
    pub(crate) fn eval(&mut self, x0: usize, res: f64, cap: f64, out: &mut [f32]) {
        let m = self.q.len();
        if m == 0 {
            out.fill(cap as f32);
            return;
        }
        let (q, f) = (&self.q, &self.f);
        self.v.resize(m, 0);
        self.z.resize(m + 1, 0.0);
        let (v, z) = (&mut self.v, &mut self.z);
        lower_envelope(m, v, z, |a: usize, b: usize| {
            ((f[a] + q[a] * q[a]) - (f[b] + q[b] * q[b])) / (2.0 * (q[a] - q[b]))
        });
        let mut k = 0;
        for (i, o) in out.iter_mut().enumerate() {
            let x = (x0 + i) as f64;
            while z[k + 1] < x {
                k += 1;
            }
            let dx = x - q[v[k]];
            let d2 = dx * dx + f[v[k]];
            *o = (d2.sqrt() * res).min(cap) as f32;
        }
    }
}

/// The whole grid's capped distances at once (row-major): the squared EDT of the grid
/// with one ring of occupied cells around it.
pub(crate) fn whole_grid(g: Cells, res: f64, cap: f64) -> Vec<f32> {
    let (pw, ph) = (g.w + 2, g.h + 2);
    // Larger than any real squared distance yet small enough to stay exact.
    let far = 4.0 * ((pw + ph) * (pw + ph)) as f64;
    let mut padded = vec![0.0; pw * ph];
    for y in 0..g.h {
        for x in 0..g.w {
            if g.cells[y * g.w + x] == FREE {
                padded[(y + 1) * pw + x + 1] = far;
            }
        }
    }
    let n = pw.max(ph);
    let (mut f, mut d, mut v, mut z) = (vec![0.0; n], vec![0.0; n], vec![0; n], vec![0.0; n + 1]);
    for px in 0..pw {
        for py in 0..ph {
            f[py] = padded[py * pw + px];
        }
        edt_1d(&f[..ph], &mut d[..ph], &mut v, &mut z);
        for py in 0..ph {
            padded[py * pw + px] = d[py];
        }
    }
    let mut out = vec![0.0f32; g.w * g.h];
    for py in 1..ph - 1 {
        f[..pw].copy_from_slice(&padded[py * pw..(py + 1) * pw]);
        edt_1d(&f[..pw], &mut d[..pw], &mut v, &mut z);
        for x in 0..g.w {
            out[(py - 1) * g.w + x] = (d[x + 1].sqrt() * res).min(cap) as f32;
        }
    }
    out
}

/// 1D squared distance transform of sampled function `f` into `d`.
fn edt_1d(f: &[f64], d: &mut [f64], v: &mut [usize], z: &mut [f64]) {
    let n = f.len();
    lower_envelope(n, v, z, |q: usize, p: usize| -> f64 {
        let (qf, pf) = (q as f64, p as f64);
        ((f[q] + qf * qf) - (f[p] + pf * pf)) / (2.0 * (qf - pf))
    });
    let mut k = 0;
    for (q, dq) in d.iter_mut().enumerate().take(n) {
        while z[k + 1] < q as f64 {
            k += 1;
        }
        let dx = q as f64 - v[k] as f64;
        *dq = dx * dx + f[v[k]];
    }
}

/// The lower envelope of `n` parabolas (Felzenszwalb and Huttenlocher): `v[..=k]` the
/// parabolas on it, in order, and `z[j]..z[j + 1]` where parabola `v[j]` is lowest;
/// `inter(a, b)` is where parabolas `a` and `b` meet.
#[inline]
fn lower_envelope(n: usize, v: &mut [usize], z: &mut [f64], inter: impl Fn(usize, usize) -> f64) {
    let mut k = 0usize;
    v[0] = 0;
    z[0] = f64::NEG_INFINITY;
    z[1] = f64::INFINITY;
    for q in 1..n {
        let mut s = inter(q, v[k]);
        while s <= z[k] {
            k -= 1;
            s = inter(q, v[k]);
        }
        k += 1;
        v[k] = q;
        z[k] = s;
        z[k + 1] = f64::INFINITY;
    }
}
