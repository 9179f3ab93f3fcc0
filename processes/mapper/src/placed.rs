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

use crate::static_map::rasterize_rect;
use aisle_geometry::{FREE, Footprint, GridMap, OCCUPIED_DETECTED, OCCUPIED_STATIC, Pose2};

/// The scene's static map and the parts placed on top of it.
#[derive(Debug, Clone)]
pub struct PlacedLayer {
    scene: GridMap,
    parts: Vec<(Pose2, Footprint)>,
}

impl PlacedLayer {
    /// `scene` is the static map without any placed part.
    pub fn new(scene: GridMap) -> Self {
        Self {
            scene,
            parts: Vec::new(),
        }
    }

    /// The parts now placed (map frame).
    pub fn parts(&self) -> &[(Pose2, Footprint)] {
        &self.parts
    }

    /// Makes `parts` the placed set: `static_map` becomes the scene plus the parts, and
    /// `global` follows it (a cell of a part is static; a cell a part no longer covers
    /// is free unless the scene has it; detections elsewhere stay). Returns whether a
    /// cell of `global` changed. Non-finite or empty parts are skipped.
    pub fn set(
        &mut self,
        parts: &[(Pose2, Footprint)],
        static_map: &mut GridMap,
        global: &mut GridMap,
    ) -> bool {
        if parts == self.parts.as_slice() {
            return false;
        }
        self.parts.clear();
        self.parts.extend_from_slice(parts);
        static_map.cells.copy_from_slice(&self.scene.cells);
        for (pose, fp) in parts {
            rasterize_rect(static_map, *pose, 0.5 * fp.length, 0.5 * fp.width);
        }
        let mut changed = false;
        for ((g, &st), &scene) in global
            .cells
            .iter_mut()
            .zip(&static_map.cells)
            .zip(&self.scene.cells)
        {
            let next = if st != FREE {
                OCCUPIED_STATIC
            } else if *g == OCCUPIED_STATIC && scene == FREE {
                // A part lifted off this cell; the lidar marks it again if it is not gone.
                FREE
            } else {
                *g
            };
            debug_assert!(next != OCCUPIED_DETECTED || *g == OCCUPIED_DETECTED);
            changed |= next != *g;
            *g = next;
        }
        changed
    }
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
