//! Grid traversal of a 2D segment (Amanatides-Woo DDA) in cell units. Test-only: the
//! reference the sparse clearing of `clearing` is checked against, cell for cell.
//!
//! Knows nothing of what the cells mean: it calls back with each cell index the segment
//! crosses, from the start cell up to but excluding the end cell.

/// Visits the cells a segment from `(x0, y0)` to `(x1, y1)` crosses, coordinates in cell
/// units (cell (i, j) spans `[i, i+1) x [j, j+1)`), excluding the cell of the end point.
/// Cells outside `[0, w) x [0, h)` are skipped; the walk stops once it has left the
/// grid for good. Never allocates.
#[inline]
pub fn walk_cells(
    (x0, y0): (f32, f32),
    (x1, y1): (f32, f32),
    w: usize,
    h: usize,
    mut visit: impl FnMut(usize),
) {
    if !(x0.is_finite() && y0.is_finite() && x1.is_finite() && y1.is_finite()) {
        return;
    }
    let (wf, hf) = (w as f32, h as f32);
    // Clip to the grid rectangle (Liang-Barsky); the clipped start keeps the cells in
    // order and bounds the walk by the grid's size.
    let (dx, dy) = (x1 - x0, y1 - y0);
    let mut t0 = 0.0f32;
    let mut t1 = 1.0f32;
    for (p, q) in [(-dx, x0), (dx, wf - x0), (-dy, y0), (dy, hf - y0)] {
        if p == 0.0 {
            if q < 0.0 {
                return;
            }
        } else {
            let r = q / p;
            if p < 0.0 {
                t0 = t0.max(r);
            } else {
                t1 = t1.min(r);
            }
        }
    }
    if t0 > t1 {
        return;
    }
    let end_ix = x1.floor() as i64;
    let end_iy = y1.floor() as i64;
    let sx = x0 + t0 * dx;
    let sy = y0 + t0 * dy;
    let mut ix = (sx.floor() as i64).clamp(0, w as i64 - 1);
    let mut iy = (sy.floor() as i64).clamp(0, h as i64 - 1);
    let step_x: i64 = if dx > 0.0 { 1 } else { -1 };
    let step_y: i64 = if dy > 0.0 { 1 } else { -1 };
    let inv_dx = if dx != 0.0 {
        1.0 / dx.abs()
    } else {
        f32::INFINITY
    };
    let inv_dy = if dy != 0.0 {
        1.0 / dy.abs()
    } else {
        f32::INFINITY
    };
    // Parameter (fraction of the whole segment) at which the next x / y boundary is crossed.
    let mut t_max_x = if dx > 0.0 {
        ((ix + 1) as f32 - x0) * inv_dx
    } else if dx < 0.0 {
        (x0 - ix as f32) * inv_dx
    } else {
        f32::INFINITY
    };
    let mut t_max_y = if dy > 0.0 {
        ((iy + 1) as f32 - y0) * inv_dy
    } else if dy < 0.0 {
        (y0 - iy as f32) * inv_dy
    } else {
        f32::INFINITY
    };
    // The clipped segment crosses at most |dx| + |dy| + 2 cells, and never more than a
    // 4-connected walk through the whole grid; the bound guards against rounding.
    let max_steps = (((t1 - t0) * (dx.abs() + dy.abs())) as usize)
        .saturating_add(2)
        .min(w + h + 2);
    for _ in 0..max_steps {
        if ix == end_ix && iy == end_iy {
            return;
        }
        if ix < 0 || iy < 0 || ix >= w as i64 || iy >= h as i64 {
            return;
        }
        visit(iy as usize * w + ix as usize);
        if t_max_x < t_max_y {
            if t_max_x > t1 {
                return;
            }
            ix += step_x;
            t_max_x += inv_dx;
        } else {
            if t_max_y > t1 {
                return;
            }
            iy += step_y;
            t_max_y += inv_dy;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cells(a: (f32, f32), b: (f32, f32), w: usize, h: usize) -> Vec<(usize, usize)> {
        let mut v = Vec::new();
        walk_cells(a, b, w, h, |i| v.push((i % w, i / w)));
        v
    }

    #[test]
    fn horizontal_walk_excludes_the_end_cell() {
        assert_eq!(
            cells((0.5, 0.5), (3.5, 0.5), 10, 10),
            vec![(0, 0), (1, 0), (2, 0)]
        );
        assert_eq!(
            cells((3.5, 2.5), (0.5, 2.5), 10, 10),
            vec![(3, 2), (2, 2), (1, 2)]
        );
    }

    #[test]
    fn diagonal_walk_is_four_connected() {
        let v = cells((0.2, 0.3), (3.7, 2.9), 10, 10);
        assert_eq!(v.first(), Some(&(0, 0)));
        for w in v.windows(2) {
            let d = w[0].0.abs_diff(w[1].0) + w[0].1.abs_diff(w[1].1);
            assert_eq!(d, 1, "{v:?}");
        }
        assert!(!v.contains(&(3, 2)));
        assert_eq!(v.len(), 3 + 2);
    }

    #[test]
    fn walk_is_clipped_to_the_grid() {
        let v = cells((-5.5, 1.5), (20.5, 1.5), 4, 4);
        assert_eq!(v, vec![(0, 1), (1, 1), (2, 1), (3, 1)]);
        assert!(cells((-5.0, -5.0), (-1.0, -2.0), 4, 4).is_empty());
        assert!(cells((f32::NAN, 0.0), (1.0, 1.0), 4, 4).is_empty());
        // Absurd end points cost at most a walk across the grid.
        assert_eq!(cells((0.5, 0.5), (1e30, 0.5), 4, 4).len(), 4);
        assert!(cells((0.5, 0.5), (-1e30, 1e30), 4, 4).len() <= 4 + 4 + 2);
    }

    #[test]
    fn same_cell_visits_nothing() {
        assert!(cells((1.2, 1.2), (1.8, 1.7), 4, 4).is_empty());
    }
}
