//! Bodies the mission set down: their parts (a rack's legs) are known obstacles, kept
//! in the map as static cells whatever the lidar sees.
//!
//! *Why:* the mapper ignores a rack while the robot stands under it, so its legs'
//! detections are gone when the robot drives out; the lidar looks forward, so it never
//! sees them again while the robot turns away, and the controller would swing the rack
//! it just set down into its path. The supervisor knows where it put the rack, so it
//! says so, and those cells are never cleared by rays. When the rack is taken again
//! (the supervisor stops naming it), its cells return to the scene's static map.
//!
//! Cells are marked by the static map's rule ([`crate::static_map::rasterize_rect`]:
//! every cell a part overlaps with positive area). Knows nothing of the bus or of the
//! mission; allocates only when the set of parts changes.

use crate::static_map::{rasterize_rect, rect_cell_box};
use aisle_geometry::{FREE, Footprint, GridMap, OCCUPIED_DETECTED, OCCUPIED_STATIC, Pose2};

/// The scene's static map and the parts placed on top of it.
#[derive(Debug, Clone)]
pub struct PlacedLayer {
    scene: GridMap,
    parts: Vec<(Pose2, Footprint)>,
    /// The cells the last [`PlacedLayer::set`] could change: under a part placed before
    /// it or by it (cell boxes, inclusive: x0, y0, x1, y1).
    regions: Vec<[usize; 4]>,
    /// The global map came from elsewhere (a restarted mapper's published map), so it
    /// may hold parts this layer never placed: the next change passes over every cell.
    whole_next: bool,
}

/// The cells [`rasterize_rect`] may mark for a part (see [`rect_cell_box`]).
fn cell_box(grid: &GridMap, (pose, fp): (Pose2, Footprint)) -> Option<[usize; 4]> {
    rect_cell_box(grid, pose, 0.5 * fp.length, 0.5 * fp.width)
}

impl PlacedLayer {
    /// `scene` is the static map without any placed part.
    pub fn new(scene: GridMap) -> Self {
        Self {
            scene,
            parts: Vec::new(),
            regions: Vec::new(),
            whole_next: false,
        }
    }

    /// The global map was replaced by one this layer did not make (resumed from what a
    /// mapper before a restart published): it may keep parts since lifted, which the next
    /// [`PlacedLayer::set`] that changes the parts then clears with a pass over the whole
    /// map, once.
    pub fn global_replaced(&mut self) {
        self.whole_next = true;
    }

    /// The parts now placed (map frame).
    pub fn parts(&self) -> &[(Pose2, Footprint)] {
        &self.parts
    }

    /// The row-major cell indices the last [`PlacedLayer::set`] could change: one span
    /// from the first cell of its regions to the last, so that the changes listed from it
    /// come in index order, as from a pass over the whole map (a restarted mapper's
    /// first change makes one): the list is the same bits with or without a restart.
    pub fn changed_span(&self) -> Option<std::ops::RangeInclusive<usize>> {
        let w = self.scene.width;
        let lo = self.regions.iter().map(|&[x0, y0, ..]| y0 * w + x0).min()?;
        let hi = self.regions.iter().map(|&[.., x1, y1]| y1 * w + x1).max()?;
        Some(lo..=hi)
    }

    /// Makes `parts` the placed set: `static_map` becomes the scene plus the parts, and
    /// `global` follows it (a cell of a part is static; a cell a part no longer covers
    /// is free unless the scene has it; detections elsewhere stay). Returns whether a
    /// cell of `global` changed. Non-finite or empty parts are skipped. Only the cells
    /// under the parts placed before and now are visited, not the whole map (8 M cells
    /// for a 100 x 200 m hall at 20 cells/m).
    pub fn set(
        &mut self,
        parts: &[(Pose2, Footprint)],
        static_map: &mut GridMap,
        global: &mut GridMap,
    ) -> bool {
        if parts == self.parts.as_slice() {
            return false;
        }
        self.regions.clear();
        let scene = &self.scene;
        if std::mem::take(&mut self.whole_next) {
            self.regions.push([0, 0, scene.width - 1, scene.height - 1]);
        } else {
            self.regions.extend(
                self.parts
                    .iter()
                    .chain(parts)
                    .filter_map(|&p| cell_box(scene, p)),
            );
        }
        self.parts.clear();
        self.parts.extend_from_slice(parts);
        let w = scene.width;
        let rows = |[x0, y0, x1, y1]: [usize; 4]| (y0..=y1).map(move |y| y * w + x0..=y * w + x1);
        for &region in &self.regions {
            for row in rows(region) {
                static_map.cells[row.clone()].copy_from_slice(&scene.cells[row]);
            }
        }
        for (pose, fp) in parts {
            rasterize_rect(static_map, *pose, 0.5 * fp.length, 0.5 * fp.width);
        }
        let mut changed = false;
        // Regions may overlap; the rule below gives the same cell on a second pass.
        for &region in &self.regions {
            for row in rows(region) {
                for ((g, &st), &sc) in global.cells[row.clone()]
                    .iter_mut()
                    .zip(&static_map.cells[row.clone()])
                    .zip(&scene.cells[row])
                {
                    let next = follow(*g, st, sc);
                    changed |= next != *g;
                    *g = next;
                }
            }
        }
        changed
    }
}

/// A global cell `g` after the placed parts changed: static where the static map
/// (scene plus parts) is; free where a part lifted off a cell the scene leaves free (the
/// lidar marks it again if something is there); else as it was.
fn follow(g: u8, static_cell: u8, scene: u8) -> u8 {
    let next = if static_cell != FREE {
        OCCUPIED_STATIC
    } else if g == OCCUPIED_STATIC && scene == FREE {
        FREE
    } else {
        g
    };
    debug_assert!(next != OCCUPIED_DETECTED || g == OCCUPIED_DETECTED);
    next
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid() -> GridMap {
        GridMap::new_free(0.0, 0.0, 0.1, 5.0, 5.0).unwrap()
    }

    fn leg(x: f64, y: f64) -> (Pose2, Footprint) {
        (Pose2::new(x, y, 0.0), Footprint::new(0.1, 0.1))
    }

    fn at(g: &GridMap, x: f64, y: f64) -> u8 {
        let (ix, iy) = ((x / g.resolution) as usize, (y / g.resolution) as usize);
        g.cells[iy * g.width + ix]
    }

    #[test]
    fn placed_parts_are_static_until_lifted_and_detections_elsewhere_stay() {
        let mut scene = grid();
        scene.cells[0] = OCCUPIED_STATIC;
        let mut layer = PlacedLayer::new(scene.clone());
        let mut static_map = scene.clone();
        let mut global = scene.clone();
        let detected = 40 * global.width + 40;
        global.cells[detected] = OCCUPIED_DETECTED;

        let parts = [leg(1.05, 1.05), leg(2.05, 1.05)];
        assert!(layer.set(&parts, &mut static_map, &mut global));
        assert_eq!(at(&global, 1.05, 1.05), OCCUPIED_STATIC);
        assert_eq!(at(&static_map, 2.05, 1.05), OCCUPIED_STATIC);
        assert_eq!(at(&global, 1.55, 1.05), FREE, "between the legs stays free");
        assert_eq!(global.cells[detected], OCCUPIED_DETECTED);
        // The same set again changes nothing.
        assert!(!layer.set(&parts, &mut static_map, &mut global));

        // Lifted: its cells are free again, the scene's cell and the detection stay.
        assert!(layer.set(&[], &mut static_map, &mut global));
        assert_eq!(at(&global, 1.05, 1.05), FREE);
        assert_eq!(static_map.cells, scene.cells);
        assert_eq!(global.cells[0], OCCUPIED_STATIC);
        assert_eq!(global.cells[detected], OCCUPIED_DETECTED);
    }

    #[test]
    fn a_detection_under_a_placed_part_becomes_static_and_is_not_kept_after() {
        let scene = grid();
        let mut layer = PlacedLayer::new(scene.clone());
        let (mut static_map, mut global) = (scene.clone(), scene.clone());
        let i = 10 * global.width + 10;
        global.cells[i] = OCCUPIED_DETECTED;
        assert!(layer.set(&[leg(1.05, 1.05)], &mut static_map, &mut global));
        assert_eq!(global.cells[i], OCCUPIED_STATIC);
        // Once lifted the cell is free: the lidar marks it again if something is there.
        assert!(layer.set(&[], &mut static_map, &mut global));
        assert_eq!(global.cells[i], FREE);
    }

    /// What `set` must give: the scene and the parts rasterised over the whole map (the
    /// static map, returned), and every global cell passed through the same rule.
    fn whole_map_pass(
        scene: &GridMap,
        parts: &[(Pose2, Footprint)],
        global: &mut GridMap,
    ) -> GridMap {
        let mut st = scene.clone();
        for (pose, fp) in parts {
            rasterize_rect(&mut st, *pose, 0.5 * fp.length, 0.5 * fp.width);
        }
        for ((g, &s), &sc) in global.cells.iter_mut().zip(&st.cells).zip(&scene.cells) {
            *g = follow(*g, s, sc);
        }
        st
    }

    #[test]
    fn only_the_cells_under_old_and_new_parts_change_as_a_whole_map_pass_would() {
        let mut scene = GridMap::new_free(-1.0, -2.0, 0.05, 12.0, 9.0).unwrap();
        for i in (0..scene.cells.len()).step_by(37) {
            scene.cells[i] = OCCUPIED_STATIC;
        }
        let mut layer = PlacedLayer::new(scene.clone());
        let (mut static_map, mut global) = (scene.clone(), scene.clone());
        let mut expected = global.clone();
        for i in (0..global.cells.len()).step_by(11) {
            if global.cells[i] == FREE {
                global.cells[i] = OCCUPIED_DETECTED;
                expected.cells[i] = OCCUPIED_DETECTED;
            }
        }
        let rack = |x: f64, y: f64, th: f64| {
            [(-0.6, -0.4), (0.6, -0.4), (-0.6, 0.4), (0.6, 0.4)].map(|(u, v)| {
                let (s, c) = f64::sin_cos(th);
                let leg = Pose2::new(x + c * u - s * v, y + s * u + c * v, th);
                (leg, Footprint::new(0.08, 0.08))
            })
        };
        // Set down, lifted, set down elsewhere, two racks, at the map's edge, none.
        let sets: Vec<Vec<(Pose2, Footprint)>> = vec![
            rack(2.0, 1.0, 0.3).to_vec(),
            vec![],
            rack(7.3, 4.1, -1.2).to_vec(),
            [rack(7.3, 4.1, -1.2), rack(0.5, 6.0, 2.0)].concat(),
            rack(10.95, -1.95, 0.0).to_vec(),
            vec![],
        ];
        for parts in &sets {
            layer.set(parts, &mut static_map, &mut global);
            let st = whole_map_pass(&scene, parts, &mut expected);
            assert_eq!(global.cells, expected.cells, "{parts:?}");
            assert_eq!(static_map.cells, st.cells);
        }
    }

    #[test]
    fn parts_in_a_resumed_map_that_the_layer_never_placed_are_cleared_at_the_next_change() {
        let scene = grid();
        let mut layer = PlacedLayer::new(scene.clone());
        let (mut static_map, mut global) = (scene.clone(), scene.clone());
        // The map a mapper published before its restart: a rack's leg since lifted.
        let stale = 30 * global.width + 30;
        global.cells[stale] = OCCUPIED_STATIC;
        layer.global_replaced();
        assert!(
            !layer.set(&[], &mut static_map, &mut global),
            "no change yet"
        );
        assert_eq!(global.cells[stale], OCCUPIED_STATIC);
        assert!(layer.set(&[leg(1.05, 1.05)], &mut static_map, &mut global));
        assert_eq!(global.cells[stale], FREE, "cleared with the next change");
        assert_eq!(at(&global, 1.05, 1.05), OCCUPIED_STATIC);
        // Afterwards only the parts' cells are visited again.
        global.cells[stale] = OCCUPIED_STATIC;
        assert!(layer.set(&[], &mut static_map, &mut global));
        assert_eq!(global.cells[stale], OCCUPIED_STATIC);
    }

    #[test]
    fn non_finite_parts_mark_nothing() {
        let scene = grid();
        let mut layer = PlacedLayer::new(scene.clone());
        let (mut static_map, mut global) = (scene.clone(), scene.clone());
        let bad = [(Pose2::new(f64::NAN, 1.0, 0.0), Footprint::new(0.1, 0.1))];
        assert!(!layer.set(&bad, &mut static_map, &mut global));
        assert_eq!(global.cells, scene.cells);
    }
}
