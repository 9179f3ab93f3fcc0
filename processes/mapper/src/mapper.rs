//! `Mapper`: the static map plus the lidar obstacle layer, giving the global map
//! (static + detections) and the local window the controller reads.
//!
//! This is the object the node drives: build it once from a static map, feed it every
//! scan, and copy the maps out. Knows nothing of the bus or of clocks.

use crate::changes::ChangeLog;
use crate::cloud::BeamGeometry;
use crate::config::{
    MAX_GLOBAL_GRID_CELLS, MAX_GLOBAL_GRID_SIDE, MAX_GRID_CELLS, MAX_GRID_SIDE, MapConfig,
};
use crate::error::MapError;
use crate::local_map::{LocalMapInfo, extract_local};
use crate::obstacle_layer::{ObstacleLayer, Scan, ScanStats};
use crate::placed::PlacedLayer;
use crate::ros_map::read_ros_map;
use crate::static_map::static_map_from_scene;
use aisle_config::scene::Scene;
use aisle_geometry::{
    FREE, Footprint, GridMap, GridView, OCCUPIED_DETECTED, OCCUPIED_STATIC, Pose2,
};
use std::path::Path;

/// The static map the configuration asks for: the ROS map in `cfg.ros_map` when set
/// (its own origin, size and resolution; no boundary band is added), else the scene at
/// `scene_path` rasterised as `cfg` describes.
pub fn load_static_map(cfg: &MapConfig, scene_path: &Path) -> Result<GridMap, MapError> {
    match &cfg.ros_map {
        Some(yaml) => read_ros_map(yaml),
        None => static_map_from_scene(&Scene::load(scene_path)?, cfg),
    }
}

#[derive(Debug, Clone)]
pub struct Mapper {
    /// The scene's static cells plus the parts of bodies set down (`placed`).
    static_map: GridMap,
    placed: PlacedLayer,
    /// Static cells plus detections: what is published as the global map.
    global: GridMap,
    layer: ObstacleLayer,
    local_side: usize,
    version: u64,
    /// What changed in `global` since the last full map the node published.
    changes: ChangeLog,
}

impl Mapper {
    /// `static_map` cells must be `FREE` or occupied (any non-zero value is taken as
    /// `OCCUPIED_STATIC`). The local window has the static map's resolution and
    /// `cfg.local.size` metres per side.
    pub fn new(
        static_map: GridMap,
        cfg: &MapConfig,
        beams: BeamGeometry,
    ) -> Result<Self, MapError> {
        aisle_config::Validate::validate(cfg)?;
        let mut static_map = static_map;
        for c in &mut static_map.cells {
            if *c != FREE {
                *c = OCCUPIED_STATIC;
            }
        }
        let side = static_map.width.max(static_map.height);
        if side > MAX_GLOBAL_GRID_SIDE {
            return Err(MapError::TooMany {
                what: "global map cells per side",
                got: side,
                max: MAX_GLOBAL_GRID_SIDE,
            });
        }
        if static_map.cells.len() > MAX_GLOBAL_GRID_CELLS {
            return Err(MapError::TooMany {
                what: "global map cells",
                got: static_map.cells.len(),
                max: MAX_GLOBAL_GRID_CELLS,
            });
        }
        let local_side = (cfg.local.size / static_map.resolution).round().max(1.0) as usize;
        if local_side > MAX_GRID_SIDE || local_side * local_side > MAX_GRID_CELLS {
            return Err(MapError::TooMany {
                what: "local map cells per side",
                got: local_side,
                max: MAX_GRID_SIDE,
            });
        }
        let layer = ObstacleLayer::new(&cfg.obstacles, beams)?;
        Ok(Self {
            changes: ChangeLog::new(&static_map.cells, 0),
            global: static_map.clone(),
            placed: PlacedLayer::new(static_map.clone()),
            static_map,
            layer,
            local_side,
            version: 0,
        })
    }

    /// [`load_static_map`] from `mapper_toml` (validated) and the scene at `scene_path`,
    /// then [`Mapper::new`]. Returns the loaded configuration too (the node needs
    /// `local_side` and the obstacle parameters for logging).
    pub fn from_files(
        mapper_toml: &Path,
        scene_path: &Path,
        beams: BeamGeometry,
    ) -> Result<(Self, MapConfig), MapError> {
        let cfg = aisle_config::load::<MapConfig>(mapper_toml)?;
        let map = load_static_map(&cfg, scene_path)?;
        Ok((Self::new(map, &cfg, beams)?, cfg))
    }

    /// Integrates one scan; bumps [`Mapper::version`] when a cell changed.
    pub fn integrate(&mut self, scan: &Scan<'_>) -> Result<ScanStats, MapError> {
        let stats = self.layer.update(&mut self.global, scan)?;
        if stats.changed() {
            self.version += 1;
            if let Some((lo, hi)) = stats.written {
                self.changes.note(&self.global.cells, lo..=hi);
            }
        }
        Ok(stats)
    }

    /// Makes `parts` (map frame: the legs of bodies set down) known obstacles, static
    /// cells no ray clears; parts no longer named are lifted. Bumps the version when the
    /// map changed. Allocates only when the set differs from the last one.
    pub fn set_placed(&mut self, parts: &[(Pose2, Footprint)]) -> bool {
        let changed = self
            .placed
            .set(parts, &mut self.static_map, &mut self.global);
        if changed {
            self.version += 1;
            if let Some(span) = self.placed.changed_span() {
                self.changes.note(&self.global.cells, span);
            }
        }
        changed
    }

    /// The parts [`Mapper::set_placed`] last made known.
    pub fn placed(&self) -> &[(Pose2, Footprint)] {
        self.placed.parts()
    }

    /// Static cells plus detections.
    pub fn global_map(&self) -> GridView<'_> {
        self.global.view()
    }

    pub fn static_map(&self) -> GridView<'_> {
        self.static_map.view()
    }

    /// Counts changes of the global map (0 at start); the `GlobalGrid.version` field.
    pub fn version(&self) -> u64 {
        self.version
    }

    /// Cells per side of the local window.
    pub fn local_side(&self) -> usize {
        self.local_side
    }

    /// Writes the local window centred on `center` (world metres) into `out`, which must
    /// hold `local_side()^2` cells. Outside the global map is occupied (see `local_map`).
    pub fn local_map_into(
        &self,
        center: (f64, f64),
        out: &mut [u8],
    ) -> Result<LocalMapInfo, MapError> {
        extract_local(&self.global.view(), center, self.local_side, out)
    }

    /// Like [`Mapper::local_map_into`], from the static map alone (no detections).
    pub fn local_static_map_into(
        &self,
        center: (f64, f64),
        out: &mut [u8],
    ) -> Result<LocalMapInfo, MapError> {
        extract_local(&self.static_map.view(), center, self.local_side, out)
    }

    /// Forgets every detection.
    pub fn clear_detections(&mut self) {
        if self.global.cells != self.static_map.cells {
            self.global.cells.copy_from_slice(&self.static_map.cells);
            self.version += 1;
            self.changes.note(&self.global.cells, 0..=usize::MAX);
        }
    }

    /// What changed in the global map since the base ([`Mapper::rebase_changes`]).
    pub fn changes(&self) -> &ChangeLog {
        &self.changes
    }

    /// Makes the global map as it is now the base of [`Mapper::changes`] (the node
    /// published it whole).
    pub fn rebase_changes(&mut self) {
        self.changes.rebase(&self.global.cells, self.version);
    }

    /// Takes back the changes a previous mapper had published (state that survives a
    /// restart, after [`Mapper::restore_detections`]): the base's version and the cells
    /// changed since, so the next changes go on from the same base with the same list.
    pub fn resume_changes(&mut self, base_version: u64, listed: impl IntoIterator<Item = u64>) {
        self.changes.rebase(&self.global.cells, base_version);
        self.changes.relist(listed);
    }

    /// Takes the detections back from a previously published global map (state that
    /// survives a restart). The grid must have this map's geometry; where the static map
    /// is free, its detected cells become detections again and its static cells (parts
    /// of set-down bodies) stay static, so telling [`Mapper::set_placed`] the same parts
    /// afterwards changes no cell and keeps the version.
    pub fn restore_detections(
        &mut self,
        published: &GridView<'_>,
        version: u64,
    ) -> Result<(), MapError> {
        let s = &self.static_map;
        let same = published.width == s.width
            && published.height == s.height
            && (published.resolution - s.resolution).abs() < 1e-12
            && (published.origin_x - s.origin_x).abs() < 1e-9
            && (published.origin_y - s.origin_y).abs() < 1e-9;
        if !same || published.cells.len() != s.cells.len() {
            return Err(MapError::GeometryMismatch(format!(
                "published map is {}x{} at {} from ({}, {}), this map {}x{} at {} from ({}, {})",
                published.width,
                published.height,
                published.resolution,
                published.origin_x,
                published.origin_y,
                s.width,
                s.height,
                s.resolution,
                s.origin_x,
                s.origin_y
            )));
        }
        for ((g, &st), &p) in self
            .global
            .cells
            .iter_mut()
            .zip(&s.cells)
            .zip(published.cells)
        {
            // Where the scene is free, the published map holds detections and the
            // parts of set-down bodies (static there until `set_placed` is told them
            // again, which then changes nothing and keeps the version).
            *g = if st == FREE && (p == OCCUPIED_DETECTED || p == OCCUPIED_STATIC) {
                p
            } else {
                st
            };
        }
        // Parts lifted since that map was published go with the next change of parts.
        self.placed.global_replaced();
        self.version = version;
        Ok(())
    }
}

#[cfg(test)]
mod tests;
