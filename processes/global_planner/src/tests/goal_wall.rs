//! A goal beside a wall, within the search's allowance (the sagitta and `sweep_cover`
//! beyond the margin) but clear with the margin itself: accepted by the planner's goal
//! test, so it must be reachable, and cheaply. Without the goal's relief every pose the
//! search could end on there failed its collision check, and the search spent its whole
//! budget (200k expansions) before it failed.

use super::{BUDGET, check_plan};
use crate::seed_map::{self, ROBOT, ROBOT_MARGIN};
use crate::{PlanErrorKind, PlanRequest, Planner, PlannerConfig, footprint_touches};
use aisle_geometry::{GridMap, Pose2};
use std::f64::consts::{FRAC_PI_2, PI};

/// Expansions a goal beside the wall may take: about what the same goal 0.2 m further
/// out takes (70 facing the wall, 10k reversing up to it: the reverse costs), far below
/// the budget that every one of them took without the goal's relief.
fn cheap(map: &GridMap, cfg: &PlannerConfig, face: Face) -> u32 {
    let mut planner = Planner::new(cfg.clone()).unwrap();
    let clear = planner.plan(&request(0.2, face), &map.view()).unwrap();
    assert_eq!(clear.stats.goal_relief, None);
    2 * clear.stats.expansions + 500
}

/// Which face of the robot stands `gap` from which band of the seed map (each 1 m
/// inside the map's edge), its margin included.
#[derive(Debug, Clone, Copy)]
enum Face {
    /// Its front to the east band (x = 14.0).
    FrontEast,
    /// Its rear to the east band: reached in reverse.
    RearEast,
    /// Its front to the south band (y = -9.0).
    FrontSouth,
}

/// From the seed's drop pose to a goal `gap` from a band, as `face` says.
fn request(gap: f64, face: Face) -> PlanRequest {
    let reach = gap + ROBOT_MARGIN + 0.5 * ROBOT.length;
    let goal = match face {
        Face::FrontEast => Pose2::new(14.0 - reach, 5.0, 0.0),
        Face::RearEast => Pose2::new(14.0 - reach, 5.0, PI),
        Face::FrontSouth => Pose2::new(2.0, -9.0 + reach, -FRAC_PI_2),
    };
    PlanRequest {
        start: Pose2::new(6.0, -7.0, 0.0),
        goal,
        footprint: ROBOT,
        margin: ROBOT_MARGIN,
        max_expansions: BUDGET,
        fixed_budget: false,
    }
}

fn plan_beside_the_wall(map: &GridMap, cfg: &PlannerConfig, gap: f64, face: Face) {
    let req = request(gap, face);
    // Legal under the planner's own rule (and the supervisor's check of a goal).
    assert!(!footprint_touches(
        &map.view(),
        ROBOT,
        ROBOT_MARGIN,
        &req.goal
    ));
    let mut planner = Planner::new(cfg.clone()).unwrap();
    let plan = planner
        .plan(&req, &map.view())
        .unwrap_or_else(|e| panic!("gap {gap} {face:?}: {e:?}"));
    let s = plan.stats;
    assert!(
        s.expansions <= cheap(map, cfg, face),
        "gap {gap} {face:?}: {s:?}"
    );
    // Held to the margin the goal keeps (at worst the sagitta and a 5 mm reach below
    // the full one, and only near the goal), and to the full one elsewhere.
    let kept = s
        .goal_relief
        .expect("the goal is within the search's allowance");
    assert!(
        kept > ROBOT_MARGIN - 0.008 && kept <= ROBOT_MARGIN,
        "{kept}"
    );
    let relaxed = PlanRequest {
        margin: kept,
        ..req
    };
    check_plan(&plan, &relaxed, &map.view(), cfg);
    let reach = cfg.start_relief_radius + 2.0 * cfg.primitive_length;
    let near = plan
        .path
        .iter()
        .position(|p| p.pose.distance(&req.goal) <= reach)
        .expect("the path ends at the goal");
    let head = &plan.path[..=near];
    crate::validate_path(head, ROBOT, ROBOT_MARGIN, &map.view(), 0.05).unwrap();
}

#[test]
fn a_goal_at_the_margin_beside_a_wall_is_reached_cheaply() {
    let map = seed_map::seed_map(10.0);
    let cfg = PlannerConfig::default();
    // From exactly at the margin to just inside the search's allowance (32 mm).
    for gap in [1e-9, 0.004, 0.012, 0.024, 0.03] {
        for face in [Face::FrontEast, Face::RearEast, Face::FrontSouth] {
            plan_beside_the_wall(&map, &cfg, gap, face);
        }
    }
    // On a finer map, and with no relief radius (only motions ending on the goal).
    plan_beside_the_wall(&seed_map::seed_map(20.0), &cfg, 1e-9, Face::FrontEast);
    let none = PlannerConfig {
        start_relief_radius: 0.0,
        ..PlannerConfig::default()
    };
    plan_beside_the_wall(&map, &none, 0.002, Face::FrontSouth);
}

#[test]
fn a_goal_with_room_to_spare_gets_no_relief() {
    let map = seed_map::seed_map(10.0);
    let mut planner = Planner::new(PlannerConfig::default()).unwrap();
    let plan = planner
        .plan(&request(0.05, Face::FrontEast), &map.view())
        .unwrap();
    assert_eq!(plan.stats.goal_relief, None);
    assert!(plan.stats.expansions < 1_000, "{:?}", plan.stats);
}

#[test]
fn a_goal_inside_the_margin_is_still_occupied() {
    let map = seed_map::seed_map(10.0);
    let mut planner = Planner::new(PlannerConfig::default()).unwrap();
    let e = planner
        .plan(&request(-0.005, Face::FrontEast), &map.view())
        .unwrap_err();
    assert_eq!(e.kind, PlanErrorKind::GoalOccupied);
    assert_eq!(e.stats.expansions, 0);
}

/// Under a margin smaller than the sagitta and the short reach, a goal whose bare
/// footprint is closer to the wall than those could not be proven reachable by any
/// motion: refused at once, not searched for.
#[test]
fn a_goal_no_motion_could_reach_is_refused_at_once() {
    let map = seed_map::seed_map(10.0);
    let mut planner = Planner::new(PlannerConfig::default()).unwrap();
    let req = PlanRequest {
        margin: 0.002,
        ..request(0.003 - ROBOT_MARGIN, Face::FrontEast)
    };
    assert!(!footprint_touches(
        &map.view(),
        ROBOT,
        req.margin,
        &req.goal
    ));
    let e = planner.plan(&req, &map.view()).unwrap_err();
    assert_eq!(e.kind, PlanErrorKind::GoalOccupied);
    assert_eq!(e.stats.expansions, 0);
}
