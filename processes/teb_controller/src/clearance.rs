//! Clearance between a placed rectangular footprint and the occupied cells of a grid,
//! with its gradient with respect to the pose.
//!
//! A cell is taken as the disc circumscribing it (radius half the cell diagonal), so the
//! clearance to a cell is the footprint's signed distance to the centre minus that
//! radius: never more than the distance to the square cell itself, so a band that keeps
//! the margin to the discs keeps it to the cells. Cells
//! outside the grid are free (MATLAB's controllerTEB treats space beyond its local map
//! so). [`overlaps_occupied`] is the exact test for tight spaces: the footprint against
//! the cell squares themselves, without the disc's extra 0.02 m at 0.1 m cells. Knows
//! nothing of the band or of the optimiser.

use aisle_geometry::{Footprint, GridView, Pose2};

/// Radius of the disc circumscribing a cell, in cell widths.
const CELL_RADIUS: f64 = std::f64::consts::FRAC_1_SQRT_2;

/// The closest occupied cell in one sector around the footprint.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct CellHit {
    pub clearance: f64,
    /// d clearance / d (x, y, theta) of the pose.
    pub grad: [f64; 3],
}

/// Signed distance from a point given in the footprint's frame to the rectangle, and
/// its gradient with respect to that point.
fn local_distance(hl: f64, hw: f64, lx: f64, ly: f64) -> (f64, f64, f64) {
    let ex = lx.abs() - hl;
    let ey = ly.abs() - hw;
    let sx = if lx >= 0.0 { 1.0 } else { -1.0 };
    let sy = if ly >= 0.0 { 1.0 } else { -1.0 };
    if ex > 0.0 && ey > 0.0 {
        let d = ex.hypot(ey);
        (d, sx * ex / d, sy * ey / d)
    } else if ex >= ey {
        (ex, sx, 0.0)
    } else {
        (ey, 0.0, sy)
    }
}

/// Clearance from `fp` placed at `pose` to a cell centred at (px, py) of half-width
/// `half_cell`, with its gradient with respect to the pose.
pub(crate) fn cell_clearance(
    fp: &Footprint,
    pose: &Pose2,
    px: f64,
    py: f64,
    half_cell: f64,
) -> CellHit {
    let (s, c) = pose.theta.sin_cos();
    let dx = px - pose.x;
    let dy = py - pose.y;
    let lx = c * dx + s * dy;
    let ly = -s * dx + c * dy;
    let (d, gx, gy) = local_distance(0.5 * fp.length, 0.5 * fp.width, lx, ly);
    // l = R(-theta) (p - x): dl/dx = (-c, s), dl/dy = (-s, -c), dl/dtheta = (ly, -lx).
    CellHit {
        clearance: d - half_cell,
        grad: [-c * gx + s * gy, -s * gx - c * gy, ly * gx - lx * gy],
    }
}

/// Index range of grid cells whose centres may lie within `reach` of the footprint.
fn window(
    map: &GridView,
    fp: &Footprint,
    pose: &Pose2,
    reach: f64,
) -> Option<(usize, usize, usize, usize)> {
    let r = fp.circumscribed_radius() + reach + map.resolution;
    let lo = map.cell_of(pose.x - r, pose.y - r);
    let hi = map.cell_of(pose.x + r, pose.y + r);
    let w = map.width as i64;
    let h = map.height as i64;
    if hi.ix < 0 || hi.iy < 0 || lo.ix >= w || lo.iy >= h {
        return None;
    }
    Some((
        lo.ix.max(0) as usize,
        (hi.ix.min(w - 1)) as usize,
        lo.iy.max(0) as usize,
        (hi.iy.min(h - 1)) as usize,
    ))
}

/// Smallest clearance to any occupied cell, capped at `reach` (returned when nothing
/// is closer).
pub(crate) fn min_clearance(map: &GridView, fp: &Footprint, pose: &Pose2, reach: f64) -> f64 {
    let mut best = reach;
    let Some((x0, x1, y0, y1)) = window(map, fp, pose, reach) else {
        return best;
    };
    let half = CELL_RADIUS * map.resolution;
    let (s, c) = pose.theta.sin_cos();
    let (hl, hw) = (0.5 * fp.length, 0.5 * fp.width);
    for iy in y0..=y1 {
        let row = &map.cells[iy * map.width..(iy + 1) * map.width];
        let cy = map.origin_y + (iy as f64 + 0.5) * map.resolution - pose.y;
        for_occupied(row, x0, x1, |ix| {
            let cx = map.origin_x + (ix as f64 + 0.5) * map.resolution - pose.x;
            let lx = c * cx + s * cy;
            let ly = -s * cx + c * cy;
            let ex = lx.abs() - hl;
            let ey = ly.abs() - hw;
            // A plain root: distances on a map cannot overflow, and hypot's care for
            // that costs several times more in this innermost loop.
            let d = if ex > 0.0 && ey > 0.0 {
                (ex * ex + ey * ey).sqrt()
            } else {
                ex.max(ey)
            } - half;
            if d < best {
                best = d;
            }
        });
    }
    best
}

/// Calls `f(ix)` for every cell of `row[x0..=x1]` that is not free, in increasing ix.
/// Free cells are skipped eight at a time: most of a window around a pose is free, and
/// testing its cells one by one was most of the clearance terms' time.
#[inline]
fn for_occupied(row: &[u8], x0: usize, x1: usize, mut f: impl FnMut(usize)) {
    let span = &row[x0..=x1];
    let mut words = span.chunks_exact(8);
    let mut ix = x0;
    for w in &mut words {
        let word = u64::from_ne_bytes([w[0], w[1], w[2], w[3], w[4], w[5], w[6], w[7]]);
        if word != u64::from_ne_bytes([aisle_geometry::FREE; 8]) {
            for (k, &v) in w.iter().enumerate() {
                if v != aisle_geometry::FREE {
                    f(ix + k);
                }
            }
        }
        ix += 8;
    }
    for (k, &v) in words.remainder().iter().enumerate() {
        if v != aisle_geometry::FREE {
            f(ix + k);
        }
    }
}

/// The closest occupied cell in each of four sectors (front, left, back, right of the
/// footprint, split along its diagonals) whose clearance is below `reach`.
pub(crate) fn nearest_per_sector(
    map: &GridView,
    fp: &Footprint,
    pose: &Pose2,
    reach: f64,
    out: &mut [Option<CellHit>; 4],
) {
    *out = [None; 4];
    let Some((x0, x1, y0, y1)) = window(map, fp, pose, reach) else {
        return;
    };
    let half = CELL_RADIUS * map.resolution;
    let (s, c) = pose.theta.sin_cos();
    let (hl, hw) = (0.5 * fp.length, 0.5 * fp.width);
    let mut best = [reach; 4];
    let mut where_: [(f64, f64); 4] = [(0.0, 0.0); 4];
    for iy in y0..=y1 {
        let row = &map.cells[iy * map.width..(iy + 1) * map.width];
        let py = map.origin_y + (iy as f64 + 0.5) * map.resolution;
        for_occupied(row, x0, x1, |ix| {
            let px = map.origin_x + (ix as f64 + 0.5) * map.resolution;
            let (dx, dy) = (px - pose.x, py - pose.y);
            let lx = c * dx + s * dy;
            let ly = -s * dx + c * dy;
            let ex = lx.abs() - hl;
            let ey = ly.abs() - hw;
            // A plain root: distances on a map cannot overflow, and hypot's care for
            // that costs several times more in this innermost loop.
            let d = if ex > 0.0 && ey > 0.0 {
                (ex * ex + ey * ey).sqrt()
            } else {
                ex.max(ey)
            } - half;
            let sector = if lx.abs() * hw >= ly.abs() * hl {
                if lx >= 0.0 { 0 } else { 2 }
            } else if ly >= 0.0 {
                1
            } else {
                3
            };
            if d < best[sector] {
                best[sector] = d;
                where_[sector] = (px, py);
            }
        });
    }
    for k in 0..4 {
        if best[k] < reach {
            let (px, py) = where_[k];
            out[k] = Some(cell_clearance(fp, pose, px, py, half));
        }
    }
}

/// Whether `fp` placed at `pose` overlaps (not merely touches) an occupied cell, each
/// cell taken as its exact square. Separating axes: the grid's two and the footprint's
/// two.
pub(crate) fn overlaps_occupied(map: &GridView, fp: &Footprint, pose: &Pose2) -> bool {
    let Some((x0, x1, y0, y1)) = window(map, fp, pose, 0.0) else {
        return false;
    };
    let h = 0.5 * map.resolution;
    let (s, c) = pose.theta.sin_cos();
    let (hl, hw) = (0.5 * fp.length, 0.5 * fp.width);
    // Half-extents of the footprint on the grid axes, and of a cell on the footprint's.
    let ex = hl * c.abs() + hw * s.abs() + h;
    let ey = hl * s.abs() + hw * c.abs() + h;
    let cell = h * (c.abs() + s.abs());
    for iy in y0..=y1 {
        let dy = map.origin_y + (iy as f64 + 0.5) * map.resolution - pose.y;
        if dy.abs() >= ey {
            continue;
        }
        let row = &map.cells[iy * map.width..(iy + 1) * map.width];
        for (ix, &v) in row.iter().enumerate().take(x1 + 1).skip(x0) {
            if v == aisle_geometry::FREE {
                continue;
            }
            let dx = map.origin_x + (ix as f64 + 0.5) * map.resolution - pose.x;
            if dx.abs() >= ex {
                continue;
            }
            let lx = c * dx + s * dy;
            let ly = -s * dx + c * dy;
            if lx.abs() < hl + cell && ly.abs() < hw + cell {
                return true;
            }
        }
    }
    false
}

#[cfg(test)]
mod tests {
    use super::*;
    use aisle_geometry::{FREE, GridMap, OCCUPIED_DETECTED};

    #[test]
    fn occupied_cells_are_visited_in_order_whatever_the_span() {
        // Occupied cells at word boundaries, inside words and in the remainder.
        let mut row = vec![FREE; 37];
        for ix in [0, 7, 8, 15, 21, 30, 35, 36] {
            row[ix] = OCCUPIED_DETECTED;
        }
        for x0 in 0..row.len() {
            for x1 in x0..row.len() {
                let mut seen = Vec::new();
                for_occupied(&row, x0, x1, |ix| seen.push(ix));
                let expected: Vec<usize> = (x0..=x1).filter(|&i| row[i] != FREE).collect();
                assert_eq!(seen, expected, "{x0}..={x1}");
            }
        }
    }

    #[test]
    fn gradient_matches_finite_differences() {
        let fp = Footprint::new(0.88, 0.8);
        for &(px, py) in &[(1.0, 0.2), (0.7, 0.9), (-0.9, -0.3), (0.1, 0.05)] {
            let pose = Pose2::new(0.1, -0.05, 0.3);
            let hit = cell_clearance(&fp, &pose, px, py, 0.05);
            let h = 1e-6;
            for k in 0..3 {
                let mut p1 = pose;
                let mut p0 = pose;
                match k {
                    0 => {
                        p1.x += h;
                        p0.x -= h
                    }
                    1 => {
                        p1.y += h;
                        p0.y -= h
                    }
                    _ => {
                        p1.theta += h;
                        p0.theta -= h
                    }
                }
                let fd = (cell_clearance(&fp, &p1, px, py, 0.05).clearance
                    - cell_clearance(&fp, &p0, px, py, 0.05).clearance)
                    / (2.0 * h);
                assert!(
                    (fd - hit.grad[k]).abs() < 1e-5,
                    "k {k}: {fd} vs {}",
                    hit.grad[k]
                );
            }
        }
    }

    #[test]
    fn min_clearance_sees_the_nearest_cell_and_ignores_outside() {
        let mut g = GridMap::new_free(-2.0, -2.0, 0.1, 4.0, 4.0).unwrap();
        let c = g.view().cell_of(1.05, 0.05);
        g.set(c, OCCUPIED_DETECTED);
        let fp = Footprint::new(1.0, 0.5);
        let d = min_clearance(&g.view(), &fp, &Pose2::new(0.0, 0.0, 0.0), 2.0);
        // Centre 0.55 m beyond the front edge, minus half a cell's diagonal.
        assert!((d - (0.55 - 0.05 * 2f64.sqrt())).abs() < 1e-9, "{d}");
        let mut hits = [None; 4];
        nearest_per_sector(&g.view(), &fp, &Pose2::new(0.0, 0.0, 0.0), 2.0, &mut hits);
        assert!(hits[0].is_some() && hits[1].is_none());
        // A pose far outside the grid sees nothing.
        let far = min_clearance(&g.view(), &fp, &Pose2::new(50.0, 0.0, 0.0), 1.0);
        assert_eq!(far, 1.0);
    }

    #[test]
    fn overlap_is_exact_against_the_cell_square() {
        let mut g = GridMap::new_free(-2.0, -2.0, 0.1, 4.0, 4.0).unwrap();
        // The cell [0.5, 0.6] x [0.0, 0.1].
        let c = g.view().cell_of(0.55, 0.05);
        g.set(c, OCCUPIED_DETECTED);
        let v = g.view();
        let fp = Footprint::new(1.0, 0.5);
        // Front edge at x = 0.49 / 0.51: clear / overlapping; touching is clear.
        assert!(!overlaps_occupied(&v, &fp, &Pose2::new(-0.01, 0.0, 0.0)));
        assert!(overlaps_occupied(&v, &fp, &Pose2::new(0.01, 0.0, 0.0)));
        assert!(!overlaps_occupied(&v, &fp, &Pose2::new(0.0, 0.0, 0.0)));
        // Side edge at y = -0.01 below the cell: clear; the disc model would not say so.
        assert!(!overlaps_occupied(&v, &fp, &Pose2::new(0.5, -0.26, 0.0)));
        assert!(min_clearance(&v, &fp, &Pose2::new(0.5, -0.26, 0.0), 1.0) < 0.0);
        // Turned 45 degrees: the corner region of the cell's bounding box is not overlap.
        let sq = Footprint::new(0.2, 0.2);
        let r = 0.1 * std::f64::consts::SQRT_2;
        let q = std::f64::consts::FRAC_PI_4;
        // The diamond's right vertex at x = 0.49 (just left of the cell), centred on its row.
        assert!(!overlaps_occupied(&v, &sq, &Pose2::new(0.49 - r, 0.05, q)));
        assert!(overlaps_occupied(&v, &sq, &Pose2::new(0.51 - r, 0.05, q)));
        // Its lower-right edge near the cell's top-left corner: bounding boxes overlap,
        // the shapes do not.
        assert!(!overlaps_occupied(
            &v,
            &sq,
            &Pose2::new(0.5 - 0.075, 0.1 + 0.075, q)
        ));
        assert!(overlaps_occupied(
            &v,
            &sq,
            &Pose2::new(0.5 - 0.065, 0.1 + 0.065, q)
        ));
    }
}
