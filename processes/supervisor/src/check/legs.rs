//! The mission walked leg by leg the way the scene will see it: where the robot may
//! stand when each leg starts and ends, and where every movable body may stand then (a
//! carried body is set down where its carry leg ends, rigidly held on the carry mount as
//! the simulator holds it).
//!
//! An approach leg without a goal drives to the body where it stands when the leg
//! starts. Where the mission leaves a heading to the planner (such a leg),
//! the robot may end under the body facing any of its four sides: every such pose is
//! kept as a candidate, and so is every pose a body may be set down at after such a
//! pick. The checks refuse only what holds for every candidate, so an unknown heading
//! can never make a feasible mission look infeasible.
//!
//! Knows nothing of maps, planners or what counts as a refusal.

use crate::mission::{LegSpec, MissionConfig};
use aisle_config::scene::Scene;
use aisle_geometry::{Pose2, wrap_angle};
use std::f64::consts::FRAC_PI_2;

/// One leg as the scene sees it when the leg starts.
pub struct LegView<'a> {
    /// 0-based, as in the mission file's `leg[i]` keys.
    pub index: usize,
    pub leg: &'a LegSpec,
    /// Where the robot may stand when the leg starts (the previous goal, or the start).
    pub start: Vec<Pose2>,
    /// The goal's position, and the headings the robot may have there (the stated one,
    /// or one per side of the approached body when the heading is free).
    pub goal: Pose2,
    pub headings: Vec<f64>,
    /// Every body of the scene (scene order) with the poses it may have during the leg.
    pub bodies: Vec<Vec<Pose2>>,
    /// On a carry leg: the carried body's scene index and where it may be set down.
    pub drop: Option<(usize, Vec<Pose2>)>,
    /// The scene index of the approached body, if any.
    pub approached: Option<usize>,
}

impl LegView<'_> {
    /// The robot's possible poses at the goal.
    pub fn goal_poses(&self) -> impl Iterator<Item = Pose2> + '_ {
        self.headings
            .iter()
            .map(|&h| Pose2::new(self.goal.x, self.goal.y, h))
    }
}

/// Walks `mission` from its start through `scene`; `mount` is the carry mount in the
/// robot's planar frame (`RobotModel::carry_mount_planar`).
pub fn walk<'a>(mission: &'a MissionConfig, scene: &Scene, mount: Pose2) -> Vec<LegView<'a>> {
    let index_of = |name: &Option<String>| name.as_deref().and_then(|n| scene.body(n)).map(|b| b.0);
    let mut bodies: Vec<Vec<Pose2>> = scene.bodies.iter().map(|b| vec![b.pose]).collect();
    let mut robot = vec![mission.start_pose()];
    let mut views = Vec::with_capacity(mission.leg.len());
    for (index, leg) in mission.leg.iter().enumerate() {
        let approached = index_of(&leg.approach);
        // A goal left out is the approached body where it stands now (the mission may
        // have carried it since the scene placed it).
        let goal = match approached {
            Some(b) if leg.goal_given.is_none() => bodies[b][0],
            _ => Pose2::new(leg.goal[0], leg.goal[1], leg.goal[2]),
        };
        let headings = match approached {
            Some(b) if leg.free_heading => {
                let mut h: Vec<f64> = Vec::new();
                for k in bodies[b]
                    .iter()
                    .flat_map(|p| (0..4).map(move |k| wrap_angle(p.theta + k as f64 * FRAC_PI_2)))
                {
                    if !h.iter().any(|&o| wrap_angle(o - k).abs() < SAME) {
                        h.push(k);
                    }
                }
                h
            }
            _ => vec![goal.theta],
        };
        let drop = index_of(&leg.carry).map(|b| {
            let at_goal: Vec<Pose2> = headings
                .iter()
                .map(|&h| Pose2::new(goal.x, goal.y, h))
                .collect();
            (b, carried_to(&robot, &bodies[b], &at_goal, mount))
        });
        let view = LegView {
            index,
            leg,
            start: robot.clone(),
            goal,
            headings,
            bodies: bodies.clone(),
            drop,
            approached,
        };
        if let Some((b, drops)) = &view.drop {
            bodies[*b] = drops.clone();
        }
        robot = view.goal_poses().collect();
        views.push(view);
    }
    views
}

/// Where a body standing at one of `body` is set down when the robot picks it up at one
/// of `picks` and sets it down at one of `drops`: the simulator's rigid grasp (the body's
/// pose relative to the mount at the pick, kept to the drop). Every combination.
fn carried_to(picks: &[Pose2], body: &[Pose2], drops: &[Pose2], mount: Pose2) -> Vec<Pose2> {
    let mut out: Vec<Pose2> = Vec::new();
    for pick in picks {
        let held = pick.compose(&mount).inverse();
        for b in body {
            let offset = held.compose(b);
            for d in drops {
                // Candidates that coincide are one: repeated free picks of the same body
                // keep at most a few poses instead of multiplying them.
                let p = d.compose(&mount).compose(&offset);
                let same =
                    |o: &Pose2| o.distance(&p) < SAME && wrap_angle(o.theta - p.theta).abs() < SAME;
                if !out.iter().any(same) {
                    out.push(p);
                }
            }
        }
    }
    out
}

/// Poses or headings closer than this (metres, radians) are the same candidate.
const SAME: f64 = 1e-6;

#[cfg(test)]
mod tests {
    use super::*;
    use aisle_config::testing::shipped;
    use std::f64::consts::PI;

    fn close(a: Pose2, b: Pose2) -> bool {
        (a.x - b.x).abs() < 1e-9
            && (a.y - b.y).abs() < 1e-9
            && aisle_geometry::wrap_angle(a.theta - b.theta).abs() < 1e-9
    }

    fn seed() -> (MissionConfig, Scene) {
        let scene = Scene::load(&shipped("warehouse.toml")).unwrap();
        let mission = MissionConfig::load(&shipped("mission.toml"), &scene).unwrap();
        (mission, scene)
    }

    #[test]
    fn the_seed_sets_the_rack_down_turned_with_the_robot() {
        let (mission, scene) = seed();
        let views = walk(&mission, &scene, Pose2::new(0.0, 0.0, 0.0));
        assert_eq!(views.len(), 4);
        let (rack, _) = scene.body("rack2b").unwrap();
        // Picked facing south (turned in place under the rack facing north), set down
        // at (6, -7) facing east: the rack turns by the same half turn plus a quarter.
        let (b, drops) = views[2].drop.as_ref().unwrap();
        assert_eq!(*b, rack);
        assert_eq!(drops.len(), 1);
        assert!(close(drops[0], Pose2::new(6.0, -7.0, PI)), "{:?}", drops[0]);
        // The park leg starts under it, where it now stands.
        assert!(close(views[3].bodies[rack][0], drops[0]));
        assert!(close(views[3].start[0], Pose2::new(6.0, -7.0, 0.0)));
        assert!(views[3].drop.is_none() && views[3].approached.is_none());
    }

    #[test]
    fn a_free_heading_keeps_every_side_as_a_candidate() {
        let (mut mission, scene) = seed();
        mission.leg.remove(1); // no turn in place: carry straight from the pick
        mission.leg[0].free_heading = true;
        let views = walk(&mission, &scene, Pose2::new(0.0, 0.0, 0.0));
        assert_eq!(views[0].headings.len(), 4);
        assert_eq!(views[1].start.len(), 4);
        let (_, drops) = views[1].drop.as_ref().unwrap();
        assert_eq!(drops.len(), 4);
        // Entered from any side, the rack is set down at the goal in one of 4 headings;
        // picked up again from a free heading and set down again, still 4.
        for k in 0..4 {
            let want = Pose2::new(6.0, -7.0, k as f64 * FRAC_PI_2);
            assert!(
                drops.iter().any(|d| close(*d, want)),
                "{want:?} in {drops:?}"
            );
        }
    }
}
