//! A robot wedged inside its margin between two obstacles (as a sweep's robot stopped
//! after cutting into a 0.9 m channel): every whole primitive from its start reaches one
//! or the other, and turning on the spot sweeps a corner closer. The start's short
//! straight moves take it to where it can turn; without them there was no path.

use super::BUDGET;
use super::relief::check_relieved;
use crate::seed_map::{ROBOT, ROBOT_MARGIN, Rect, rasterise};
use crate::{PlanRequest, Planner, PlannerConfig};
use aisle_geometry::{Direction, GridMap, Pose2};
use std::f64::consts::FRAC_PI_2;

/// A box to the robot's left rear and a shelf to its right front, the channel between
/// them (x from 1.6 to 2.5) leading north.
fn wedge_map() -> GridMap {
    let mut map = GridMap::new_free(0.0, 0.0, 0.1, 6.0, 6.0).unwrap();
    rasterise(
        &mut map,
        &[Rect::new(0.8, 1.9, 1.6, 4.0), Rect::new(2.5, 1.4, 5.0, 2.4)],
    );
    map
}

#[test]
fn a_wedged_start_leaves_by_a_short_move() {
    let map = wedge_map();
    let cfg = PlannerConfig::default();
    let mut planner = Planner::new(cfg.clone()).unwrap();
    let req = PlanRequest {
        start: Pose2::new(1.96, 1.987, 0.495),
        goal: Pose2::new(2.05, 4.5, FRAC_PI_2),
        footprint: ROBOT,
        margin: ROBOT_MARGIN,
        max_expansions: BUDGET,
    };
    let plan = planner.plan(&req, &map.view()).unwrap();
    check_relieved(&plan, &req, &map.view(), &cfg);
    // It leaves by a straight move shorter than a primitive before it turns.
    let first_turn = plan
        .path
        .iter()
        .position(|p| (p.pose.theta - req.start.theta).abs() > 1e-6)
        .unwrap();
    let straight = plan.path[first_turn].pose.distance(&req.start);
    assert!(straight > 0.1 && straight < 0.2, "{straight}");
    assert_ne!(plan.path[0].direction, Direction::Rotate);
}
