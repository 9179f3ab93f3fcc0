//! Docking plans on small synthetic maps: the side chosen, the moves out, the bound.

use super::*;
use crate::PlannerConfig;
use aisle_geometry::{Footprint, GridMap};
use std::f64::consts::FRAC_PI_2;

use crate::dock::seed_rack as rack;

/// Twenty occupied cells from `at`, `step` apart in each direction.
fn wall(map: &mut GridMap, at: (f64, f64), step: (f64, f64)) {
    for k in -10..10 {
        let (x, y) = (at.0 + step.0 * f64::from(k), at.1 + step.1 * f64::from(k));
        let c = map.view().cell_of(x, y);
        map.set(c, aisle_geometry::OCCUPIED_STATIC);
    }
}

fn request(start: Pose2, goal: Pose2) -> PlanRequest {
    PlanRequest {
        start,
        goal,
        footprint: Footprint::new(0.508, 0.43),
        margin: 0.1,
        max_expansions: 100_000,
        fixed_budget: false,
    }
}

#[test]
fn a_free_heading_dock_enters_the_side_facing_the_robot_straight() {
    let map = GridMap::new_free(-5.0, -5.0, 0.1, 10.0, 10.0).unwrap();
    let (body, legs) = rack(Pose2::new(0.0, 2.0, FRAC_PI_2));
    let site = DockSite {
        kind: DockKind::Dock,
        body,
        parts: &legs,
        free_heading: true,
    };
    let mut planner = Planner::new(PlannerConfig::default()).unwrap();
    let req = request(Pose2::new(0.0, -3.0, FRAC_PI_2), body.pose);
    let plan = planner
        .plan_docked(&req, &site, &map.view(), &mut || false)
        .unwrap();
    // From the south: the straight part runs north along x = 0 into the centre.
    let last = plan.path.last().unwrap().pose;
    assert!((last.x, last.y) == (0.0, 2.0) && (last.theta - FRAC_PI_2).abs() < 1e-9);
    for p in &plan.path[plan.split..] {
        assert!(p.pose.x.abs() < 1e-9 && (p.pose.theta - FRAC_PI_2).abs() < 1e-9);
    }
    // Nothing before the straight part comes near the rack.
    let robot = Footprint::new(0.508, 0.43);
    for p in &plan.path[..=plan.split] {
        assert!(
            !robot.overlaps(&p.pose, &body.footprint, &body.pose),
            "{p:?}"
        );
    }
}

#[test]
fn an_undock_leaves_backwards_when_the_goal_is_behind_else_through_a_side_and_blocked_sides_are_refused()
 {
    let map = GridMap::new_free(-5.0, -5.0, 0.1, 10.0, 10.0).unwrap();
    let (body, legs) = rack(Pose2::new(0.0, 0.0, 0.0));
    let site = DockSite {
        kind: DockKind::Undock,
        body,
        parts: &legs,
        free_heading: false,
    };
    let mut planner = Planner::new(PlannerConfig::default()).unwrap();
    let req = request(body.pose, Pose2::new(-3.5, 0.0, 0.0));
    let plan = planner
        .plan_docked(&req, &site, &map.view(), &mut || false)
        .unwrap();
    assert_eq!(plan.path[0].direction, Direction::Reverse);
    assert!(plan.path[plan.split].pose.x < -1.0);
    // Walled in at both ends: out through a side after a quarter turn in place.
    let mut walled = map.clone();
    wall(&mut walled, (-1.0, 0.0), (0.0, 0.05));
    wall(&mut walled, (1.0, 0.0), (0.0, 0.05));
    let plan = planner
        .plan_docked(&req, &site, &walled.view(), &mut || false)
        .unwrap();
    assert_eq!(plan.path[0].direction, Direction::Rotate);
    let out = plan.path[plan.split].pose;
    assert!(out.x.abs() < 1e-9 && out.y.abs() > 1.0, "{out:?}");
    // Walled in on every side: no way out.
    wall(&mut walled, (0.0, -1.0), (0.05, 0.0));
    wall(&mut walled, (0.0, 1.0), (0.05, 0.0));
    let e = planner
        .plan_docked(&req, &site, &walled.view(), &mut || false)
        .unwrap_err();
    assert_eq!(e.kind, PlanErrorKind::NoOpenSide);
}

/// A rack in the open with every side free: the sides searched after the cheapest
/// so far stop early, and the plan is the one searching every side to its end
/// gives.
#[test]
fn the_cheapest_side_wins_as_if_every_side_were_searched_in_full() {
    let map = GridMap::new_free(-8.0, -8.0, 0.1, 16.0, 16.0).unwrap();
    let (body, legs) = rack(Pose2::new(1.0, 2.0, 0.4));
    let site = DockSite {
        kind: DockKind::Dock,
        body,
        parts: &legs,
        free_heading: true,
    };
    let mut planner = Planner::new(PlannerConfig::default()).unwrap();
    let req = request(Pose2::new(-5.0, -5.0, 0.3), body.pose);
    let plan = planner
        .plan_docked(&req, &site, &map.view(), &mut || false)
        .unwrap();
    // Every open side searched in full, in order, the first of the cheapest kept.
    let params = planner.dock_params(1.0);
    let mut scratch = Vec::new();
    let blocked = dock::with_body_blocked(&map.view(), &site.body, &mut scratch);
    let (mut best, mut expansions, mut sides) = (None::<(f64, Pose2)>, 0, 0);
    for mv in dock::entries(&site, &req.goal, req.footprint, &params) {
        if !dock::corridor_clear(&site, &mv, req.footprint, &params, &map.view()) {
            continue;
        }
        let leg = PlanRequest {
            goal: mv.from,
            ..req
        };
        let searched = planner.plan(&leg, &blocked).unwrap();
        sides += 1;
        expansions += searched.stats.expansions;
        let cost = searched.stats.path_cost + planner.straight_cost(&mv);
        if best.is_none_or(|(c, _)| cost < c) {
            best = Some((cost, mv.from));
        }
    }
    assert_eq!(sides, 4);
    let (_, entry) = best.unwrap();
    let split = plan.path[plan.split].pose;
    assert!(split.distance(&entry) < 1e-9, "{split:?} vs {entry:?}");
    assert!(
        plan.stats.expansions < expansions,
        "{} vs {expansions}",
        plan.stats.expansions
    );
}

/// The next rack of the leg stands 3 m east; its legs are on the map, so its centre
/// (the leg's goal) is occupied: the plan is the move out alone, east, towards it.
#[test]
fn an_undock_towards_a_goal_under_another_body_is_the_move_out_alone() {
    let mut map = GridMap::new_free(-5.0, -5.0, 0.05, 10.0, 10.0).unwrap();
    let (body, legs) = rack(Pose2::new(0.0, 0.0, 0.0));
    let (next, next_legs) = rack(Pose2::new(3.0, 0.0, 0.0));
    // Each leg seen as a 3 x 3 block of cells, as noisy returns spread it.
    for leg in &next_legs {
        for (dx, dy) in (-1..=1).flat_map(|i| (-1..=1).map(move |j| (i, j))) {
            let (x, y) = (
                leg.pose.x + 0.05 * f64::from(dx),
                leg.pose.y + 0.05 * f64::from(dy),
            );
            let c = map.view().cell_of(x, y);
            map.set(c, aisle_geometry::OCCUPIED_STATIC);
        }
    }
    let site = DockSite {
        kind: DockKind::Undock,
        body,
        parts: &legs,
        free_heading: false,
    };
    let mut planner = Planner::new(PlannerConfig::default()).unwrap();
    let req = request(body.pose, next.pose);
    let plan = planner
        .plan_docked(&req, &site, &map.view(), &mut || false)
        .unwrap();
    assert_eq!(plan.split, plan.path.len() - 1, "only the straight move");
    let end = plan.path[plan.split].pose;
    assert!(end.x > 0.8 && end.y.abs() < 1e-9, "{end:?}");
    assert!(plan.path.iter().all(|p| p.direction == Direction::Forward));
    // A goal occupied by anything gets the same answer: the robot leaves the body
    // first, and the plan from outside says why it cannot go on.
    let walled_goal = request(body.pose, Pose2::new(3.0, 4.0, 0.0));
    let mut boxed = map.clone();
    for k in -10..=10 {
        let c = boxed.view().cell_of(3.0 + 0.05 * f64::from(k), 4.0);
        boxed.set(c, aisle_geometry::OCCUPIED_STATIC);
    }
    let e = planner.plan_docked(&walled_goal, &site, &boxed.view(), &mut || false);
    assert!(
        e.is_ok_and(|p| p.split == p.path.len() - 1),
        "occupied goal: out first"
    );
}
