//! The static map from the warehouse scene: MATLAB's
//! `binaryOccupancyMap(scenario, MapHeightLimits, GridOriginInLocal, MapSize)` followed
//! by `exampleHelperDefineMapBoundary`.
//!
//! Only static bodies are rasterised; each box part whose vertical extent meets the
//! height limits contributes its (rotated) footprint. Then the band along the map edge
//! is marked occupied. Movable bodies never reach this map: the lidar finds them.
//!
//! **Cell rule.** A cell is occupied when the footprint rectangle and the cell square
//! overlap with positive area: on each of the four separating axes (the grid's two and
//! the rectangle's two) their projections overlap by more than [`TOUCH_EPS`]. A box
//! whose edge lies exactly on a cell boundary therefore does not occupy the neighbour
//! cell, and one that reaches 1 mm into a cell does. The same rule gives the boundary
//! band: every cell overlapping the band is occupied.
//!
//! Knows nothing of the lidar, the bus or files other than through `Scene`.

use crate::config::MapConfig;
use crate::error::MapError;
use aisle_config::scene::{BoxPart, Scene};
use aisle_geometry::{GridMap, OCCUPIED_STATIC, Pose2};

/// Overlap (metres) below which a rectangle and a cell only touch. Absorbs the rounding
/// of `origin + i * resolution` without changing any real overlap.
pub const TOUCH_EPS: f64 = 1e-9;

/// Builds the static map of `scene` as `cfg` describes it.
pub fn static_map_from_scene(scene: &Scene, cfg: &MapConfig) -> Result<GridMap, MapError> {
    let mut grid = empty_grid(cfg)?;
    let [lo, hi] = cfg.height_limits;
    for body in scene.static_bodies() {
        for part in &body.parts {
            // Closed intervals: a part standing exactly on the lower limit still counts.
            if part.z_max() >= lo && part.z_min() <= hi {
                rasterize_part(&mut grid, &body.pose, part);
            }
        }
    }
    mark_boundary(&mut grid, cfg.boundary_band);
    Ok(grid)
}

/// An all-free grid with the configured origin, size and resolution.
pub fn empty_grid(cfg: &MapConfig) -> Result<GridMap, MapError> {
    Ok(GridMap::new_free(
        cfg.origin[0],
        cfg.origin[1],
        cfg.resolution(),
        cfg.size[0],
        cfg.size[1],
    )?)
}

/// Marks the footprint of `part` (a box in the frame of a body placed at `pose`).
pub fn rasterize_part(grid: &mut GridMap, pose: &Pose2, part: &BoxPart) {
    let (cx, cy) = pose.transform_point(part.center[0], part.center[1]);
    rasterize_rect(
        grid,
        Pose2::new(cx, cy, pose.theta),
        0.5 * part.size[0],
        0.5 * part.size[1],
    );
}

/// The cells [`rasterize_rect`] may mark for the same rectangle: the box of its
/// projection on the grid axes, clamped to the grid (x0, y0, x1, y1, inclusive); `None`
/// for a rectangle that is not finite, empty or off the grid.
pub(crate) fn rect_cell_box(grid: &GridMap, at: Pose2, hx: f64, hy: f64) -> Option<[usize; 4]> {
    let (s, c) = at.theta.sin_cos();
    let (ex, ey) = projection(c.abs(), s.abs(), hx, hy);
    cell_box(grid, at, hx, hy, ex, ey)
}

/// Half extents on the grid axes of a rectangle of half extents `hx` x `hy` whose
/// axis makes an angle of |cos| `ac` and |sin| `as_` with them.
fn projection(ac: f64, as_: f64, hx: f64, hy: f64) -> (f64, f64) {
    (ac * hx + as_ * hy, as_ * hx + ac * hy)
}

/// The clamped cells of the box of half extents `ex` x `ey` (the projection of the
/// rectangle `hx` x `hy` at `at`) on the grid axes.
fn cell_box(grid: &GridMap, at: Pose2, hx: f64, hy: f64, ex: f64, ey: f64) -> Option<[usize; 4]> {
    if !(at.is_finite() && hx.is_finite() && hy.is_finite()) || hx <= 0.0 || hy <= 0.0 {
        return None;
    }
    let r = grid.resolution;
    let to_cell = |v: f64, o: f64| ((v - o) / r).floor();
    let ix0 = to_cell(at.x - ex, grid.origin_x).max(0.0);
    let iy0 = to_cell(at.y - ey, grid.origin_y).max(0.0);
    let ix1 = to_cell(at.x + ex, grid.origin_x).min(grid.width as f64 - 1.0);
    let iy1 = to_cell(at.y + ey, grid.origin_y).min(grid.height as f64 - 1.0);
    (ix0 <= ix1 && iy0 <= iy1).then_some([ix0 as usize, iy0 as usize, ix1 as usize, iy1 as usize])
}

/// Marks every cell that overlaps the rectangle of half extents `hx` x `hy` centred on
/// `at` (its x axis along `at.theta`) with positive area.
pub fn rasterize_rect(grid: &mut GridMap, at: Pose2, hx: f64, hy: f64) {
    let (s, c) = at.theta.sin_cos();
    let (ac, as_) = (c.abs(), s.abs());
    let (ex, ey) = projection(ac, as_, hx, hy);
    let Some([ix0, iy0, ix1, iy1]) = cell_box(grid, at, hx, hy, ex, ey) else {
        return;
    };
    let r = grid.resolution;
    let half = 0.5 * r;
    // Half extent of a cell's projection on the rectangle's axes.
    let cell_on_rect = half * (ac + as_);
    let overlap = |a0: f64, a1: f64, b0: f64, b1: f64| a1.min(b1) - a0.max(b0) > TOUCH_EPS;
    for iy in iy0..=iy1 {
        let y0 = grid.origin_y + iy as f64 * r;
        if !overlap(y0, y0 + r, at.y - ey, at.y + ey) {
            continue;
        }
        for ix in ix0..=ix1 {
            let x0 = grid.origin_x + ix as f64 * r;
            if !overlap(x0, x0 + r, at.x - ex, at.x + ex) {
                continue;
            }
            let (dx, dy) = (x0 + half - at.x, y0 + half - at.y);
            let du = dx * c + dy * s;
            let dv = -dx * s + dy * c;
            if overlap(du - cell_on_rect, du + cell_on_rect, -hx, hx)
                && overlap(dv - cell_on_rect, dv + cell_on_rect, -hy, hy)
            {
                grid.cells[iy * grid.width + ix] = OCCUPIED_STATIC;
            }
        }
    }
}

/// Marks every cell within `band` metres of the map edge (MATLAB's
/// `exampleHelperDefineMapBoundary`). Cells that overlap the band are occupied, by the
/// same rule as the boxes.
pub fn mark_boundary(grid: &mut GridMap, band: f64) {
    // NaN is refused by config validation; treat it like no band anyway.
    if band.is_nan() || band <= 0.0 {
        return;
    }
    let n = ((band / grid.resolution) - TOUCH_EPS / grid.resolution).ceil() as usize;
    let (w, h) = (grid.width, grid.height);
    for iy in 0..h {
        let row = &mut grid.cells[iy * w..(iy + 1) * w];
        if iy < n || iy + n >= h {
            row.fill(OCCUPIED_STATIC);
        } else {
            let k = n.min(w);
            row[..k].fill(OCCUPIED_STATIC);
            row[w - k..].fill(OCCUPIED_STATIC);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use aisle_geometry::{CellIndex, FREE};
    use std::path::Path;

    fn shipped_scene() -> Scene {
        let path = aisle_config::testing::shipped("warehouse.toml");
        Scene::load(&path).unwrap()
    }

    #[test]
    fn box_edge_on_a_cell_boundary_does_not_spill() {
        let cfg = MapConfig::default();
        let mut g = empty_grid(&cfg).unwrap();
        // A 1 x 1 m box with its edges exactly on x = 0, 1 and y = 0, 1.
        rasterize_rect(&mut g, Pose2::new(0.5, 0.5, 0.0), 0.5, 0.5);
        let v = g.view();
        let at = |x: f64, y: f64| v.get(v.cell_of(x, y)).unwrap();
        assert_eq!(at(0.05, 0.05), OCCUPIED_STATIC);
        assert_eq!(at(0.95, 0.95), OCCUPIED_STATIC);
        assert_eq!(at(1.05, 0.5), FREE, "touching the edge is not overlap");
        assert_eq!(at(-0.05, 0.5), FREE);
        assert_eq!(at(0.5, 1.05), FREE);
        assert_eq!(at(0.5, -0.05), FREE);
        assert_eq!(g.cells.iter().filter(|&&c| c != FREE).count(), 100);
        // 1 mm past the boundary occupies the next column.
        rasterize_rect(&mut g, Pose2::new(0.5005, 0.5, 0.0), 0.5, 0.5);
        assert_eq!(
            g.view().get(g.view().cell_of(1.05, 0.5)),
            Some(OCCUPIED_STATIC)
        );
    }

    #[test]
    fn rotated_box_marks_its_diamond_not_its_bounding_box() {
        let cfg = MapConfig::default();
        let mut g = empty_grid(&cfg).unwrap();
        rasterize_rect(
            &mut g,
            Pose2::new(0.0, 0.0, std::f64::consts::FRAC_PI_4),
            0.5,
            0.5,
        );
        let v = g.view();
        assert_eq!(v.get(v.cell_of(0.0, 0.0)), Some(OCCUPIED_STATIC));
        assert_eq!(v.get(v.cell_of(0.65, 0.0)), Some(OCCUPIED_STATIC));
        // The bounding box corner (0.7, 0.7) is far outside the diamond.
        assert_eq!(v.get(v.cell_of(0.6, 0.6)), Some(FREE));
        // Quarter-turn rotation of an axis-aligned box gives the swapped box.
        let mut g2 = empty_grid(&cfg).unwrap();
        rasterize_rect(
            &mut g2,
            Pose2::new(0.5, 0.5, std::f64::consts::FRAC_PI_2),
            0.5,
            0.3,
        );
        assert_eq!(g2.cells.iter().filter(|&&c| c != FREE).count(), 60);
    }

    #[test]
    fn boundary_band_is_occupied_and_origin_is_free() {
        let scene = shipped_scene();
        for cpm in [10.0, 20.0] {
            let cfg = MapConfig {
                cells_per_metre: cpm,
                ..MapConfig::default()
            };
            let g = static_map_from_scene(&scene, &cfg).unwrap();
            let v = g.view();
            let n = cpm as usize; // a 1 m band
            for iy in 0..v.height {
                for ix in 0..v.width {
                    let in_band = ix < n || iy < n || ix >= v.width - n || iy >= v.height - n;
                    let c = CellIndex {
                        ix: ix as i64,
                        iy: iy as i64,
                    };
                    if in_band {
                        assert_eq!(v.get(c), Some(OCCUPIED_STATIC), "{cpm} {ix} {iy}");
                    }
                }
            }
            // The first cell inside the band, and the start pose.
            assert_eq!(
                v.get(CellIndex {
                    ix: n as i64,
                    iy: n as i64
                }),
                Some(FREE)
            );
            assert_eq!(v.get(v.cell_of(0.0, 0.0)), Some(FREE));
            assert!(!v.occupied_at(0.0, 0.0));
        }
    }

    #[test]
    fn static_bodies_are_on_the_map_and_movable_ones_are_not() {
        let scene = shipped_scene();
        let cfg = MapConfig::default();
        let g = static_map_from_scene(&scene, &cfg).unwrap();
        // Everything under a static body, cell by cell (rasterised again on its own).
        let mut statics = empty_grid(&cfg).unwrap();
        for b in scene.static_bodies() {
            for p in &b.parts {
                rasterize_part(&mut statics, &b.pose, p);
            }
        }
        for (i, &s) in statics.cells.iter().enumerate() {
            if s != FREE {
                assert_eq!(g.cells[i], OCCUPIED_STATIC);
            }
        }
        mark_boundary(&mut statics, cfg.boundary_band);
        let mut checked = 0;
        for b in scene.movable_bodies() {
            let mut under = empty_grid(&cfg).unwrap();
            for p in &b.parts {
                rasterize_part(&mut under, &b.pose, p);
            }
            for (i, &u) in under.cells.iter().enumerate() {
                if u != FREE && statics.cells[i] == FREE {
                    assert_eq!(g.cells[i], FREE, "{} is on the static map", b.name);
                    checked += 1;
                }
            }
        }
        assert!(checked > 500, "only {checked} cells under movable bodies");
        // A rack row and a packing table are there.
        assert!(g.view().occupied_at(5.0, 13.0));
        assert!(g.view().occupied_at(5.0, -2.5));
        // The rack being carried stands in a free lane.
        assert!(!g.view().occupied_at(2.0, 13.0));
    }

    #[test]
    fn parts_outside_the_height_limits_are_skipped() {
        let text = r#"
[[body]]
name = "low"
kind = "box"
static = true
pose = [0.0, 0.0, 0.0]
size = [1.0, 1.0, 0.5]

[[body]]
name = "floating"
kind = "box"
static = true
pose = [3.0, 0.0, 0.0]
template = "high"

[templates.high]
parts = [{ center = [0.0, 0.0, 6.0], size = [1.0, 1.0, 1.0] }]
"#;
        let scene = Scene::parse(Path::new("t.toml"), text).unwrap();
        let g = static_map_from_scene(&scene, &MapConfig::default()).unwrap();
        assert!(g.view().occupied_at(0.0, 0.0));
        assert!(
            !g.view().occupied_at(3.0, 0.0),
            "a part above 5 m is not mapped"
        );
    }
}
