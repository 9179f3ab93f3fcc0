//! The rolling local map: a square window of the global map centred on the robot,
//! copied cell for cell into a caller buffer (the node passes shared memory).
//!
//! The window is snapped to the global grid so that cells copy exactly: its corner is
//! the global cell boundary nearest to `center - side/2`, which puts the robot within
//! half a cell of the window's centre.
//!
//! **Outside the global map is occupied** (`OCCUPIED_STATIC`). MATLAB's local map would
//! start free there, but the global planner already treats outside as occupied
//! (`GridView::occupied_or_outside`) and the controller treats outside *its* window as
//! free; filling unknown space as occupied keeps the two maps consistent and keeps the
//! controller from optimising a band through space nobody has mapped. In the seed's
//! warehouse the difference never shows: the 1 m boundary band and the walls surround
//! every pose the robot can reach.
//!
//! Knows nothing of how the window is published.

use crate::error::MapError;
use aisle_geometry::{GridView, OCCUPIED_STATIC};

/// Where a local map window lies, for the message header and for `GridView::new`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LocalMapInfo {
    /// World coordinates of the outer corner of local cell (0, 0).
    pub origin_x: f64,
    pub origin_y: f64,
    pub resolution: f64,
    pub width: usize,
    pub height: usize,
    /// Global cell index of local cell (0, 0) (may be negative or beyond the map).
    pub global_ix: i64,
    pub global_iy: i64,
}

/// Copies the `side x side` window of `global` centred on `center` into `out`
/// (row-major, `side * side` cells).
pub fn extract_local(
    global: &GridView<'_>,
    center: (f64, f64),
    side: usize,
    out: &mut [u8],
) -> Result<LocalMapInfo, MapError> {
    let expected = side.checked_mul(side).ok_or(MapError::TooMany {
        what: "local map side",
        got: side,
        max: crate::config::MAX_GRID_SIDE,
    })?;
    if out.len() != expected || side == 0 {
        return Err(MapError::BufferSize {
            what: "local map",
            expected,
            got: out.len(),
        });
    }
    if !(center.0.is_finite() && center.1.is_finite()) {
        return Err(MapError::NotFinite {
            what: "local map centre",
        });
    }
    let r = global.resolution;
    let half = 0.5 * side as f64;
    // `as` saturates: an absurd centre gives a window entirely outside, all occupied.
    let gx0 = ((center.0 - global.origin_x) / r - half).round() as i64;
    let gy0 = ((center.1 - global.origin_y) / r - half).round() as i64;
    let (gw, gh) = (global.width as i64, global.height as i64);
    // Columns of the window that fall inside the global map: [lx0, lx1).
    let lx0 = (0i64.saturating_sub(gx0)).clamp(0, side as i64) as usize;
    let lx1 = (gw.saturating_sub(gx0)).clamp(0, side as i64) as usize;
    for (ly, row) in out.chunks_exact_mut(side).enumerate() {
        let gy = gy0.saturating_add(ly as i64);
        if gy < 0 || gy >= gh || lx0 >= lx1 {
            row.fill(OCCUPIED_STATIC);
            continue;
        }
        let src_row = gy as usize * global.width;
        let gx_start = (gx0 + lx0 as i64) as usize;
        row[..lx0].fill(OCCUPIED_STATIC);
        row[lx0..lx1]
            .copy_from_slice(&global.cells[src_row + gx_start..src_row + gx_start + (lx1 - lx0)]);
        row[lx1..].fill(OCCUPIED_STATIC);
    }
    Ok(LocalMapInfo {
        origin_x: global.origin_x + gx0 as f64 * r,
        origin_y: global.origin_y + gy0 as f64 * r,
        resolution: r,
        width: side,
        height: side,
        global_ix: gx0,
        global_iy: gy0,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use aisle_geometry::{CellIndex, FREE, GridMap, OCCUPIED_DETECTED};

    fn numbered() -> GridMap {
        // Varying values make a misplaced copy visible.
        let mut g = GridMap::new_free(-5.0, -10.0, 0.1, 20.0, 30.0).unwrap();
        for iy in 0..g.height {
            for ix in 0..g.width {
                g.cells[iy * g.width + ix] = ((ix * 7 + iy * 13) % 3) as u8;
            }
        }
        g
    }

    #[test]
    fn window_is_centred_and_copies_cells() {
        let g = numbered();
        let v = g.view();
        let mut out = vec![9u8; 150 * 150];
        let info = extract_local(&v, (2.03, 3.0), 150, &mut out).unwrap();
        // 7.5 m each side, snapped to the 0.1 m grid.
        assert!((info.origin_x - (2.0 - 7.5)).abs() < 1e-9, "{info:?}");
        assert!((info.origin_y - (3.0 - 7.5)).abs() < 1e-9, "{info:?}");
        let lv = GridView::new(
            info.origin_x,
            info.origin_y,
            info.resolution,
            150,
            150,
            &out,
        )
        .unwrap();
        let (min_x, min_y, max_x, max_y) = lv.bounds();
        assert!((0.5 * (min_x + max_x) - 2.03).abs() <= 0.05 + 1e-9);
        assert!((0.5 * (min_y + max_y) - 3.0).abs() <= 0.05 + 1e-9);
        for ly in 0..150 {
            for lx in 0..150 {
                let (x, y) = lv.cell_center(CellIndex { ix: lx, iy: ly });
                let want = v.get(v.cell_of(x, y)).unwrap_or(OCCUPIED_STATIC);
                assert_eq!(out[ly as usize * 150 + lx as usize], want, "{lx} {ly}");
            }
        }
    }

    #[test]
    fn near_the_edge_outside_is_occupied() {
        let mut g = GridMap::new_free(-5.0, -10.0, 0.1, 20.0, 30.0).unwrap();
        g.set(CellIndex { ix: 0, iy: 0 }, OCCUPIED_DETECTED);
        let v = g.view();
        let mut out = vec![0u8; 150 * 150];
        // Robot at the south-west corner: three quarters of the window are outside.
        let info = extract_local(&v, (-5.0, -10.0), 150, &mut out).unwrap();
        assert_eq!((info.global_ix, info.global_iy), (-75, -75));
        let at = |lx: usize, ly: usize| out[ly * 150 + lx];
        assert_eq!(at(75, 75), OCCUPIED_DETECTED, "global cell (0, 0)");
        assert_eq!(at(76, 76), FREE);
        assert_eq!(at(74, 80), OCCUPIED_STATIC, "west of the map");
        assert_eq!(at(80, 74), OCCUPIED_STATIC, "south of the map");
        assert_eq!(out.iter().filter(|&&c| c == FREE).count(), 75 * 75 - 1);
        // Far away: all occupied; NaN: an error.
        extract_local(&v, (1e300, -1e300), 150, &mut out).unwrap();
        assert!(out.iter().all(|&c| c == OCCUPIED_STATIC));
        assert!(extract_local(&v, (f64::NAN, 0.0), 150, &mut out).is_err());
        assert!(extract_local(&v, (0.0, 0.0), 149, &mut out).is_err());
    }
}
