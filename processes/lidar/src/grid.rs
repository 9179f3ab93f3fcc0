//! `BoxGrid`: a uniform grid of buckets over the XY plane listing the boxes whose
//! bounding rectangle meets each cell, so a scan gathers only the boxes within range of
//! the sensor instead of the whole scene.
//!
//! Built once over the scene's extent; moving a body re-buckets only its boxes (O(its
//! parts x the cells each covers)). A box outside the extent (a body moved beyond it)
//! is listed in the nearest border cells: clamping cell coordinates keeps every
//! overlap, so a query never misses it. The gathered set is a superset of the boxes
//! within range, returned in box order, so callers that take the nearest hit give the
//! same points as a scan over every box. Knows nothing of rays, poses or bodies.

/// Target cell side (metres): a 12 m range then covers about 150 cells.
const CELL: f64 = 2.0;
/// At most this many cells; larger scenes get larger cells.
const MAX_CELLS: f64 = 65_536.0;
/// Room each bucket keeps for boxes moved into it (a carried rack has 7 parts), so
/// moving a body allocates nothing.
const SPARE: usize = 16;

/// Inclusive cell rectangle: x0, y0, x1, y1.
type CellSpan = [u32; 4];

#[derive(Debug, Clone)]
pub(crate) struct BoxGrid {
    origin: [f64; 2],
    cell: f64,
    nx: u32,
    ny: u32,
    buckets: Vec<Vec<u32>>,
    /// The cells each box is listed in.
    spans: Vec<CellSpan>,
}

/// The axis-aligned rectangle (x0, y0, x1, y1) covering a box of half sizes `half` at
/// `center` turned by `yaw`.
pub(crate) fn bounds(center: [f64; 2], half: [f64; 2], yaw: f64) -> [f64; 4] {
    let (s, c) = yaw.sin_cos();
    let ex = c.abs() * half[0] + s.abs() * half[1];
    let ey = s.abs() * half[0] + c.abs() * half[1];
    [
        center[0] - ex,
        center[1] - ey,
        center[0] + ex,
        center[1] + ey,
    ]
}

impl BoxGrid {
    /// A grid over the union of `rects` (one per box, in box order), each box listed.
    pub(crate) fn new(rects: &[[f64; 4]]) -> BoxGrid {
        let mut lo = [f64::INFINITY; 2];
        let mut hi = [f64::NEG_INFINITY; 2];
        for r in rects {
            lo = [lo[0].min(r[0]), lo[1].min(r[1])];
            hi = [hi[0].max(r[2]), hi[1].max(r[3])];
        }
        if rects.is_empty() {
            (lo, hi) = ([0.0; 2], [0.0; 2]);
        }
        let (w, h) = ((hi[0] - lo[0]).max(CELL), (hi[1] - lo[1]).max(CELL));
        let cell = CELL.max((w * h / MAX_CELLS).sqrt());
        let nx = (w / cell).ceil() as u32 + 1;
        let ny = (h / cell).ceil() as u32 + 1;
        let mut g = BoxGrid {
            origin: lo,
            cell,
            nx,
            ny,
            buckets: vec![Vec::new(); (nx * ny) as usize],
            spans: Vec::with_capacity(rects.len()),
        };
        for (i, r) in rects.iter().enumerate() {
            let span = g.span(r);
            g.spans.push(span);
            g.insert(i as u32, span);
        }
        for b in &mut g.buckets {
            b.reserve_exact(SPARE);
        }
        g
    }

    fn coord(&self, v: f64, o: f64, n: u32) -> u32 {
        // NaN and far-off values clamp to the border too.
        ((v - o) / self.cell).floor().clamp(0.0, f64::from(n - 1)) as u32
    }

    fn span(&self, r: &[f64; 4]) -> CellSpan {
        [
            self.coord(r[0], self.origin[0], self.nx),
            self.coord(r[1], self.origin[1], self.ny),
            self.coord(r[2], self.origin[0], self.nx),
            self.coord(r[3], self.origin[1], self.ny),
        ]
    }

    fn cells(&self, s: CellSpan) -> impl Iterator<Item = usize> + use<> {
        let nx = self.nx as usize;
        (s[1]..=s[3]).flat_map(move |y| (s[0]..=s[2]).map(move |x| y as usize * nx + x as usize))
    }

    fn insert(&mut self, index: u32, s: CellSpan) {
        for c in self.cells(s) {
            self.buckets[c].push(index);
        }
    }

    /// Lists box `index` under its new rectangle.
    pub(crate) fn update(&mut self, index: usize, rect: &[f64; 4]) {
        let new = self.span(rect);
        let old = self.spans[index];
        if new == old {
            return;
        }
        for c in self.cells(old) {
            let b = &mut self.buckets[c];
            if let Some(k) = b.iter().position(|&i| i as usize == index) {
                b.swap_remove(k);
            }
        }
        self.insert(index as u32, new);
        self.spans[index] = new;
    }

    /// Fills `near.list` with every box listed in a cell that meets the disc of
    /// `radius` around `center`, each once, in box order.
    pub(crate) fn gather(&self, center: [f64; 2], radius: f64, near: &mut Near) {
        near.begin(self.spans.len());
        let r = [
            center[0] - radius,
            center[1] - radius,
            center[0] + radius,
            center[1] + radius,
        ];
        let s = self.span(&r);
        for y in s[1]..=s[3] {
            for x in s[0]..=s[2] {
                if !self.meets_disc(x, y, center, radius) {
                    continue;
                }
                for &i in &self.buckets[(y * self.nx + x) as usize] {
                    near.add(i);
                }
            }
        }
        near.list.sort_unstable();
    }

    /// Whether cell (x, y) comes within `radius` of `center`. Border cells also hold
    /// everything beyond the extent, so they always count.
    fn meets_disc(&self, x: u32, y: u32, center: [f64; 2], radius: f64) -> bool {
        if x == 0 || y == 0 || x + 1 == self.nx || y + 1 == self.ny {
            return true;
        }
        let x0 = self.origin[0] + f64::from(x) * self.cell;
        let y0 = self.origin[1] + f64::from(y) * self.cell;
        let dx = (x0 - center[0]).max(center[0] - (x0 + self.cell)).max(0.0);
        let dy = (y0 - center[1]).max(center[1] - (y0 + self.cell)).max(0.0);
        dx * dx + dy * dy <= radius * radius
    }
}

/// A scan's scratch for [`BoxGrid::gather`]: the gathered boxes and a per-box stamp
/// that drops a box met again in another cell. Sized once; reused every scan.
#[derive(Debug, Clone, Default)]
pub(crate) struct Near {
    pub(crate) list: Vec<u32>,
    stamp: Vec<u32>,
    epoch: u32,
}

impl Near {
    /// Scratch for a world of `boxes` boxes: a gather then allocates nothing.
    pub(crate) fn new(boxes: usize) -> Near {
        Near {
            list: Vec::with_capacity(boxes),
            stamp: vec![0; boxes],
            epoch: 0,
        }
    }

    fn begin(&mut self, boxes: usize) {
        self.list.clear();
        if self.stamp.len() != boxes {
            *self = Near::new(boxes);
        }
        self.epoch = self.epoch.wrapping_add(1);
        if self.epoch == 0 {
            self.stamp.fill(0);
            self.epoch = 1;
        }
    }

    #[inline]
    fn add(&mut self, i: u32) {
        let s = &mut self.stamp[i as usize];
        if *s != self.epoch {
            *s = self.epoch;
            self.list.push(i);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gathers_each_box_once_within_the_disc_and_follows_a_move() {
        // Box 0 spans many cells, box 1 is far away, box 2 is near the centre.
        let rects = [
            [0.0, 0.0, 40.0, 1.0],
            [90.0, 90.0, 91.0, 91.0],
            [10.0, 10.0, 10.5, 10.5],
        ];
        let mut g = BoxGrid::new(&rects);
        let mut near = Near::default();
        g.gather([10.0, 5.0], 12.0, &mut near);
        assert_eq!(near.list, vec![0, 2]);
        g.update(1, &[11.0, 11.0, 12.0, 12.0]);
        g.gather([10.0, 5.0], 12.0, &mut near);
        assert_eq!(near.list, vec![0, 1, 2]);
        // Moved far beyond the extent: listed in border cells, found from near there.
        g.update(2, &[500.0, 500.0, 501.0, 501.0]);
        g.gather([10.0, 5.0], 12.0, &mut near);
        assert_eq!(near.list, vec![0, 1]);
        g.gather([95.0, 95.0], 3.0, &mut near);
        assert_eq!(near.list, vec![2]);
    }
}
