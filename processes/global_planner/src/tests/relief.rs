//! Start relief on a synthetic map: a robot parked with its rear 5 cm from a crate
//! (inside its 0.1 m margin) still gets a plan with the full margin, and the margin it
//! is held to drops only near the start.

use super::{BUDGET, check_plan};
use crate::seed_map::{self, ROBOT, ROBOT_MARGIN, Rect, rasterise};
use crate::{Plan, PlanErrorKind, PlanRequest, Planner, PlannerConfig, validate_path};
use aisle_geometry::{GridMap, GridView, Pose2};

/// The seed hall at 20 cells/m with a crate whose east face stands 5 cm behind a robot
/// at (0, 0) facing east (its rear edge is at x = -0.254).
fn crate_behind_map() -> GridMap {
    let mut map = seed_map::seed_map(20.0);
    rasterise(&mut map, &[Rect::new(-0.9, -0.5, -0.3, 0.5)]);
    map
}

fn request(goal: Pose2) -> PlanRequest {
    PlanRequest {
        start: Pose2::new(0.0, 0.0, 0.0),
        goal,
        footprint: ROBOT,
        margin: ROBOT_MARGIN,
        max_expansions: BUDGET,
        fixed_budget: false,
    }
}

/// Checks a plan from a start inside the margin: held to the margin the start keeps
/// throughout, and to the full one once clear of the relief (a motion that leaves inside
/// it may end a primitive beyond it). Returns the kept margin.
pub(super) fn check_relieved(
    plan: &Plan,
    req: &PlanRequest,
    map: &GridView,
    cfg: &PlannerConfig,
) -> f64 {
    let kept = plan
        .stats
        .start_relief
        .expect("the start is inside the margin");
    let held = PlanRequest {
        margin: kept,
        ..*req
    };
    check_plan(plan, &held, map, cfg);
    let reach = cfg.start_relief_radius + 2.0 * cfg.primitive_length;
    let far = plan
        .path
        .iter()
        .position(|p| p.pose.distance(&req.start) > reach);
    let tail = &plan.path[far.expect("the path leaves the relief")..];
    validate_path(tail, req.footprint, req.margin, map, 0.05).unwrap();
    kept
}

#[test]
fn a_start_inside_the_margin_plans_with_the_full_margin_beyond_the_relief() {
    let map = crate_behind_map();
    let cfg = PlannerConfig::default();
    let mut planner = Planner::new(cfg.clone()).unwrap();
    // Ahead, and round the crate to its far side.
    for goal in [Pose2::new(3.0, 0.5, 0.0), Pose2::new(-2.0, 1.5, 0.0)] {
        let req = request(goal);
        let plan = planner.plan(&req, &map.view()).unwrap();
        let kept = check_relieved(&plan, &req, &map.view(), &cfg);
        assert!((0.03..0.05).contains(&kept), "{kept}");
    }
}

#[test]
fn without_relief_the_same_start_has_no_plan() {
    let map = crate_behind_map();
    let cfg = PlannerConfig {
        start_relief_radius: 0.0,
        ..PlannerConfig::default()
    };
    let mut planner = Planner::new(cfg).unwrap();
    let e = planner
        .plan(&request(Pose2::new(3.0, 0.5, 0.0)), &map.view())
        .unwrap_err();
    assert_eq!(e.kind, PlanErrorKind::StartOccupied);
}

#[test]
fn a_start_touching_an_obstacle_is_occupied_whatever_the_relief() {
    let map = crate_behind_map();
    let mut planner = Planner::new(PlannerConfig::default()).unwrap();
    let req = PlanRequest {
        start: Pose2::new(-0.1, 0.0, 0.0),
        ..request(Pose2::new(3.0, 0.5, 0.0))
    };
    let e = planner.plan(&req, &map.view()).unwrap_err();
    assert_eq!(e.kind, PlanErrorKind::StartOccupied);
}
