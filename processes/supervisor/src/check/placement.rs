//! Where a mission puts the robot, against the scene and the map, before anything is
//! launched: a start pose whose footprint overlaps a body (the simulator's own contact
//! test, so the verdict is the one the simulator would give after launch), a start or
//! goal outside the map, and then leg by leg ([`super::legs`]) a goal where the robot
//! (or a carried rack) would overlap a known body ([`super::goals`]) or that the static
//! map cannot connect to where the leg starts ([`super::reach`]). Each refusal names the
//! mission file, the key, the leg and the body or the map. Knows nothing of how the
//! mission is driven.

use super::arrival;
use super::goals::{self, Refusal};
use super::legs::{self, LegView};
use super::open_side;
use super::reach::{Reach, Verdict};
use crate::mission::MissionConfig;
use aisle_config::ConfigError;
use aisle_config::scene::Scene;
use aisle_geometry::{Footprint, GridView, Pose2};
use aisle_robot::{RobotConfig, RobotModel};
use aisle_simulator::SimError;
use aisle_simulator::world::World;
use std::path::Path;

/// The map's extent: (min x, min y, max x, max y), metres.
pub type Extent = (f64, f64, f64, f64);

/// What a placement is checked against.
pub struct Ground<'a> {
    pub scene: &'a Scene,
    pub scene_path: &'a Path,
    pub robot: &'a RobotConfig,
    pub model: &'a RobotModel,
    pub map: Extent,
    /// The static map the planner plans on first (`mapper.toml`), and that file.
    pub static_map: GridView<'a>,
    pub map_path: &'a Path,
    /// How the planner lays out its straight moves under a body (`planner.toml`).
    pub dock: aisle_global_planner::dock::DockParams,
}

/// Checks the start pose and every leg's goal of `mission` (read from `path`).
pub fn check_mission(
    mission: &MissionConfig,
    path: &Path,
    ground: &Ground,
) -> Result<(), ConfigError> {
    let text = aisle_config::read_capped(path).unwrap_or_default();
    let bad = |key: &str, why: String| ConfigError::invalid(path, &text, key, why);
    let footprint = ground.robot.footprint.alone.footprint();
    let start = mission.start_pose();
    if let Some(why) = outside(start, footprint, ground.map) {
        return Err(bad("start", format!("the start pose {why}")));
    }
    match World::new_at(ground.scene, ground.model, ground.robot, start) {
        Ok(_) => {}
        Err(SimError::StartInCollision { body, .. }) => {
            return Err(bad(
                "start",
                format!(
                    "the robot's footprint ({} x {} m, robot.toml footprint.alone) at ({}, {}, {}) \
                     overlaps body `{body}` of {}",
                    footprint.length,
                    footprint.width,
                    start.x,
                    start.y,
                    start.theta,
                    ground.scene_path.display()
                ),
            ));
        }
        Err(e) => return Err(bad("start", e.to_string())),
    }
    // The planner refuses a start whose bare footprint touches the static map (a wall,
    // the boundary band), unless the first leg leaves from under a body straight ahead.
    let departs = mission.leg.first().is_some_and(|l| l.depart.is_some());
    if !departs
        && aisle_global_planner::footprint_touches(&ground.static_map, footprint, 0.0, &start)
    {
        return Err(bad(
            "start",
            format!(
                "the robot's footprint ({} x {} m, robot.toml footprint.alone) at ({}, {}, {}) \
                 touches occupied cells of the static map ({}: a wall, a body's legs or the \
                 map's boundary band), where the planner cannot start",
                footprint.length,
                footprint.width,
                start.x,
                start.y,
                start.theta,
                ground.map_path.display()
            ),
        ));
    }
    for (i, leg) in mission.leg.iter().enumerate() {
        let goal = Pose2::new(leg.goal[0], leg.goal[1], leg.goal[2]);
        if let Some(why) = outside(goal, footprint, ground.map) {
            return Err(bad(
                &format!("leg[{i}].goal"),
                format!("the goal of leg `{}` {why}", leg.name),
            ));
        }
    }
    let mut reach = Reach::new(ground.static_map);
    for view in legs::walk(mission, ground.scene, ground.model.carry_mount_planar()) {
        let tolerance = mission.goal_tolerance[0].hypot(mission.goal_tolerance[1]);
        goals::check_pick(&view, ground, tolerance)
            .and_then(|()| arrival::check_rotate(&view, tolerance))
            .and_then(|()| arrival::check_approach(&view, ground, tolerance))
            .and_then(|()| open_side::check_open_side(&view, ground))
            .and_then(|()| goals::check_goal(&view, ground))
            .and_then(|()| goals::check_drop(&view, ground))
            .and_then(|()| reachable(&view, ground, &mut reach))
            .and_then(|()| arrival::check_goal_clear(&view, ground))
            .map_err(|r| bad(&r.key, r.why))?;
    }
    Ok(())
}

/// Leg `view`'s goal against the static map, with the leg's footprint (carrying on a
/// carry leg). A turn in place goes nowhere; a start the map blocks proves nothing.
fn reachable(view: &LegView, ground: &Ground, reach: &mut Reach) -> Result<(), Refusal> {
    if view.leg.rotate {
        return Ok(());
    }
    let (spec, which) = if view.drop.is_some() {
        (&ground.robot.footprint.carrying, "carrying")
    } else {
        (&ground.robot.footprint.alone, "alone")
    };
    let f = spec.footprint();
    let footprint = format!(
        "the robot's footprint (robot.toml footprint.{which}, {} x {} m)",
        f.length, f.width
    );
    let (from, to) = (view.start[0], view.goal);
    let map = ground.map_path.display();
    let why = match reach.verdict((from.x, from.y), (to.x, to.y), f.inscribed_radius()) {
        Verdict::Connected | Verdict::StartBlocked => return Ok(()),
        Verdict::GoalBlocked => format!(
            "the goal ({}, {}) of leg `{}` is unreachable on the static map ({map}): \
             whatever its heading, {footprint} there touches occupied cells",
            to.x, to.y, view.leg.name
        ),
        Verdict::Disconnected => format!(
            "the goal ({}, {}) of leg `{}` is unreachable on the static map ({map}): \
             no passage wide enough for {footprint} connects it to ({}, {}), where the \
             leg starts",
            to.x, to.y, view.leg.name, from.x, from.y
        ),
    };
    Err(Refusal {
        key: goals::goal_key(view),
        why,
    })
}

/// Why `pose` is outside the map, if it is: its centre, or a corner of the robot's
/// footprint there (the planner counts cells beyond the map as occupied).
fn outside(pose: Pose2, footprint: Footprint, (x0, y0, x1, y1): Extent) -> Option<String> {
    let inside = |x: f64, y: f64| x >= x0 && x <= x1 && y >= y0 && y <= y1;
    let extent = format!("x {x0}..{x1} m, y {y0}..{y1} m (mapper.toml origin and size)");
    if !inside(pose.x, pose.y) {
        return Some(format!(
            "({}, {}) is outside the map: {extent}",
            pose.x, pose.y
        ));
    }
    if footprint.corners(&pose).iter().any(|&(x, y)| !inside(x, y)) {
        return Some(format!(
            "({}, {}) is outside the map: the robot's footprint there leaves {extent}",
            pose.x, pose.y
        ));
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;
    use aisle_config::testing::shipped;

    struct Fixture {
        scene: Scene,
        robot: RobotConfig,
        model: RobotModel,
    }

    fn fixture() -> Fixture {
        let scene = Scene::load(&shipped("warehouse.toml")).unwrap();
        let (robot, model) = aisle_robot::load_robot(&shipped("robot.toml")).unwrap();
        Fixture {
            scene,
            robot,
            model,
        }
    }

    /// The shipped mission with `from` replaced by `to`, written to a scratch file.
    fn check_with(f: &Fixture, name: &str, from: &str, to: &str) -> Result<(), ConfigError> {
        let text = std::fs::read_to_string(shipped("mission.toml")).unwrap();
        let changed = text.replace(from, to);
        assert!(
            from.is_empty() || changed != text,
            "{from} not in mission.toml"
        );
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join(name);
        std::fs::write(&path, changed).unwrap();
        let mission = MissionConfig::load(&path, &f.scene).unwrap();
        let cfg = aisle_config::load::<aisle_mapper::MapConfig>(&shipped("mapper.toml")).unwrap();
        let map = aisle_mapper::load_static_map(&cfg, &shipped("warehouse.toml")).unwrap();
        let ground = Ground {
            scene: &f.scene,
            scene_path: &shipped("warehouse.toml"),
            robot: &f.robot,
            model: &f.model,
            map: map.view().bounds(),
            static_map: map.view(),
            map_path: &shipped("mapper.toml"),
            dock: super::super::open_side::params(&Default::default()),
        };
        check_mission(&mission, &path, &ground)
    }

    #[test]
    fn the_shipped_mission_is_placed_well() {
        check_with(&fixture(), "ok.toml", "", "").unwrap();
    }

    #[test]
    fn a_start_inside_a_body_names_the_body() {
        let f = fixture();
        let body = f.scene.body("table_1").unwrap().1.pose;
        let e = check_with(
            &f,
            "in-body.toml",
            "start = [0.0, 0.0, 0.0]",
            &format!("start = [{}, {}, 0.0]", body.x, body.y),
        )
        .unwrap_err()
        .to_string();
        assert!(
            e.contains("in-body.toml:") && e.contains("key `start`"),
            "{e}"
        );
        assert!(e.contains("overlaps body `table_1`"), "{e}");
    }

    #[test]
    fn a_goal_or_start_outside_the_map_is_named_so() {
        let f = fixture();
        let text = std::fs::read_to_string(shipped("mission.toml")).unwrap();
        let first_goal = text
            .lines()
            .find(|l| l.trim_start().starts_with("goal = "))
            .unwrap()
            .to_string();
        let e = check_with(&f, "far.toml", &first_goal, "goal = [500.0, 0.0, 0.0]")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("key `leg[0].goal`") && e.contains("outside the map"),
            "{e}"
        );
        let e = check_with(
            &f,
            "edge.toml",
            "start = [0.0, 0.0, 0.0]",
            "start = [-1000.0, 0.0, 0.0]",
        )
        .unwrap_err()
        .to_string();
        assert!(
            e.contains("key `start`") && e.contains("outside the map"),
            "{e}"
        );
    }
}
