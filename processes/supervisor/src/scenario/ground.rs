//! What a scenario is generated from: the base config directory loaded once (scene,
//! robot footprints, the map's interior, the static map, the base mission or, when it
//! does not fit the scene, its settings), and the
//! layout of bodies the generator places things against. Knows the config files, not
//! the families.

use super::geom::Rect;
use crate::check::placement::Extent;
use crate::check::{ConfigFiles, Loaded};
use crate::mission::MissionConfig;
use aisle_config::scene::Scene;
use aisle_geometry::{Footprint, GridMap, Pose2};
use std::path::Path;

/// Clearance beyond robot.toml's `footprint.alone.margin` kept around a sampled start or
/// park pose (metres): the planner can start and end there without backing off first.
pub const ALONE_CLEARANCE: f64 = 0.3;
/// Clearance beyond `footprint.carrying.margin` kept around a sampled drop pose, for the
/// rack set down there (metres).
pub const CARRY_CLEARANCE: f64 = 0.2;
/// Gap kept between a placed obstacle and any other body (metres).
pub const OBSTACLE_GAP: f64 = 0.15;
/// Free space kept around the mission's start, goals and named racks when obstacles are
/// placed or moved (metres, beyond the footprint there).
pub const KEEP_OUT: f64 = 0.6;

/// One body of the layout: its covering rectangle on the floor.
#[derive(Debug, Clone, PartialEq)]
pub struct Placed {
    pub name: String,
    pub kind: String,
    pub is_static: bool,
    pub rect: Rect,
}

/// The base config directory, loaded.
pub struct Ground {
    pub scene: Scene,
    /// The base mission; only its settings (no legs) when it does not fit the scene.
    pub mission: MissionConfig,
    /// Why the base mission does not fit the scene (a scene replaced by `aisle scene
    /// generate`, say): then only the `mission` family, which draws a mission of its
    /// own, can be generated.
    pub mission_unfit: Option<String>,
    /// The map's extent (mapper.toml origin and size).
    pub map: Extent,
    /// The map minus its boundary band: where a footprint may stand.
    pub interior: Extent,
    pub alone: Footprint,
    pub alone_margin: f64,
    pub carrying: Footprint,
    pub carrying_margin: f64,
    /// The static map the planner gets (scene or ROS map, with the band).
    pub static_map: GridMap,
}

impl Ground {
    pub fn load(dir: &Path) -> Result<Ground, String> {
        let files = ConfigFiles::in_dir(dir);
        let loaded = Loaded::load(&files)?;
        let (mission, mission_unfit) = match MissionConfig::load(&files.mission, &loaded.scene) {
            Ok(m) => (m, None),
            Err(unfit) => match MissionConfig::load_settings(&files.mission) {
                Ok(settings) => (settings, Some(unfit.to_string())),
                Err(_) => return Err(unfit.to_string()),
            },
        };
        let map_cfg = aisle_config::load::<aisle_mapper::MapConfig>(&files.mapper)
            .map_err(|e| e.to_string())?;
        let static_map = aisle_mapper::load_static_map(&map_cfg, &files.scene)
            .map_err(|e| format!("{}: {e}", files.mapper.display()))?;
        let (x0, y0, x1, y1) = loaded.map;
        let band = map_cfg.boundary_band;
        let fp = &loaded.robot.footprint;
        Ok(Ground {
            map: loaded.map,
            interior: (x0 + band, y0 + band, x1 - band, y1 - band),
            alone: fp.alone.footprint(),
            alone_margin: fp.alone.margin,
            carrying: fp.carrying.footprint(),
            carrying_margin: fp.carrying.margin,
            scene: loaded.scene,
            mission,
            mission_unfit,
            static_map,
        })
    }

    /// Why `family` cannot be generated from this base: every family but `mission`
    /// varies the base mission, so it needs one that fits the scene.
    pub fn unfit_for(&self, family: super::Family) -> Option<String> {
        let why = self.mission_unfit.as_ref()?;
        (family != super::Family::Mission).then(|| {
            format!(
                "the base config: {why}; --family {} varies the base mission, so it needs \
                 one that fits the scene (--family mission draws a mission of its own)",
                family.name()
            )
        })
    }

    /// Every body of the scene as a rectangle.
    pub fn layout(&self) -> Layout {
        Layout {
            bodies: self
                .scene
                .bodies
                .iter()
                .map(|b| Placed {
                    name: b.name.clone(),
                    kind: b.kind.clone(),
                    is_static: b.is_static,
                    rect: Rect::new(b.pose, b.footprint()),
                })
                .collect(),
            keep_out: Vec::new(),
        }
    }

    /// The movable racks a mission may pick (by kind, as the scene names them).
    pub fn racks(&self) -> Vec<&aisle_config::scene::Body> {
        self.scene
            .movable_bodies()
            .filter(|b| b.kind == "pallet_rack")
            .collect()
    }

    /// The rectangle the robot needs at `at`, with its margin and `clearance`.
    pub fn robot_rect(&self, at: Pose2, clearance: f64) -> Rect {
        Rect::new(at, self.alone).grown(self.alone_margin + clearance)
    }

    /// The rectangle a carried rack needs at `at`, with its margin and `clearance`.
    pub fn carried_rect(&self, at: Pose2, clearance: f64) -> Rect {
        Rect::new(at, self.carrying).grown(self.carrying_margin + clearance)
    }
}

/// The bodies as the generator has placed them so far, and the areas kept free for the
/// mission (start, goals, named racks and their way in).
#[derive(Debug, Clone)]
pub struct Layout {
    pub bodies: Vec<Placed>,
    pub keep_out: Vec<Rect>,
}

impl Layout {
    /// Whether `r` is inside `interior` and touches no body (except those named in
    /// `except`).
    pub fn free(&self, r: &Rect, interior: Extent, except: &[&str]) -> bool {
        r.inside(interior)
            && self
                .bodies
                .iter()
                .filter(|b| !except.contains(&b.name.as_str()))
                .all(|b| !b.rect.overlaps(r))
    }

    /// Whether an obstacle at `r` keeps [`OBSTACLE_GAP`] from every body but `except`
    /// and stays out of the mission's areas. `r` need not be inside the interior (an
    /// obstacle may stand in the boundary band).
    pub fn obstacle_fits(&self, r: &Rect, except: &str) -> bool {
        let grown = r.grown(OBSTACLE_GAP);
        self.bodies
            .iter()
            .filter(|b| b.name != except)
            .all(|b| !b.rect.overlaps(&grown))
            && self.keep_out.iter().all(|k| !k.overlaps(r))
    }

    pub fn get_mut(&mut self, name: &str) -> Option<&mut Placed> {
        self.bodies.iter_mut().find(|b| b.name == name)
    }
}
