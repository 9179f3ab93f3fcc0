//! What both scan paths share to cast one azimuth column nearest first: the sweep that
//! lists the boxes a column may see in order of a lower bound on their distance, the
//! column's per-row best hits, and the table from a tangent of elevation to the rows
//! that may have it.
//!
//! A column visits its boxes nearest first and stops at the first one whose lower bound
//! lies beyond every row's best hit: the boxes behind those hits cost nothing, so a
//! scan's cost follows what it sees more than what lies within range (a box hidden in
//! some rows only still costs its column test). Each box tests only the rows its
//! tangents allow, and a row whose best hit is nearer than the box's entry skips it. The result of each ray is the minimum over the boxes that can
//! be hit, so the visiting order changes no point. Knows nothing of boxes' shapes, of
//! poses or of the world: callers pass distances and tangents.

/// Lower bounds on a box's distance are this much below the f64 one (metres), so the
/// f32 distances the rays compute never fall short of them.
pub(crate) const NEAR_SLACK: f64 = 1e-3;

/// Columns `c_lo..=c_hi` may see item `item`, no hit of which is nearer than `near`
/// (never negative).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Span {
    pub(crate) c_lo: u32,
    pub(crate) c_hi: u32,
    pub(crate) item: u32,
    pub(crate) near: f32,
}

impl Span {
    /// Orders spans nearest first; the item breaks ties, so the order is total.
    #[inline]
    fn key(&self) -> u64 {
        // + 0.0 turns a -0.0 into 0.0; non-negative floats sort as their bits.
        (u64::from((self.near + 0.0).to_bits()) << 32) | u64::from(self.item)
    }
}

/// A span that covers the current column: its order key (see [`Span`]) and last
/// column, side by side so that keeping the list costs no lookups.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Active {
    key: u64,
    c_hi: u32,
}

impl Active {
    /// No hit of the item is nearer than this.
    #[inline]
    pub(crate) fn near(&self) -> f32 {
        f32::from_bits((self.key >> 32) as u32)
    }

    #[inline]
    pub(crate) fn item(&self) -> usize {
        (self.key & 0xffff_ffff) as usize
    }
}

/// The spans of one scan and those that cover the current column, nearest first.
/// Sized once; reused every scan.
#[derive(Debug, Clone, Default)]
pub(crate) struct Sweep {
    pub(crate) spans: Vec<Span>,
    cursor: Cursor,
}

impl Sweep {
    pub(crate) fn with_capacity(spans: usize) -> Sweep {
        Sweep {
            spans: Vec::with_capacity(spans),
            cursor: Cursor::with_capacity(spans),
        }
    }

    pub(crate) fn clear(&mut self) {
        self.spans.clear();
        self.cursor.restart();
    }

    /// Call once every span is pushed, before the first [`Sweep::advance`].
    pub(crate) fn start(&mut self) {
        sort_spans(&mut self.spans);
        self.cursor.restart();
    }

    /// Moves to column `col` (columns in increasing order).
    #[inline]
    pub(crate) fn advance(&mut self, col: usize) {
        self.cursor.advance(&self.spans, col);
    }

    /// The spans covering the current column, nearest first.
    #[inline]
    pub(crate) fn active(&self) -> &[Active] {
        self.cursor.active()
    }
}

/// Puts spans in the order a [`Cursor`] reads them.
pub(crate) fn sort_spans(spans: &mut [Span]) {
    spans.sort_unstable_by_key(|s| (s.c_lo, s.item));
}

/// The spans (of a list sorted by [`sort_spans`], which someone else may own) that cover
/// the current column, nearest first. It may start at any column: the list it holds
/// there is the same as if it had advanced through every column before.
#[derive(Debug, Clone, Default)]
pub(crate) struct Cursor {
    active: Vec<Active>,
    next: usize,
}

impl Cursor {
    pub(crate) fn with_capacity(spans: usize) -> Cursor {
        Cursor {
            active: Vec::with_capacity(spans),
            next: 0,
        }
    }

    /// Back before the first column.
    pub(crate) fn restart(&mut self) {
        self.active.clear();
        self.next = 0;
    }

    /// Moves to column `col` of `spans` (columns in increasing order since the last
    /// restart).
    pub(crate) fn advance(&mut self, spans: &[Span], col: usize) {
        let col = col as u32;
        self.active.retain(|a| a.c_hi >= col);
        while let Some(s) = spans.get(self.next).filter(|s| s.c_lo <= col) {
            // Spans that ended before `col` only occur when a cursor starts past them.
            if s.c_hi >= col {
                let key = s.key();
                let at = self.active.partition_point(|a| a.key < key);
                self.active.insert(at, Active { key, c_hi: s.c_hi });
            }
            self.next += 1;
        }
    }

    /// The spans covering the current column, nearest first.
    #[inline]
    pub(crate) fn active(&self) -> &[Active] {
        &self.active
    }
}

/// One column's best hit per row: its distance and whether it is a return.
#[derive(Debug, Clone, Default)]
pub(crate) struct Column {
    pub(crate) best: Vec<f32>,
    pub(crate) hit: Vec<bool>,
    /// An upper bound on every row's best: their largest when `stale` is false.
    max: f32,
    /// The row that holds `max`; once it gets nearer, `max` is stale.
    arg: usize,
    stale: bool,
}

impl Column {
    pub(crate) fn new(rows: usize) -> Column {
        Column {
            best: vec![0.0; rows],
            hit: vec![false; rows],
            max: 0.0,
            arg: 0,
            stale: false,
        }
    }

    /// Starts a column as a copy of `start` (each row's distance and return flag
    /// before any box). Allocates nothing.
    #[inline]
    pub(crate) fn begin(&mut self, start: &Column) {
        self.best.copy_from_slice(&start.best);
        self.hit.copy_from_slice(&start.hit);
        (self.max, self.arg, self.stale) = (start.max, start.arg, start.stale);
    }

    /// Recomputes the largest best after rows were set directly.
    #[inline]
    pub(crate) fn refresh(&mut self) {
        (self.arg, self.max) = (0, f32::NEG_INFINITY);
        for (r, &b) in self.best.iter().enumerate() {
            if b > self.max {
                (self.arg, self.max) = (r, b);
            }
        }
        self.stale = false;
    }

    /// Row `row` returns at distance `s`, no farther than its best so far.
    #[inline]
    pub(crate) fn set(&mut self, row: usize, s: f32) {
        self.best[row] = s;
        self.hit[row] = true;
        self.stale |= row == self.arg;
    }

    /// Whether distance `d` lies beyond every row's best hit, so that nothing starting
    /// there can change the column.
    #[inline]
    pub(crate) fn beyond(&mut self, d: f32) -> bool {
        if d > self.max {
            return true;
        }
        if self.stale {
            self.refresh();
            return d > self.max;
        }
        false
    }
}

/// From a tangent of elevation to the rows that may have it, through bins over the
/// pattern's tangents squeezed into (-1, 1) by t / (1 + |t|) (so that rows near +-90 deg
/// do not spread the bins): each bin knows the first row at or above its lower edge and
/// the last row at or below its upper edge.
#[derive(Debug, Clone)]
pub(crate) struct RowTable {
    u0: f32,
    u1: f32,
    inv_w: f32,
    first: Vec<u32>,
    last: Vec<u32>,
}

/// At most this many bins.
const MAX_BINS: usize = 4096;
/// Widening of a tangent interval before it is looked up, relative to 1 + |tangent|:
/// far above the rounding of the f32 tests the rows are then put to.
const TAN_PAD: f32 = 1e-5;

/// Monotone, from the tangents onto (-1, 1).
#[inline]
fn squeeze(t: f32) -> f32 {
    t / (1.0 + t.abs())
}

impl RowTable {
    /// A table for the rows' tangents `tan`, increasing.
    pub(crate) fn new(tan: &[f32]) -> RowTable {
        let u: Vec<f32> = tan.iter().map(|&t| squeeze(t)).collect();
        let n = u.len();
        let (u0, u1) = (u[0], u[n - 1]);
        let gap = u
            .windows(2)
            .map(|w| w[1] - w[0])
            .fold(f32::INFINITY, f32::min);
        let bins = if n > 1 && gap > 0.0 {
            (f64::from(u1 - u0) / f64::from(0.5 * gap))
                .ceil()
                .clamp(1.0, MAX_BINS as f64) as usize
        } else {
            1
        };
        let w = ((u1 - u0) / bins as f32).max(f32::MIN_POSITIVE);
        let first = (0..bins)
            .map(|b| u.partition_point(|&v| v < u0 + b as f32 * w) as u32)
            .collect();
        let mut last: Vec<u32> = (0..bins)
            .map(|b| (u.partition_point(|&v| v <= u0 + (b + 1) as f32 * w) as u32).max(1) - 1)
            .collect();
        // The top bin reaches the top row, whatever the rounding of its upper edge.
        last[bins - 1] = n as u32 - 1;
        RowTable {
            u0,
            u1,
            inv_w: 1.0 / w,
            first,
            last,
        }
    }

    /// The rows whose tangent may lie in [`lo`, `hi`] (a superset, in order), or `None`
    /// when none does. NaN bounds count as unbounded.
    #[inline]
    pub(crate) fn rows(&self, lo: f32, hi: f32) -> Option<(usize, usize)> {
        let lo = squeeze(lo - TAN_PAD * (1.0 + lo.abs()));
        let hi = squeeze(hi + TAN_PAD * (1.0 + hi.abs()));
        if lo > self.u1 || hi < self.u0 {
            return None;
        }
        let bins = self.first.len();
        // One spare bin either way covers the rounding of the squeeze and the index.
        let bin = |u: f32| ((u - self.u0) * self.inv_w) as isize;
        let a = if lo >= self.u0 {
            self.first[(bin(lo) - 1).clamp(0, bins as isize - 1) as usize] as usize
        } else {
            0
        };
        let b = if hi <= self.u1 {
            self.last[(bin(hi) + 1).clamp(0, bins as isize - 1) as usize] as usize
        } else {
            self.last[bins - 1] as usize
        };
        (a <= b).then_some((a, b))
    }
}

/// The rows that may see a box whose points lie at sensor-frame offsets within `half`
/// of `centre` horizontally (x, y) and at heights in `z` (relative to the sensor), and
/// its least horizontal distance from the sensor; `None` when it is beyond `range` or
/// outside every row. The points' horizontal distances lie in [dmin, dmax], which with
/// `z` bound the tangents of their elevations.
#[inline]
pub(crate) fn box_rows(
    table: &RowTable,
    range: f64,
    centre: [f64; 2],
    half: [f64; 2],
    z: [f64; 2],
) -> Option<(usize, usize, f64)> {
    let ex = (centre[0].abs() - half[0]).max(0.0);
    let ey = (centre[1].abs() - half[1]).max(0.0);
    let dmin = (ex * ex + ey * ey).sqrt();
    if dmin > range {
        return None;
    }
    let fx = centre[0].abs() + half[0];
    let fy = centre[1].abs() + half[1];
    let dmax = (fx * fx + fy * fy).sqrt().min(range);
    // 0 / 0 is NaN, which the table takes as unbounded.
    let hi = z[1] / if z[1] > 0.0 { dmin } else { dmax };
    let lo = z[0] / if z[0] > 0.0 { dmax } else { dmin };
    let (a, b) = table.rows(lo as f32, hi as f32)?;
    Some((a, b, dmin))
}

/// Largest error of [`azimuth`] (radians).
pub(crate) const AZIMUTH_ERR: f64 = 2e-5;

/// `y.atan2(x)` within [`AZIMUTH_ERR`], for the columns a box may cover (a polynomial
/// on [0, 1], Abramowitz and Stegun 4.4.47); a fraction of the cost of `atan2`.
#[inline]
pub(crate) fn azimuth(y: f64, x: f64) -> f64 {
    let (ax, ay) = (x.abs(), y.abs());
    let (num, den) = if ay <= ax { (ay, ax) } else { (ax, ay) };
    if den == 0.0 {
        return 0.0;
    }
    let t = num / den;
    let t2 = t * t;
    let mut a = t
        * (0.999_866
            + t2 * (-0.330_299_5 + t2 * (0.180_141 + t2 * (-0.085_133 + t2 * 0.020_835_1))));
    if ay > ax {
        a = std::f64::consts::FRAC_PI_2 - a;
    }
    if x < 0.0 {
        a = std::f64::consts::PI - a;
    }
    if y < 0.0 { -a } else { a }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn azimuth_is_within_its_error_of_atan2() {
        let mut worst = 0.0f64;
        for i in 0..20_000 {
            let a = i as f64 * std::f64::consts::TAU / 20_000.0 - std::f64::consts::PI;
            for r in [1e-3, 1.0, 37.0] {
                let (y, x) = (r * a.sin(), r * a.cos());
                let d = aisle_geometry::wrap_angle(azimuth(y, x) - y.atan2(x));
                worst = worst.max(d.abs());
            }
        }
        assert!(worst <= AZIMUTH_ERR, "{worst}");
        assert!(worst > 1e-7, "{worst}: not the polynomial");
        assert_eq!(azimuth(0.0, 0.0), 0.0);
    }

    #[test]
    fn row_table_keeps_every_row_whose_tangent_is_in_range() {
        for tan in [
            (0..31)
                .map(|r| (r as f64).to_radians().tan() as f32)
                .collect::<Vec<_>>(),
            (0..61)
                .map(|r| ((r as f64) * 3.0 - 90.0).to_radians().tan() as f32)
                .collect(),
            vec![0.25],
            // The coarse test pattern's, whose top edge rounds below the top row.
            (0..26)
                .map(|r| (-20.0 + 2.0 * r as f64).to_radians().tan() as f32)
                .collect(),
        ] {
            let table = RowTable::new(&tan);
            let probes: Vec<f32> = (-200..200).map(|i| i as f32 * 0.013).collect();
            for &lo in &probes {
                for &hi in probes.iter().filter(|&&h| h >= lo) {
                    let want: Vec<usize> = (0..tan.len())
                        .filter(|&r| tan[r] >= lo && tan[r] <= hi)
                        .collect();
                    match table.rows(lo, hi) {
                        Some((a, b)) => {
                            assert!(want.iter().all(|r| (a..=b).contains(r)), "{lo} {hi}");
                            // Not much wider than needed: a few spare rows at most.
                            assert!(b + 1 - a <= want.len() + 4, "{lo} {hi}: {a}..={b}");
                        }
                        None => assert!(want.is_empty(), "{lo} {hi}"),
                    }
                }
            }
            assert_eq!(table.rows(f32::NAN, f32::NAN), Some((0, tan.len() - 1)));
        }
    }

    #[test]
    fn sweep_lists_covering_spans_nearest_first() {
        let mut s = Sweep::with_capacity(4);
        for (c_lo, c_hi, item, near) in [(0, 5, 0, 3.0), (2, 3, 1, 1.0), (3, 9, 2, 2.0)] {
            s.spans.push(Span {
                c_lo,
                c_hi,
                item,
                near,
            });
        }
        s.start();
        let items = |s: &mut Sweep, c| -> Vec<u32> {
            s.advance(c);
            s.active().iter().map(|a| a.item() as u32).collect()
        };
        assert_eq!(items(&mut s, 0), vec![0]);
        assert_eq!(items(&mut s, 2), vec![1, 0]);
        assert_eq!(items(&mut s, 3), vec![1, 2, 0]);
        assert_eq!(items(&mut s, 4), vec![2, 0]);
        assert_eq!(items(&mut s, 9), vec![2]);
    }
}
