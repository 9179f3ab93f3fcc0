//! `aisle check`: load every config file the way the processes will, so a mistake is
//! reported with its file, line and key before anything starts; then the checks across
//! files: [`sensor`] (can the lidar see what the robot can drive into before it can
//! stop?) and [`placement`] (a start pose inside a body, a start or goal outside the
//! map, and leg by leg a goal or drop pose that overlaps a known body or that the static
//! map cannot reach: [`legs`], [`goals`], [`reach`]), and [`realtime`] (the real-time
//! options against the graph and this host's CPUs). `aisle run` goes through the same
//! path before it launches anything. [`scene_limits`]: how large a scene the messages
//! can carry (`aisle scene generate` asks it too); [`open_side`]: a body a leg
//! approaches or carries can be driven under.

pub mod arrival;
pub mod external;
pub mod goals;
pub mod legs;
#[cfg(test)]
mod mission_tests;
pub mod open_side;
pub mod placement;
pub mod reach;
pub mod realtime;
pub mod scene_limits;
pub mod sensor;
#[cfg(test)]
mod testing;

use crate::mission::MissionConfig;
use aisle_config::scene::Scene;
use aisle_tools::latency::Budgets;
use std::path::{Path, PathBuf};

/// The files a config directory holds, by role.
pub struct ConfigFiles {
    pub scene: PathBuf,
    pub robot: PathBuf,
    pub lidar: PathBuf,
    pub mapper: PathBuf,
    pub planner: PathBuf,
    pub teb: PathBuf,
    pub mission: PathBuf,
    pub budgets: PathBuf,
    pub restart: PathBuf,
}

impl ConfigFiles {
    pub fn in_dir(dir: &Path) -> ConfigFiles {
        ConfigFiles {
            scene: dir.join("warehouse.toml"),
            robot: dir.join("robot.toml"),
            lidar: dir.join("lidar.toml"),
            mapper: dir.join("mapper.toml"),
            planner: dir.join("planner.toml"),
            teb: dir.join("teb.toml"),
            mission: dir.join("mission.toml"),
            budgets: dir.join("budgets.toml"),
            restart: dir.join("restart.toml"),
        }
    }

    pub fn all(&self) -> [&Path; 9] {
        [
            &self.scene,
            &self.robot,
            &self.lidar,
            &self.mapper,
            &self.planner,
            &self.teb,
            &self.mission,
            &self.budgets,
            &self.restart,
        ]
    }
}

/// Validates every config file in `dir`; returns the files checked. A `.toml` file that
/// aisle does not read is an error too (a typo in a file name would otherwise be
/// silently ignored).
pub fn check_dir(dir: &Path) -> Result<Vec<PathBuf>, String> {
    if !dir.is_dir() {
        return Err(format!("{}: not a directory", dir.display()));
    }
    let files = ConfigFiles::in_dir(dir);
    let ground = Loaded::load(&files)?;
    load_mission(&files, &ground, &files.mission)?;
    aisle_config::load::<Budgets>(&files.budgets).map_err(|e| e.to_string())?;
    aisle_config::load::<crate::restart::RestartConfig>(&files.restart)
        .map_err(|e| e.to_string())?;
    let model = &ground.model;
    let mut checked: Vec<PathBuf> = files.all().iter().map(|p| p.to_path_buf()).collect();
    checked.push(model.file().to_path_buf());
    // The graph is optional in a config directory (the shipped one stands in).
    let graph = aisle_node::graph::path_in(dir);
    if graph.exists() {
        let loaded = aisle_node::Graph::load(&graph).map_err(|e| e.to_string())?;
        checked.push(graph);
        checked.extend(external::check(dir, &loaded)?);
    }
    // So is realtime.toml (absent: every option off).
    let realtime_file = aisle_node::realtime::path_in(dir);
    if realtime_file.exists() {
        let graph = aisle_node::Graph::load_dir(dir).map_err(|e| e.to_string())?;
        realtime::check(dir, &graph)?;
        checked.push(realtime_file);
    }
    // And hosts.toml (where a spread run places the nodes; absent: all local).
    let hosts_file = dir.join("hosts.toml");
    if hosts_file.exists() {
        let graph = aisle_node::Graph::load_dir(dir).map_err(|e| e.to_string())?;
        aisle_link::Placement::load(&hosts_file, &graph).map_err(|e| e.to_string())?;
        checked.push(hosts_file);
    }
    let known: Vec<PathBuf> = checked
        .iter()
        .filter_map(|p| p.file_name().map(PathBuf::from))
        .collect();
    let entries = std::fs::read_dir(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    for entry in entries.flatten() {
        let p = entry.path();
        if p.extension().is_some_and(|e| e == "toml")
            && !known.iter().any(|k| Some(k.as_os_str()) == p.file_name())
        {
            return Err(format!(
                "{}: not a file aisle reads (expected warehouse, robot, lidar, mapper, planner, teb, mission, budgets, restart, graph, realtime, hosts .toml, or <node>.toml for a node of graph.toml's own)",
                p.display()
            ));
        }
    }
    Ok(checked)
}

/// The files the cross-file checks need, loaded and each checked on its own, with the
/// lidar checked against the robot's limits.
pub struct Loaded {
    pub scene: Scene,
    pub robot: aisle_robot::RobotConfig,
    pub model: aisle_robot::RobotModel,
    pub map: placement::Extent,
    /// The static map (`mapper.toml`: the scene's static bodies, or a ROS map).
    pub static_map: aisle_geometry::GridMap,
    pub teb: aisle_teb_controller::TebConfig,
    pub planner: aisle_global_planner::PlannerConfig,
}

impl Loaded {
    pub fn load(files: &ConfigFiles) -> Result<Loaded, String> {
        let s = |e: &dyn std::fmt::Display| e.to_string();
        let scene = Scene::load(&files.scene).map_err(|e| s(&e))?;
        let map_cfg =
            aisle_config::load::<aisle_mapper::MapConfig>(&files.mapper).map_err(|e| s(&e))?;
        let bytes = std::fs::metadata(&files.scene).map_or(0, |m| m.len() as usize);
        if let Some(why) = scene_limits::problem(bytes, &scene, map_cfg.cells_per_metre) {
            return Err(format!(
                "{}: {why} ({} cells_per_metre = {})",
                files.scene.display(),
                files.mapper.display(),
                map_cfg.cells_per_metre
            ));
        }
        let (robot, model) = aisle_robot::load_robot(&files.robot).map_err(|e| s(&e))?;
        aisle_config::load::<aisle_robot::LidarConfig>(&files.lidar).map_err(|e| s(&e))?;
        let map = aisle_mapper::load_static_map(&map_cfg, &files.scene)
            .map_err(|e| format!("{}: {e}", files.mapper.display()))?;
        let planner = aisle_config::load::<aisle_global_planner::PlannerConfig>(&files.planner)
            .map_err(|e| s(&e))?;
        let teb =
            aisle_config::load::<aisle_teb_controller::TebConfig>(&files.teb).map_err(|e| s(&e))?;
        Ok(Loaded {
            map: map.view().bounds(),
            static_map: map,
            scene,
            robot,
            model,
            teb,
            planner,
        })
    }
}

/// Loads the mission at `path` (the directory's `mission.toml` or `--mission`) and
/// checks it against the scene and the map, and the lidar against the robot's limits
/// with the mission's controller period.
pub fn load_mission(
    files: &ConfigFiles,
    ground: &Loaded,
    path: &Path,
) -> Result<MissionConfig, String> {
    let mission = MissionConfig::load(path, &ground.scene).map_err(|e| e.to_string())?;
    let g = placement::Ground {
        scene: &ground.scene,
        scene_path: &files.scene,
        robot: &ground.robot,
        model: &ground.model,
        map: ground.map,
        static_map: ground.static_map.view(),
        map_path: &files.mapper,
        dock: open_side::params(&ground.planner),
    };
    placement::check_mission(&mission, path, &g).map_err(|e| e.to_string())?;
    let mount = ground
        .model
        .mount_in_base(&ground.robot.lidar_mount)
        .map_err(|e| e.to_string())?;
    // A tilted mount: the heading of its x axis projected on the floor.
    let yaw = mount
        .level_yaw()
        .unwrap_or_else(|| mount.rotation[1][0].atan2(mount.rotation[0][0]));
    let limits = sensor::Limits::new(
        &ground.teb,
        mission.controller_period_s,
        &ground.robot,
        &mount,
    );
    let text = aisle_config::read_capped(&files.lidar)
        .map_err(|e| format!("{}: cannot read: {e}", files.lidar.display()))?;
    let lidar = aisle_config::parse::<aisle_robot::LidarConfig>(&files.lidar, &text)
        .map_err(|e| e.to_string())?;
    sensor::check_lidar(&lidar, &files.lidar, &text, &limits, yaw, &ground.scene)
        .map_err(|e| e.to_string())?;
    Ok(mission)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn shipped() -> PathBuf {
        aisle_config::testing::shipped_dir()
    }

    #[test]
    fn the_shipped_config_is_valid() {
        let files = check_dir(&shipped()).unwrap();
        assert!(files.len() >= 9);
    }

    #[test]
    fn a_bad_key_is_named_with_file_and_line() {
        let dir = std::env::temp_dir().join(format!("aisle-check-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        for e in std::fs::read_dir(shipped()).unwrap().flatten() {
            if e.path().is_file() {
                std::fs::copy(e.path(), dir.join(e.file_name())).unwrap();
            }
        }
        let budgets = std::fs::read_to_string(dir.join("budgets.toml")).unwrap();
        std::fs::write(
            dir.join("budgets.toml"),
            budgets.replace("lidar = 10.0", "lidar = -1.0"),
        )
        .unwrap();
        let err = check_dir(&dir).unwrap_err();
        assert!(err.contains("budgets.toml"), "{err}");
        assert!(err.contains("stage.lidar"), "{err}");
        std::fs::write(dir.join("budgets.toml"), budgets).unwrap();
        std::fs::write(dir.join("lidr.toml"), "").unwrap();
        let err = check_dir(&dir).unwrap_err();
        assert!(err.contains("lidr.toml"), "{err}");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
