//! A robot wedged inside its margin between two obstacles (as a sweep's robot stopped
//! after cutting into a 0.9 m channel): every whole primitive from its start reaches one
//! or the other, and turning on the spot sweeps a corner closer. The start's short
//! straight moves take it to where it can turn; without them there was no path. And a
//! robot boxed in at its margin, which no motion keeps: it turns out with half of it.

use super::BUDGET;
use super::relief::check_relieved;
use crate::seed_map::{ROBOT, ROBOT_MARGIN, Rect, rasterise};
use crate::{PlanErrorKind, PlanRequest, Planner, PlannerConfig};
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
        fixed_budget: false,
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

/// A robot at (3.05, 3.0) facing east between two blocks 0.45 m either side of its
/// centre (0.196 m before and behind it; the margin is 0.1 m). Whole primitives reach a
/// block, and turning on the spot swings the footprint grown by the margin (and the
/// search's allowance) to 0.477 m from the centre, past them; grown by half the margin,
/// to 0.413 m. Turned north, it has 0.235 m either side.
fn boxed_in_map() -> GridMap {
    let mut map = GridMap::new_free(0.0, 0.0, 0.1, 6.0, 6.0).unwrap();
    rasterise(
        &mut map,
        &[Rect::new(1.5, 2.0, 2.6, 4.0), Rect::new(3.5, 2.0, 4.5, 4.0)],
    );
    map
}

fn request(start: Pose2) -> PlanRequest {
    PlanRequest {
        start,
        goal: Pose2::new(3.05, 5.3, FRAC_PI_2),
        footprint: ROBOT,
        margin: ROBOT_MARGIN,
        max_expansions: BUDGET,
        fixed_budget: false,
    }
}

#[test]
fn a_boxed_in_start_turns_out_with_half_the_margin() {
    let map = boxed_in_map();
    let req = request(Pose2::new(3.05, 3.0, 0.0));
    let no_escape = PlannerConfig {
        boxed_in_margin: 1.0,
        ..PlannerConfig::default()
    };
    let failed = Planner::new(no_escape).unwrap().plan(&req, &map.view());
    let failed = failed.expect_err("no motion keeps the margin");
    assert_eq!(failed.kind, PlanErrorKind::NoPath);
    assert!(failed.stats.boxed_in && !failed.stats.escaped);

    let cfg = PlannerConfig::default();
    let plan = Planner::new(cfg.clone())
        .unwrap()
        .plan(&req, &map.view())
        .unwrap();
    assert!(plan.stats.escaped);
    let kept = check_relieved(&plan, &req, &map.view(), &cfg);
    assert!((kept - 0.5 * ROBOT_MARGIN).abs() < 1e-9, "{kept}");
    assert_eq!(plan.path[0].direction, Direction::Rotate);
}

#[test]
fn only_a_boxed_in_start_is_searched_again() {
    // The channel closed into a corridor 0.9 m wide, from y = 2 to 5.8, where the robot
    // cannot turn with its margin, and a goal in it facing east: no path.
    let mut map = boxed_in_map();
    let walls = [
        Rect::new(0.0, 0.0, 6.0, 2.0),
        Rect::new(0.0, 4.0, 2.6, 6.0),
        Rect::new(3.5, 4.0, 6.0, 6.0),
        Rect::new(2.6, 5.8, 3.5, 6.0),
    ];
    rasterise(&mut map, &walls);
    let mut planner = Planner::new(PlannerConfig::default()).unwrap();
    let facing_east = |start| PlanRequest {
        goal: Pose2::new(3.05, 5.3, 0.0),
        ..request(start)
    };
    // Boxed in: searched again (it may turn near the start, not at the goal).
    let e = planner
        .plan(&facing_east(Pose2::new(3.05, 3.0, 0.0)), &map.view())
        .unwrap_err();
    assert_eq!(e.kind, PlanErrorKind::NoPath);
    assert!(e.stats.escaped);
    // Facing north, the robot drives up and down the corridor with the full margin: not
    // boxed in, searched once.
    let e = planner
        .plan(&facing_east(Pose2::new(3.05, 3.0, FRAC_PI_2)), &map.view())
        .unwrap_err();
    assert_eq!(e.kind, PlanErrorKind::NoPath);
    assert!(!e.stats.boxed_in && !e.stats.escaped, "{:?}", e.stats);
}
