//! Test fixture for the mission checks: the shipped robot and static map with the
//! shipped scene or a variant of it, and missions given as text, checked the way
//! `aisle check` checks them ([`super::placement::check_mission`]).

use super::placement::{Ground, check_mission};
use crate::mission::MissionConfig;
use aisle_config::scene::Scene;
use aisle_config::testing::shipped;
use aisle_geometry::GridMap;
use aisle_robot::{RobotConfig, RobotModel};
use std::path::PathBuf;

pub struct Fixture {
    pub scene: Scene,
    scene_path: PathBuf,
    robot: RobotConfig,
    model: RobotModel,
    map: GridMap,
    planner: aisle_global_planner::PlannerConfig,
    dir: PathBuf,
}

impl Fixture {
    /// The shipped config; scratch files go to a directory named after `name`.
    pub fn shipped(name: &str) -> Fixture {
        Fixture::with_scene(name, "", "")
    }

    /// The shipped config with `from` replaced by `to` in the scene.
    pub fn with_scene(name: &str, from: &str, to: &str) -> Fixture {
        let dir = std::env::temp_dir().join(format!("aisle-goals-{}-{name}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let text = std::fs::read_to_string(shipped("warehouse.toml")).unwrap();
        let changed = text.replace(from, to);
        assert!(
            from.is_empty() || changed != text,
            "{from} not in the scene"
        );
        let scene_path = dir.join("warehouse.toml");
        std::fs::write(&scene_path, changed).unwrap();
        let scene = Scene::load(&scene_path).unwrap();
        let (robot, model) = aisle_robot::load_robot(&shipped("robot.toml")).unwrap();
        let cfg = aisle_config::load::<aisle_mapper::MapConfig>(&shipped("mapper.toml")).unwrap();
        let map = aisle_mapper::load_static_map(&cfg, &scene_path).unwrap();
        Fixture {
            scene,
            scene_path,
            robot,
            model,
            map,
            planner: aisle_config::load(&shipped("planner.toml")).unwrap(),
            dir,
        }
    }

    /// Checks `mission` (the text of a mission file, written as `mission.toml`).
    pub fn check(&self, mission: &str) -> Result<(), String> {
        let path = self.dir.join("mission.toml");
        std::fs::write(&path, mission).unwrap();
        let mission = MissionConfig::load(&path, &self.scene).map_err(|e| e.to_string())?;
        let ground = Ground {
            scene: &self.scene,
            scene_path: &self.scene_path,
            robot: &self.robot,
            model: &self.model,
            map: self.map.view().bounds(),
            static_map: self.map.view(),
            map_path: &shipped("mapper.toml"),
            dock: super::open_side::params(&self.planner),
        };
        check_mission(&mission, &path, &ground).map_err(|e| e.to_string())
    }
}

impl Drop for Fixture {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}

/// The shipped mission's text with `from` replaced by `to`.
pub fn seed_with(from: &str, to: &str) -> String {
    let text = std::fs::read_to_string(shipped("mission.toml")).unwrap();
    let changed = text.replace(from, to);
    assert!(
        from.is_empty() || changed != text,
        "{from} not in mission.toml"
    );
    changed
}

/// A mission from the seed's start with these legs.
pub fn mission(legs: &str) -> String {
    format!(
        "start = [0.0, 0.0, 0.0]\nleg_timeout_s = 60.0\nmax_replans_per_leg = 12\n\
         replan_cooldown_steps = 2\n{legs}"
    )
}
