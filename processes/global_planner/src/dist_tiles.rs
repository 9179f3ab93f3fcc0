//! The arithmetic of the capped obstacle-distance table, apart from its storage
//! (`distance_map.rs`): one tile from the cells near it, and the whole grid at once.
//!
//! A tile is computed in two separable passes. The vertical pass gives, per column, the
//! distance in cells to the nearest occupied cell of that column (the rows just outside
//! the grid count as occupied) when it is at most `reach`, else [`FAR`]; beyond the tile
//! it reads occupancy words (64 columns a word), nearest row first, until every column
//! has met an obstacle or `reach` rows are read. The row pass takes, per row, the lower
//! envelope of the parabolas `(x - x')² + V(x')²` of the columns within `reach` on either
//! side (the columns just outside the grid with V = 0), in integers, and evaluates it at
//! the tile's cells. An obstacle closer than `reach` cells is always among the parabolas,
//! so the squared distance is exact whenever it is under the cap, and at or beyond the
//! cap either way: the stored value, `(sqrt(d²) · res).min(cap)` in f32, is bit for bit
//! the one of the whole-grid transform (Felzenszwalb and Huttenlocher, in f64, whose
//! squared distances are exact integers too), which small maps use to fill every tile at
//! once. Knows cells and distances only.

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

/// Vertical distances of columns `x0..x1` (at most 64), rows `y0..y1` into `out` (row
/// stride `stride`): cells to the nearest occupied cell of the same column (the rows -1
/// and `h` occupied) if at most `reach`, else [`FAR`]. The tile's own rows are read from
/// the cells; the rows within `reach` above and below it as occupancy words (`word(y)`:
/// bit `x - x0` set when cell (x, y) is occupied), nearest first, and only until every
/// column has met an occupied cell.
pub(crate) fn vertical(
    g: Cells,
    word: impl Fn(usize) -> u64,
    reach: usize,
    (x0, x1, y0, y1): (usize, usize, usize, usize),
    out: &mut [u32],
    stride: usize,
) {
    let n = x1 - x0;
    debug_assert!(n <= 64);
    let columns = u64::MAX >> (64 - n);
    // Rows as i32 (half the width of isize, for the vector units). Row -1 is occupied;
    // from a tile row more than `reach` below the margin it is beyond the reach anyway.
    let mut near = [-1i32; 64];
    let mut open = columns;
    for y in (y0.saturating_sub(reach)..y0).rev() {
        open = meet(word(y) & open, y as i32, open, &mut near);
        if open == 0 {
            break;
        }
    }
    for y in y0..y1 {
        let row = &g.cells[y * g.w + x0..y * g.w + x1];
        for (last, &c) in near.iter_mut().zip(row) {
            if c != FREE {
                *last = y as i32;
            }
        }
        let o = &mut out[(y - y0) * stride..(y - y0) * stride + n];
        for (v, &last) in o.iter_mut().zip(&near) {
            *v = (y as i32 - last) as u32;
        }
    }
    near = [g.h as i32; 64];
    open = columns;
    for y in y1..(y1 + reach).min(g.h) {
        open = meet(word(y) & open, y as i32, open, &mut near);
        if open == 0 {
            break;
        }
    }
    for y in (y0..y1).rev() {
        let row = &g.cells[y * g.w + x0..y * g.w + x1];
        for (next, &c) in near.iter_mut().zip(row) {
            if c != FREE {
                *next = y as i32;
            }
        }
        let o = &mut out[(y - y0) * stride..(y - y0) * stride + n];
        for (v, &next) in o.iter_mut().zip(&near) {
            let d = (*v).min((next - y as i32) as u32);
            *v = if d as usize > reach { FAR } else { d };
        }
    }
}

/// Row `y` for the columns of `hits` (still open): they meet an occupied cell there.
/// Returns the columns still open.
#[inline]
fn meet(mut hits: u64, y: i32, open: u64, near: &mut [i32; 64]) -> u64 {
    let left = open & !hits;
    while hits != 0 {
        near[hits.trailing_zeros() as usize] = y;
        hits &= hits - 1;
    }
    left
}

/// One bit per cell of `row` (at most 64 cells), set when the cell is not free.
pub(crate) fn occupancy_word(row: &[u8]) -> u64 {
    const LOW7: u64 = 0x7f7f_7f7f_7f7f_7f7f;
    const HIGH: u64 = 0x8080_8080_8080_8080;
    // Gathers bit 0 of each byte into the top byte, byte i to bit 56 + i.
    const GATHER: u64 = 0x0102_0408_1020_4080;
    let mut word = 0u64;
    let mut chunks = row.chunks_exact(8);
    for (k, chunk) in chunks.by_ref().enumerate() {
        let w = u64::from_le_bytes(chunk.try_into().expect("8 bytes"));
        // Bit 7 of each byte: set when the byte is not zero.
        let nonzero = (((w & LOW7) + LOW7) | w) & HIGH;
        word |= ((nonzero >> 7).wrapping_mul(GATHER) >> 56) << (8 * k);
    }
    let done = row.len() - chunks.remainder().len();
    for (x, &c) in chunks.remainder().iter().enumerate() {
        word |= u64::from(c != FREE) << (done + x);
    }
    word
}

/// The row pass of one row: the lower envelope of the parabolas pushed so far, built as
/// they come (positions strictly increasing). All in integers: a parabola is its column
/// and squared vertical distance, and where two meet is kept as an exact fraction, so no
/// division decides which parabola is lowest and every squared distance is the exact
/// integer the whole-grid transform computes in f64.
#[derive(Debug, Default)]
pub(crate) struct Envelope {
    /// The parabolas on the envelope, in order (`len` of them; the rest is scratch).
    lowest: Vec<Parabola>,
    len: usize,
}

/// A parabola of the envelope and where it becomes the lowest.
#[derive(Debug, Default, Clone, Copy)]
struct Parabola {
    /// Its column.
    q: i64,
    /// Its squared vertical distance.
    f: i64,
    /// Lowest from `num / den` on (den > 0; den 0 is minus infinity).
    num: i64,
    den: i64,
}

impl Envelope {
    pub(crate) fn clear(&mut self) {
        self.len = 0;
    }

    /// Adds the parabola of column `x` (positions strictly increasing) with vertical
    /// distance `vd`.
    #[inline]
    pub(crate) fn push(&mut self, x: isize, vd: u32) {
        if vd == FAR {
            return;
        }
        let (q, f) = (x as i64, i64::from(vd) * i64::from(vd));
        let mut new = Parabola {
            q,
            f,
            num: -1,
            den: 0,
        };
        while self.len > 0 {
            let last = self.lowest[self.len - 1];
            // Where this parabola meets the last one: num / den, den > 0.
            new.num = (f + q * q) - (last.f + last.q * last.q);
            new.den = 2 * (q - last.q);
            // At or before where the last one became lowest: the last one never is.
            if new.num * last.den > last.num * new.den {
                break;
            }
            self.len -= 1;
            (new.num, new.den) = (-1, 0);
        }
        if self.len == self.lowest.len() {
            self.lowest.push(new);
        } else {
            self.lowest[self.len] = new;
        }
        self.len += 1;
    }

    /// Writes `(sqrt(d²) · res).min(cap)` for columns `x0..x0 + out.len()`.
    pub(crate) fn eval(&self, x0: usize, res: f64, cap: f64, out: &mut [f32]) {
        let lowest = &self.lowest[..self.len];
        let Some(mut p) = lowest.first() else {
            out.fill(cap as f32);
            return;
        };
        let mut rest = lowest[1..].iter();
        let mut next = rest.next();
        for (i, o) in out.iter_mut().enumerate() {
            let x = (x0 + i) as i64;
            // The next parabola is lowest from num / den on: strictly before x.
            while let Some(n) = next.filter(|n| n.num < x * n.den) {
                p = n;
                next = rest.next();
            }
            let dx = x - p.q;
            let d2 = dx * dx + p.f;
            *o = ((d2 as f64).sqrt() * res).min(cap) as f32;
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
